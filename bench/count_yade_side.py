#!/usr/bin/env python3
"""What the YADE side of an iteration does, counted instead of timed (issue 12 item 5): the
branching plate's scene as bench_yade_side.py builds it, run under callgrind inside YADE, with
collection only inside `yade::PyRunner::action()` (our engines are PyRunners) and callgrind's
cache model set to this machine's L2 (1 MiB, 8 ways) as the last level. Two runs per package,
of --iters A,B iterations after the first; the differences over B - A are per iteration, so the
scene's set-up and first step drop out. Printed per package: instructions, first-level and
last-level (L2-model) misses of the YADE side (everything inside the PyRunners but the solver's
step) and of the step itself.

Wall time cannot resolve a few microseconds per iteration on this shared machine (the share of
bench_yade_side.py moves by 1-3 points with the machine's state, doc/performance.md
"Session 33"); these counts repeat (with the fixed hash seed used here: instructions to about
0.15 %, last-level misses to about 1 %). They leave out what YADE's own loop and C++ engines do
between the PyRunners.

    /usr/bin/python3.11 bench/count_yade_side.py [LABEL=]PYTHONPATH ... [--iters 12,36] [--h-mm 0.5]

Each PYTHONPATH is a build's python/ folder (copy an old one with `cp -rL`: build/python links
the package's .py files to the source tree). Needs valgrind (Debian package `valgrind`); each
package takes about four minutes. Run from the repository root.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
EVENTS = ("Ir", "I1mr", "D1mr", "D1mw", "ILmr", "DLmr", "DLmw")
STEP = re.compile(r"Solver<\d, emp::\w+>::step\(double, int")


def scene(iterations, hMm):
    """Inside YADE: the scene of bench_yade_side.py, one iteration, then `iterations` more."""
    from yade import O
    import eigenmpm as em
    sys.path[:0] = [os.path.join(os.getcwd(), "examples")]  # (the runs' working directory is the root)
    import crack_branching
    o = dict(crack_branching.DEFAULTS, h_mm=hMm, dt_us=0.018, endTime_us=80, vtkPeriod_us=1000.0)
    mpm, crack = crack_branching.build(o)
    O.dt = o["dt_us"] * 1e-6
    out = tempfile.mkdtemp()
    # (the example's engines; its VTK period (1 000 us) is never reached in these iterations)
    O.engines = [mpm, crack, em.PlotRecorder(iterPeriod=crack.iterPeriod),
                 em.VTKRecorder(fileName=os.path.join(out, "plate-"), iterPeriod=10 ** 6),
                 em.Progress(endIter=4444, realPeriod=20)]
    O.run(1, True)
    O.run(iterations, True)
    shutil.rmtree(out, ignore_errors=True)


def totals(path):
    """(whole collection, the solver's step inclusive), each a dict of EVENTS."""
    out = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", "--show=" + ",".join(EVENTS),
                          path], check=True, capture_output=True, text=True).stdout
    def numbers(line):
        return [int(n.replace(",", "")) for n in re.findall(r"([\d,]+)(?: \([^)]*\))?", line)][:len(EVENTS)]
    whole = step = None
    for line in out.splitlines():
        if "PROGRAM TOTALS" in line:
            whole = numbers(line.split("PROGRAM TOTALS")[0])
        elif step is None and STEP.search(line):
            step = numbers(line.split("???:")[0] if "???:" in line else line)
    if whole is None or step is None:
        sys.exit(f"count_yade_side.py: no totals or no solver step in {path}")
    return dict(zip(EVENTS, whole)), dict(zip(EVENTS, step))


def count(pythonpath, iters, hMm, work):
    runs = []
    for n in iters:
        out = os.path.join(work, f"callgrind.{len(os.listdir(work))}")
        # (a fixed hash seed: the order of sets and dicts of strings, and so the counts, repeat)
        env = dict(os.environ, PYTHONPATH=os.path.abspath(pythonpath), PYTHONHASHSEED="0")
        cmd = ["valgrind", "--tool=callgrind", "--cache-sim=yes", "--LL=1048576,8,64",
               "--toggle-collect=yade::PyRunner::action()", f"--callgrind-out-file={out}",
               "yade", "-n", "-j", "1", "-x", os.path.abspath(__file__), "--scene", str(n), "--h-mm", str(hMm)]
        res = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, stdin=subprocess.DEVNULL)
        if res.returncode != 0 or not os.path.exists(out):
            sys.exit(f"count_yade_side.py: the run failed (exit {res.returncode}):\n{res.stdout[-1500:]}{res.stderr[-1500:]}")
        runs.append(totals(out))
    (wa, sa), (wb, sb) = runs
    k = iters[1] - iters[0]
    side = {e: ((wb[e] - sb[e]) - (wa[e] - sa[e])) / k for e in EVENTS}
    step = {e: (sb[e] - sa[e]) / k for e in EVENTS}
    return side, step


def main(argv):
    if "--scene" in argv:  # (inside YADE)
        n = int(argv[argv.index("--scene") + 1])
        h = float(argv[argv.index("--h-mm") + 1]) if "--h-mm" in argv else 0.5
        return scene(n, h)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("packages", nargs="+", help="[LABEL=]PYTHONPATH of a build's python/ folder")
    ap.add_argument("--iters", default="12,36", help="the two run lengths A,B (iterations after the first)")
    ap.add_argument("--h-mm", type=float, default=0.5)
    a = ap.parse_args(argv)
    iters = [int(x) for x in a.iters.split(",")]
    if len(iters) != 2 or not 0 < iters[0] < iters[1]:
        sys.exit(f"count_yade_side.py: --iters {a.iters} is invalid; allowed: two lengths A,B with 0 < A < B")
    if shutil.which("valgrind") is None:
        sys.exit("count_yade_side.py: needs valgrind (apt-get install valgrind)")
    print(f"per iteration, the branching plate at h = {a.h_mm} mm, iterations {iters[0]} to {iters[1]}; "
          "misses: callgrind's model, last level = 1 MiB")
    print(f"{'package':<22}{'part':<11}" + "".join(f"{e:>12}" for e in EVENTS))
    with tempfile.TemporaryDirectory() as work:
        for spec in a.packages:
            label, _, path = spec.rpartition("=")
            side, step = count(path, iters, a.h_mm, work)
            for part, d in (("YADE side", side), ("step", step)):
                print(f"{(label or path)[:21]:<22}{part:<11}" + "".join(f"{d[e]:>12.0f}" for e in EVENTS), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
