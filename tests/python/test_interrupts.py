"""Interrupts and failures (eigenmpm.cli.runSteps and finish): SIGINT and SIGTERM stop a run at
the end of the current step within a second, a solver error stops it with its message; either
way the example writes its outputs, marks its figures and exits non-zero."""
import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em
from eigenmpm.cli import markStoppedEarly, runSteps

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def block(h=0.005):
    mpm = em.MpmEngine(h=h, domain=((-0.1, -0.1, 0), (0.5, 0.2, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.1, 0)), em.ElasticMaterial(E=30e9, nu=0.2, rho=2400),
             velocity=(1, 0, 0))
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm


def signalLater(signum, delay):
    sent = {}

    def send():
        sent["at"] = time.time()
        os.kill(os.getpid(), signum)
    threading.Timer(delay, send).start()
    return sent


@pytest.mark.parametrize("signum, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_stops_the_run_at_a_step_boundary_within_a_second(signum, status):
    mpm = block()
    O.engines = [mpm]
    before = signal.getsignal(signum)
    sent = signalLater(signum, 0.5)
    end = runSteps(30000)  # about 30 s
    latency = time.time() - sent["at"]
    assert latency < 1.0
    assert end.reason == "interrupted" and end.signal == signal.Signals(signum).name
    assert end.early and end.exitStatus == status
    assert 0 < O.iter < 30000 and mpm.solver.steps == O.iter == end.iter
    assert end.time == O.time == pytest.approx(mpm.solver.time, rel=1e-12)
    assert end.summary() == {"stopped_early": "interrupted", "stopped_early_time_s": O.time, "instruction_set": em.isa}
    assert signal.getsignal(signum) is before  # the handler was the run's only
    with pytest.raises(KeyboardInterrupt):
        end.check()


def test_the_step_in_progress_completes_before_run_steps_returns():
    # O.pause() lets O.run return while the loop thread still runs the current iteration; the
    # state must not be read before that iteration is over.
    mpm = block(h=0.01)
    O.engines = [mpm, em.callEvery(lambda: time.sleep(0.2))]
    signalLater(signal.SIGINT, 0.5)
    end = runSteps(50)
    assert end.reason == "interrupted"
    assert O.subStep == -1 and mpm.solver.steps == O.iter


def test_a_run_the_script_pauses_itself_is_complete():
    mpm = block(h=0.01)

    def stop():
        if O.iter == 7:
            O.pause()
    O.engines = [mpm, em.callEvery(stop)]
    end = runSteps(100)
    assert not end.early and end.reason is None and end.exitStatus == 0
    assert O.iter == 8 == mpm.solver.steps
    assert end.summary() == {"stopped_early": None, "stopped_early_time_s": None, "instruction_set": em.isa}
    assert end.check() is end


def test_a_solver_error_ends_the_run_with_its_message():
    mpm = em.MpmEngine(h=0.01, padding=1)
    ids = mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=30e9, nu=0.2, rho=2400))
    vel = np.zeros((len(ids), 3))
    vel[:, 1] = 200.0
    mpm.solver.setVelocities(vel)
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    end = runSteps(1000)
    assert end.early and end.signal is None and end.exitStatus == 1
    assert "left the grid" in end.reason and "STACK TRACE" not in end.reason
    assert end.summary()["stopped_early_time_s"] == O.time
    with pytest.raises(RuntimeError, match="left the grid"):
        end.check()


def test_stopped_early_mark_keeps_the_figure_and_adds_a_band(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 3))
    ax.plot([0, 1], [1, 0])
    path = str(tmp_path / "f.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    before = plt.imread(path)
    markStoppedEarly(path, "stopped early at t = 1 us (iteration 10): interrupted (SIGINT)")
    after = plt.imread(path)
    band = after.shape[0] - before.shape[0]
    assert band > 20 and after.shape[1] == before.shape[1]
    assert np.array_equal(after[band:], before)  # the figure, pixel for pixel
    assert np.allclose(after[1, 1, :3], (0xb0 / 255, 0, 0x20 / 255), atol=0.01)  # the red band


def runExample(tmp_path, *args):
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    return subprocess.Popen(["yade", "-n", "-x", os.path.join(ROOT, "examples", "crack_branching.py"), "--quick",
                             "--out", str(tmp_path), *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, stdin=subprocess.DEVNULL)


def checkStoppedOutputs(out, summary, reason):
    assert summary["stopped_early"] == reason
    t = summary["stopped_early_time_s"]
    assert 0 < t < 400e-6
    for name in ("damage.png", "energy.png", "tip_speed.png"):
        img = _imread(out / name)
        assert np.allclose(img[2, 2, :3], (0xb0 / 255, 0, 0x20 / 255), atol=0.01), name  # marked
    assert (out / "eroded.csv").exists()
    return t


def _imread(path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt.imread(str(path))


@pytest.mark.parametrize("signum, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_example_interrupted_writes_its_outputs_and_exits_non_zero(tmp_path, signum, status):
    # about 10^4 steps: still running when signalled
    proc = runExample(tmp_path, "endTime_us=400", "--checkpoint-every", "500")
    deadline = time.time() + 240
    while not (tmp_path / "vtk" / "plate-00000000.vtp").exists():
        assert proc.poll() is None and time.time() < deadline, "the run did not start"
        time.sleep(0.2)
    time.sleep(2.0)
    proc.send_signal(signum)
    log, _ = proc.communicate(timeout=240)
    assert proc.returncode == status, log[-3000:]
    name = signal.Signals(signum).name
    latency = float(re.search(r"run stopped at iteration \d+, t = [^,]*, ([0-9.]+) s after " + name, log).group(1))
    assert latency < 1.0
    summary = json.load(open(tmp_path / "summary.json"))
    t = checkStoppedOutputs(tmp_path, summary, "interrupted")
    assert summary["steps"] < 10000
    # the checkpoint of the stop, from which --resume continues
    newest = sorted((tmp_path / "checkpoints").iterdir())[-1]
    assert newest.name == f"checkpoint-{summary['steps']:09d}" and (newest / "scene.yade.bz2").exists()
    # the final record: the state at the stop closes the series
    sets = ET.parse(tmp_path / "vtk" / "plate-series.pvd").getroot().find("Collection").findall("DataSet")
    assert float(sets[-1].get("timestep")) == pytest.approx(t, rel=1e-9)
    assert (tmp_path / "vtk" / sets[-1].get("file")).exists()


def test_example_stopped_by_a_solver_error_exits_non_zero(tmp_path):
    # A grid too small for the plate once it is cut through: the solver stops the run when the
    # halves leave the grid; the example still writes summary and figures, marked, and fails.
    proc = runExample(tmp_path, "traction_MPa=400", "endTime_us=200")
    log, _ = proc.communicate(timeout=300)
    assert proc.returncode == 1, log[-3000:]
    summary = json.load(open(tmp_path / "summary.json"))
    assert "left the grid" in summary["stopped_early"]
    checkStoppedOutputs(tmp_path, summary, summary["stopped_early"])
    assert summary["steps"] < 5000
    assert (tmp_path / "vtk" / "plate-failure.vtp").exists()


def test_yade_batch_marks_a_stopped_run_failed(tmp_path):
    (tmp_path / "t.table").write_text("traction_MPa endTime_us quick\n400 200 1\n")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade-batch", "-j", "1", "--log", "job%.log", "t.table",
                          os.path.join(ROOT, "examples", "crack_branching.py")], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert re.search(r"#0 \(.*\) FAILED", res.stdout), res.stdout[-3000:] + res.stderr[-2000:]
    summary = json.load(open(tmp_path / "out" / "crack_branching" / "traction_MPa=400,endTime_us=200,quick=1"
                             / "summary.json"))
    assert "left the grid" in summary["stopped_early"]


def test_ctrl_c_stops_a_plain_o_run_at_a_step_boundary(tmp_path):
    """In any script (not only the examples' runSteps), Ctrl-C stops O.run(n, True) within a
    second and raises KeyboardInterrupt there, with the solver at the iteration YADE is at."""
    script = tmp_path / "plain.py"
    script.write_text(textwrap.dedent(f"""
        import os, signal, sys, threading, time
        sys.path[:0] = [{os.path.join(ROOT, 'build', 'python')!r}, '/usr/lib/x86_64-linux-gnu/yade-double/py']
        import yade
        from yade import O, pack
        import eigenmpm as em
        mpm = em.MpmEngine(dim=2, h=0.002, thickness=0.002, threads=1)
        mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.04, 0)),
                 em.ElasticMaterial(E=72e9, nu=0.22, rho=2440, planeStress=True))
        O.engines = [mpm]
        O.dt = 0.5 * mpm.criticalTimeStep()
        sent = []
        threading.Timer(1.0, lambda: (sent.append(time.time()), os.kill(os.getpid(), signal.SIGINT))).start()
        try:
            O.run(10**8, True)
        except KeyboardInterrupt:
            print("STOPPED", time.time() - sent[0], O.iter, mpm.solver.steps, O.running, flush=True)
        os._exit(0)  # the interpreter's exit is not under test here (see the session-6 note)
    """))
    # The child gets SIGINT's default disposition, as a script started from a shell has: an
    # earlier test of the suite leaves SIGINT ignored at the OS level in this process (measured:
    # SigIgn of the child held SIGINT), which the child would inherit, and Python then never
    # raises KeyboardInterrupt (which test does it is not found yet).
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120,
                       preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    line = [l for l in r.stdout.splitlines() if l.startswith("STOPPED")]
    assert line, r.stdout[-2000:] + r.stderr[-2000:]
    _, delay, it, steps, running = line[0].split()
    assert float(delay) < 1.0 and int(it) == int(steps) > 0 and running == "False"
