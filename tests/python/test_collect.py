"""tools/collect.py lays out sweep summaries like the paper's tables."""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_collect_lays_out_rows_and_columns(tmp_path):
    for alpha in (1.0, 2.0):
        for kappa in (0.9, 1.1):
            d = tmp_path / f"alpha={alpha},kappaOverH={kappa}"
            d.mkdir()
            (d / "summary.json").write_text(json.dumps({
                "parameters": {"alpha": alpha, "kappaOverH": kappa},
                "peak_load_kN": 10 * alpha + kappa, "displacement_at_peak_mm": alpha / 10}))
    res = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "collect.py"), str(tmp_path),
                          "--rows", "alpha", "--cols", "kappaOverH", "--value", "peak_load_kN",
                          "--csv", str(tmp_path / "t.csv")], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[0] == "| alpha | peak_load_kN kappaOverH=0.9 | peak_load_kN kappaOverH=1.1 |"
    assert lines[2] == "| 1 | 10.9 | 11.1 |" and lines[3] == "| 2 | 20.9 | 21.1 |"
    assert (tmp_path / "t.csv").read_text().splitlines()[1] == "1,10.9,11.1"
