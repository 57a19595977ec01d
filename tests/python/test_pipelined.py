"""The step as a wavefront over the strips (MpmEngine.solver.pipelined, doc/performance.md
"Session 52") through the YADE engine: a 2D FLIP scene with node conditions runs as one, with
bitwise the results of the step pass by pass on one and two threads, with an erosion stage that
erodes too; the switch is not part of the saved state, and a restored run continues bitwise."""
import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em
from eigenmpm import _eigenmpm


def column(pipelined, threads, eroding=False, pulled=True):
    """A glass column 20 x 60 cells, its base fixed, its top pulled up (or moving freely, its
    points given an upward velocity): 40 steps. The erosion stage erodes the layer below the
    pulled top within them."""
    O.reset()
    mpm = em.MpmEngine(dim=2, h=0.001, threads=threads, thickness=0.001)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.02, 0.06, 0)), em.ElasticMaterial(E=72e9, nu=0.22, rho=2440))
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, 0.0005, 1)))
    if pulled:
        mpm.velocityBC(region=pack.inAlignedBox((-1, 0.0595, -1), (1, 1, 1)), components="y", velocity=(0, 0.5, 0))
    else:
        v = mpm.solver.velocities()
        v[:, 1] = 0.5 * mpm.solver.positions()[:, 1] / 0.06
        mpm.solver.setVelocities(v)
    engines = [mpm]
    if eroding:
        engines.append(em.EigenErosion(engine=mpm, Gc=1.0, alpha=2, kappaOverH=1.1))
    O.engines = engines
    O.dt = 0.4 * mpm.criticalTimeStep()
    mpm.solver.pipelined = pipelined
    O.run(40, True)
    return mpm


def fields(s):
    return [s.positions(), s.velocities(), s.stress(), s.strain(), s.history(), s.psiPlus()]


@pytest.mark.parametrize("threads, pulled, workers", [(1, True, 1), (2, True, 1), (2, False, 2)])
def test_the_wavefront_gives_the_passes_results_bitwise(threads, pulled, workers):
    """(Conditions at both ends make two threads one worker: doc/architecture.md.)"""
    passes = column(False, threads, pulled=pulled)
    a = fields(passes.solver)
    assert not passes.solver.lastStepPipelined() and passes.solver.lastStepWorkers() == 0
    wave = column(True, threads, pulled=pulled)
    if not wave.solver.lastStepPipelined():
        pytest.skip("no AVX2 or AVX-512 lanes here: every step runs pass by pass")
    assert wave.solver.lastStepWorkers() == workers
    for x, y in zip(a, fields(wave.solver)):
        assert np.array_equal(x, y)
    assert np.abs(a[2]).max() > 1e3  # (a loaded column, not a scene at rest)


@pytest.mark.parametrize("threads", [1, 2])
def test_with_erosion_the_wavefront_gives_the_passes_results_and_events(threads):
    passes = column(False, threads, eroding=True)
    a = fields(passes.solver) + [passes.solver.damage()]
    ea = passes.solver.erosion
    events = [ea.eventPoints(), ea.eventTimes()]
    dissipated, eroded = ea.dissipatedEnergy, ea.erodedCount
    wave = column(True, threads, eroding=True)
    if not wave.solver.lastStepPipelined():
        pytest.skip("no AVX2 or AVX-512 lanes here: every step runs pass by pass")
    for x, y in zip(a, fields(wave.solver) + [wave.solver.damage()]):
        assert np.array_equal(x, y)
    eb = wave.solver.erosion
    assert eroded > 0 and eb.erodedCount == eroded and eb.dissipatedEnergy == dissipated
    assert np.array_equal(events[0], eb.eventPoints()) and np.array_equal(events[1], eb.eventTimes())


def test_a_restored_run_continues_bitwise():
    plain = column(True, 1)
    copy = _eigenmpm.solverFromState(plain.solver.saveState())
    assert copy.pipelined  # (a speed switch, not saved: a restored solver has the default)
    for s in (plain.solver, copy):
        for _ in range(20):
            s.step(O.dt, 2)
    for x, y in zip(fields(plain.solver), fields(copy)):
        assert np.array_equal(x, y)
