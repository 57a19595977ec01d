#!/usr/bin/env python3
"""Two threads against what the machine gives two processes. For each case, in alternating
rounds: bench_block on one thread alone, two one-thread bench_block processes at once (the sum of
their rates over the rate alone is what the machine allows two workers: shared caches, memory
bandwidth, a vCPU slower than the other), and bench_block on two threads (its rate over the rate
alone is the code's scaling). Prints per case the medians of both ratios and their quotient, the
share of the machine's ceiling the threads reach.

    /usr/bin/python3.11 bench/thread_ceiling.py [--cases gimp2,gimp3] [--sizes 1e5] [--size3d 1e5]
        [--rounds 3] [--min-time 2] [--build build]
"""
import argparse
import json
import os
import statistics
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def start(exe, case, size, threads, minTime):
    sizeArg = "--size3d" if case.endswith("3") else "--sizes"
    return subprocess.Popen([exe, "--cases", case, sizeArg, size, "--threads", str(threads), "--min-time", str(minTime),
                             "--warmup", "1"], stdout=subprocess.PIPE, text=True)


def rate(proc):
    out, _ = proc.communicate()
    if proc.returncode:
        raise SystemExit(f"bench_block failed ({proc.returncode})")
    rows = [json.loads(line[5:]) for line in out.splitlines() if line.startswith("JSON ")]
    return rows[0]["particle_steps_per_s"]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", default="gimp2,gimp3")
    p.add_argument("--sizes", default="1e5", help="2D points")
    p.add_argument("--size3d", default="1e5", help="3D points")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--min-time", type=float, default=2.0)
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    a = p.parse_args()
    exe = os.path.join(a.build, "bench_block")
    print(f"{'case':8} {'points':>7} {'round':>5} {'alone':>10} {'two procs':>10} {'2 threads':>10}")
    for case in a.cases.split(","):
        size = a.size3d if case.endswith("3") else a.sizes
        machine, code = [], []
        for r in range(a.rounds):
            alone = rate(start(exe, case, size, 1, a.min_time))
            pair = [start(exe, case, size, 1, a.min_time) for _ in range(2)]
            both = sum(rate(q) for q in pair)
            threads = rate(start(exe, case, size, 2, a.min_time))
            machine.append(both / alone)
            code.append(threads / alone)
            print(f"{case:8} {size:>7} {r + 1:>5} {alone:10.3e} {both / alone:10.3f} {threads / alone:10.3f}", flush=True)
        m, c = statistics.median(machine), statistics.median(code)
        print(f"{case}: two processes {m:.3f}x one alone (median), two threads {c:.3f}x: "
              f"{100 * c / m:.0f} % of the machine's ceiling")


if __name__ == "__main__":
    main()
