"""The README's quick start runs as shipped and gives the elastic energy of the pulled bar."""
import math
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_quickstart_runs_and_writes_its_outputs(tmp_path):
    script = os.path.join(ROOT, "examples", "quickstart.py")
    readme = open(os.path.join(ROOT, "README.md")).read()
    shipped = open(script).read()
    code = readme.split("```python\n# examples/quickstart.py\n")[1].split("```")[0]
    assert code in shipped, "README snippet and examples/quickstart.py differ"
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", script], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    for name in ("bar-00000000.vtp", "bar-00001000.vtp", "bar-series.pvd", "energy.png"):
        assert (tmp_path / "out" / name).exists(), name


def test_yade_batch_table_runs_each_line(tmp_path):
    table = tmp_path / "bar.table"
    table.write_text("cells shape plot\n10 'uGIMP' 0\n20 'linear' 0\n")
    script = os.path.join(ROOT, "examples", "verification", "vibrating_bar.py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade-batch", "-j", "1", "--log", "job%.log", str(table), script],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
                         stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    import json
    a = json.load(open(tmp_path / "out" / "vibrating_bar" / "cells=10,shape=uGIMP,plot=0" / "summary.json"))
    b = json.load(open(tmp_path / "out" / "vibrating_bar" / "cells=20,shape=linear,plot=0" / "summary.json"))
    assert (a["cells_along_bar"], a["shape"]) == (10, "uGIMP")
    assert (b["cells_along_bar"], b["shape"]) == (20, "linear")
    assert not (tmp_path / "out" / "vibrating_bar" / "tip_displacement.png").exists()


def test_bar_convergence_quick_runs(tmp_path):
    script = os.path.join(ROOT, "examples", "verification", "bar_convergence.py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", script, "--quick", "--out", str(tmp_path)], env=env, capture_output=True,
                         text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    import json
    rows = json.load(open(tmp_path / "convergence.json"))
    assert [r["cells"] for r in rows] == [10, 20, 40, 10, 20, 40]
    assert all(abs(r["order"] - 2.0) < 0.2 for r in rows if r["cells"] > 10)  # measured 2.00
    assert (tmp_path / "convergence.png").exists() and (tmp_path / "convergence.md").exists()


@pytest.mark.parametrize("name", ["lshaped_panel", "dem_lshaped_panel"])
def test_lpanel_examples_read_the_experiment_shipped_with_them(name, monkeypatch):
    """The experimental band is in examples/data (a clone has no ../shared)."""
    import importlib.util
    import sys
    script = os.path.join(ROOT, "examples", name + ".py")
    assert "shared" not in open(script).read()
    monkeypatch.setattr(sys, "argv", [script])  # as under `yade -x script`
    spec = importlib.util.spec_from_file_location(f"example_{name}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    band = module.experiment()
    d, lower, upper = (band[:, 0], band[:, 1], band[:, 2]) if name == "lshaped_panel" else band[1:]
    assert len(d) == 10 and (lower <= upper).all()
    assert (lower.max(), upper.max(), d[upper.argmax()]) == (6.7, 7.6, 0.2)  # the peak band of the data


def test_make_demo_runs_the_quick_branching_plate_and_the_readme_shows_its_damage_map():
    makefile = open(os.path.join(ROOT, "Makefile")).read()
    recipe = makefile.split("\ndemo: build\n")[1].split("\n\n")[0]
    assert "yade -n -x examples/crack_branching.py --quick --out out/demo" in recipe
    for name in ("damage.png", "energy.png", "tip_speed.png", "summary.json"):  # what the example writes
        assert f"out/demo/{name}" in recipe and f"DIR/{name}" in open(os.path.join(ROOT, "examples",
                                                                                  "crack_branching.py")).read()
    readme = open(os.path.join(ROOT, "README.md")).read()
    assert "](doc/img/demo_branching_damage.png)" in readme
    assert os.path.getsize(os.path.join(ROOT, "doc", "img", "demo_branching_damage.png")) < 100_000


def test_griffith_initiation_quick_starts_near_griffith_and_alpha_2_at_the_predicted_factor(tmp_path):
    """examples/verification/griffith_initiation.py --quick (h = 2 mm, a/h = 2): with
    alpha='griffith' the centre crack starts at 0.81 sigma_G here (0.89 at a/h = 4, 0.94 at 8,
    doc/validation.md); with alpha = 2 the traction at initiation is higher by sqrt(alpha_G / 2)
    (Eq 24: G = Gc / (alpha r) and G ~ sigma^2), measured 1.754 here (1.70-1.71 at finer h) against
    1.725."""
    import json
    script = os.path.join(ROOT, "examples", "verification", "griffith_initiation.py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    runs = {}
    for alpha in ("griffith", "2"):
        out = tmp_path / alpha
        res = subprocess.run(["yade", "-n", "-x", script, "--quick", f"alpha={alpha}", "--out", str(out)], env=env,
                             capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
        assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
        runs[alpha] = json.load(open(out / "summary.json"))
    g, p = runs["griffith"], runs["2"]
    assert g["alpha_used"] == pytest.approx(5.951, abs=0.01)  # 1 / 0.168: glass, plane strain, spectral
    assert 0.7 < g["initiation_ratio"] < 1.0
    assert p["initiation_ratio"] / g["initiation_ratio"] == pytest.approx(math.sqrt(g["alpha_used"] / 2.0), rel=0.03)
    # Both tips start together (the plate and the crack are symmetric about x = W/2).
    xs = sorted(x for x, _ in g["first_eroded"])
    assert xs[0] + xs[-1] == pytest.approx(g["W_m"], abs=1e-9)
    # tools/griffith_figures.py draws its two figures from these run directories.
    import griffith_figures
    griffith_figures.main([str(tmp_path), "--outdir", str(tmp_path / "img")])
    for name in ("griffith_convergence.png", "griffith_grid_bias.png"):
        assert os.path.getsize(tmp_path / "img" / name) > 10_000


@pytest.mark.parametrize("extra", [["geometry=edge"], ["angle_deg=30", "tipShift=0.25"]])
def test_griffith_initiation_quick_edge_crack_and_turned_specimen(tmp_path, extra):
    """The edge crack (Tada's correction) and a specimen turned by 30 degrees against the grid with
    its tips a quarter cell off the node lines start near sigma_G with alpha='griffith' too
    (--quick, a/h = 2: measured 0.876 for the edge crack; doc/validation.md has the fine values)."""
    import json
    script = os.path.join(ROOT, "examples", "verification", "griffith_initiation.py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", script, "--quick", *extra, "--out", str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    s = json.load(open(tmp_path / "summary.json"))
    assert 0.7 < s["initiation_ratio"] < 1.05
    assert s["particles"] == pytest.approx(1600, abs=40)  # the turned square holds as many points


def test_griffith_initiation_quick_inclined_crack_against_the_mixed_mode_predictions(tmp_path):
    """A centre crack inclined by 30 degrees (mixed mode) against the straight one, --quick: the
    initiation traction rises by the factor Eq 24 predicts on the mixed field (sqrt(r_I / r(30)) /
    cos 30 = 1.052; measured 1.097 at a/h = 2, doc/validation.md has finer values), and the crack
    kinks away from the load's normal, as the maximum hoop stress criterion says (-43 degrees;
    measured -32 here)."""
    import json
    script = os.path.join(ROOT, "examples", "verification", "griffith_initiation.py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    runs = {}
    for angle in ("0", "30"):
        out = tmp_path / angle
        res = subprocess.run(["yade", "-n", "-x", script, "--quick", f"crackAngle_deg={angle}", "kinkPoints=30",
                              "ratioMax=2", "--out", str(out)], env=env, capture_output=True, text=True, timeout=300,
                             stdin=subprocess.DEVNULL)
        assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
        runs[angle] = json.load(open(out / "summary.json"))
    s = runs["30"]
    assert s["pred_erosion_ratio"] == pytest.approx(1.052, abs=0.002)
    assert s["pred_mts_kink_deg"] == pytest.approx(-43.2, abs=0.1)
    assert s["initiation_ratio"] / runs["0"]["initiation_ratio"] == pytest.approx(s["pred_erosion_ratio"], rel=0.08)
    assert -60 < s["kink_deg"] < -15
    m = pytest.importorskip("eigenmpm")._eigenmpm
    assert m.initiationRatio(2, 32e9, 0.2, False, "spectral", mixity_deg=0.0) == m.initiationRatio(2, 32e9, 0.2, False, "spectral")
    assert m.initiationRatio(2, 32e9, 0.2, False, "spectral", mixity_deg=90.0) == pytest.approx(
        m.initiationRatio(2, 32e9, 0.2, False, "spectral", mode="II"), rel=1e-12)


def test_griffith_initiation_quick_propagation_energy_outputs(tmp_path):
    """With kinkPoints the straight crack grows on; the summary compares the engine's dissipated
    energy (Eq 33) with Gc t times the length grown, and gives |C_kappa| / (2 kappa) of the eroded
    set, which for any cut of length L is at least L (plus pi kappa / 2 per free end for a
    straight one). --quick (h = 2 mm): the crack cuts the plate (31 mm grown). It also checks the
    energy balance over the run (energy.csv and the summary keys)."""
    import json

    import numpy as np
    script = os.path.join(ROOT, "examples", "verification", "griffith_initiation.py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", script, "--quick", "kinkPoints=60", "ratioMax=2", "--out", str(tmp_path)],
                         env=env, capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    s = json.load(open(tmp_path / "summary.json"))
    assert s["eroded_points"] >= 60
    assert 0.02 < s["grown_length_m"] <= 0.032  # at most the ligaments, 2 x 16 mm
    assert s["C_kappa_over_2kappa_m"] > s["grown_length_m"]
    vol = (s["h_m"] / 2) ** 2  # the points' area, ppc = 2, thickness 1 m
    assert s["dissipated_over_Gc_t_m"] == pytest.approx(s["eroded_points"] * vol / (2 * s["kappa_m"]), rel=1e-9)
    # The energy balance Ek + Ee + Psi_f - Wext (energy.csv, every 20 steps and at the stop).
    e = np.loadtxt(tmp_path / "energy.csv", delimiter=",", skiprows=1)
    assert open(tmp_path / "energy.csv").readline().strip() == "t_s,Ek_J,Ee_J,Psi_f_J,Wext_J,balance_J,eroded"
    assert e[:, 5] == pytest.approx(e[:, 1] + e[:, 2] + e[:, 3] - e[:, 4], abs=1e-8)  # 9 digits in the CSV
    assert s["external_work_J"] == pytest.approx(e[-1, 4], rel=1e-8)
    assert s["dissipated_energy_J"] == pytest.approx(s["dissipated_J"], rel=1e-12)
    assert s["energy_balance_max_abs_J"] == pytest.approx(np.max(np.abs(e[:, 5] - e[0, 5])), abs=1e-8)
    # Before the crack grows the scheme keeps the balance within 1 % of the work done (measured
    # 0.2 %); during growth it drifts by +6.3 % of the interval's external work (Eq 33 books
    # more than the mechanical energy Ek + Ee - Wext the growth gives up), while without Psi_f
    # it would drift by -15 %: the 10 % bound catches a balance that forgot the dissipation.
    i = np.flatnonzero(e[:, 6] == 0)[-1]
    assert abs(e[i, 5]) < 0.01 * e[i, 4]
    assert s["growth_external_work_J"] == pytest.approx(e[-1, 4] - e[i, 4], rel=1e-6)
    assert abs(s["growth_balance_drift_over_work"]) < 0.1
    assert abs(s["growth_drift_without_Ef_over_work"]) > 0.1


def test_script_parameters_take_alpha_griffith_and_refuse_other_words():
    """Every example's command line takes alpha=griffith (EigenErosion's keyword) in place of a
    number; any other word is refused with the parameter's name, as before."""
    from eigenmpm.cli import scriptArgs
    o, _, _ = scriptArgs("x", dict(alpha=2.0, h_mm=1.0), argv=["alpha=Griffith", "h_mm=0.5"])
    assert o == dict(alpha="griffith", h_mm=0.5)
    assert scriptArgs("x", dict(alpha=2.0), argv=["alpha=1.5"])[0]["alpha"] == 1.5
    with pytest.raises(SystemExit, match="alpha = 'grifith' is not a float"):
        scriptArgs("x", dict(alpha=2.0), argv=["alpha=grifith"])
    with pytest.raises(SystemExit, match="h_mm = 'griffith' is not a float"):
        scriptArgs("x", dict(h_mm=1.0), argv=["h_mm=griffith"])
