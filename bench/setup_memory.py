"""Memory of each rank of a distributed run: the peak resident set (VmHWM) of every process after
it built the scene of examples/plate3d.py and after two steps, with the points distributed at
set-up (MpmEngine(distributedSetup=True)) or built whole by every rank first. One JSON line per
rank (doc/parallel.md, "Memory"):

    [mpiexec -n N] yade -n -j1 -x bench/setup_memory.py [h_mm=0.5] [distributedSetup=1]

Fields: rank, ranks, held (distributed at set-up), points (the whole scene's), setupPoints (this
rank's before the first step), points_after (its after two steps), start_MB (before the scene:
YADE, Python, the modules), setup_MB, peak_MB.
"""
import json
import os
import sys

from yade import O

import eigenmpm as em

sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(em.__file__)), "..", "..", "examples"))
import plate3d  # noqa: E402


def peakMB():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmHWM in /proc/self/status")


def main(argv):
    o = dict(plate3d.DEFAULTS, h_mm=0.5)
    for a in argv:
        k, v = a.split("=", 1)
        if k not in ("h_mm", "distributedSetup"):
            raise SystemExit(f"setup_memory: unknown parameter {k}; known: h_mm, distributedSetup")
        o[k] = float(v) if k == "h_mm" else v.lower() in ("1", "true", "yes")
    start = peakMB()
    mpm, crack = plate3d.build(o)
    O.engines = [mpm, crack]
    O.dt = o["dt_us"] * 1e-6
    setup, setupPoints = peakMB(), len(mpm.solver.positions())
    O.run(2, True)
    row = dict(rank=em.parallel.rank(), ranks=em.parallel.worldSize(), held=mpm.referencePositions is None,
               points=mpm.numPoints(), setupPoints=setupPoints, points_after=len(mpm.solver.positions()),
               start_MB=round(start), setup_MB=round(setup), peak_MB=round(peakMB()))
    print("JSON " + json.dumps(row), flush=True)


main(sys.argv[1:])
