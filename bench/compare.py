#!/usr/bin/env python3
"""Paired speed comparison of two commits: builds bench_block of each (in a git worktree per
commit under --workdir) and runs them in alternating rounds in one invocation, so that a slow
spell of the shared machine hits both. Prints, per case, the median over the rounds of the
ratio NEW/OLD of particle-steps per second and its spread (min, quartiles, max). With --steps
the builds also time exactly that many steps and their checksums are compared: an optimisation
that keeps the arithmetic keeps them.

    /usr/bin/python3.11 bench/compare.py OLD NEW [--rounds 7] [--cases gimp2,gimp3]
        [--sizes 1e5] [--size3d 1e5] [--threads 1] [--min-time 2] [--steps N] [--metric cpu]
        [--bench-args "--transfer APIC --stress-update corotational"]
        [--old-target bench_block] [--new-target bench_block_v2] [--cpus 0] [--new-args=--erosion]

--new-args=ARGS adds arguments to NEW's runs only (with the "=", as they begin with "--"):
--new-args=--erosion times NEW with an erosion stage attached (one that never fires, so the
checksums still compare) against OLD without one, where OLD's bench_block has no such option
(issue 12 item 1, "with eigenerosion attached").

--metric cpu rates each run by its CPU time (points x steps / CPU seconds) instead of its wall
time: on one thread it is much less sensitive to other jobs on a shared machine (they still
share caches and memory bandwidth), but it cannot measure thread scaling.

--cpus 0 runs every benchmark on CPU 0 only (os.sched_setaffinity; a list such as 0,1 for two
threads). On this project's 2-vCPU machine the two vCPUs ran at different speeds for minutes at
a time, and an unpinned run landed on either: rounds' ratios spread over 0.6-1.7, against
0.92-1.06 pinned (doc/performance.md, "Session 37").

OLD and NEW are anything git rev-parse takes (a commit, a branch, HEAD). NEW may also be
'worktree': the current working tree as it is (built in build-compare/ beside build/).
Exit status 1 when a checksum differs.
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys

from cpus import cpuList, pinning

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, text=True, **kw)


def build(rev, workdir, jobs, target="bench_block"):
    """Path of the benchmark `target` built from rev (a worktree per commit, reused when it exists)."""
    if rev == "worktree":
        src, bld = ROOT, os.path.join(ROOT, "build-compare")
    else:
        sha = run(["git", "-C", ROOT, "rev-parse", "--short=12", rev], capture_output=True).stdout.strip()
        src = os.path.join(workdir, sha)
        if not os.path.isdir(src):
            run(["git", "-C", ROOT, "worktree", "add", "--detach", src, sha], capture_output=True)
        bld = os.path.join(src, "build")
    run(["cmake", "-S", src, "-B", bld, "-DCMAKE_BUILD_TYPE=Release",
         "-DPython3_EXECUTABLE=/usr/bin/python3.11"], stdout=subprocess.DEVNULL)
    run(["cmake", "--build", bld, "--target", target, "-j", str(jobs)], stdout=subprocess.DEVNULL)
    return os.path.join(bld, target)


def measure(exe, a, extra=""):
    cmd = [exe, "--sizes", a.sizes, "--size3d", a.size3d, "--threads", a.threads, "--cases", a.cases,
           "--warmup", "2"]
    cmd += ["--steps", str(a.steps)] if a.steps else ["--min-time", str(a.min_time)]
    cmd += shlex.split(a.bench_args) + shlex.split(extra)
    out = run(cmd, capture_output=True, preexec_fn=pinning(a.cpus)).stdout
    rows = [json.loads(line[5:]) for line in out.splitlines() if line.startswith("JSON ")]
    return {(r["case"], r["points"], r["threads"]): r for r in rows}


def rate(row, metric):
    """Particle-steps per second of one run, by wall or CPU time."""
    if metric == "cpu":
        return row["points"] * row["steps"] / row["cpu_time_s"]
    return row["particle_steps_per_s"]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("old")
    p.add_argument("new")
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--cases", default="gimp2,gimp3")
    p.add_argument("--sizes", default="1e5")
    p.add_argument("--size3d", default="1e5")
    p.add_argument("--threads", default="1")
    p.add_argument("--min-time", type=float, default=2.0)
    p.add_argument("--steps", type=int, default=0, help="exactly N timed steps (checksums compared)")
    p.add_argument("--metric", choices=("wall", "cpu"), default="wall",
                   help="rate by wall time (default) or CPU time (one thread on a busy machine)")
    p.add_argument("--bench-args", default="",
                   help="more arguments for both builds' bench_block (the option modes: --transfer, --stress-update)")
    p.add_argument("--new-args", default="",
                   help="more arguments for NEW's runs only (--erosion: NEW with an erosion stage that never fires)")
    p.add_argument("--old-target", default="bench_block",
                   help="the benchmark built from OLD: bench_block, or bench_block_v2 (the x86-64-v2 build "
                        "that the Python module runs on such a processor, since session 17)")
    p.add_argument("--new-target", default="bench_block", help="the same for NEW")
    p.add_argument("--workdir", default="/tmp/emp-compare")
    p.add_argument("--jobs", type=int, default=os.cpu_count())
    p.add_argument("--cpus", type=cpuList, default=None,
                   help="run every benchmark on these CPUs only (e.g. 0; default: anywhere)")
    a = p.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    exe = {"old": build(a.old, a.workdir, a.jobs, a.old_target), "new": build(a.new, a.workdir, a.jobs, a.new_target)}
    ratios, checks = {}, {}
    for r in range(a.rounds):
        res = {}
        # Alternate which build runs first, so that a trend in the machine's speed cancels.
        for which in (("old", "new") if r % 2 == 0 else ("new", "old")):
            res[which] = measure(exe[which], a, a.new_args if which == "new" else "")
        for key in res["old"]:
            ratios.setdefault(key, []).append(rate(res["new"][key], a.metric) / rate(res["old"][key], a.metric))
            checks.setdefault(key, set()).add((res["old"][key]["checksum"], res["new"][key]["checksum"]))
        print(f"round {r + 1}/{a.rounds}: " + ", ".join(f"{k[0]} {k[1]} pts {k[2]} thr {ratios[k][-1]:.3f}"
                                                        for k in ratios), flush=True)
    print(f"\nNEW/OLD particle-steps per {a.metric} second, {a.rounds} alternating rounds "
          f"(old {a.old}, new {a.new}{' ' + a.new_args if a.new_args else ''}):")
    print(f"{'case':<12}{'points':>9}{'threads':>8}{'median':>8}{'min':>8}{'q1':>8}{'q3':>8}{'max':>8}  checksums")
    bad = False
    for key, rs in ratios.items():
        q = statistics.quantiles(rs, n=4) if len(rs) > 1 else [rs[0]] * 3
        same = "-"
        if a.steps:
            same = "equal" if all(o == n for o, n in checks[key]) else "DIFFER"
            bad = bad or same == "DIFFER"
        print(f"{key[0]:<12}{key[1]:>9}{key[2]:>8}{statistics.median(rs):>8.3f}{min(rs):>8.3f}"
              f"{q[0]:>8.3f}{q[2]:>8.3f}{max(rs):>8.3f}  {same}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
