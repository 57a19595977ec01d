#!/usr/bin/env python3
"""What the transfer and stress-update options cost, in one build: for each mode, its CPU time per
step over the default's (FLIP + small strain), measured in pairs (the default and the mode back
to back, in alternating order, so that a slow spell of a shared machine hits both). Prints per
case and mode the median of the rounds' ratios and their range.

    /usr/bin/python3.11 bench/option_cost.py [--exe build/bench_block] [--rounds 9]
        [--cases gimp2,gimp3] [--sizes 1e5] [--size3d 5e4] [--min-time 1]
        [--modes "APIC smallStrain,FLIP corotational,APIC corotational"]
"""
import argparse
import json
import os
import statistics
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT = ("FLIP", "smallStrain")


def cpu_rate(a, case, mode):
    """Particle-steps per CPU second of one run of bench_block."""
    cmd = [a.exe, "--cases", case, "--sizes", a.sizes, "--size3d", a.size3d, "--threads", "1",
           "--min-time", str(a.min_time), "--warmup", "1", "--transfer", mode[0], "--stress-update", mode[1]]
    out = subprocess.run(cmd, check=True, text=True, capture_output=True).stdout
    row = next(json.loads(line[5:]) for line in out.splitlines() if line.startswith("JSON "))
    return row["points"] * row["steps"] / row["cpu_time_s"]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--exe", default=os.path.join(ROOT, "build", "bench_block"))
    p.add_argument("--rounds", type=int, default=9)
    p.add_argument("--cases", default="gimp2,gimp3")
    p.add_argument("--sizes", default="1e5")
    p.add_argument("--size3d", default="5e4")
    p.add_argument("--min-time", type=float, default=1.0)
    p.add_argument("--modes", default="APIC smallStrain,FLIP corotational,APIC corotational",
                   help="comma-separated 'TRANSFER STRESSUPDATE' pairs")
    a = p.parse_args()
    modes = [tuple(m.split()) for m in a.modes.split(",")]
    print(f"time per step over the default's (FLIP smallStrain), {a.rounds} paired rounds, CPU time, one thread")
    print(f"{'case':<7}{'mode':<26}{'median':>8}{'min':>8}{'max':>8}")
    for case in a.cases.split(","):
        for mode in modes:
            ratios = []
            for r in range(a.rounds):
                if r % 2 == 0:
                    d = cpu_rate(a, case, DEFAULT)
                    m = cpu_rate(a, case, mode)
                else:
                    m = cpu_rate(a, case, mode)
                    d = cpu_rate(a, case, DEFAULT)
                ratios.append(d / m)
            print(f"{case:<7}{' + '.join(mode):<26}{statistics.median(ratios):>8.3f}{min(ratios):>8.3f}"
                  f"{max(ratios):>8.3f}", flush=True)


if __name__ == "__main__":
    main()
