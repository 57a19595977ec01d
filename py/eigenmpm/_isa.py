"""Which build of the compiled module this processor runs.

The module is built twice from the same sources: ``_eigenmpm`` for any x86-64 processor and,
where the compiler offers it, ``_eigenmpm_v2`` for x86-64-v2 (SSE3, SSSE3, SSE4.1, SSE4.2,
POPCNT, CMPXCHG16B, LAHF: every x86-64 processor since about 2009). The second computes the same
values with fewer instructions (doc/performance.md, "Session 17"): results are bitwise equal
(tests/python/test_isa.py), so the choice changes only the speed. ``load()`` imports the one the
processor can run, once, before anything else of the package, and makes it
``eigenmpm._eigenmpm`` for the rest of the package; the baseline one is never imported then.

The environment variable ``EIGENMPM_ISA`` overrides the choice: ``x86-64`` (the baseline
module), ``x86-64-v2`` (an error when the processor or the build lacks it) or ``auto`` (the
default).
"""
import importlib
import importlib.util
import os
import platform
import sys

LEVELS = ("x86-64", "x86-64-v2")
# The processor features x86-64-v2 adds (the x86-64 psABI), as Linux names them in /proc/cpuinfo.
V2_FLAGS = frozenset(("cx16", "lahf_lm", "popcnt", "pni", "ssse3", "sse4_1", "sse4_2"))
_MODULES = {"x86-64": "_eigenmpm", "x86-64-v2": "_eigenmpm_v2"}


def cpuFlags(path="/proc/cpuinfo"):
    """The feature flags of the first processor listed in `path`; empty when unreadable."""
    try:
        with open(path) as f:
            for line in f:
                if line.startswith("flags"):
                    return frozenset(line.split(":", 1)[1].split())
    except OSError:
        pass
    return frozenset()


def processorLevel(flags=None, machine=None):
    """The highest level of LEVELS this processor runs ('x86-64' when in doubt)."""
    machine = platform.machine() if machine is None else machine
    if machine not in ("x86_64", "AMD64"):
        return "x86-64"
    return "x86-64-v2" if V2_FLAGS <= (cpuFlags() if flags is None else flags) else "x86-64"


def _built(level):
    return importlib.util.find_spec(f"{__package__}.{_MODULES[level]}") is not None


def choose(requested=None, level=None, built=_built):
    """The level to import: `requested` ('auto', 'x86-64' or 'x86-64-v2'; default: the
    environment's EIGENMPM_ISA or 'auto') on a processor of `level` (default: this one)."""
    requested = (os.environ.get("EIGENMPM_ISA", "auto") if requested is None else requested).strip() or "auto"
    level = processorLevel() if level is None else level
    if requested == "auto":
        return "x86-64-v2" if level == "x86-64-v2" and built("x86-64-v2") else "x86-64"
    if requested not in LEVELS:
        raise ImportError(f"EigenMPM: EIGENMPM_ISA={requested!r} is invalid; allowed: auto, {', '.join(LEVELS)}")
    if requested == "x86-64-v2" and level != "x86-64-v2":
        raise ImportError(f"EigenMPM: EIGENMPM_ISA=x86-64-v2 is invalid on this processor (it lacks "
                          f"{', '.join(sorted(V2_FLAGS - cpuFlags())) or 'x86-64'}); allowed: auto, x86-64")
    if not built(requested):
        raise ImportError(f"EigenMPM: EIGENMPM_ISA={requested} is invalid: this build has no "
                          f"{_MODULES[requested]} module (configure with -DEMP_ISA_VARIANTS=ON); "
                          "allowed: auto, x86-64")
    return requested


def load():
    """Imports the chosen module as eigenmpm._eigenmpm and returns (module, level)."""
    level = choose()
    module = importlib.import_module(f"{__package__}.{_MODULES[level]}")
    sys.modules[f"{__package__}._eigenmpm"] = module
    return module, level
