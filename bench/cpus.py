"""Pinning a benchmark's processes to chosen CPUs (bench/compare.py, bench/option_cost.py --cpus).

On this project's 2-vCPU machine the two vCPUs ran at different speeds for minutes at a time,
and an unpinned benchmark landed on either: the same binary's runs differed by up to 40 %
(doc/performance.md, "Session 37").
"""
import argparse
import os


def cpuList(text):
    """The CPUs of a list such as "0" or "0,1" (argparse type)."""
    try:
        cpus = {int(c) for c in text.split(",")}
    except ValueError:
        raise argparse.ArgumentTypeError(f"--cpus {text!r}: a comma-separated list of CPU numbers, such as 0 or 0,1")
    allowed = os.sched_getaffinity(0)
    if not cpus <= allowed:
        raise argparse.ArgumentTypeError(f"--cpus {text!r}: this process may run on CPUs {sorted(allowed)} only")
    return cpus


def pinning(cpus):
    """A preexec_fn that keeps the child on `cpus` (None: no pinning)."""
    if not cpus:
        return None
    return lambda: os.sched_setaffinity(0, cpus)
