"""Velocity conditions on nodes (fixed, ramp, roller, by region or by points), their reactions,
tractions (Eq 28) and body force."""
import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em
from eigenmpm.ramp import rampDisplacement, rampFactor, rampTimeTo


def concrete():
    return em.ElasticMaterial(E=30e9, nu=0.2, rho=2400)


def momentum(mpm):
    return np.sum(mpm.solver.mass()[:, None] * mpm.solver.velocities(), axis=0)


@pytest.mark.parametrize("cutoff, tol", [(0.0, 1e-12), (None, 1e-9)])
def test_traction_gives_exact_momentum_rate(cutoff, tol):
    # Free block, traction on the band of points one layer (h) thick at x = 0.1: the band's
    # volume / h is the loaded face area x thickness, so the force is t * 0.05 * 0.5. Without a
    # mass cut-off momentum is exact to round-off; the default cut-off drops the forces of the
    # lightest GIMP edge nodes (force ~ sqrt(mass)), a loss below 1e-9.
    kw = {} if cutoff is None else {"massCutoff": cutoff}
    mpm = em.MpmEngine(h=0.01, thickness=0.5, **kw)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    mpm.traction(points=pack.inAlignedBox((0.09, -1, -1), (0.2, 1, 1)), traction=(1e5, 0, 0), rampTime=0.0)
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(30, True)
    assert momentum(mpm)[0] == pytest.approx(1e5 * 0.05 * 0.5 * 30 * O.dt, rel=tol)
    assert abs(momentum(mpm)[1]) < 1e-12 * abs(momentum(mpm)[0])


def test_traction_ramp():
    mpm = em.MpmEngine(h=0.01, massCutoff=0.0)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    O.dt = 0.5 * mpm.criticalTimeStep()
    t0 = 10 * O.dt
    mpm.traction(points=pack.inAlignedBox((-1, 0.04, -1), (1, 1, 1)), traction=(0, 2e5, 0), rampTime=t0)
    O.engines = [mpm]
    O.run(20, True)
    # Traction at the start of step k (t = k dt) is t_max * min(k dt / t0, 1).
    impulse = sum(min(k * O.dt / t0, 1.0) for k in range(20)) * O.dt * 2e5 * 0.1 * 1.0
    assert momentum(mpm)[1] == pytest.approx(impulse, rel=1e-10)


def test_fixed_base_reaction_balances_momentum_and_weight():
    g = 9.81
    mpm = em.MpmEngine(h=0.01, gravity=(0, -g, 0), label="col", massCutoff=0.0)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.05, 0.2, 0)), concrete())
    base = mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, 0.0, 1)), label="base")
    weight = np.sum(mpm.solver.mass()) * g
    reactions = []
    last = [momentum(mpm)[:2]]

    def check():
        p = momentum(mpm)[:2]
        r = np.array(base.reaction)[:2]
        # Discrete momentum balance of the points: dP = dt (W + R) in every step.
        assert p - last[0] == pytest.approx(O.dt * (np.array([0, -weight]) + r), rel=1e-8, abs=1e-9 * weight * O.dt)
        last[0] = p
        reactions.append(r)

    O.engines = [mpm, em.callEvery(check)]
    O.dt = 0.5 * mpm.criticalTimeStep()
    period = 4 * 0.2 / np.sqrt((30e9 * 0.8 / (1.2 * 0.6)) / 2400)
    O.run(int(10 * period / O.dt), True)
    mean = np.mean(reactions, axis=0)
    assert mean[1] == pytest.approx(weight, rel=0.05)
    assert abs(mean[0]) < 1e-9 * weight


def test_ramp_velocity_region_moves_covered_points_exactly():
    v0 = 2.0
    h = 0.01
    mpm = em.MpmEngine(h=h)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.05, 0)), concrete())
    x0 = mpm.solver.positions()
    O.dt = 0.5 * mpm.criticalTimeStep()
    t0 = 15 * O.dt
    # Nodes at x <= h (and the padding column to the left): points at x = h/4 use only them.
    bc = mpm.velocityBC(region=pack.inAlignedBox((-1, -1, -1), (h, 1, 1)), components="x",
                        velocity=(v0, 0, 0), rampTime=t0, label="piston")
    O.engines = [mpm]
    n = 40
    O.run(n, True)
    moved = mpm.solver.positions()[:, 0] - x0[:, 0]
    first = np.isclose(x0[:, 0], h / 4)
    # the ramp of Eq 34 as Python code (DEM conditions, run planning) has it: the solver's
    expected = sum(v0 * rampFactor((k + 0.5) * O.dt, t0) for k in range(n)) * O.dt
    assert moved[first] == pytest.approx(expected, rel=1e-9)
    assert bc.reaction[0] > 0  # the piston pushes the bar


@pytest.mark.parametrize("u, t0", [(2e-6, 1e-3), (5e-4, 1e-3), (5e-4, 0.0)])
def test_ramp_time_to_a_displacement_inverts_the_ramped_motion(u, t0):
    # integrate v rampFactor(t) up to rampTimeTo(u): within the ramp and after it; rampDisplacement
    # is that integral in closed form
    v, n = 0.02, 200000
    T = rampTimeTo(u, v, t0)
    dt = T / n
    moved = sum(v * rampFactor((k + 0.5) * dt, t0) for k in range(n)) * dt
    assert moved == pytest.approx(u, rel=1e-6)
    assert rampDisplacement(T, v, t0) == pytest.approx(u, rel=1e-12)
    half = 0.5 * T
    assert rampDisplacement(half, v, t0) == pytest.approx(sum(v * rampFactor((k + 0.5) * dt, t0)
                                                              for k in range(n // 2)) * dt, rel=1e-6)
    assert rampFactor(-1.0, t0) == (0.0 if t0 > 0 else 1.0) and rampFactor(2 * t0 + 1, t0) == 1.0


def test_condition_by_points_follows_the_points_across_cells():
    h = 0.01
    mpm = em.MpmEngine(h=h, domain=((-0.05, -0.05, 0), (0.5, 0.1, 0)))
    ids = mpm.fill(pack.inAlignedBox((0, 0, 0), (0.05, 0.05, 0)), concrete())
    x0 = mpm.solver.positions()
    mpm.velocityBC(points=ids, velocity=(100.0, 0, 0), label="carry")
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    steps = int(0.1 / 100.0 / O.dt)  # about ten cells
    O.run(steps, True)
    x = mpm.solver.positions()
    # Every support node of a point farther than 1.5 h from the block's edges is the nearest node
    # of some selected point, hence constrained wherever the block has moved: such points move
    # exactly with the prescribed velocity.
    inner = np.all((x0[:, :2] > 0.015) & (x0[:, :2] < 0.035), axis=1)
    assert inner.sum() == 16
    assert x[inner, 0] - x0[inner, 0] == pytest.approx(np.full(16, 100.0 * steps * O.dt), rel=1e-9)
    assert np.all(np.isfinite(x)) and np.all(x[:, 0] - x0[:, 0] > 0.09)


def test_roller_constrains_only_its_component():
    mpm = em.MpmEngine(h=0.01, gravity=(0, -9.81, 0))
    ids = mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete(), velocity=(0.3, 0, 0))
    roller = mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, 0.0, 1)), components="y", label="roller")
    px0 = momentum(mpm)[0]
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(50, True)
    assert momentum(mpm)[0] == pytest.approx(px0, rel=1e-12)
    assert roller.reaction[0] == 0.0 and roller.reaction[1] > 0


def test_velocity_as_function_of_time():
    mpm = em.MpmEngine(h=0.01)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.05, 0)), concrete())
    seen = []

    def v(t):
        seen.append(t)
        return (0.0, 5.0 * t, 0.0)

    mpm.velocityBC(region=pack.inAlignedBox((-1, -1, -1), (0.0, 1, 1)), velocity=v, label="f")
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(5, True)
    assert seen == pytest.approx([k * O.dt for k in range(5)])


def test_selection_errors():
    mpm = em.MpmEngine(h=0.01)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    with pytest.raises(ValueError, match="exactly one of"):
        mpm.velocityBC()
    with pytest.raises(ValueError, match="selects no node"):
        mpm.fix(region=pack.inAlignedBox((5, 5, -1), (6, 6, 1)))
    with pytest.raises(ValueError, match="components"):
        mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (0, 1, 1)), components="z")
    with pytest.raises(ValueError, match="rampTime"):
        mpm.velocityBC(region=pack.inAlignedBox((-1, -1, -1), (0, 1, 1)), velocity=(1, 0, 0), rampTime=-1)


@pytest.mark.parametrize("dim", [2, 3])
def test_nodes_in_a_region_are_those_of_every_node_position(dim):
    """nodesIn tests only the nodes of the region's box (builders.nodeBox), not the whole grid:
    the same nodes as a test of every node's position, for boxes, spheres, differences, regions
    off the grid or unbounded on a side, and pads."""
    from eigenmpm.builders import select
    mpm = em.MpmEngine(dim=dim, h=0.01, domain=((-0.03, -0.02, -0.01), (0.31, 0.2, 0.05)))
    regions = [pack.inAlignedBox((-1, -1, -1), (0, 1, 1)), pack.inAlignedBox((0.1, 0.05, 0), (0.2, 0.1, 0.02)),
               pack.inSphere((0.15, 0.1, 0.02), 0.05),
               pack.inAlignedBox((0.1, 0.05, -1), (0.2, 0.1, 1)) - pack.inSphere((0.15, 0.07, 0), 0.02),
               pack.inAlignedBox((5, 5, 5), (6, 6, 6)), pack.inHalfSpace((0, 0.1, 0), (0, 1, 0))]
    every = mpm.solver.nodePositions()
    found = 0
    for region in regions:
        for pad in (None, 0.0, 0.005):
            expected = select(every, region, -1e-6 * mpm.h if pad is None else pad, dim)
            assert np.array_equal(mpm.nodesIn(region, pad), expected), (region, pad)
            found += len(expected)
    assert found > 1000
