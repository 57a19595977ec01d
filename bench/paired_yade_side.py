#!/usr/bin/env python3
"""Paired runs of bench/bench_yade_side.py (issue 12 item 5: what the YADE side adds to each
iteration of the branching run) with two builds of the Python package, one round each in
alternating order, in one invocation:

    bench/paired_yade_side.py OLD_PYTHONPATH NEW_PYTHONPATH [--rounds 4] [bench_yade_side.py options]

Each PYTHONPATH is a build's python/ folder; copy an old build's with `cp -rL` (build/python
links the package's .py files to the source tree, which would otherwise be the new ones); its
module must have `_eigenmpm.timeSteps` (session 34 on): to compare older Python files, copy them
into a copy of a current package. The
benchmark and the example it builds are this tree's. Printed: each run's line of
bench_yade_side.py, then each package's shares (the YADE side over the time inside the step)
and their median.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--rounds", type=int, default=4)
    a, rest = ap.parse_known_args(argv)
    shares = {"old": [], "new": []}
    for r in range(1, a.rounds + 1):
        for which in (("old", "new") if r % 2 else ("new", "old")):
            env = dict(os.environ, PYTHONPATH=os.path.abspath(getattr(a, which)))
            res = subprocess.run(["yade", "-n", "-j", "1", "-x", os.path.join(HERE, "bench_yade_side.py"), "--rounds", "1",
                                  *rest], cwd=os.path.dirname(HERE), env=env, capture_output=True, text=True,
                                 stdin=subprocess.DEVNULL)
            line = next((l for l in res.stdout.splitlines() if l.startswith('{"round"')), None)
            if res.returncode != 0 or line is None:
                sys.exit(f"{which}: bench_yade_side.py failed (exit {res.returncode}):\n{res.stdout[-2000:]}{res.stderr[-2000:]}")
            shares[which].append(json.loads(line)["share"])
            print(f"round {r} {which}: {line}", flush=True)
    for which, v in shares.items():
        print(f"{which}: shares {', '.join(f'{100 * s:.2f} %' for s in v)}; median {100 * statistics.median(v):.2f} %")


if __name__ == "__main__":
    main(sys.argv[1:])
