#!/usr/bin/env python3
"""What the transfer and stress-update options cost, in one build: for each mode, its CPU time per
step over the default's (FLIP + small strain).

Each invocation of the benchmark builds one block per mode (the default first) and steps them in
turn, one step each, in alternating order (`bench_block --modes`): every round's modes run under
the same state of the machine, whose speed on this shared machine changes from second to second.
(Separate processes per mode, as this script ran until session 30, gave rounds' ratios from 0.7
to 1.7.) Prints per case and mode the ratio of the total times and the median of the rounds' own
ratios with their quartiles, for each of --repeats invocations, then the median over them.

    /usr/bin/python3.11 bench/option_cost.py [--exe build/bench_block_v2] [--repeats 3]
        [--cases gimp2,gimp3] [--sizes 1e5] [--size3d 5e4] [--min-time 4]
        [--modes "APIC smallStrain,FLIP corotational,APIC corotational"] [--control] [--cpus 0]

--control adds the default mode a second time: its ratio shows what the method itself reads for
two identical scenes (1.00 within a few per mille when the pairing holds).

--separate instead runs each mode alone in its own process (one scene in memory, as in a user's
run), the default's and each mode's processes alternated --rounds times (the order swapped every
round), and prints per mode the median of the rounds' ratios of CPU time per step with their
quartiles. Two or three scenes stepped in turn share the caches: the mode with the most bytes a
point loses more to that, so the readings of the two methods differ (doc/performance.md, "Session
51"); this one has no such bias but more noise, hence the rounds.
"""
import argparse
import json
import os
import statistics
import subprocess

from cpus import cpuList, pinning

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT = "FLIP smallStrain"


def run(a, case, modes):
    """One invocation: the JSON row of each mode, in the order given."""
    cmd = [a.exe, "--cases", case, "--sizes", a.sizes, "--size3d", a.size3d, "--threads", "1",
           "--min-time", str(a.min_time), "--warmup", "2", "--modes", ",".join(modes)]
    out = subprocess.run(cmd, check=True, text=True, capture_output=True, preexec_fn=pinning(a.cpus)).stdout
    return [json.loads(line[5:]) for line in out.splitlines() if line.startswith("JSON ")]


def runAlone(a, case, mode):
    """One process stepping one scene of `mode` alone: its CPU time per step."""
    transfer, update = mode.split()
    cmd = [a.exe, "--cases", case, "--sizes", a.sizes, "--size3d", a.size3d, "--threads", "1",
           "--min-time", str(a.min_time), "--warmup", "2", "--transfer", transfer, "--stress-update", update]
    out = subprocess.run(cmd, check=True, text=True, capture_output=True, preexec_fn=pinning(a.cpus)).stdout
    row = [json.loads(line[5:]) for line in out.splitlines() if line.startswith("JSON ")][0]
    return row["cpu_time_s"] / row["steps"]


def separate(a, case, modes):
    """--separate: each mode alone in its process, alternated with the default's round by round."""
    for mode in modes[1:]:
        ratios = []
        for r in range(a.rounds):
            if r % 2 == 0:
                base = runAlone(a, case, DEFAULT)
                other = runAlone(a, case, mode)
            else:
                other = runAlone(a, case, mode)
                base = runAlone(a, case, DEFAULT)
            ratios.append(other / base)
        q = statistics.quantiles(ratios, n=4, method="inclusive") if len(ratios) > 1 else [ratios[0]] * 3
        print(f"{case:<7}{' + '.join(mode.split()):<26} alone, median of {len(ratios)} rounds "
              f"{statistics.median(ratios):.3f} (quartiles {q[0]:.3f}-{q[2]:.3f}, range "
              f"{min(ratios):.3f}-{max(ratios):.3f})", flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--exe", default=os.path.join(ROOT, "build", "bench_block_v2"))
    p.add_argument("--repeats", type=int, default=3, help="invocations per case")
    p.add_argument("--cases", default="gimp2,gimp3")
    p.add_argument("--sizes", default="1e5")
    p.add_argument("--size3d", default="5e4")
    p.add_argument("--min-time", type=float, default=4.0, help="seconds of steps per mode and invocation")
    p.add_argument("--modes", default="APIC smallStrain,FLIP corotational,APIC corotational",
                   help="comma-separated 'TRANSFER STRESSUPDATE' pairs")
    p.add_argument("--control", action="store_true", help="also time the default against itself")
    p.add_argument("--separate", action="store_true",
                   help="each mode alone in its own process, alternated with the default's (see above)")
    p.add_argument("--rounds", type=int, default=11, help="with --separate: rounds (pairs of processes) per mode")
    p.add_argument("--cpus", type=cpuList, default=None,
                   help="run the benchmark on these CPUs only (e.g. 0; default: anywhere)")
    a = p.parse_args()
    if a.separate and a.control:
        p.error("--separate and --control exclude each other (--separate has one scene per process)")
    if a.rounds < 1:
        p.error(f"--rounds {a.rounds}: at least 1")
    modes = [DEFAULT] + [m.strip() for m in a.modes.split(",")] + ([DEFAULT] if a.control else [])
    if a.separate:
        print(f"time per step over the default's ({DEFAULT}), each mode alone in its own process, CPU time, "
              f"one thread, {a.min_time} s per process")
        for case in a.cases.split(","):
            separate(a, case, modes)
        return
    print(f"time per step over the default's ({DEFAULT}), one process per invocation stepping the modes in "
          f"turn, CPU time, one thread, {a.min_time} s per mode")
    print(f"{'case':<7}{'mode':<26}{'total':>8}{'rounds: median':>16}{'q1-q3':>14}")
    for case in a.cases.split(","):
        totals = {m: [] for m in range(1, len(modes))}
        for _ in range(a.repeats):
            rows = run(a, case, modes)
            for m in range(1, len(modes)):
                r = rows[m]
                totals[m].append(r["time_ratio_to_first_mode"])
                name = " + ".join(modes[m].split()) + (" (control)" if a.control and m == len(modes) - 1 else "")
                print(f"{case:<7}{name:<26}{r['time_ratio_to_first_mode']:>8.3f}{r['median_round_ratio']:>16.3f}"
                      f"{r['round_ratio_q1']:>8.3f}-{r['round_ratio_q3']:.3f}", flush=True)
        for m in range(1, len(modes)):
            v = totals[m]
            print(f"{case:<7}{' + '.join(modes[m].split()):<26} median of {len(v)} invocations "
                  f"{statistics.median(v):.3f} (range {min(v):.3f}-{max(v):.3f})", flush=True)


if __name__ == "__main__":
    main()
