"""The engines live in O.engines and use YADE's types, predicates, plot and output conventions."""
import io
import os

import numpy as np
import pytest
from yade import O, Vector3, pack, plot

import eigenmpm as em


def concrete():
    return em.ElasticMaterial(E=30e9, nu=0.2, rho=2400)


def test_engine_is_a_labelled_yade_engine_advancing_with_O_dt():
    mpm = em.MpmEngine(h=0.01, label="specimen")
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    O.engines = [mpm]
    O.dt = 0.3 * mpm.criticalTimeStep()
    O.run(7, True)
    assert O.engines[0] is mpm and O.engines[0].label == "specimen"
    assert mpm.solver.steps == 7
    assert mpm.solver.time == pytest.approx(O.time, rel=1e-12)


def test_fill_matches_predicate_volume_for_boxes_cylinders_unions_differences_and_notches():
    h, ppc = 0.01, 2
    mpm = em.MpmEngine(h=h, ppc=ppc, thickness=0.5)
    mat = concrete()
    box = pack.inAlignedBox((0, 0, 0), (0.2, 0.1, 0))
    n = len(mpm.fill(box, mat))
    assert n == 40 * 20
    assert np.sum(mpm.solver.volume()) == pytest.approx(0.2 * 0.1 * 0.5)
    disc = pack.inCylinder((0.5, 0.5, -1), (0.5, 0.5, 1), 0.1)
    n_disc = len(mpm.fill(disc, mat))
    assert n_disc * (h / ppc) ** 2 == pytest.approx(np.pi * 0.1 ** 2, rel=0.03)
    union = pack.inAlignedBox((1, 0, 0), (1.1, 0.1, 0)) | pack.inAlignedBox((1.05, 0, 0), (1.2, 0.1, 0))
    assert len(mpm.fill(union, mat)) == 40 * 20
    diff = pack.inAlignedBox((2, 0, 0), (2.2, 0.1, 0)) - pack.inAlignedBox((2.1, 0, -1), (2.3, 0.05, 1))
    assert len(mpm.fill(diff, mat)) == 40 * 20 - 20 * 10
    # notInNotch removes a slab of width `aperture` around the plane x = 3.1: two lattice columns.
    notched = pack.inAlignedBox((3, 0, -0.5), (3.2, 0.1, 0.5)) & pack.notInNotch(
        (3.1, 0.0, 0), (0, 0, 1), (1, 0, 0), 0.012)
    assert len(mpm.fill(notched, mat)) == 40 * 20 - 2 * 20
    pts = mpm.solver.positions()
    assert np.all(pts[:, 2] == 0.0)


def test_fill_3d_ball():
    mpm = em.MpmEngine(dim=3, h=0.02, ppc=2)
    n = len(mpm.fill(pack.inSphere((0, 0, 0), 0.1), concrete()))
    assert n * 0.01 ** 3 == pytest.approx(4 / 3 * np.pi * 0.1 ** 3, rel=0.05)


def test_vector3_accepted_wherever_a_vector_is_expected():
    mpm = em.MpmEngine(h=0.01, gravity=Vector3(0, -9.81, 0),
                       domain=(Vector3(-0.1, -0.1, 0), Vector3(0.3, 0.2, 0)))
    ids = mpm.fill(pack.inAlignedBox(Vector3(0, 0, 0), Vector3(0.2, 0.1, 0)), concrete(),
                   velocity=Vector3(1, 0, 0))
    assert np.allclose(mpm.solver.velocities()[:, 0], 1.0)
    bc = mpm.velocityBC(region=pack.inAlignedBox((-1, -1, -1), (0.0, 1, 1)),
                        velocity=Vector3(0.5, 0, 0), label="left")
    mpm.traction(points=pack.inAlignedBox((0.19, 0, -1), (0.2, 0.1, 1)), traction=Vector3(1e5, 0, 0))
    mpm.addPoints([Vector3(0.25, 0.15, 0)], concrete(), volumes=1e-4, velocities=Vector3(0, 0, 0))
    assert mpm.solver.numPoints == len(ids) + 1
    assert tuple(mpm.solver.gravity) == (0.0, -9.81, 0.0)
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(3, True)
    assert isinstance(bc.reaction, Vector3)


def test_plot_receives_time_energies_and_reactions():
    mpm = em.MpmEngine(h=0.01, gravity=(0, -9.81, 0), label="col")
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.05, 0.2, 0)), concrete())
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, 0.0, 1)), label="base")
    O.engines = [mpm, em.PlotRecorder(iterPeriod=5)]
    O.dt = 0.5 * mpm.criticalTimeStep()
    plot.reset()
    O.run(20, True)
    keys = set(plot.data)
    assert {"t", "iter", "col_Ek", "col_Ee", "col_base_Rx", "col_base_Ry"} <= keys
    # Recorded at iterations 0, 5, 10, 15, after the solver's step of that iteration.
    assert plot.data["iter"] == [0, 5, 10, 15]
    assert plot.data["t"] == pytest.approx([1 * O.dt, 6 * O.dt, 11 * O.dt, 16 * O.dt])
    assert plot.data["col_Ek"][-1] > 0 and plot.data["col_Ee"][-1] > 0
    plot.plots = {"t": ("col_Ek", "col_Ee")}
    fig = plot.plot(noShow=True)
    assert fig is not None


def test_vtk_series_readable_with_all_fields(tmp_path):
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    mpm = em.MpmEngine(h=0.01)
    n = len(mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete(), velocity=(1, 0, 0)))
    rec = em.VTKRecorder(fileName=str(tmp_path / "vtk" / "blk-"), iterPeriod=4)
    O.engines = [mpm, rec]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(10, True)
    assert len(rec.files) == 3  # iterations 0, 4, 8
    pvd = open(rec.collection).read()
    assert pvd.count("<DataSet") == 3
    r = vtkXMLPolyDataReader()
    r.SetFileName(rec.files[-1][1])
    r.Update()
    out = r.GetOutput()
    assert out.GetNumberOfPoints() == n
    pd = out.GetPointData()
    for name, comps in (("velocity", 3), ("displacement", 3), ("stress", 9), ("strain", 9),
                        ("psiPlus", 1), ("H", 1), ("damage", 1)):
        arr = pd.GetArray(name)
        assert arr is not None and arr.GetNumberOfComponents() == comps, name
    assert pd.GetArray("velocity").GetTuple3(0)[0] == pytest.approx(1.0)


def test_vtk_virt_period(tmp_path):
    mpm = em.MpmEngine(h=0.01)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    O.dt = 0.5 * mpm.criticalTimeStep()
    rec = em.VTKRecorder(fileName=str(tmp_path / "v-"), virtPeriod=5 * O.dt)
    O.engines = [mpm, rec]
    O.run(21, True)
    assert 3 <= len(rec.files) <= 5


def test_failure_writes_last_state(tmp_path):
    mpm = em.MpmEngine(h=0.01, padding=1)
    ids = mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    vel = np.zeros((len(ids), 3))
    vel[:, 1] = 200.0
    mpm.solver.setVelocities(vel)
    rec = em.VTKRecorder(fileName=str(tmp_path / "f-"), iterPeriod=1000)
    O.engines = [mpm, rec]
    O.dt = 0.5 * mpm.criticalTimeStep()
    with pytest.raises(RuntimeError):
        O.run(1000, True)
    assert os.path.exists(str(tmp_path / "f-failure.vtp"))


def test_progress_prints_eta():
    mpm = em.MpmEngine(h=0.01)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    out = io.StringIO()
    prog = em.Progress(endIter=400, realPeriod=1e-9, stream=out)
    O.engines = [mpm, prog]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(400, True)
    text = out.getvalue()
    assert "ETA" in text and "iter" in text and "%" in text


def test_critical_time_step_helper_and_threads():
    mpm = em.MpmEngine(h=0.02, threads=2)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    O.engines = [mpm]
    E, nu, rho = 30e9, 0.2, 2400
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    assert em.criticalTimeStep() == pytest.approx(0.02 / np.sqrt((lam + 2 * mu) / rho))
    O.dt = 0.9 * em.criticalTimeStep()
    O.run(5, True)
    assert mpm.solver.steps == 5


def test_two_engines_side_by_side():
    a = em.MpmEngine(h=0.01, label="a")
    b = em.MpmEngine(h=0.01, shape="linear", label="b")
    a.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    b.fill(pack.inAlignedBox((1, 0, 0), (1.1, 0.05, 0)), concrete())
    O.engines = [a, b]
    O.dt = 0.5 * em.criticalTimeStep()
    O.run(4, True)
    assert a.solver.steps == 4 and b.solver.steps == 4
    with pytest.raises(ValueError, match="2 MpmEngine"):
        em.findEngine()
    assert em.findEngine("b") is b


def _settle(count, target, timeout=10.0):
    """count() once it is at most target (O.run's thread gives its Python state back as it ends,
    just after O.run returns), or its value after timeout seconds."""
    import time
    end = time.monotonic() + timeout
    while count() > target and time.monotonic() < end:
        time.sleep(0.01)
    return count()


def test_yade_run_thread_keeps_its_python_state_while_it_runs_and_gives_it_back():
    # YADE makes and deletes a Python thread state for each PyRunner call in O.run's thread; the
    # MpmEngine keeps the first one for the thread's life (py/module.cpp, keepThreadState). Seen
    # from Python: a threading.local's value set at one iteration is there at the next.
    import threading
    from eigenmpm import _eigenmpm
    local, seen = threading.local(), []

    def probe():
        seen.append(getattr(local, "iteration", None))
        local.iteration = O.iter

    mpm = em.MpmEngine(h=0.02)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), concrete())
    O.engines = [mpm, em.callEvery(probe)]
    O.dt = 0.5 * mpm.criticalTimeStep()
    before = _eigenmpm.threadStates()
    O.run(6, True)
    assert seen == [None, 0, 1, 2, 3, 4]  # (each call sees the iteration of the one before)
    # Each O.run has a thread of its own; each gives its state back as it ends.
    for _ in range(40):
        O.run(2, True)
    assert _settle(_eigenmpm.threadStates, before) == before
    # The main thread's state is Python's own and is not held. A Python thread may be held, but
    # Python deletes its state as it ends (and the hold's release then does nothing).
    assert not _eigenmpm.keepThreadState()
    worker = threading.Thread(target=_eigenmpm.keepThreadState)
    worker.start()
    worker.join()
    assert _settle(_eigenmpm.threadStates, before) == before
    O.step()  # (in the main thread)
    assert mpm.solver.steps == 87


def test_step_clock_sums_the_cpu_time_inside_the_steps_only_while_on():
    # bench/bench_yade_side.py reads the steps' CPU time from the module (timeSteps): off by
    # default, reset when turned on or off, and a part of the process's CPU time.
    import time
    from eigenmpm import _eigenmpm
    mpm = em.MpmEngine(h=0.01)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.1, 0)), concrete())
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(2, True)
    assert _eigenmpm.stepCpuSeconds() == 0.0  # (off)
    _eigenmpm.timeSteps(True)
    t = time.process_time()
    O.run(20, True)
    elapsed, inside = time.process_time() - t, _eigenmpm.stepCpuSeconds()
    assert 0.0 < inside <= elapsed
    O.run(5, True)
    assert _eigenmpm.stepCpuSeconds() > inside  # (still summing)
    _eigenmpm.timeSteps(False)
    O.run(5, True)
    assert _eigenmpm.stepCpuSeconds() == 0.0
