#!/usr/bin/env python3
"""Paired end-to-end runs of an example with two trees (issue 12 item 5): each tree's own
example script and package (TREE/examples/..., TREE/build/python), one run per tree per round
in alternating order (a slow spell of the shared machine then hits both), one thread:

    bench/paired_e2e.py OLD_TREE NEW_TREE [--rounds 5] [--example crack_branching.py]
        [--out DIR] [-- example parameters]

Default parameters: the issue's run, h_mm=0.5 dt_us=0.018 endTime_us=80 vtkPeriod_us=1000. A
tree is a checkout with its build (`make build`; an old commit: `git worktree add` and build
there). Printed per round: each tree's `wall_time_s` (the example's own timing of its O.run,
from its summary.json) and the process's elapsed time (YADE's start-up and the scene's set-up
included), and OLD / NEW for both; then the median ratios with their ranges. The results that
define the crack (initiation, branching, largest tip speed) are printed per run, so that a
change of results shows.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

DEFAULT = ["h_mm=0.5", "dt_us=0.018", "endTime_us=80", "vtkPeriod_us=1000"]
KEYS = ("initiation_time_us", "branching_time_us", "max_tip_speed_m_s")


def run(tree, example, params, out):
    env = dict(os.environ, PYTHONPATH=os.path.join(tree, "build", "python"))
    t = time.perf_counter()
    res = subprocess.run(["yade", "-n", "-j", "1", "-x", os.path.join("examples", example), *params, "--out", out],
                         cwd=tree, env=env, capture_output=True, text=True, stdin=subprocess.DEVNULL)
    elapsed = time.perf_counter() - t
    if res.returncode != 0:
        sys.exit(f"{tree}: the example failed (exit {res.returncode}):\n{res.stdout[-2000:]}{res.stderr[-2000:]}")
    summary = json.load(open(os.path.join(out, "summary.json")))
    return summary["wall_time_s"], elapsed, {k: summary.get(k) for k in KEYS}


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--example", default="crack_branching.py")
    ap.add_argument("--out", help="keep the runs' outputs here (default: a temporary folder)")
    ap.add_argument("params", nargs="*", help="the example's parameters (default: the issue's run)")
    a = ap.parse_intermixed_args(argv)
    params = a.params or DEFAULT
    trees = {"old": os.path.abspath(a.old), "new": os.path.abspath(a.new)}
    ratios, elapsedRatios = [], []
    with tempfile.TemporaryDirectory() as scratch:
        base = a.out or scratch
        for r in range(1, a.rounds + 1):
            got = {}
            for which in (("old", "new") if r % 2 else ("new", "old")):
                got[which] = run(trees[which], a.example, params, os.path.join(base, f"{which}-{r}"))
                wall, elapsed, crack = got[which]
                print(f"round {r} {which}: wall_time_s {wall:.2f}, elapsed {elapsed:.2f} s, {crack}", flush=True)
            ratios.append(got["old"][0] / got["new"][0])
            elapsedRatios.append(got["old"][1] / got["new"][1])
            print(f"round {r}: old / new {ratios[-1]:.3f} (elapsed {elapsedRatios[-1]:.3f})", flush=True)
    print(f"median old / new: wall_time_s {statistics.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f}), "
          f"elapsed {statistics.median(elapsedRatios):.3f} (range {min(elapsedRatios):.3f}-{max(elapsedRatios):.3f}), "
          f"{a.rounds} rounds")


if __name__ == "__main__":
    main(sys.argv[1:])
