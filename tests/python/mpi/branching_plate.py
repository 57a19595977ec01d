"""The quick crack-branching plate of examples/crack_branching.py (its build(), its quick
parameters: h = 1 mm, 16 000 points, a phantom pre-crack, eigenerosion, tractions), stepped
`steps` steps, on one process or under mpiexec (tests/python/test_mpi.py): every rank writes its
points by id to OUT/rank-R.npz and rank 0 the totals to OUT/summary.json.

    [mpiexec -n N] yade -n -j1 -x tests/python/mpi/branching_plate.py OUT [steps] [held]

`held`: the engine distributes its points at set-up (MpmEngine(distributedSetup=True)).
"""
import hashlib
import json
import os
import sys

import numpy as np
from yade import O

import eigenmpm as em
from eigenmpm import plots

# (the package's .py files in the build tree link to the source tree: its examples are beside)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(em.__file__)), "..", "..", "examples"))
import crack_branching  # noqa: E402

out = sys.argv[1]
steps = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
held = sys.argv[3:] == ["held"]
os.makedirs(out, exist_ok=True)
o = dict(crack_branching.DEFAULTS)
o.update(crack_branching.QUICK)
o["distributedSetup"] = held
mpm, crack = crack_branching.build(o)
O.engines = [mpm, crack]
O.dt = o["dt_us"] * 1e-6
setup = em.parallel.allCounts(len(mpm.solver.positions()))  # each rank's points before the first step
O.run(steps, True)
s = mpm.solver
np.savez(os.path.join(out, f"rank-{em.parallel.rank()}.npz"), ids=s.globalIds(), x=s.positions(), v=s.velocities(),
         stress=s.stress(), damage=s.damage())
summary = {"ranks": s.ranks, "points": mpm.numPoints(), "setup": setup, "held": mpm.referencePositions is None, "eroded": crack.erodedCount(), "dissipated": crack.dissipatedEnergy(),
           "kinetic": mpm.kineticEnergy(), "elastic": mpm.elasticEnergy(), "work": mpm.externalWork(),
           "reaction": [0.0, 0.0, 0.0], "front": crack.frontDistance(),
           "tips": [t.tolist() for t in crack.tips()], "initiation": crack.initiationTime(),
           "branching": crack.branchingTime(),
           "x": em.parallel.gather(mpm, s.positions()).tolist()[:5]}
# The eroded points' positions as the crack diagnostics read them: only those travel.
eroded = np.array([p for p, _, _ in crack.core.events()], dtype=np.int64)
summary["positionsOf"] = bool(len(eroded) > 0 and np.array_equal(em.parallel.positionsOf(mpm, eroded),
                                                                  em.parallel.gather(mpm, s.positions())[eroded]))
# their reference positions, sent alone (MpmEngine.referenceOf): bitwise the one-process ones
summary["referenceOf"] = hashlib.sha1(mpm.referenceOf(eroded).tobytes()).hexdigest()
# damageMap's raster (16 000 points: summed over the ranks, no gather)
raster = plots.damageRaster(mpm)
summary["raster"] = [int((raster == k).sum()) for k in range(3)] + [hashlib.sha1(raster.tobytes()).hexdigest()]
if em.parallel.isRoot():
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f)
