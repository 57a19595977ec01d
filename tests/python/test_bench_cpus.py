"""bench/cpus.py: the --cpus option of bench/compare.py and bench/option_cost.py (each benchmark
run pinned to the CPUs given)."""
import argparse
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench"))
import cpus  # noqa: E402


def test_a_list_of_allowed_cpus_is_taken():
    first = min(os.sched_getaffinity(0))
    assert cpus.cpuList(str(first)) == {first}
    assert cpus.cpuList(",".join(map(str, sorted(os.sched_getaffinity(0))))) == os.sched_getaffinity(0)


@pytest.mark.parametrize("text,says", [("x", "comma-separated list"), ("0,,1", "comma-separated list"),
                                       ("4096", "may run on CPUs")])
def test_a_bad_list_is_refused_naming_the_value(text, says):
    with pytest.raises(argparse.ArgumentTypeError) as e:
        cpus.cpuList(text)
    assert repr(text) in str(e.value) and says in str(e.value)


def test_the_child_runs_on_the_cpus_given_and_anywhere_without():
    first = min(os.sched_getaffinity(0))
    show = [sys.executable, "-c", "import os; print(sorted(os.sched_getaffinity(0)))"]
    pinned = subprocess.run(show, check=True, text=True, capture_output=True, preexec_fn=cpus.pinning({first}))
    assert pinned.stdout.strip() == str([first])
    assert cpus.pinning(None) is None
    free = subprocess.run(show, check=True, text=True, capture_output=True, preexec_fn=cpus.pinning(None))
    assert free.stdout.strip() == str(sorted(os.sched_getaffinity(0)))
