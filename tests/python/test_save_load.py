"""YADE's save and load carry the EigenMPM state (eigenmpm.state): continuing after
O.saveTmp/O.loadTmp or O.save/O.load (in a new process) gives bitwise the results of the run
that was not interrupted, in 2D and 3D, with a crack and while eroding, on 1 and 2 threads; what
cannot be restored is refused."""
import functools
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em
from eigenmpm.state import StateError

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def plate(dim=2, threads=1, velocity=None, vtk=None):
    """A small cracked plate pulled apart by tractions, eroding (about 30 points by 300 steps)."""
    h = 0.002
    extra = dict(thickness=h) if dim == 2 else {}
    mpm = em.MpmEngine(dim=dim, h=h, threads=threads, label="plate",
                       domain=((-0.005, -0.005, -0.005), (0.035, 0.025, 0.011)), **extra)
    glass = em.ElasticMaterial(E=72e9, nu=0.22, rho=2440, planeStress=dim == 2)
    top = 0.006 if dim == 3 else 0
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.03, 0.02, top)), glass)
    if dim == 2:
        mpm.crack([(-0.001, 0.01, 0), (0.012, 0.01, 0)])
    else:
        mpm.crack([(-0.001, 0.01, -0.001), (0.012, 0.01, -0.001), (0.012, 0.01, 0.007), (-0.001, 0.01, 0.007)])
    mpm.traction(points=pack.inAlignedBox((-1, 0.018, -1), (1, 1, 1)), traction=(0, 14e6, 0))
    mpm.traction(points=pack.inAlignedBox((-1, -1, -1), (1, 0.002, 1)), traction=(0, -14e6, 0))
    if velocity is not None:
        mpm.velocityBC(points=pack.inAlignedBox((0.028, -1, -1), (1, 1, 1)), components="x", velocity=velocity)
    erosion = em.EigenErosion(engine=mpm, Gc=60, alpha=2, kappaOverH=1.1, iterPeriod=20)
    engines = [mpm, erosion, em.PlotRecorder(iterPeriod=25)]
    if vtk:
        engines.append(em.VTKRecorder(fileName=vtk, iterPeriod=100))
    O.engines = engines
    O.dt = 0.4 * mpm.criticalTimeStep()
    return mpm


def state():
    mpm = em.findEngine("plate")
    s = mpm.solver
    (erosion,) = mpm.physics.values()
    return (s.positions(), s.velocities(), s.stress(), s.damage(), s.history(), s.steps, s.time,
            erosion.erodedCount(), erosion.dissipatedEnergy(),
            [tuple(v) for v in mpm.crackVertices()])


def same(a, b):
    for x, y in zip(a, b):
        if isinstance(x, np.ndarray):
            assert np.array_equal(x, y)
        else:
            assert x == y


@pytest.mark.parametrize("dim, threads", [(2, 1), (2, 2), (3, 1)])
def test_save_tmp_and_load_tmp_continue_bitwise(dim, threads):
    plate(dim, threads)
    O.run(150, True)
    O.saveTmp("mid")
    O.run(150, True)
    reference = state()
    assert reference[7] > 0, "the plate should erode"
    O.loadTmp("mid")
    assert O.iter == 150 and em.findEngine("plate").solver.steps == 150
    O.run(150, True)
    same(state(), reference)


def test_loaded_engines_keep_their_recorders_and_periods(tmp_path):
    from yade import plot
    plot.reset()
    plate(vtk=str(tmp_path / "vtk" / "p-"))
    O.run(150, True)
    O.saveTmp("mid")
    O.run(250, True)
    files = len(em.findEngine("plate").recorders[0].files)
    O.loadTmp("mid")
    O.run(250, True)
    assert len(em.findEngine("plate").recorders[0].files) == files == 4
    assert len(plot.data["t"]) == 16 and plot.data["plate_Ek"][-1] > 0  # yade.plot's series too
    assert isinstance(O.engines[1], em.EigenErosion) and isinstance(O.engines[2], em.PlotRecorder)


def test_save_and_load_in_a_new_process_continue_bitwise(tmp_path):
    """O.save in one process, O.load in another: the same final state as without stopping."""
    script = textwrap.dedent(f"""
        import sys
        sys.path[:0] = [{os.path.join(ROOT, 'build', 'python')!r}, '/usr/lib/x86_64-linux-gnu/yade-double/py',
                        {os.path.dirname(os.path.abspath(__file__))!r}]
        import numpy as np
        import yade
        from yade import O
        import eigenmpm as em
        import test_save_load as t
        mode, path = sys.argv[1], sys.argv[2]
        if mode == "save":
            t.plate(velocity=t.pull)
            O.run(150, True)
            O.save(path + "/scene.yade.bz2")
        elif mode == "load":
            O.load(path + "/scene.yade.bz2")
            O.run(150, True)
            np.save(path + "/loaded.npy", em.findEngine("plate").solver.positions())
        else:
            t.plate(velocity=t.pull)
            O.run(300, True)
            np.save(path + "/straight.npy", em.findEngine("plate").solver.positions())
    """)
    (tmp_path / "run.py").write_text(script)
    for mode in ("save", "load", "straight"):
        r = subprocess.run([sys.executable, str(tmp_path / "run.py"), mode, str(tmp_path)],
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
    assert (tmp_path / "scene.yade.bz2.eigenmpm").exists()
    assert np.array_equal(np.load(tmp_path / "loaded.npy"), np.load(tmp_path / "straight.npy"))


pull = functools.partial(np.multiply, (0.5, 0.0, 0.0))  # velocity(t) = (0.5 t, 0, 0): importable


def test_condition_driven_by_a_lambda_is_refused_at_save_time(tmp_path):
    plate(velocity=lambda t: (0.5 * t, 0, 0))
    O.run(5, True)
    with pytest.raises(StateError, match=r"cannot save MpmEngine 'plate'\.bcs\['bc0'\]\.velocity = <function"):
        O.saveTmp("x")
    with pytest.raises(StateError, match="importable by name"):
        O.save(str(tmp_path / "s.yade.bz2"))


def test_scene_that_went_back_without_its_state_refuses_to_step():
    plate()
    O.run(10, True)
    em.state._original["saveTmp"](O, "bare")  # YADE's own save: no EigenMPM snapshot
    O.run(10, True)
    em.state._original["loadTmp"](O, "bare")  # the old engine objects, at a later state
    with pytest.raises(RuntimeError, match="went back without its EigenMPM state"):
        O.run(1, True)


def test_load_without_the_state_file_or_with_a_damaged_one_is_refused(tmp_path):
    plate()
    O.run(10, True)
    f = str(tmp_path / "scene.yade.bz2")
    O.save(f)
    side = f + ".eigenmpm"
    data = open(side, "rb").read()
    os.remove(side)
    with pytest.raises(StateError, match="keep the two files together"):
        O.load(f)
    with open(side, "wb") as out:
        out.write(data[: len(data) // 2])
    with pytest.raises(StateError, match="damaged"):
        O.load(f)


@pytest.mark.parametrize("legacy", [False, True])
def test_engines_saved_without_their_state_are_refused_at_load(legacy):
    """A scene saved by YADE alone (no EigenMPM snapshot) whose O.engines holds EigenMPM
    engines comes back with bare PyRunners: loading it is refused, for the engines' commands of
    this version and of earlier ones (which imported eigenmpm.engines in the command)."""
    mpm = plate()
    O.run(2, True)
    if legacy:
        mpm.command = em.engines.LEGACY_PREFIXES[0] + "0]._action()"
    else:
        assert mpm.command.startswith(em.engines.COMMAND_PREFIX) and em.engines.registered(mpm) is mpm
    em.state._original["saveTmp"](O, "bare")
    with pytest.raises(StateError, match="holds EigenMPM engines but no EigenMPM state"):
        O.loadTmp("bare")


def test_saved_solver_state_of_another_version_is_refused():
    mpm = plate()
    O.run(5, True)
    data = bytearray(mpm.solver.saveState())
    at = 8 + len("EigenMPM solver state")
    data[at] += 1
    with pytest.raises(RuntimeError, match=f"format version {data[at]}; this EigenMPM reads versions 1 to {data[at] - 1}"):
        em._eigenmpm.solverFromState(bytes(data))


def test_scene_without_eigenmpm_engines_saves_and_loads_as_before(tmp_path):
    O.engines = []
    f = str(tmp_path / "plain.yade.bz2")
    O.save(f)
    assert not os.path.exists(f + ".eigenmpm")
    O.load(f)
    O.saveTmp("plain")
    O.loadTmp("plain")


def test_checkpoints_resume_to_the_same_end_state(tmp_path):
    """A run checkpointed every 100 iterations, resumed in a new process from its newest
    checkpoint, ends where the uninterrupted run ends; only the last `keep` are kept, and an
    unfinished (.tmp) checkpoint is never taken."""
    script = textwrap.dedent(f"""
        import sys
        sys.path[:0] = [{os.path.join(ROOT, 'build', 'python')!r}, '/usr/lib/x86_64-linux-gnu/yade-double/py',
                        {os.path.dirname(os.path.abspath(__file__))!r}]
        import numpy as np
        import yade
        from yade import O
        import eigenmpm as em
        import test_save_load as t
        mode, path = sys.argv[1], sys.argv[2]
        if mode == "first":
            t.plate()
            O.engines = [em.Checkpoint(directory=path + "/ckpt", iterPeriod=100, keep=2)] + list(O.engines)
            O.run(350, True)
        elif mode == "resume":
            em.checkpoint.resume(path + "/ckpt")
            O.run(400 - O.iter, True)
            np.save(path + "/resumed.npy", em.findEngine("plate").solver.positions())
        else:
            t.plate()
            O.run(400, True)
            np.save(path + "/straight.npy", em.findEngine("plate").solver.positions())
    """)
    (tmp_path / "run.py").write_text(script)
    r = subprocess.run([sys.executable, str(tmp_path / "run.py"), "first", str(tmp_path)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    ckpt = tmp_path / "ckpt"
    assert sorted(os.listdir(ckpt)) == ["checkpoint-000000200", "checkpoint-000000300"]
    (ckpt / "checkpoint-000000340.tmp").mkdir()  # a save that was interrupted
    assert em.checkpoint.latest(str(ckpt)).endswith("checkpoint-000000300")
    for mode in ("resume", "straight"):
        r = subprocess.run([sys.executable, str(tmp_path / "run.py"), mode, str(tmp_path)],
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
    assert np.array_equal(np.load(tmp_path / "resumed.npy"), np.load(tmp_path / "straight.npy"))


def test_checkpoint_must_come_first_and_resume_needs_a_checkpoint(tmp_path):
    plate()
    O.engines = list(O.engines) + [em.Checkpoint(directory=str(tmp_path), iterPeriod=5)]
    with pytest.raises(RuntimeError, match="must be the first engine"):
        O.run(12, True)
    with pytest.raises(FileNotFoundError, match="no complete checkpoint"):
        em.checkpoint.resume(str(tmp_path / "none"))
    with pytest.raises(ValueError, match="iterPeriod or wallPeriod"):
        em.Checkpoint(directory=str(tmp_path))


def test_example_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """crack_branching.py --checkpoint-every N, then --resume from its checkpoints: the same
    eroded points and the same summary as the uninterrupted run (only wall times differ)."""
    import json
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    script = os.path.join(ROOT, "examples", "crack_branching.py")
    a, b = tmp_path / "a", tmp_path / "b"
    for args in (["--out", str(a), "--checkpoint-every", "300"],
                 ["--out", str(b), "--resume", str(a / "checkpoints")]):
        r = subprocess.run(["yade", "-n", "-x", script, "--quick", "endTime_us=30"] + args, env=env,
                           capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert sorted(os.listdir(a / "checkpoints")) == ["checkpoint-000000300", "checkpoint-000000600"]
    assert (a / "eroded.csv").read_bytes() == (b / "eroded.csv").read_bytes()
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    assert sa["eroded_count"] > 0
    for k in sa:
        if k not in ("wall_time_s", "particle_steps_per_s"):
            assert sa[k] == sb[k], k


def _resumeExample(tmp_path, script, params, every, checkpoints, csvs):
    """Runs examples/<script> --quick with params and --checkpoint-every `every`, then again with
    --resume from its checkpoints (the names `checkpoints` are expected): the CSVs `csvs` are
    the same byte for byte and the summaries the same value for value but the wall times.
    Returns the two summaries."""
    import json
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    path = os.path.join(ROOT, "examples", script)
    a, b = tmp_path / "a", tmp_path / "b"
    for args in (["--out", str(a), "--checkpoint-every", str(every)],
                 ["--out", str(b), "--resume", str(a / "checkpoints")]):
        r = subprocess.run(["yade", "-n", "-x", path, "--quick"] + list(params) + args, env=env,
                           capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert sorted(os.listdir(a / "checkpoints")) == checkpoints
    for name in csvs:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    assert sorted(sa) == sorted(sb)
    for k in sa:
        if k not in ("wall_time_s", "particle_steps_per_s", "resumed_from_iteration"):
            assert sa[k] == sb[k], k
    return sa, sb


def test_kalthoff_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """kalthoff.py --checkpoint-every 300, then --resume: the newest checkpoint (iteration 900)
    lies after the crack reached the edge (iteration ~887) and before the stop 2 us later, so
    the resumed run ends at the same step (909 < 917 = endTime_us / dt_us) only if the edge watch
    came back with its state."""
    sa, _ = _resumeExample(tmp_path, "kalthoff.py", [], 300, ["checkpoint-000000600", "checkpoint-000000900"],
                           ["crack_path.csv"])
    assert sa["steps"] == 909 and sa["boundary_time_us"] is not None and sa["crack_points"] > 0


def test_john_shah_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """john_shah.py (gamma = 0.5) --checkpoint-every 1760, then --resume: the newest checkpoint
    (iteration 3520) lies after the crack reached 0.9 D (iteration ~3504) and before the stop
    20 us later, so the resumed run ends at the same step (3545; 3560 if the watch had found
    the crack again after the resume) only if the load watch came back with its state; peak_load_N comes from the load record, most of which was
    saved in the checkpoint."""
    sa, _ = _resumeExample(tmp_path, "john_shah.py", ["gamma=0.5"], 1760,
                           ["checkpoint-000001760", "checkpoint-000003520"], [])
    assert sa["steps"] == 3545 and sa["crack_origin"] == "notch" and sa["peak_load_N"] > 0


def test_lshaped_panel_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """lshaped_panel.py --quick endDisplacement_mm=0.42 (17 162 steps; erosion from about step
    16 550) --checkpoint-every 5700, then --resume from the newest checkpoint (iteration 17 100,
    after the crack started): the same load-displacement record (most of it saved in the
    checkpoint), eroded points and summary."""
    sa, _ = _resumeExample(tmp_path, "lshaped_panel.py", ["endDisplacement_mm=0.42"], 5700,
                           ["checkpoint-000011400", "checkpoint-000017100"],
                           ["load_displacement.csv", "eroded.csv"])
    assert sa["steps"] == 17162 and sa["eroded_count"] > 0 and sa["initiation_load_kN"] is not None


def _yade(script, args):
    """Runs examples/<script> with args under yade (the built package on PYTHONPATH); returns the
    completed process, which must have exited 0."""
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    r = subprocess.run(["yade", "-n", "-x", os.path.join(ROOT, "examples", script)] + list(args), env=env,
                       capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    return r


def _sameSummaries(a, b, name="summary.json", times=("wall_time_s", "particle_steps_per_s")):
    """The JSON files `name` in folders a and b hold the same values, but the wall times."""
    import json
    sa, sb = (json.loads((d / name).read_text()) for d in (a, b))
    rows = (sa, sb) if isinstance(sa, list) else ([sa], [sb])
    assert len(rows[0]) == len(rows[1])
    for ra, rb in zip(*rows):
        assert sorted(ra) == sorted(rb)
        for k in ra:
            if k not in times:
                assert ra[k] == rb[k] or ra[k] != ra[k] and rb[k] != rb[k], k  # NaN == NaN here
    return sa


# Timings of a DEM/MPM comparison's summary: they count the resumed part only.
DEM_TIMES = ("wall_time_s", "particle_steps_per_s", "cpu_time_s", "mpm_wall_s", "dem_wall_s", "engine_wall_s",
             "mpm_particle_steps_per_s", "dem_particle_steps_per_s")


def _resumeDem(tmp_path, script, params, every, checkpoints):
    """Runs the DEM/MPM comparison examples/<script> --quick model=jcfpm with params and
    --checkpoint-every `every`, then again with --resume from its checkpoints (the names
    `checkpoints` expected). The MPM side continues bitwise: the same MPM columns of
    load_displacement.csv and the same summary values. The DEM side continues to round-off only:
    YADE's load restores the bodies and bonds bitwise, but its collider rebuilds its lists and the
    contacts are then visited, and their forces summed, in another order (measured on the beam:
    positions and velocities 3e-17 apart 20 steps after a load, 2e-10 after 100 while bonds break), so its
    floating-point values are compared to 1e-6 and its counts exactly. Returns the summary."""
    a, b = tmp_path / "a", tmp_path / "b"
    args = ["--quick", "model=jcfpm", "calibrate=0"] + list(params)
    _yade(script, args + ["--out", str(a), "--checkpoint-every", str(every)])
    _yade(script, args + ["--out", str(b), "--resume", str(a / "checkpoints")])
    assert sorted(os.listdir(a / "checkpoints")) == checkpoints
    import json
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    assert sorted(sa) == sorted(sb)
    for k in sa:
        if k in DEM_TIMES:
            continue
        if k.startswith("dem_") and isinstance(sa[k], float):
            assert sb[k] == pytest.approx(sa[k], rel=1e-6, abs=1e-300), k
        else:
            assert sa[k] == sb[k], k
    ca, cb = (np.loadtxt(d / "load_displacement.csv", delimiter=",", skiprows=1) for d in (a, b))
    assert ca.shape == cb.shape
    assert np.array_equal(ca[:, :3], cb[:, :3])  # time, MPM displacement and load
    assert np.allclose(cb[:, 3:], ca[:, 3:], rtol=1e-5, atol=1e-12)  # DEM displacement and load
    return sa


def test_dem_three_point_bending_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """dem_three_point_bending.py (JCFpm) to 0.1 mm (4199 steps) --checkpoint-every 2000, then
    --resume from the newest checkpoint (iteration 4000, DEM bonds broken): the same records
    of both models and the same summary (the DEM's to round-off, see _resumeDem); the broken bonds
    and the JCFpm crack energy come from the loaded scene, not from the copies of the DEM's engines
    that the checkpoint holds with the pair."""
    s = _resumeDem(tmp_path, "dem_three_point_bending.py", ["endDisplacement_mm=0.1"], 2000,
                   ["checkpoint-000002000", "checkpoint-000004000"])
    assert s["steps"] == 4199 and s["dem_broken_bonds"] > 0 and s["dem_dissipated_energy_J"] > 0


def test_dem_lshaped_panel_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """dem_lshaped_panel.py (JCFpm) to 0.15 mm (2904 steps) --checkpoint-every 1400, then --resume
    from iteration 2800 (DEM bonds broken from about 0.1 mm): as for the beam. With CPM (the
    default) both options are refused: YADE does not save the damage and shear strain of CPM
    bonds, so a resumed CPM run would not continue the same run."""
    s = _resumeDem(tmp_path, "dem_lshaped_panel.py", ["endDisplacement_mm=0.15"], 1400,
                   ["checkpoint-000001400", "checkpoint-000002800"])
    assert s["steps"] == 2904 and s["dem_broken_bonds"] > 0
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    r = subprocess.run(["yade", "-n", "-x", os.path.join(ROOT, "examples", "dem_lshaped_panel.py"), "--quick",
                        "--out", str(tmp_path / "c"), "--checkpoint-every", "100"], env=env, capture_output=True,
                       text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert r.returncode != 0 and "need model=jcfpm" in r.stdout + r.stderr
    assert not (tmp_path / "c" / "checkpoints").exists()


def test_vibrating_bar_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """vibrating_bar.py --quick (481 steps) --checkpoint-every 200, then --resume from iteration
    400: the same summary, whose frequency comes from the modal record of the whole run (most of it
    saved in the checkpoint)."""
    sa, _ = _resumeExample(tmp_path, "verification/vibrating_bar.py", ["plot=0"], 200,
                           ["checkpoint-000000200", "checkpoint-000000400"], [])
    assert sa["steps"] == 481 and sa["rel_error"] < 0.01


def test_spinning_disc_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """spinning_disc.py --quick (1383 steps, APIC + corotational) --checkpoint-every 500, then
    --resume from iteration 1000: the same summary (its means and peaks come from the record of
    the whole run, most of it saved in the checkpoint; the affine velocities and deformation
    gradients come back with the solver)."""
    sa, _ = _resumeExample(tmp_path, "verification/spinning_disc.py", ["plot=0"], 500,
                           ["checkpoint-000000500", "checkpoint-000001000"], [])
    assert sa["steps"] == 1383 and sa["eroded_points"] == 0 and sa["transfer"] == "APIC"


def test_lpanel_corner_resumes_in_the_ramp_or_in_the_load_record_to_the_same_end_state(tmp_path):
    """lpanel_corner.py h_mm=10 (a ramp of 2042 steps, then 82 recording the load)
    --checkpoint-every 1050: resumed from iteration 2100 (in the load record, which the checkpoint
    holds) and, once that checkpoint is removed, from iteration 1050 (in the ramp; the record is
    made after it): the same summary."""
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    script = "verification/lpanel_corner.py"
    _yade(script, ["h_mm=10", "--out", str(a), "--checkpoint-every", "1050"])
    assert sorted(os.listdir(a / "checkpoints")) == ["checkpoint-000001050", "checkpoint-000002100"]
    _yade(script, ["h_mm=10", "--out", str(b), "--resume", str(a / "checkpoints")])
    import shutil
    shutil.rmtree(a / "checkpoints" / "checkpoint-000002100")
    _yade(script, ["h_mm=10", "--out", str(c), "--resume", str(a / "checkpoints")])
    s = _sameSummaries(a, b)
    _sameSummaries(a, c)
    assert s["steps"] == 2124 and s["load_kN"] > 0


def test_precracked_bar_resumes_the_unfinished_bar_and_reads_the_finished_one_back(tmp_path):
    """precracked_bar.py --quick (two bars of 401 steps) --checkpoint-every 150: each bar keeps
    its checkpoints 300 and 401 (its end) in its own folder. With the intact bar's end removed (the
    pair stopped in the intact bar after iteration 300), --resume continues the intact bar from 300
    and reads the cracked one back from its end without running it: the same summary."""
    a, b = tmp_path / "a", tmp_path / "b"
    script = "verification/precracked_bar.py"
    _yade(script, ["--quick", "plot=0", "--out", str(a), "--checkpoint-every", "150"])
    for bar in ("cracked", "intact"):
        assert sorted(os.listdir(a / "checkpoints" / bar)) == ["checkpoint-000000300", "checkpoint-000000401"]
    import shutil
    shutil.rmtree(a / "checkpoints" / "intact" / "checkpoint-000000401")
    done = (a / "checkpoints" / "cracked" / "checkpoint-000000401").stat().st_mtime_ns
    _yade(script, ["--quick", "plot=0", "--out", str(b), "--resume", str(a / "checkpoints")])
    s = _sameSummaries(a, b)
    assert s["steps"] == 401 and s["gap_m"] > 0 and s["reaction_intact_N"] is not None
    assert sorted(os.listdir(a / "checkpoints" / "intact")) == ["checkpoint-000000300", "checkpoint-000000401"]
    assert (a / "checkpoints" / "cracked" / "checkpoint-000000401").stat().st_mtime_ns == done


def test_bar_convergence_resumes_an_interrupted_sweep_to_the_same_table(tmp_path):
    """bar_convergence.py --quick (six runs, 241 to 961 steps) --checkpoint-every 300: each run
    keeps its checkpoints, its end among them, in its own folder. With the sweep made to look
    stopped in its fifth run (linear, 20 cells: its end removed, checkpoint 300 left) before the
    sixth began (its folder removed), --resume reads the four finished runs back from their ends
    without running them, continues the fifth from 300 and runs the sixth from the start,
    checkpointed at the sweep's period (300, learnt from the resumed runs): the same table."""
    a, b = tmp_path / "a", tmp_path / "b"
    script = "verification/bar_convergence.py"
    _yade(script, ["--quick", "--out", str(a), "--checkpoint-every", "300"])
    ck = a / "checkpoints"
    assert sorted(os.listdir(ck)) == ["linear-10", "linear-20", "linear-40", "uGIMP-10", "uGIMP-20", "uGIMP-40"]
    assert sorted(os.listdir(ck / "linear-20")) == ["checkpoint-000000300", "checkpoint-000000481"]
    import shutil
    shutil.rmtree(ck / "linear-20" / "checkpoint-000000481")
    shutil.rmtree(ck / "linear-40")
    ends = {run: (ck / run / f"checkpoint-{steps:09d}").stat().st_mtime_ns
            for run, steps in (("uGIMP-10", 241), ("uGIMP-20", 481), ("uGIMP-40", 961), ("linear-10", 241))}
    _yade(script, ["--quick", "--out", str(b), "--resume", str(ck)])
    assert (a / "convergence.md").read_bytes() == (b / "convergence.md").read_bytes()
    rows = _sameSummaries(a, b, "convergence.json")
    assert len(rows) == 6 and rows[-1]["steps"] == 961
    assert sorted(os.listdir(ck / "linear-20")) == ["checkpoint-000000300", "checkpoint-000000481"]
    assert sorted(os.listdir(ck / "linear-40")) == ["checkpoint-000000900", "checkpoint-000000961"]
    assert {run: (ck / run / f"checkpoint-{steps:09d}").stat().st_mtime_ns
            for run, steps in (("uGIMP-10", 241), ("uGIMP-20", 481), ("uGIMP-40", 961), ("linear-10", 241))} == ends


def test_griffith_initiation_resumes_from_its_checkpoint_to_the_same_end_state(tmp_path):
    """griffith_initiation.py --quick kinkPoints=60 --checkpoint-every 400, then --resume: the
    newest checkpoint (iteration 800) lies before the first erosion (iteration ~1000), so the
    resumed run must start the crack in the same step, at the same traction, and grow it to the
    same eroded set (the erosion engine and its events come back with the scene)."""
    sa, sb = _resumeExample(tmp_path, "verification/griffith_initiation.py", ["kinkPoints=60", "ratioMax=2"], 400,
                            ["checkpoint-000000400", "checkpoint-000000800"], [])
    assert sa["initiation_ratio"] > 0.7 and sa["eroded_points"] >= 60
    assert (sa["resumed_from_iteration"], sb["resumed_from_iteration"]) == (0, 800)


def test_a_load_ends_the_scene_it_replaces_its_engines_labels_and_state():
    # The engines of the scene a load replaces are in no scene any more: their default labels
    # are free, and the next O.reset() releases them as it releases the scene's own. (Engines
    # that other tests built and dropped may still hold labels until the collector frees them.)
    import gc
    gc.collect()
    plate(2, 1)
    old = [e for e in O.engines if isinstance(e, (em.EigenErosion, em.PlotRecorder))]
    labels = [e.label for e in old]
    assert [label.rstrip("0123456789") for label in labels] == ["erosion", "mpmPlot"]
    O.run(20, True)
    O.saveTmp("replaced")
    O.loadTmp("replaced")
    # The loaded scene's engines hold the labels now, the replaced ones do not.
    loaded = [e for e in O.engines if isinstance(e, (em.EigenErosion, em.PlotRecorder))]
    assert [e.label for e in loaded] == labels and not any(a is b for a, b in zip(old, loaded))
    assert em.EigenErosion(Gc=1.0, kappaOverH=1.1).label != labels[0]
    O.reset()
    gc.collect()
    assert em.EigenErosion(Gc=1.0, kappaOverH=1.1).label == labels[0]
    assert em.PlotRecorder(iterPeriod=5).label == labels[1]
    with pytest.raises(RuntimeError, match="freed by O.reset"):
        old[0].core.erodedCount
