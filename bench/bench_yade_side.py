"""What the YADE side adds to each iteration of the branching plate (issue 12 item 5: below 5 %
at 6.4e4 points): examples/crack_branching.py's scene and engines (MpmEngine, EigenErosion with
its records every 0.1 us, PlotRecorder, VTKRecorder, Progress) stepped by O.run, against the same
steps taken by a plain Python loop that calls the solver's step and nothing else. Run inside
YADE, one thread:

    PYTHONPATH=build/python yade -n -j 1 -x bench/bench_yade_side.py [--h-mm 0.5] [--dt-us 0.018]
        [--end-us 80] [--rounds 2] [--minimal]

(--minimal: O.engines = [MpmEngine, EigenErosion] and no record, the floor of YADE's loop.)

A round builds the scene twice from its start and steps it to --end-us, once each way, the order
alternating from round to round; times are the process's CPU time. Reported per round:
- `yade_s`: O.run with the example's engines; `inside_step_s`: the part of it inside the
  solver's step (the C++ step, timed in C++ around each call: `_eigenmpm.timeSteps`; a Python
  wrapper around the step, as before session 34, ran cold after each step and added its own
  cost to the YADE side);
- `share`: (yade_s - inside_step_s) / inside_step_s, what YADE's loop, the engines' Python and
  the recorders add per iteration (the robust figure: one run, no difference of two runs);
- `main_thread_s` and `share_run_thread`: the CPU time of the script's own thread while it waits
  in O.run(wait=True) (YADE's wait polls, about 0.2-0.4 % of the steps' time; on a machine with
  a core to spare it runs beside the stepping thread, not in its way), and the share without it;
- `bare_s` and `ratio` = yade_s / bare_s: the same, read against the loop (it also carries what
  the Python between the steps costs the step itself: caches it leaves cold);
- each engine's own time per iteration (YADE's O.timingEnabled).
Both ways must end in the same state, bitwise (the engines only read between the steps).
"""
import argparse
import hashlib
import json
import os
import statistics
import sys
import tempfile
import time

from yade import O, plot

import eigenmpm as em
from eigenmpm import _eigenmpm

# (run from the repository root; or the examples beside the package's source, which build/python links to)
sys.path[:0] = [os.path.join(os.getcwd(), "examples"),
                os.path.join(os.path.dirname(os.path.realpath(em.__file__)), "..", "..", "examples")]
import crack_branching  # noqa: E402


def _state(solver):
    h = hashlib.sha1()
    for a in (solver.positions(), solver.velocities(), solver.damage(), solver.stress()):
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def yadeRun(o, out, minimal=False):
    O.reset()
    plot.reset()
    mpm, crack = crack_branching.build(o)
    O.dt = o["dt_us"] * 1e-6
    steps = int(round(o["endTime_us"] / o["dt_us"]))
    if minimal:  # the solver's engine and the erosion stage, no record: what YADE's loop costs alone
        crack.iterPeriod = 10 ** 9
        O.engines = [mpm, crack]
    else:
        vtk = em.VTKRecorder(fileName=os.path.join(out, "plate-"),
                             iterPeriod=max(1, int(round(o["vtkPeriod_us"] / o["dt_us"]))))
        O.engines = [mpm, crack, em.PlotRecorder(iterPeriod=crack.iterPeriod), vtk,
                     em.Progress(endIter=steps, realPeriod=20)]
    O.run(1, True)  # the first iteration builds the solver's state and writes the first VTK file
    O.timingEnabled = True
    for e in O.engines:
        e.execTime, e.execCount = 0, 0
    _eigenmpm.timeSteps(True)  # (the step's CPU time, summed in C++)
    t, tMain = time.process_time(), time.thread_time()
    O.run(steps - 1, True)
    total, waiting = time.process_time() - t, time.thread_time() - tMain
    inside = _eigenmpm.stepCpuSeconds()
    _eigenmpm.timeSteps(False)
    O.timingEnabled = False
    engines = {e.label or type(e).__name__: round(e.execTime * 1e-9 / (steps - 1) * 1e3, 4) for e in O.engines}
    return total, inside, waiting, engines, _state(mpm.solver), len(crack.core.events())


def bareRun(o):
    O.reset()
    plot.reset()
    mpm, crack = crack_branching.build(o)
    O.dt = dt = o["dt_us"] * 1e-6
    steps = int(round(o["endTime_us"] / o["dt_us"]))
    O.engines = [mpm, crack]  # (the first iteration attaches the erosion stage, as O.run does)
    O.run(1, True)
    O.engines = []
    solver, bcs, threads = mpm.solver, list(mpm.bcs.values()), 1
    t = time.process_time()
    now = O.time
    for _ in range(steps - 1):
        solver.time = now
        for bc in bcs:
            bc._update(now)
        solver.step(dt, threads)
        now += dt
    total = time.process_time() - t
    return total, _state(solver), len(crack.core.events())


def main(argv):
    ap = argparse.ArgumentParser(prog="bench_yade_side.py")
    ap.add_argument("--h-mm", type=float, default=0.5)
    ap.add_argument("--dt-us", type=float, default=0.018)
    ap.add_argument("--end-us", type=float, default=80.0)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--minimal", action="store_true",
                    help="O.engines = [MpmEngine, EigenErosion] without records: the part YADE's loop and the "
                         "MpmEngine's Python take alone")
    a = ap.parse_args(argv)
    if not hasattr(_eigenmpm, "timeSteps"):
        sys.exit("bench_yade_side.py: this package's module has no timeSteps (added in session 34); to compare "
                 "older Python files, copy them into a package with a current module")
    o = dict(crack_branching.DEFAULTS, h_mm=a.h_mm, dt_us=a.dt_us, endTime_us=a.end_us, vtkPeriod_us=1000.0)
    shares, runThread, ratios = [], [], []
    with tempfile.TemporaryDirectory() as out:
        for r in range(a.rounds):
            result = {}
            for way in (("yade", "bare") if r % 2 == 0 else ("bare", "yade")):
                result[way] = yadeRun(o, out, a.minimal) if way == "yade" else bareRun(o)
            yade, inside, waiting, engines, state, eroded = result["yade"]
            bare, bareState, bareEroded = result["bare"]
            assert state == bareState and eroded == bareEroded, "the YADE path changed the run"
            shares.append((yade - inside) / inside)
            runThread.append((yade - waiting - inside) / inside)
            ratios.append(yade / bare)
            print(json.dumps({"round": r + 1, "yade_s": round(yade, 2), "inside_step_s": round(inside, 2),
                              "share": round(shares[-1], 4), "main_thread_s": round(waiting, 3),
                              "share_run_thread": round(runThread[-1], 4),
                              "bare_s": round(bare, 2), "ratio": round(ratios[-1], 4),
                              "eroded": eroded, "engines_wall_ms_per_iteration": engines}), flush=True)
    print(f"YADE side per iteration: median share {statistics.median(shares):.4f} (of the run's thread alone "
          f"{statistics.median(runThread):.4f}), median ratio to the bare loop "
          f"{statistics.median(ratios):.4f} over {a.rounds} rounds (h = {a.h_mm} mm, dt = {a.dt_us} us, "
          f"{a.end_us} us)")


if __name__ == "__main__":
    main(sys.argv[1:])
