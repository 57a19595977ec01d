"""The same YADE script on one process and under mpiexec (doc/parallel.md): a notched plate
with tractions, a roller edge and eigenerosion (tests/python/mpi/notched_plate.py), and the quick
crack-branching plate of examples/crack_branching.py with its phantom pre-crack
(tests/python/mpi/branching_plate.py). Every point must end bitwise where it ends on one process,
the eroded points, the dissipated energy and the crack diagnostics must be the same, and the sums
over the ranks (energies, work, reaction) equal to round-off."""
import json
import os
import re
import signal
import subprocess
import time

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPTS = {"notched_plate": "300", "branching_plate": "1000"}  # script: steps


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.path.join(ROOT, "build", "python")
    # mpiexec refuses root without these (CI runs as root in a throwaway container); one OpenMP
    # thread per rank, and waiting threads that sleep, on an oversubscribed machine.
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1",
               OMP_WAIT_POLICY="PASSIVE")
    return env


def _run(out, script, ranks, held=False, extra=()):
    cmd = ["yade", "-n", "-j1", "-x", os.path.join(ROOT, "tests", "python", "mpi", script + ".py"), str(out),
           SCRIPTS[script]] + (["held"] if held else []) + list(extra)
    if ranks:
        cmd = ["mpiexec", "--oversubscribe", "-n", str(ranks)] + cmd
    res = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    with open(out / "summary.json") as f:
        summary = json.load(f)
    parts = [np.load(out / name) for name in sorted(os.listdir(out)) if name.startswith("rank-")]
    ids = np.concatenate([p["ids"] for p in parts])
    arrays = {}
    for key in ("x", "v", "stress", "damage"):
        values = np.concatenate([p[key] for p in parts])
        arrays[key] = np.empty_like(values)
        arrays[key][ids] = values
    return summary, arrays, ids


_single = {}


def single(script, tmp_path_factory):
    if script not in _single:
        _single[script] = _run(tmp_path_factory.mktemp(script), script, 0)
    return _single[script]


@pytest.mark.parametrize("script", sorted(SCRIPTS))
@pytest.mark.parametrize("ranks,held", [(2, False), (3, False), (2, True), (3, True)])
def test_mpiexec_runs_the_script_bitwise_as_one_process(tmp_path_factory, tmp_path, script, ranks, held):
    """With held: the points are distributed at set-up (MpmEngine(distributedSetup=True)), so that
    no rank ever holds the whole scene; the same results."""
    one, ref, refIds = single(script, tmp_path_factory)
    summary, arrays, ids = _run(tmp_path, script, ranks, held)
    assert summary["ranks"] == ranks and summary["held"] == held and not one["held"]
    assert summary["points"] == one["points"] == len(refIds)
    if held:  # no rank held the whole scene, even before the first step (fill shares the candidates
        # of the predicate's box evenly, so a notch or a hole makes the shares of points uneven)
        assert sum(summary["setup"]) == len(refIds) and max(summary["setup"]) <= 1.2 * len(refIds) / ranks
    else:
        assert summary["setup"] == [len(refIds)] * ranks
    assert sorted(ids.tolist()) == list(range(len(refIds)))  # every point on exactly one rank
    assert one["eroded"] > 50  # the plate cracks: the erosion exchange is exercised
    for key in ("x", "v", "stress", "damage"):
        assert np.array_equal(arrays[key], ref[key]), key
    assert summary["eroded"] == one["eroded"]
    assert summary["dissipated"] == one["dissipated"]
    assert summary["front"] == one["front"]
    assert summary["x"] == one["x"]
    for key in ("tips", "initiation", "branching"):
        assert summary.get(key) == one.get(key), key
    if script == "branching_plate":  # the eroded points' positions, sent alone, are the gathered ones
        assert summary["positionsOf"] and one["positionsOf"]
        assert summary["referenceOf"] == one["referenceOf"]
        # damageMap's raster, summed over the ranks, is the one-process raster (with eroded pixels)
        assert summary["raster"] == one["raster"] and one["raster"][2] > 0
    for key in ("kinetic", "elastic", "work"):
        assert summary[key] == pytest.approx(one[key], rel=1e-12)
    assert summary["reaction"] == pytest.approx(one["reaction"], rel=1e-12)


@pytest.mark.parametrize("ranks,cols,held", [(4, 2, False), (3, 3, True)])
def test_blocks_in_two_directions_run_the_script_bitwise_as_one_process_with_the_same_columns(
        tmp_path_factory, tmp_path, ranks, cols, held):
    """MpmEngine(columnCells=2, rankColumns=cols): the ranks in cols columns along x times rows
    along y (2 x 2, and 1 x 3 distributed at set-up), against one process with columnCells=2."""
    if "cols" not in _single:
        _single["cols"] = _run(tmp_path_factory.mktemp("notched_cols"), "notched_plate", 0, extra=["cols=1"])
    one, ref, refIds = _single["cols"]
    summary, arrays, ids = _run(tmp_path, "notched_plate", ranks, held, extra=[f"cols={cols}"])
    assert summary["ranks"] == ranks and summary["rankColumns"] == cols and one["rankColumns"] == 1
    assert sorted(ids.tolist()) == list(range(len(refIds)))
    assert one["eroded"] > 50
    for key in ("x", "v", "stress", "damage"):
        assert np.array_equal(arrays[key], ref[key]), key
    for key in ("eroded", "dissipated", "front", "x"):
        assert summary[key] == one[key], key
    for key in ("kinetic", "elastic", "work"):
        assert summary[key] == pytest.approx(one[key], rel=1e-12)
    assert summary["reaction"] == pytest.approx(one["reaction"], rel=1e-12)


def _vtk(path):
    """Positions and damage of a .vtp or .pvtp file, sorted by position."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader, vtkXMLPPolyDataReader
    reader = vtkXMLPPolyDataReader() if str(path).endswith(".pvtp") else vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    poly = reader.GetOutput()
    x = vtk_to_numpy(poly.GetPoints().GetData())
    damage = vtk_to_numpy(poly.GetPointData().GetArray("damage"))
    order = np.lexsort(x.T[::-1])
    return x[order], damage[order]


@pytest.mark.parametrize("ranks", [2])
def test_vtk_recorder_writes_a_parallel_file_of_the_whole_scene(tmp_path_factory, tmp_path, ranks):
    single("notched_plate", tmp_path_factory)
    _run(tmp_path, "notched_plate", ranks)
    one = tmp_path_factory.getbasetemp()
    ref = sorted(one.glob("notched_plate*/vtk/plate-00000300.vtp"))[0]
    pvtp = tmp_path / "vtk" / "plate-00000300.pvtp"
    assert pvtp.exists() and (tmp_path / "vtk" / "plate-00000300-r1.vtp").exists()
    collection = (tmp_path / "vtk" / "plate-series.pvd").read_text()
    assert "plate-00000300.pvtp" in collection and "-r0.vtp" not in collection
    x, damage = _vtk(pvtp)
    xr, damageRef = _vtk(ref)
    assert np.array_equal(x, xr) and np.array_equal(damage, damageRef)
    assert damage.max() == 1.0  # eroded points are in it


@pytest.mark.parametrize("ranks", [2])
def test_each_rank_saves_its_part_and_the_same_ranks_resume_bitwise(tmp_path, ranks):
    script = os.path.join(ROOT, "tests", "python", "mpi", "save_resume.py")
    for phase in ("save", "resume"):
        cmd = ["mpiexec", "--oversubscribe", "-n", str(ranks), "yade", "-n", "-j1", "-x", script, phase, str(tmp_path), "300"]
        res = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
        assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    # rank 0 wrote the scene, every rank its part beside it
    assert (tmp_path / "scene.yade").exists()
    assert all((tmp_path / f"scene.yade.r{r}of{ranks}.eigenmpm").exists() for r in range(ranks))
    for r in range(ranks):
        full, resumed = np.load(tmp_path / f"full-r{r}.npz"), np.load(tmp_path / f"resumed-r{r}.npz")
        for key in ("ids", "x", "v", "stress", "damage", "eroded"):
            assert np.array_equal(full[key], resumed[key]), (r, key)
    assert int(np.load(tmp_path / "full-r0.npz")["eroded"][0]) > 0


def test_a_rank_part_is_refused_on_another_number_of_ranks(tmp_path):
    script = os.path.join(ROOT, "tests", "python", "mpi", "save_resume.py")
    cmd = ["mpiexec", "--oversubscribe", "-n", "2", "yade", "-n", "-j1", "-x", script, "save", str(tmp_path), "20"]
    res = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    cmd = ["mpiexec", "--oversubscribe", "-n", "3", "yade", "-n", "-j1", "-x", script, "resume", str(tmp_path), "20"]
    res = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert res.returncode != 0
    assert "resume it with as many" in res.stdout + res.stderr or "cannot be read" in res.stdout + res.stderr


def _exampleOnOneAndTwo(tmp_path, name):
    """The summaries of examples/<name>.py --quick on one process and under mpiexec -n 2 (outputs
    in tmp_path/ranks0 and ranks2)."""
    runs = []
    for ranks in (0, 2):
        out = tmp_path / f"ranks{ranks}"
        cmd = ["yade", "-n", "-j1", "-x", os.path.join(ROOT, "examples", name + ".py"), "--quick", "--out", str(out)]
        if ranks:
            cmd = ["mpiexec", "--oversubscribe", "-n", str(ranks)] + cmd
        res = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
        assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
        runs.append(json.loads((out / "summary.json").read_text()))
    return runs


def test_the_branching_example_writes_the_same_outputs_under_mpiexec(tmp_path):
    """examples/crack_branching.py --quick, unchanged, on 2 ranks: rank 0 writes the outputs,
    with the crack's numbers of the one-process run and a .pvtp per record."""
    one, two = _exampleOnOneAndTwo(tmp_path, "crack_branching")
    for key in ("initiation_time_us", "branching_time_us", "cut_through_time_us", "max_tip_speed_m_s",
                "dissipated_energy_J", "particles", "steps", "tips_at_end"):
        assert two[key] == one[key], key
    assert two["external_work_J"] == pytest.approx(one["external_work_J"], rel=1e-12)
    assert (tmp_path / "ranks2" / "eroded.csv").read_text() == (tmp_path / "ranks0" / "eroded.csv").read_text()
    assert (tmp_path / "ranks2" / "damage.png").exists()
    assert sorted(p.name for p in (tmp_path / "ranks2" / "vtk").glob("*.pvtp"))


def test_the_3d_plate_cracks_alike_on_one_and_on_two_ranks(tmp_path):
    """examples/plate3d.py --quick (16 000 points, a planar phantom pre-crack through the
    thickness): the crack starts from the pre-crack, and 2 ranks give the one-process numbers."""
    one, two = _exampleOnOneAndTwo(tmp_path, "plate3d")
    assert one["eroded_points"] > 100 and one["initiation_time_us"] is not None
    assert 5 < one["initiation_time_us"] < 20  # the 2D plates start at 10-12 us
    for key in ("initiation_time_us", "branching_time_us", "eroded_points", "dissipated_energy_J",
                "crack_front_distance_m", "max_tip_speed_m_s", "particles", "steps", "front_profile_mm"):
        assert two[key] == one[key], key
    assert two["ranks"] == 2 and (tmp_path / "ranks2" / "damage.png").exists()
    # the front layer by layer through the thickness (4 layers of points at h = 2 mm): the deepest is
    # the summary's front
    assert len(one["front_profile_mm"]) == 4
    assert max(f for _, f in one["front_profile_mm"]) == pytest.approx(1e3 * one["crack_front_distance_m"])


@pytest.mark.parametrize("name", ["lshaped_panel", "kalthoff", "john_shah"])
def test_the_2d_paper_examples_distributed_at_set_up_give_the_one_process_summary(tmp_path, name):
    """The other 2D paper examples --quick, unchanged, on 2 ranks, their points distributed at
    set-up (no rank holds the whole scene; their crack analyses read the eroded points' reference
    positions with MpmEngine.referenceOf): every number of the one-process summary."""
    one, two = _exampleOnOneAndTwo(tmp_path, name)
    assert two["parameters"]["distributedSetup"] is True
    timing = {"wall_time_s", "particle_steps_per_s", "ranks"}
    assert one.keys() == two.keys()
    # The crack's numbers come from the erosion events (the same on every rank): exact. Energies,
    # loads and reactions are sums over the ranks: equal to round-off.
    crack = [k for k in one if any(w in k for w in ("time_us", "points", "eroded", "angle", "crack", "dissipated"))]
    assert len(crack) >= 5
    for key in crack:
        assert two[key] == one[key], key
    for key in one.keys() - timing - set(crack):
        if isinstance(one[key], float) or (isinstance(one[key], list) and one[key]
                                           and all(isinstance(v, float) for v in one[key])):
            assert two[key] == pytest.approx(one[key], rel=1e-12, abs=1e-12 * abs(np.max(one[key]))), key
        else:
            assert two[key] == one[key], key
    assert two["dissipated_energy_J"] > 0


def test_checkpoints_under_mpiexec_resume_to_the_uninterrupted_run(tmp_path):
    """crack_branching.py --quick --checkpoint-every 300 on 2 ranks (every rank writes its part
    into the checkpoint folder, rank 0 completes it), then --resume from it on 2 ranks: the crack's
    numbers and eroded.csv of the uninterrupted run. The same run stopped by a signal to mpiexec
    in the middle (SIGUSR1, which Open MPI passes on to the ranks): both ranks end the same
    iteration, a checkpoint of it is written, and --resume from it ends as the uninterrupted run."""
    script = os.path.join(ROOT, "examples", "crack_branching.py")
    full, resumed, stopped, afterStop = (tmp_path / d for d in ("full", "resumed", "stopped", "afterStop"))

    def mpiexec(*args):
        return ["mpiexec", "--oversubscribe", "-n", "2", "yade", "-n", "-j1", "-x", script, "--quick"] + list(args)

    for args in (["--out", str(full), "--checkpoint-every", "300"],
                 ["--out", str(resumed), "--resume", str(full / "checkpoints")]):
        res = subprocess.run(mpiexec(*args), env=_env(), capture_output=True, text=True, timeout=600,
                             stdin=subprocess.DEVNULL)
        assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    newest = sorted((full / "checkpoints").iterdir())[-1]
    assert newest.name == "checkpoint-000000900"
    assert sorted(p.name for p in newest.iterdir() if p.name.endswith(".eigenmpm")) == [
        "scene.yade.bz2.r0of2.eigenmpm", "scene.yade.bz2.r1of2.eigenmpm"]

    returncode, log = _signalled(mpiexec("--out", str(stopped), "--checkpoint-every", "300"), _env(),
                                 stopped / "checkpoints" / "checkpoint-000000300", signal.SIGUSR1)
    assert returncode == 128 + signal.SIGUSR1, log[-3000:]
    stop, _ = _stoppedTogether(stopped, log, "SIGUSR1")
    assert 300 < stop < 1000
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for name in ("damage.png", "energy.png", "tip_speed.png"):  # marked stopped early, by the root alone
        assert np.allclose(plt.imread(str(stopped / name))[2, 2, :3], (0xb0 / 255, 0, 0x20 / 255), atol=0.01), name
    assert not list(stopped.glob("*.part.png"))
    res = subprocess.run(mpiexec("--out", str(afterStop), "--resume", str(stopped / "checkpoints")), env=_env(),
                         capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]

    a = json.loads((full / "summary.json").read_text())
    for d in (resumed, afterStop):
        b = json.loads((d / "summary.json").read_text())
        for key in ("initiation_time_us", "branching_time_us", "cut_through_time_us", "dissipated_energy_J",
                    "max_tip_speed_m_s", "steps"):
            assert b[key] == a[key], (d.name, key)
        assert (d / "eroded.csv").read_text() == (full / "eroded.csv").read_text(), d.name


def test_ctrl_c_to_mpiexec_stops_every_rank_at_the_same_iteration_and_saves_it(tmp_path):
    """Ctrl-C in the terminal sends SIGINT to mpiexec. Open MPI then sends the ranks SIGTERM
    odls_base_sigkill_timeout seconds later (1 by default; 5 here, for a loaded machine) and
    SIGKILL as long after that. Every rank stops at the end of the same step, the checkpoint of
    that step is written with every rank's part, and the summary says so."""
    script = os.path.join(ROOT, "examples", "crack_branching.py")
    out = tmp_path / "out"
    env = dict(_env(), OMPI_MCA_odls_base_sigkill_timeout="5")
    returncode, log = _signalled(["mpiexec", "--oversubscribe", "-n", "2", "yade", "-n", "-j1", "-x", script, "--quick",
                                  "endTime_us=400", "--out", str(out), "--checkpoint-every", "200"], env,
                                 out / "checkpoints" / "checkpoint-000000200", signal.SIGINT)
    assert returncode != 0
    stop, latencies = _stoppedTogether(out, log, "SIGTERM")
    assert all(latency < 1.0 for latency in latencies)
    assert 200 < stop < 10000


def _signalled(cmd, env, started, signum):
    """Starts cmd, sends it signum once the file `started` exists; returns (exit status, output)."""
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            stdin=subprocess.DEVNULL)
    deadline = time.time() + 300
    while not started.exists():
        assert proc.poll() is None and time.time() < deadline, f"the run did not reach {started.name}"
        time.sleep(0.05)
    proc.send_signal(signum)
    log, _ = proc.communicate(timeout=300)
    return proc.returncode, log


def _stoppedTogether(out, log, name):
    """Both ranks of the run in `out` stopped at the same iteration after the signal `name`, the
    newest checkpoint is that iteration's with both ranks' parts, and the summary says so.
    Returns (iteration, the ranks' seconds from the signal to the stop)."""
    found = re.findall(r"rank (\d): run stopped at iteration (\d+), t = [^,]*, ([0-9.]+) s after " + name, log)
    assert sorted(r for r, _, _ in found) == ["0", "1"] and found[0][1] == found[1][1], log[-3000:]
    stop = int(found[0][1])
    newest = sorted((out / "checkpoints").iterdir())[-1]
    assert newest.name == f"checkpoint-{stop:09d}", log[-3000:]
    assert sorted(p.name for p in newest.iterdir() if p.name.endswith(".eigenmpm")) == [
        "scene.yade.bz2.r0of2.eigenmpm", "scene.yade.bz2.r1of2.eigenmpm"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stopped_early"] == "interrupted" and summary["steps"] == stop
    return stop, [float(latency) for _, _, latency in found]
