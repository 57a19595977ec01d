"""Issue 14 through the YADE engines: the APIC transfer and the co-rotational stress update as
MpmEngine options, the energy and momentum diagnostics in plotData, and a spinning disc that
must not erode (coarse here; fine numbers in doc/stability.md)."""
import math

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em
from eigenmpm import _eigenmpm

GLASS = dict(E=72e9, nu=0.22, rho=2440)


def spinning_disc(transfer, stressUpdate, R=0.01, h=0.001, rim=0.1, Gc=None):
    """A free plane-stress glass disc spinning as a rigid body at a rim speed of `rim` times the
    dilatational wave speed, with eigenerosion whose Gc is four times the closed-form steady
    value of alpha kappa psi+ at the centre (twice the stress). Returns (engine, erosion, omega,
    steady centre stress)."""
    mpm = em.MpmEngine(dim=2, h=h, thickness=h, transfer=transfer, stressUpdate=stressUpdate,
                       domain=((-2 * R, -2 * R, 0), (2 * R, 2 * R, 0)))
    glass = em.ElasticMaterial(planeStress=True, **GLASS)
    ids = mpm.fill(pack.inCylinder((0, 0, -1), (0, 0, 1), R), glass)
    E, nu, rho = GLASS["E"], GLASS["nu"], GLASS["rho"]
    c = math.sqrt(E / (rho * (1 - nu ** 2)))
    omega = rim * c / R
    x = mpm.solver.positions()
    mpm.solver.setVelocities(np.ascontiguousarray(np.column_stack([-omega * x[:, 1], omega * x[:, 0], 0 * x[:, 0]])))
    W = np.array([[0, -omega, 0], [omega, 0, 0], [0, 0, 0]])
    if transfer == "APIC":
        mpm.setVelocityGradient(ids, W)
    # Steady spinning disc, plane stress: sigma_r = sigma_theta = (3 + nu)/8 rho omega^2 R^2 at the centre.
    steady = (3 + nu) / 8 * rho * omega ** 2 * R ** 2
    # alpha kappa psi+ at twice the centre's equibiaxial stress: psi = 2 s^2 (1 - nu) / E per volume
    psi2 = 2 * (2 * steady) ** 2 * (1 - nu) / E
    alpha, kappa = 2.0, 1.1 * h
    erosion = em.EigenErosion(engine=mpm, Gc=Gc or 2 * alpha * kappa * psi2, alpha=alpha, kappaOverH=1.1)
    O.engines = [mpm, erosion]
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm, erosion, omega, steady


def run_revolution(mpm, omega, steady, R):
    x0 = mpm.solver.positions()
    centre = np.where(np.hypot(x0[:, 0], x0[:, 1]) < 0.25 * R)[0]
    L0 = mpm.angularMomentum()[2]
    n = int(2 * math.pi / omega / O.dt) + 1
    mean, peak, worstL = [], 0.0, 0.0
    for _ in range(n // 20):
        O.run(20, True)
        s = mpm.solver.stress()[centre]
        m = float(np.mean(0.5 * (s[:, 0, 0] + s[:, 1, 1])))
        mean.append(m)
        peak = max(peak, abs(m))
        worstL = max(worstL, abs(mpm.angularMomentum()[2] - L0) / abs(L0))
    return float(np.mean(mean)) / steady, peak / steady, worstL


def test_spinning_disc_with_apic_and_corotational_update_does_not_erode_and_keeps_its_angular_momentum():
    R = 0.01
    mpm, erosion, omega, steady = spinning_disc("APIC", "corotational", R=R)
    mean, peak, dL = run_revolution(mpm, omega, steady, R)
    print(f"[ measured ] spinning disc R = 10 h, rim 0.1 c, one revolution, APIC + corotational: mean centre stress "
          f"{mean:.3f} of the steady value, peak {peak:.3f}, eroded {erosion.erodedCount()}, max |L - L0|/L0 {dL:.1e}")
    assert erosion.erodedCount() == 0
    assert dL < 1e-10
    assert peak < 2.2 and abs(mean - 1) < 0.25  # coarse; 10 % at the fine resolution (doc/stability.md)


def test_spinning_disc_with_the_papers_transfer_loses_angular_momentum():
    """The same disc with FLIP and the small-strain update (the paper's): at this coarse
    resolution and Gc it does not erode in one revolution, but its angular momentum drifts
    by about 1 % (the issue's glass disc at Gc = 135 N/m erodes: doc/stability.md)."""
    R = 0.01
    mpm, erosion, omega, steady = spinning_disc("FLIP", "smallStrain", R=R)
    mean, peak, dL = run_revolution(mpm, omega, steady, R)
    print(f"[ measured ] same disc, FLIP + smallStrain: mean centre stress {mean:.3f} of steady, peak {peak:.3f}, "
          f"eroded {erosion.erodedCount()}, max |L - L0|/L0 {dL:.1e}")
    assert dL > 1e-4


def test_options_are_named_in_errors_and_the_linear_shape_refuses_apic():
    with pytest.raises(ValueError, match="transfer"):
        em.MpmEngine(dim=2, h=0.01, transfer="PIC")
    with pytest.raises(ValueError, match="stressUpdate"):
        em.MpmEngine(dim=2, h=0.01, stressUpdate="jaumann")
    with pytest.raises(ValueError, match="'APIC' with shape 'linear'"):
        em.MpmEngine(dim=2, h=0.01, shape="linear", transfer="APIC")
    mpm = em.MpmEngine(dim=2, h=0.01, transfer="apic")  # case-insensitive, declared spelling kept
    assert mpm.transfer == "APIC" and mpm.solver.transfer == "APIC" and mpm.solver.stressUpdate == "smallStrain"
    flip = em.MpmEngine(dim=2, h=0.01)
    ids = flip.fill(pack.inAlignedBox((0, 0, 0), (0.05, 0.05, 0)), em.ElasticMaterial(**GLASS))
    with pytest.raises(ValueError, match="the APIC transfer"):
        flip.setVelocityGradient(ids, np.eye(2))
    with pytest.raises(ValueError, match="gradient of shape"):
        mpm.setVelocityGradient([0, 1], np.zeros((3, 2, 2)))


def test_plot_data_has_the_energy_balance_and_momenta_and_a_restart_continues_bitwise():
    mpm, erosion, omega, steady = spinning_disc("APIC", "corotational", R=0.005)
    O.run(30, True)
    d = mpm.plotData()
    assert {"mpm_EkStep", "mpm_Wext", "mpm_balance", "mpm_Px", "mpm_Py", "mpm_Lz", "erosion_Ef"} <= set(d)
    b = mpm.energyBalance()
    assert b["balance"] == pytest.approx(b["Ek"] + b["Ee"] + b["Ef"] - b["Wext"])
    assert d["mpm_Lz"] == pytest.approx(mpm.angularMomentum()[2])
    copy = _eigenmpm.solverFromState(mpm.solver.saveState())
    assert copy.transfer == "APIC" and copy.stressUpdate == "corotational"
    for s in (mpm.solver, copy):
        for _ in range(25):
            s.step(O.dt, 2)
    for f in ("positions", "velocities", "stress", "velocityGradients", "deformationGradients"):
        assert np.array_equal(getattr(mpm.solver, f)(), getattr(copy, f)()), f
    assert mpm.solver.kineticEnergyAtStep() == copy.kineticEnergyAtStep()


def test_external_work_of_a_pulled_bar_balances_its_energy():
    """A bar pulled slowly at one end by a velocity condition (the other fixed): the work the
    condition does equals kinetic plus elastic energy at the same time level, within 2 %."""
    h = 0.01
    mpm = em.MpmEngine(dim=2, h=h, thickness=h)
    mat = em.ElasticMaterial(E=1e7, nu=0.3, rho=1000)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.04, 0)), mat)
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (0.0001, 1, 1)), components="x")
    mpm.velocityBC(region=pack.inAlignedBox((0.1999, -1, -1), (1, 1, 1)), components="x", velocity=(0.5, 0, 0),
                   rampTime=0.02)
    O.engines = [mpm]
    O.dt = 0.4 * mpm.criticalTimeStep()
    O.run(int(0.04 / O.dt), True)
    b = mpm.energyBalance()
    print(f"[ measured ] pulled bar: Wext {b['Wext']:.4e} J, Ek + Ee {b['Ek'] + b['Ee']:.4e} J, balance "
          f"{b['balance']:.2e} J")
    assert b["Wext"] > 0
    assert abs(b["balance"]) < 0.02 * b["Wext"]


def test_spinning_sphere_in_3d_keeps_its_angular_momentum_and_does_not_erode():
    """A free glass sphere, R = 3 h, spinning about z at a rim speed of 0.1 c for one
    revolution, APIC + corotational, erosion attached with Gc at four times the plane-stress
    disc's centre value: no point erodes, the angular momentum holds to round-off, and the mean
    stress at the centre rings about its own mean (peak at most 2.2 times it). (The 3D steady
    solution is not compared here.)"""
    R, h = 0.003, 0.001
    mpm = em.MpmEngine(dim=3, h=h, transfer="APIC", stressUpdate="corotational",
                       domain=((-2 * R, -2 * R, -2 * R), (2 * R, 2 * R, 2 * R)))
    glass = em.ElasticMaterial(**GLASS)
    ids = mpm.fill(pack.inSphere((0, 0, 0), R), glass)
    E, nu, rho = GLASS["E"], GLASS["nu"], GLASS["rho"]
    c = math.sqrt(E * (1 - nu) / (rho * (1 + nu) * (1 - 2 * nu)))
    omega = 0.1 * c / R
    x = mpm.solver.positions()
    mpm.solver.setVelocities(np.ascontiguousarray(np.column_stack([-omega * x[:, 1], omega * x[:, 0], 0 * x[:, 0]])))
    mpm.setVelocityGradient(ids, [[0, -omega, 0], [omega, 0, 0], [0, 0, 0]])
    steady = (3 + nu) / 8 * rho * omega ** 2 * R ** 2
    Gc = 2 * 2.0 * 1.1 * h * 2 * (2 * steady) ** 2 * (1 - nu) / E
    erosion = em.EigenErosion(engine=mpm, Gc=Gc, alpha=2.0, kappaOverH=1.1)
    O.engines = [mpm, erosion]
    O.dt = 0.5 * mpm.criticalTimeStep()
    mean, peak, dL = run_revolution(mpm, omega, steady, R)
    print(f"[ measured ] spinning sphere R = 3 h, rim 0.1 c, one revolution, APIC + corotational: mean centre stress "
          f"{mean:.3f} of the plane-stress disc's steady value, peak / mean {peak / mean:.3f}, eroded "
          f"{erosion.erodedCount()}, max |L - L0|/L0 {dL:.1e}")
    assert erosion.erodedCount() == 0
    assert dL < 1e-10
    assert mean > 0 and peak / mean < 2.2
