"""DEM fracture beside EigenMPM (eigenmpm.dem): the calibration rule, the pair of specimens, and
the shipped L-panel comparison in its quick mode."""
import json
import math
import os
import subprocess

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em
from eigenmpm import dem

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
E, NU, RHO, GC, FT = 30e9, 0.2, 2400.0, 100.0, 3e6


def test_calibration_rule_outputs():
    # Poisson: the fitted stiffness ratio gives nu back through the fit, within the allowed range
    a, b = dem.NU_FIT
    for nu in (0.18, 0.2, 0.25, 0.3):
        alpha = dem.stiffnessRatio(nu)
        assert 0 <= alpha <= dem.ALPHA_MAX
        assert a * (1 - alpha) / (b + alpha) == pytest.approx(nu, abs=1e-12)
    assert dem.stiffnessRatio(0.05) == dem.ALPHA_MAX and dem.stiffnessRatio(0.45) == 0.0
    with pytest.raises(ValueError):
        dem.stiffnessRatio(0.5)
    # affine modulus factor: alpha = 1 gives E = C L^2 kn / 3 = phi 12 / 4 * 5/5 E_b
    assert dem.modulusFactor(1.0) == pytest.approx(3 * dem.HCP_FRACTION)
    r = 0.005
    cpm = dem.calibrate("cpm", E, NU, FT, GC, r)
    m = cpm["material"]
    cE = cpm["modulusFactor"]
    assert m["young"] == pytest.approx(E / cE) and m["poisson"] == pytest.approx(dem.stiffnessRatio(NU))
    assert m["epsCrackOnset"] == pytest.approx(FT / E)  # bond onset strain = specimen's
    # relDuctility reproduces Gc through the bond-counting estimate
    Gc = 9 * dem.HCP_FRACTION * r * m["young"] * m["epsCrackOnset"] ** 2 * (0.5 + m["relDuctility"])
    assert Gc == pytest.approx(GC)
    jcf = dem.calibrate("jcfpm", E, NU, FT, GC, r)
    assert jcf["material"]["young"] == pytest.approx(0.5 * math.pi * E / cE)  # kn = young r
    assert jcf["material"]["tensileStrength"] == pytest.approx(FT / cE)
    # a correction scales bond modulus and strength and keeps Gc
    c2 = dem.calibrate("cpm", E, NU, FT, GC, r, correction=(0.9, 0.7))
    m2 = c2["material"]
    assert m2["young"] == pytest.approx(0.9 * m["young"])
    assert m2["young"] * m2["epsCrackOnset"] == pytest.approx(0.7 * m["young"] * m["epsCrackOnset"])
    assert 9 * dem.HCP_FRACTION * r * m2["young"] * m2["epsCrackOnset"] ** 2 * (0.5 + m2["relDuctility"]) \
        == pytest.approx(GC)
    with pytest.raises(ValueError, match="too large"):
        dem.calibrate("cpm", E, NU, FT, 1.0, 0.05)  # Gc too small for 5 cm spheres
    with pytest.raises(ValueError):
        dem.calibrate("lattice", E, NU, FT, GC, r)


def test_cpm_bond_energy_is_the_work_of_yades_damage_law():
    from yade import CpmPhys
    e0, ef = 1e-4, 1.2e-3
    for kappa in (0.5e-4, 2e-4, 1e-3, 5e-3):
        # envelope work (stress / E = (1 - omega) eps, omega from YADE's funcG) minus elastic energy left
        eps = np.linspace(0, kappa, 20001)
        s = np.array([(1 - CpmPhys.funcG(e, e0, ef)) * e if e > 0 else 0.0 for e in eps])
        work = np.trapz(s, eps)
        left = 0.5 * (1 - CpmPhys.funcG(kappa, e0, ef)) * kappa ** 2
        assert dem.cpmBondEnergy(kappa, e0, ef) == pytest.approx(work - left, rel=1e-5, abs=1e-16)
    assert dem.cpmBondEnergy(math.inf, e0, ef) == pytest.approx(0.5 * e0 ** 2 + e0 * ef)


def beam_pair(**kw):
    beam = pack.inAlignedBox((0, 0, 0), (0.2, 0.05, 0))
    pair = em.DemMpmPair(beam, E=E, nu=NU, rho=RHO, Gc=GC, ft=FT, h=0.01, radius=0.005, thickness=0.05, **kw)
    return pair


def test_pair_specimens_apart_same_mass_and_time_step_below_both():
    pair = beam_pair()
    x = pair.mpm.solver.positions()
    c, ids = pair.dem.centres()
    r = pair.dem.radius
    # the DEM slab lies beside the MPM beam, not touching it
    assert c[:, 0].min() - r > x[:, 0].max() + 0.5 * pair.mpm.h
    assert pair.layers == dem.layersFor(0.05, r) == 6
    # same mass per thickness: DEM mass x force scale = MPM mass
    mass = sum(O.bodies[i].state.mass for i in ids) * pair.dem.scale
    assert mass == pytest.approx(RHO * 0.2 * 0.05 * 0.05, rel=0.03)
    # spheres do not overlap one another (hcp: nearest centres 2 r apart)
    from scipy.spatial import cKDTree
    d, _ = cKDTree(c).query(c, k=2)
    assert d[:, 1].min() == pytest.approx(2 * r, rel=1e-9)
    dt = pair.setTimeStep(0.8)
    dem_dt, mpm_dt = pair.criticalTimeSteps()
    assert dt <= dem_dt and dt <= mpm_dt and dt == pytest.approx(0.8 * min(dem_dt, mpm_dt))
    with pytest.raises(ValueError):
        pair.setTimeStep(1.5)


def test_notch_cuts_every_bond_across_it_and_conditions_move_both_models():
    pair = beam_pair(layers=2)
    removed = pair.notch([(0.1, -0.01, 0), (0.1, 0.025, 0)])
    assert len(removed) > 0
    pair.fix("left", points=pack.inAlignedBox((-1, -1, -1), (0.0051, 1, 1)), components="xy")
    pull = pair.velocityBC("pull", points=pack.inAlignedBox((0.1949, -1, -1), (1, 1, 1)), components="x",
                           velocity=(0.05, 0, 0), rampTime=1e-4)
    O.engines = pair.engines() + [em.callEvery(pair.record, iterPeriod=10)]
    pair.setTimeStep(0.8)
    O.run(200, True)
    # no bond crosses the notch line more than r below its tip (and some cross above it)
    x0 = pair.dem.offset[0] + 0.1
    above = 0
    for (a, b) in pair.dem.bonds:
        pa, pb = O.bodies[a].state.pos, O.bodies[b].state.pos
        if (pa[0] - x0) * (pb[0] - x0) < 0:
            y = pa[1] + (x0 - pa[0]) / (pb[0] - pa[0]) * (pb[1] - pa[1])
            assert y > 0.025 - pair.dem.radius
            above += 1
    assert above > 0
    t, um, Fm, ud, Fd = pair.curve("pull", component=0)
    # the same imposed history: ramp over 1e-4 s then 0.05 m/s
    T = t[-1] + O.dt
    expected = 0.05 * (T - 0.5e-4)
    assert ud[-1] == pytest.approx(expected, rel=0.02)
    assert um[-1] == pytest.approx(expected, rel=0.1)
    # both pulled specimens resist: reactions along the pull on the pulled end
    assert Fm[-1] < 0 and Fd[-1] < 0 or Fm[-1] > 0 and Fd[-1] > 0
    w = pair.wallTimes()
    assert w["dem_wall_s"] > 0 and w["mpm_wall_s"] > 0


def test_uniaxial_tension_gives_the_target_modulus():
    cal = dem.calibrate("cpm", E, NU, FT, GC, 0.005)
    res = dem.uniaxialTension(cal, RHO, layers=3, direction="y", endStrain=0.6e-4, length=16 * 0.005)
    # measured (24 r x 12 r, x and y): E within 2 % of the target by the rule alone
    assert res["E"] == pytest.approx(E, rel=0.06)
    assert res["nu"] == pytest.approx(NU, abs=0.03)


def test_lshaped_comparison_quick(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", os.path.join(ROOT, "examples", "dem_lshaped_panel.py"), "--quick",
                          "--out", str(tmp_path)], env=env, capture_output=True, text=True, timeout=300,
                         stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    s = json.load(open(tmp_path / "summary.json"))
    keys = {"mpm_peak_load_N", "dem_peak_load_N", "mpm_wall_s", "dem_wall_s", "particles", "steps", "wall_time_s",
            "particle_steps_per_s", "mpm_dissipated_energy_J", "dem_dissipated_energy_J", "dem_broken_bonds",
            "mpm_eroded", "calibration", "dt_s", "dem_critical_dt_s", "mpm_critical_dt_s"}
    assert keys <= set(s)
    assert s["quick"] and s["stopped_early"] is None
    assert s["dt_s"] <= min(s["dem_critical_dt_s"], s["mpm_critical_dt_s"])
    # both carried load and broke
    for k in ("mpm_peak_load_N", "dem_peak_load_N"):
        assert math.isfinite(s[k]) and s[k] > 1e3, k
    assert s["dem_broken_bonds"] > 0 and s["mpm_eroded"] > 0
    assert s["dem_dissipated_energy_J"] > 0 and s["mpm_dissipated_energy_J"] > 0
    # the same imposed displacement history, to 0.5 mm
    assert s["dem_end_displacement_m"] == pytest.approx(5e-4, rel=0.01)
    assert s["mpm_end_displacement_m"] == pytest.approx(s["dem_end_displacement_m"], rel=0.05)
    # both peaks before the end, loads fall after them
    assert s["dem_displacement_at_peak_m"] < 4.5e-4 and s["mpm_displacement_at_peak_m"] < 4.5e-4
    m = s["calibration"]["measured"]
    assert abs(m["errorE"]) < 0.05 and abs(m["errorFt"]) < 0.15
    assert s["mpm_wall_s"] > 0 and s["dem_wall_s"] > 0 and s["particles"] == s["mpm_points"] + s["dem_spheres"]
    rows = open(tmp_path / "load_displacement.csv").read().splitlines()
    assert rows[0].startswith("t_s,mpm_displacement_mm") and len(rows) > 100
    for name in ("load_displacement.png", "crack_patterns.png"):
        assert (tmp_path / name).stat().st_size > 10000, name
