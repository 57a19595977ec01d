"""What a scene holds is freed with it: O.reset() frees the solvers of the scene it ends (YADE
itself keeps every Python engine that was ever in O.engines alive), and an engine that no one
holds is freed at once."""
import gc
import weakref

import pytest
from yade import O, pack

import eigenmpm as em


def scene(h=0.001, erosion=True):
    mpm = em.MpmEngine(h=h)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.2, rho=1000))
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (0.001, 1, 1)), label="support")
    engines = [mpm, em.callEvery(lambda: mpm.kineticEnergy(), iterPeriod=10)]
    if erosion:
        engines.append(em.EigenErosion(engine=mpm, Gc=100.0, kappaOverH=1.1))
    O.engines = engines
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(2, True)
    return mpm, engines


def rssMB():
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS")) / 1024.0


def test_reset_frees_the_solver_and_the_erosion_state():
    mpm, engines = scene()
    solver, core = weakref.ref(mpm.solver), weakref.ref(engines[2].core)
    O.reset()
    gc.collect()
    assert solver() is None and core() is None
    # Default labels are unique among live objects: earlier tests may hold 'mpm' or 'erosion'.
    with pytest.raises(RuntimeError, match=rf"the solver of MpmEngine '{mpm.label}' was freed by O.reset\(\)"):
        mpm.kineticEnergy()
    with pytest.raises(RuntimeError, match=rf"erosion state of EigenErosion '{engines[2].label}' was freed by "
                                           r"O.reset\(\)"):
        engines[2].dissipatedEnergy()


def test_memory_stays_flat_over_reset_cycles():
    # 20 000 points each; before O.reset() freed the solver, each cycle kept about 6 MB.
    scene()
    O.reset()
    start = rssMB()
    for _ in range(4):
        scene()
        O.reset()
    assert rssMB() - start < 4.0


def test_an_engine_no_one_holds_is_freed():
    mpm = em.MpmEngine(h=0.01)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.2, rho=1000))
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (0.001, 1, 1)))
    ref = weakref.ref(mpm)
    del mpm
    gc.collect()
    assert ref() is None


def test_an_engine_outside_the_reset_scene_is_kept():
    kept = em.MpmEngine(h=0.01)
    kept.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.2, rho=1000))
    O.reset()
    O.engines = [kept]
    O.dt = 0.5 * kept.criticalTimeStep()
    O.run(2, True)
    assert kept.solver.steps == 2


def test_an_erosion_engine_taken_out_before_the_reset_ends_with_its_solver():
    # Its MpmEngine ends with the scene, so it does too: its default label is free for the next
    # scene's (plotData's keys carry it), and its state is released.
    O.reset()
    mpm, engines = scene()
    erosion = engines[-1]
    O.engines = engines[:-1]  # (taken out; the MpmEngine stays)
    O.run(2, True)
    O.reset()
    with pytest.raises(RuntimeError, match="freed by O.reset"):
        erosion.core.erodedCount
    mpm2, engines2 = scene()
    assert engines2[-1].label == erosion.label and f"{erosion.label}_Ef" in mpm2.plotData()
