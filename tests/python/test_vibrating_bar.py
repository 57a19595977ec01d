"""Fixed-free vibrating bar against omega1 = (pi / 2L) sqrt(E / rho); the shipped script is run."""
import json
import math
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "examples", "verification", "vibrating_bar.py")
sys.path.insert(0, os.path.dirname(SCRIPT))
import vibrating_bar  # noqa: E402

KEYS = {"omega_numeric", "omega_analytic", "rel_error", "particles", "steps", "wall_time_s",
        "particle_steps_per_s"}


def test_script_quick_writes_summary_and_plot(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", SCRIPT, "--quick", "--out", str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    summary = json.load(open(tmp_path / "summary.json"))
    assert KEYS <= set(summary)
    assert summary["omega_analytic"] == pytest.approx(0.5 * math.pi * math.sqrt(1e7 / 1000.0))
    assert summary["rel_error"] < 0.01
    assert summary["particles"] > 0 and summary["steps"] > 0 and summary["particle_steps_per_s"] > 0
    assert (tmp_path / "tip_displacement.png").stat().st_size > 10000


def test_default_resolution_within_one_percent():
    summary, _, _ = vibrating_bar.run()
    assert summary["rel_error"] < 0.01


@pytest.mark.parametrize("shape", ["uGIMP", "linear"])
def test_error_falls_under_refinement(shape):
    errors = [vibrating_bar.run(cells=c, shape=shape)[0]["rel_error"] for c in (10, 20, 40)]
    assert errors[0] > errors[1] > errors[2]
    order = math.log(errors[0] / errors[2]) / math.log(4.0)
    assert order > 1.8  # measured 2.00 (doc/verification.md)


def test_frequency_independent_of_amplitude_sign():
    a = vibrating_bar.run(cells=20, v0=1e-3)[0]["omega_numeric"]
    b = vibrating_bar.run(cells=20, v0=-1e-3)[0]["omega_numeric"]
    assert a == pytest.approx(b, rel=1e-6)
