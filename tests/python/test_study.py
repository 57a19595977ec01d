"""The speed/accuracy study tool (tools/study.py): a tiny real sweep, the Pareto
front, the error measures on synthetic runs, and the messages for bad knobs."""
import csv
import json
import math
import os
import subprocess

import pytest

import study  # tools/study.py (conftest puts tools/ on sys.path)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_tiny_bar_sweep_writes_table_and_plot_and_error_falls_with_h(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    out = tmp_path / "bar"
    res = subprocess.run(["yade", "-n", "-x", os.path.join(ROOT, "tools", "study.py"), "bar", "h=250,125",
                          "periods=1", "--out", str(out)], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=120, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    for name in ("study.csv", "study.md", "study.json", "pareto.png"):
        assert (out / name).exists(), name
    assert 0 < (out / "pareto.png").stat().st_size < 200_000
    rows = list(csv.DictReader(open(out / "study.csv")))
    assert [r["h"] for r in rows] == ["250", "125"]
    assert [r["status"] for r in rows] == ["ok", "ok"]
    # h = 250 mm is 4 cells along the 1 m bar (the generic knob h in mm becomes the script's cells)
    runs = [json.load(open(out / "runs" / f"run_{i:03d}" / "summary.json")) for i in range(2)]
    assert [s["cells_along_bar"] for s in runs] == [4, 8]
    coarse, fine = (float(r["err_freq"]) for r in rows)
    assert fine < 0.5 * coarse  # the frequency error falls with h (second order: about 4 times)
    assert coarse == pytest.approx(runs[0]["rel_error"])  # closed-form reference: the script's own error
    assert all(float(r["cpu_s"]) > 0 and int(r["particles"]) > 0 for r in rows)
    md = (out / "study.md").read_text()
    assert "reference: closed form" in md and "| run_001 | 125 |" in md and "error <= 5 %" in md


def test_pareto_front_on_a_synthetic_set():
    cost = [1.0, 2.0, 3.0, 4.0, 2.0, 5.0, float("nan"), 0.5]
    err = [10.0, 5.0, 6.0, 1.0, 5.0, 1.0, 0.1, float("nan")]
    # (3, 6) is dominated by (2, 5); (5, 1) by (4, 1); the two equal points (2, 5) both stay
    assert study.paretoFront(cost, err) == [True, True, False, True, True, False, False, False]
    assert study.paretoFront([1.0], [1.0]) == [True]
    assert study.paretoFront([1.0, 1.0], [2.0, 1.0]) == [False, True]  # same cost, smaller error wins


def test_recommend_picks_the_cheapest_run_within_each_target():
    rows = [dict(run="a", cost=10.0, cpu_s=10.0, error=0.004), dict(run="b", cost=3.0, cpu_s=3.0, error=0.03),
            dict(run="c", cost=1.0, cpu_s=1.0, error=0.15), dict(run="d", cost=0.5, cpu_s=0.5, error=float("nan"))]
    rec = study.recommend(rows, targets=(0.001, 0.01, 0.05, 0.2))
    assert rec[0.001] is None
    assert [rec[t]["run"] for t in (0.01, 0.05, 0.2)] == ["a", "b", "c"]


def test_error_measures_on_synthetic_runs(tmp_path):
    import numpy as np
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    line = np.column_stack([np.linspace(0, 100, 51), np.full(51, 250.0)])
    np.savetxt(a / "eroded.csv", line, delimiter=",", header="x_mm,y_mm", comments="")
    np.savetxt(b / "eroded.csv", line + [0.0, 4.0], delimiter=",", header="x_mm,y_mm", comments="")
    ref = {"peak_load_kN": 20.0, "crack_front_distance_m": 0.2}
    e = study.errors("lshaped_panel", {"peak_load_kN": 22.0}, str(b), ref, str(a))
    assert e["peak"] == pytest.approx(0.1)
    assert e["path_mm"] == pytest.approx(4.0)  # the same path 4 mm higher
    assert e["path"] == pytest.approx(4.0 / 200.0)  # over the reference crack length
    assert study.pathDistance(line, line) == 0.0
    assert math.isnan(study.pathDistance(line, np.zeros((0, 2))))
    # crack branching: energies of an h-thick plate are compared per unit thickness
    fine = {"branching_time_us": 32.0, "dissipated_energy_J": 0.002, "parameters": {"h_mm": 0.5}}
    coarse = {"branching_time_us": 36.0, "dissipated_energy_J": 0.0044, "parameters": {"h_mm": 1.0}}
    e = study.errors("crack_branching", coarse, None, fine, None)
    assert e["branch"] == pytest.approx(0.125) and e["energy"] == pytest.approx(0.1)
    e = study.errors("crack_branching", dict(coarse, branching_time_us=None), None, fine, None)
    assert math.isnan(e["branch"])
    bar = {"omega_numeric": 99.0, "omega_analytic": 100.0}
    assert study.errors("vibrating_bar", bar, None, "closed-form", None)["freq"] == pytest.approx(0.01)
    assert study.errors("vibrating_bar", bar, None, {"omega_numeric": 90.0}, None)["freq"] == pytest.approx(0.1)


@pytest.mark.parametrize("argv, words", [
    (["bar", "alpha=1,2"], ["unknown knob 'alpha'", "allowed: h, ppc, shape, dtFraction", "cells"]),
    (["lpanel", "shape=quad"], ["knob shape = 'quad'", "linear or uGIMP"]),
    (["lpanel", "ppc=0"], ["knob ppc = '0'", "integer >= 1"]),
    (["branching", "ppc=2.5"], ["knob ppc = '2.5'", "integer >= 1"]),
    (["branching", "dtFraction=0.2,1.5"], ["knob dtFraction = '1.5'", "0 < dtFraction <= 1"]),
    (["lpanel", "kappaOverH=-1"], ["knob kappaOverH = '-1'", "kappaOverH > 0"]),
    (["lpanel", "h=fine"], ["knob h = 'fine' is not a number", "h > 0 (mm)"]),
    (["bar", "h=30"], ["knob h = 30 mm does not divide the bar length", "1000/N mm"]),
    (["plate", "h=1"], ["unknown scene 'plate'", "vibrating_bar, lshaped_panel, crack_branching"]),
    (["lpanel", "h=10", "--reference", "closed-form"], ["closed-form exists only for vibrating_bar"]),
    (["bar", "h=100", "--cost", "money"], ["--cost 'money'", "cpu, loop, psteps"]),
    (["bar", "h="], ["bad knob argument 'h='", "knob=v1,v2"]),
    (["bar", "--fast"], ["unknown argument '--fast'"]),
])
def test_bad_knobs_and_options_name_what_is_allowed(argv, words, tmp_path):
    with pytest.raises(SystemExit) as err:
        study.main(argv + ["--out", str(tmp_path), "--dry-run"])
    message = str(err.value)
    assert message.startswith("study: ")
    for w in words:
        assert w in message, message
    assert not os.listdir(tmp_path)  # nothing was run


def test_dry_run_maps_the_generic_knobs_to_each_script(capsys):
    lines = []
    study.study("lpanel", ["h=10,5", "shape=LINEAR", "ppc=3"], out="o", dryRun=True, log=lines.append)
    assert len(lines) == 2 and lines[0].endswith("h_mm=10.0 shape=linear ppc=3")
    assert "examples/lshaped_panel.py --out o/runs/run_001" in lines[1] and "h_mm=5.0" in lines[1]
    lines = []
    study.study("bar", ["h=62.5", "dtFraction=0.9"], out="o", dryRun=True, log=lines.append)
    assert lines[0].endswith("plot=0 cells=16 dtFraction=0.9")


def _row(run, config, cpu, err, reference=False):
    return dict(run=run, dir=f"sweep/runs/{run}", config=config, status="ok", h_mm=1.0, dt_us=0.1, particles=10,
                steps=10, cpu_s=cpu, wall_s=cpu, loop_wall_s=cpu, particle_steps_per_s=1.0, load_avg=0.0,
                particle_steps=100, summary={}, reference=reference, errors={"freq": err}, error=err, cost=cpu)


def test_combine_merges_studies_against_one_reference(tmp_path):
    meta = dict(scene="vibrating_bar", script="examples/verification/vibrating_bar.py", reference="closed form",
                quick=False, errors=["freq"], command=None, cost="cpu", reference_dir="closed-form")
    a, b = tmp_path / "h", tmp_path / "ppc"
    study.finish(str(a), dict(meta, knobs=["h"]), [_row("run_000", {"h": "100"}, 1.0, 0.03),
                                                  _row("run_001", {"h": "50"}, 2.0, 0.01)], log=lambda *_: None)
    study.finish(str(b), dict(meta, knobs=["ppc"]), [_row("run_000", {"ppc": "3"}, 1.5, 0.005)], log=lambda *_: None)
    rows = study.combine([str(a), str(b)], str(tmp_path / "all"), log=lambda *_: None)
    assert [r["run"] for r in rows] == ["h/run_000", "h/run_001", "ppc/run_000"]
    assert [r["pareto"]["error"] for r in rows] == [True, False, True]  # (2 s, 1 %) loses to (1.5 s, 0.5 %)
    md = (tmp_path / "all" / "study.md").read_text()
    assert "| h/run_001 | 50 |  |" in md and (tmp_path / "all" / "pareto.png").exists()
    c = tmp_path / "other"
    study.finish(str(c), dict(meta, knobs=["h"], reference_dir="runs/run_004"), [_row("run_000", {"h": "9"}, 1, 0.1)],
                 log=lambda *_: None)
    with pytest.raises(study.StudyError, match="reference_dir"):
        study.combine([str(a), str(c)], str(tmp_path / "bad"))


def test_runs_stopped_early_keep_their_summary_and_only_repeatable_ones_are_reused(tmp_path):
    # A stand-in for yade: writes the summary it is told to (or none) into --out and exits with
    # the status it is told to; each call is counted.
    fake = tmp_path / "fake-yade"
    fake.write_text("#!/bin/sh\n"
                    "out=''; prev=''\n"
                    "for a in \"$@\"; do [ \"$prev\" = --out ] && out=$a; prev=$a; done\n"
                    "echo call >> \"$out/calls\"\n"
                    "[ -n \"$FAKE_SUMMARY\" ] && printf '%s' \"$FAKE_SUMMARY\" > \"$out/summary.json\"\n"
                    "exit $FAKE_STATUS\n")
    fake.chmod(0o755)

    def run(name, summary, status):
        os.environ.update(FAKE_SUMMARY=json.dumps(summary) if summary else "", FAKE_STATUS=str(status))
        try:
            out = tmp_path / name
            out.mkdir(exist_ok=True)
            rec = study.runOne("examples/crack_branching.py", str(out), [], yade=str(fake))
            return rec, study._status(rec, rec["summary"]), len((out / "calls").read_text().split())
        finally:
            del os.environ["FAKE_SUMMARY"], os.environ["FAKE_STATUS"]

    error = {"stopped_early": "point 3 left the grid", "steps": 10}
    rec, status, calls = run("error", error, 1)
    assert rec["returncode"] == 1 and rec["summary"] == error and status == "stopped early" and calls == 1
    rec, status, calls = run("error", error, 1)
    assert rec["reused"] and calls == 1  # a solver error repeats: not run again
    interrupted = {"stopped_early": "interrupted", "steps": 5}
    rec, status, calls = run("sigint", interrupted, 130)
    assert rec["summary"] == interrupted and status == "stopped early" and calls == 1
    rec, status, calls = run("sigint", interrupted, 130)
    assert not rec["reused"] and calls == 2  # an interrupted run is run again
    (tmp_path / "crash").mkdir()
    (tmp_path / "crash" / "summary.json").write_text(json.dumps({"stopped_early": None, "steps": 99}))
    os.utime(tmp_path / "crash" / "summary.json", (1e9, 1e9))  # left by an older run
    rec, status, calls = run("crash", None, 1)  # exits before writing its summary
    assert rec["summary"] is None and status == "failed (1)"
