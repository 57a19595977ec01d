"""Bad input stops the run with a message naming the quantity, its value and the allowed range."""
import math

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em

BOX = pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0))


def steel():
    return em.ElasticMaterial(E=200e9, nu=0.3, rho=7800)


@pytest.mark.parametrize("kw, name, allowed", [
    (dict(E=0.0, nu=0.3, rho=1000), "E", "E > 0"),
    (dict(E=-5.0, nu=0.3, rho=1000), "E", "E > 0"),
    (dict(E=1e9, nu=0.5, rho=1000), "nu", "-1 < nu < 0.5"),
    (dict(E=1e9, nu=-1.0, rho=1000), "nu", "-1 < nu < 0.5"),
    (dict(E=1e9, nu=0.7, rho=1000), "nu", "-1 < nu < 0.5"),
    (dict(E=1e9, nu=0.2, rho=0.0), "rho", "rho > 0"),
    (dict(E=1e9, nu=0.2, rho=-1.0), "rho", "rho > 0"),
])
def test_bad_material_named_with_value_and_range(kw, name, allowed):
    with pytest.raises(ValueError) as err:
        em.ElasticMaterial(**kw)
    msg = str(err.value)
    assert name in msg and allowed in msg and repr(kw[name]).rstrip("0").rstrip(".") in msg


@pytest.mark.parametrize("kw, name, allowed", [
    (dict(h=0.01, ppc=0), "ppc", "1 <= ppc"),
    (dict(h=0.01, ppc=-2), "ppc", "1 <= ppc"),
    (dict(h=0.0), "h", "h > 0"),
    (dict(h=-0.1), "h", "h > 0"),
])
def test_bad_engine_parameter(kw, name, allowed):
    with pytest.raises(ValueError) as err:
        em.MpmEngine(**kw)
    assert name in str(err.value) and allowed in str(err.value)


def test_unknown_parameter_is_refused():
    with pytest.raises(TypeError, match="unknown parameter.*hh"):
        em.MpmEngine(h=0.01, hh=2)


def test_dt_above_critical_is_refused_with_the_limit():
    mpm = em.MpmEngine(h=0.01)
    mpm.fill(BOX, steel())
    O.engines = [mpm]
    crit = mpm.criticalTimeStep()
    O.dt = 1.01 * crit
    with pytest.raises(RuntimeError) as err:
        O.run(5, True)
    msg = str(err.value)
    assert "dt" in msg and "critical time step" in msg and f"{crit:.6g}" in msg
    assert mpm.solver.steps == 0
    # Exactly critical is allowed. YADE resumes the interrupted iteration after the engine that
    # raised, so the first of these iterations does not step the solver.
    O.dt = crit
    O.run(3, True)
    assert mpm.solver.steps == 2


def test_point_leaving_grid_stops_run_and_keeps_point():
    mpm = em.MpmEngine(h=0.01, padding=1)
    ids = mpm.fill(BOX, steel(), velocity=(0, 0, 0))
    n = len(ids)
    vel = np.zeros((n, 3))
    vel[:, 0] = -50.0  # the block drifts left; the grid has one cell of padding
    mpm.solver.setVelocities(vel)
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    with pytest.raises(RuntimeError) as err:
        O.run(1000, True)
    msg = str(err.value)
    assert "point id 0 left the grid" in msg and "larger domain" in msg
    assert mpm.solver.numPoints == n


def test_non_finite_input_velocity_is_refused():
    mpm = em.MpmEngine(h=0.01)
    ids = mpm.fill(BOX, steel())
    vel = np.zeros((len(ids), 3))
    vel[7, 1] = math.inf
    with pytest.raises(ValueError, match="velocity of point 7"):
        mpm.solver.setVelocities(vel)


def test_non_finite_value_in_a_step_names_step_and_point():
    # A body force near the largest double makes the nodal forces overflow to infinity in the
    # third step: the run must stop there, naming the step and the first point hit.
    mpm = em.MpmEngine(h=0.01, threads=2)
    mpm.fill(BOX, em.ElasticMaterial(E=1e9, nu=0.2, rho=1e5))
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(2, True)
    mpm.solver.gravity = (0.0, 1.7e308, 0.0)
    with pytest.raises(RuntimeError) as err:
        O.run(5, True)
    msg = str(err.value)
    assert "non-finite value appeared in step 3" in msg
    assert "point id 0 " in msg
    assert mpm.solver.steps == 3
