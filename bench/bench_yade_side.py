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
  solver's step (the C++ step, timed around each call);
- `share`: (yade_s - inside_step_s) / inside_step_s, what YADE's loop, the engines' Python and
  the recorders add per iteration (the robust figure: one run, no difference of two runs);
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

# (run from the repository root; or the examples beside the package's source, which build/python links to)
sys.path[:0] = [os.path.join(os.getcwd(), "examples"),
                os.path.join(os.path.dirname(os.path.realpath(em.__file__)), "..", "..", "examples")]
import crack_branching  # noqa: E402


class _TimedSolver:
    """The MpmEngine's solver, its step timed (CPU time); everything else passed on."""

    def __init__(self, solver):
        object.__setattr__(self, "_solver", solver)
        object.__setattr__(self, "inside", 0.0)

    def step(self, *args):
        t = time.process_time()
        try:
            return self._solver.step(*args)
        finally:
            object.__setattr__(self, "inside", self.inside + time.process_time() - t)

    def __getattr__(self, name):
        return getattr(self._solver, name)

    def __setattr__(self, name, value):
        setattr(self._solver, name, value)


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
    timed = _TimedSolver(mpm.solver)
    mpm.solver = timed
    O.timingEnabled = True
    for e in O.engines:
        e.execTime, e.execCount = 0, 0
    t = time.process_time()
    O.run(steps - 1, True)
    total = time.process_time() - t
    O.timingEnabled = False
    engines = {e.label or type(e).__name__: round(e.execTime * 1e-9 / (steps - 1) * 1e3, 4) for e in O.engines}
    mpm.solver = timed._solver
    return total, timed.inside, engines, _state(mpm.solver), len(crack.core.events())


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
    o = dict(crack_branching.DEFAULTS, h_mm=a.h_mm, dt_us=a.dt_us, endTime_us=a.end_us, vtkPeriod_us=1000.0)
    shares, ratios = [], []
    with tempfile.TemporaryDirectory() as out:
        for r in range(a.rounds):
            result = {}
            for way in (("yade", "bare") if r % 2 == 0 else ("bare", "yade")):
                result[way] = yadeRun(o, out, a.minimal) if way == "yade" else bareRun(o)
            yade, inside, engines, state, eroded = result["yade"]
            bare, bareState, bareEroded = result["bare"]
            assert state == bareState and eroded == bareEroded, "the YADE path changed the run"
            shares.append((yade - inside) / inside)
            ratios.append(yade / bare)
            print(json.dumps({"round": r + 1, "yade_s": round(yade, 2), "inside_step_s": round(inside, 2),
                              "share": round(shares[-1], 4), "bare_s": round(bare, 2), "ratio": round(ratios[-1], 4),
                              "eroded": eroded, "engines_wall_ms_per_iteration": engines}), flush=True)
    print(f"YADE side per iteration: median share {statistics.median(shares):.4f}, median ratio to the bare loop "
          f"{statistics.median(ratios):.4f} over {a.rounds} rounds (h = {a.h_mm} mm, dt = {a.dt_us} us, "
          f"{a.end_us} us)")


if __name__ == "__main__":
    main(sys.argv[1:])
