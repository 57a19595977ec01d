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
    p.add_argument("--cpus", type=cpuList, default=None,
                   help="run the benchmark on these CPUs only (e.g. 0; default: anywhere)")
    a = p.parse_args()
    modes = [DEFAULT] + [m.strip() for m in a.modes.split(",")] + ([DEFAULT] if a.control else [])
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
