"""Stability at the extremes through YADE (issue 6, items 3-4; doc/stability.md): the ranges the
engines accept run without a NaN, the ones they refuse stop with a message naming the quantity
and its allowed range, and a 2D scene runs the 2D solver. The C++ cases are in
tests/cpp/test_stability.cpp."""
import math
import warnings

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em
from eigenmpm import _eigenmpm

BAR = pack.inAlignedBox((0, 0, 0), (0.08, 0.02, 0))


def bar(E=1e7, nu=0.3, rho=1000, h=0.01, ppc=2, dim=2, shape="uGIMP", planeStress=False):
    mpm = em.MpmEngine(dim=dim, h=h, ppc=ppc, shape=shape)
    box = BAR if dim == 2 else pack.inAlignedBox((0, 0, 0), (0.08, 0.02, 0.02))
    ids = mpm.fill(box, em.ElasticMaterial(E=E, nu=nu, rho=rho, planeStress=planeStress))
    c = math.sqrt(E / rho)
    x = mpm.solver.positions()
    v = np.zeros_like(x)
    v[:, 0] = -1e-3 * c * np.cos(math.pi * x[:, 0] / 0.08)  # first axial mode, zero momentum
    mpm.solver.setVelocities(v)
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm, ids


def energy(mpm):
    return mpm.kineticEnergy() + mpm.elasticEnergy()


@pytest.mark.parametrize("E", [1e3, 1e12])
@pytest.mark.parametrize("nu", [0.0, 0.499])
def test_extreme_material_constants_run_within_the_energy_bound(E, nu):
    mpm, _ = bar(E=E, nu=nu)
    E0 = energy(mpm)
    worst = 0.0
    for _ in range(10):
        O.run(10, True)
        worst = max(worst, abs(energy(mpm) - E0) / E0)
    assert np.isfinite(mpm.solver.positions()).all()
    assert worst < 0.15, worst  # dt 0.5 critical: see the C++ Stability.* cases for the bound


def test_poisson_ratio_one_half_is_refused_by_name():
    with pytest.raises(ValueError, match=r"EigenMPM: nu = 0.5 is invalid; allowed: -1 < nu < 0.5 \(ElasticMaterial\)"):
        em.ElasticMaterial(E=1e9, nu=0.5, rho=1000)


@pytest.mark.parametrize("ppc", [1, 2, 3, 4])
def test_points_per_cell_one_to_four_fill_and_run(ppc):
    mpm, ids = bar(ppc=ppc)
    assert len(ids) == 8 * 2 * ppc * ppc
    O.run(20, True)
    assert np.isfinite(mpm.solver.stress()).all()


@pytest.mark.parametrize("alpha", [0.5, 4.0])
def test_alpha_from_half_to_four_is_accepted_without_warning(alpha):
    mpm, _ = bar()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        crack = em.EigenErosion(engine=mpm, Gc=1e3, alpha=alpha, kappaOverH=1.1)
    O.engines = [mpm, crack]
    O.run(20, True)
    assert crack.erodedCount() == 0 and crack.core.alpha == alpha


@pytest.mark.parametrize("kappaOverH", [0.5, 3.0])
def test_kappa_outside_appendix_a_range_warns_with_the_range(kappaOverH):
    mpm, _ = bar()
    low, high = em.fracture.kappaRange(mpm.h, 2)
    with pytest.warns(UserWarning) as rec:
        crack = em.EigenErosion(engine=mpm, Gc=1e3, alpha=2.0, kappaOverH=kappaOverH)
    msg = str(rec[0].message)
    assert f"kappa = {kappaOverH * mpm.h:.4g} m" in msg and f"{low:.4g} to {high:.4g} m" in msg
    O.engines = [mpm, crack]
    O.run(20, True)  # still runs: the warning is advice
    assert crack.erodedCount() == 0


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan")])
def test_non_positive_alpha_is_refused_by_name(bad):
    mpm, _ = bar()
    with pytest.raises(ValueError, match="alpha .* is invalid; allowed: alpha > 0"):
        em.EigenErosion(engine=mpm, Gc=1e3, alpha=bad, kappaOverH=1.1)


def test_empty_scene_steps_and_an_infinite_dt_is_refused_by_name():
    mpm = em.MpmEngine(dim=2, h=0.01)
    O.engines = [mpm]
    assert math.isinf(mpm.criticalTimeStep())  # no material: no wave speed
    O.dt = 1e-5
    O.run(5, True)
    d = mpm.plotData()
    assert mpm.solver.steps == 5 and {"mpm_Ek", "mpm_Ee", "mpm_EkStep", "mpm_Wext", "mpm_balance", "mpm_Px", "mpm_Py",
                                      "mpm_Lz"} == set(d) and not any(d.values())
    O.dt = 0.5 * em.criticalTimeStep()
    with pytest.raises(RuntimeError, match=r"dt \(time step, s\) = inf is invalid; allowed: 0 < dt"):
        O.run(1, True)
    assert mpm.solver.steps == 5


def test_point_on_the_upper_edge_of_a_given_domain_is_refused_with_the_remedy():
    mpm = em.MpmEngine(dim=2, h=0.01, domain=((0, 0, 0), (0.1, 0.1, 0)))
    mat = em.ElasticMaterial(E=1e7, nu=0.3, rho=1000)
    mpm.addPoints([(0.05, 0.05, 0), (0.1, 0.05, 0)], mat, 1e-6)
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    with pytest.raises(RuntimeError, match=r"point 1 at \(0.1, 0.05\) lies outside the domain .* enlarge the domain"):
        O.run(1, True)


# --- only what a scene requires (issue 6, item 4) ---------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("shape, name", [("uGIMP", "UGIMP"), ("linear", "Linear")])
def test_engine_instantiates_the_solver_of_its_dimension(dim, shape, name):
    """A 2D scene runs Solver2* (2D kernels, 2x2 tensors), never a 3D solver: the solver class,
    and its dimension say so (tests/cpp/test_stability.cpp checks at compile time that the 2D
    classes hold 2-vectors and 2x2 tensors)."""
    mpm, _ = bar(dim=dim, shape=shape)
    assert type(mpm.solver) is getattr(_eigenmpm, f"Solver{dim}{name}")
    assert mpm.solver.dim == dim
    O.run(2, True)
    assert mpm.solver.steps == 2


def test_scene_without_cracks_has_no_phantom_nodes_and_without_erosion_no_erosion_stage():
    mpm, _ = bar()
    O.run(5, True)
    assert mpm.solver.numCracks == 0 and mpm.solver.numTwins == 0 and len(mpm.solver.markedNodes()) == 0
    assert mpm.solver.erosion is None and mpm.physics == {}
    assert mpm.solver.numNodes == int(np.prod(mpm.solver.gridShape()))
