"""Fixed-free vibrating bar: the first mode against the closed form.

A 2D bar (length L, height H, nu = 0 so the 1D wave speed c = sqrt(E/rho) holds exactly) is
fixed at x = 0 (grid nodes at x <= 0) and free elsewhere. It starts in its first mode,
v(x) = v0 sin(pi x / 2L), so the modal amplitude q(t) = sum m u phi / sum m phi^2 with
phi = sin(pi x / 2L) follows q = (v0/omega1) sin(omega1 t), omega1 = (pi/2L) sqrt(E/rho).
The measured omega is 2 pi over the mean period between upward zero crossings of q(t). The
amplitude is that of a least-squares fit a sin(omega t) + b cos(omega t) + c to q over the last
period (omega the measured one), sqrt(a^2 + b^2), against the closed form v0/omega1: a scheme that
dissipates energy lets it decay. The fit's offset c and phase are left out: the record carries an
offset of about omega1 dt v0/omega1 (first order in dt; the points' positions and the solver's time
are staggered), which the largest |q| would count as amplitude.

Run::

    yade -n -x examples/verification/vibrating_bar.py [--quick] [--out DIR] [cells=N] [shape=linear] [plot=0]
        [transfer=APIC] [stressUpdate=corotational] [--checkpoint-every N] [--resume DIR/checkpoints]

params: cells (along the bar; --quick: 20), shape (uGIMP or linear), ppc, periods, dtFraction (time
step / critical step), plot (0: no figure), transfer (the particle-grid transfer of MpmEngine:
FLIP, the paper's and the default, or APIC, which needs shape=uGIMP; with APIC the points start
with the gradient of the mode's velocity, MpmEngine.setVelocityGradient) and stressUpdate
(smallStrain, the paper's and the default, or corotational; doc/stability.md).

writes DIR/summary.json (omega_numeric, omega_analytic, rel_error, amplitude_ratio (the fitted
amplitude of q over the last period over v0/omega1), amplitude_rel_error (|amplitude_ratio - 1|),
transfer, stress_update, particles, steps, wall_time_s, particle_steps_per_s, ...) and DIR/tip_displacement.png (tip displacement over
time against the closed form). Default DIR: out/vibrating_bar.

--checkpoint-every N saves the scene every N iterations into DIR/checkpoints (eigenmpm.Checkpoint,
doc/restart.md); --resume DIR/checkpoints continues from the newest of them (give the same
parameters) to the end state of the uninterrupted run, the modal record (ModalRecord) included,
and writes the outputs as usual (wall_time_s then counts the resumed part only).
"""
import math
import os
import sys
import time

import numpy as np
from yade import O, pack

import eigenmpm as em
from eigenmpm.cli import checkpointArgs, finish, report, runSteps, scriptArgs


DEFAULTS = dict(cells=80, shape="uGIMP", ppc=2, periods=3.0, dtFraction=0.5, plot=True, transfer="FLIP",
                stressUpdate="smallStrain")
QUICK = dict(cells=20)


class ModalRecord:
    """Records (time, modal amplitude q, mean tip displacement) after each step (a callEvery; it
    runs after the solver in the same iteration, so it sees the state at solver.time). A class at
    the top level, not a local function, so that a checkpoint saves it with its series and a
    resumed run continues it."""

    def __init__(self, mpm, L, h):
        self.mpm = mpm
        self.x0 = mpm.solver.positions()[:, 0]
        self.phi = np.sin(0.5 * math.pi * self.x0 / L)
        self.m = mpm.solver.mass()
        self.tip = self.x0 > L - h
        self.series = []

    def __call__(self):
        u = self.mpm.solver.positions()[:, 0] - self.x0
        q = float(np.sum(self.m * u * self.phi) / np.sum(self.m * self.phi * self.phi))
        self.series.append((self.mpm.solver.time, q, float(np.mean(u[self.tip]))))


def run(cells=80, shape="uGIMP", ppc=2, periods=3.0, dtFraction=0.5, L=1.0, E=1e7, rho=1000.0, v0=1e-3,
        checkpoints=None, checkpointEvery=0, resume=None, saveEnd=False, transfer="FLIP", stressUpdate="smallStrain",
        **_):
    """Runs the bar with `cells` cells along its length; returns the summary, the time series and
    how the run ended (eigenmpm.cli.RunEnd: a stopped run has the series up to the stop).
    With checkpointEvery > 0 a Checkpoint engine saves the scene every checkpointEvery iterations
    into the folder `checkpoints`, and with saveEnd also at the end of a complete run (what a sweep
    reads back instead of running it again); `resume`, a folder of checkpoints, continues the run
    from the newest of them instead of building it (give the same parameters)."""
    O.reset()
    omega = 0.5 * math.pi / L * math.sqrt(E / rho)
    if resume:  # the scene and its record as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        mpm = em.findEngine("bar")
        (record,) = [e.function for e in O.engines if isinstance(getattr(e, "function", None), ModalRecord)]
    else:
        h = L / cells
        height = 4 * h
        mpm = em.MpmEngine(dim=2, h=h, ppc=ppc, shape=shape, label="bar", transfer=transfer,
                           stressUpdate=stressUpdate)
        mat = em.ElasticMaterial(E=E, nu=0.0, rho=rho)
        mpm.fill(pack.inAlignedBox((0, 0, 0), (L, height, 0)), mat)
        record = ModalRecord(mpm, L, h)
        vel = np.zeros_like(mpm.solver.positions())
        vel[:, 0] = v0 * record.phi
        mpm.solver.setVelocities(vel)
        if mpm.transfer == "APIC":  # the mode's velocity gradient dv_x/dx, so that the first transfer carries it
            grad = np.zeros((len(vel), 2, 2))
            grad[:, 0, 0] = v0 * 0.5 * math.pi / L * np.cos(0.5 * math.pi * record.x0 / L)
            mpm.setVelocityGradient(np.arange(len(vel)), grad)
        mpm.fix(region=pack.inAlignedBox((-L, -L, -1), (0.0, 2 * L, 1)), label="support")
        O.engines = [mpm, em.callEvery(record)]
        if checkpointEvery:
            O.engines = [em.Checkpoint(directory=checkpoints, iterPeriod=checkpointEvery)] + list(O.engines)
        O.dt = dtFraction * mpm.criticalTimeStep()
        record()
    steps = int(math.ceil(periods * 2 * math.pi / omega / O.dt))
    todo = steps - O.iter  # 0 after a resume from the checkpoint of the end
    start = time.time()
    end = runSteps(todo)
    wall = time.time() - start
    if saveEnd and todo > 0 and not end.early:
        (checkpoint,) = [e for e in O.engines if isinstance(e, em.Checkpoint)]
        checkpoint.save()
    steps = mpm.solver.steps
    t, q, utip = (np.array(c) for c in zip(*record.series))
    up = [t[i] - q[i] * (t[i + 1] - t[i]) / (q[i + 1] - q[i])
          for i in range(len(q) - 1) if q[i] < 0 <= q[i + 1]]
    down = [t[i] - q[i] * (t[i + 1] - t[i]) / (q[i + 1] - q[i])
            for i in range(len(q) - 1) if q[i] > 0 >= q[i + 1]]
    crossings = sorted(up + down)
    # Zero crossings of a sine are half a period apart; q(0) = 0 is the first.
    halfPeriods = np.diff([0.0] + crossings)
    omegaNum = math.pi / float(np.mean(halfPeriods)) if crossings else None  # none in a run stopped early
    amplitude = None
    if omegaNum:  # fitted over the last period (closed form): a sin + b cos + c at the measured omega
        last = t >= t[-1] - 2 * math.pi / omega
        w = omegaNum * t[last]
        (a, b, _), *_ = np.linalg.lstsq(np.column_stack([np.sin(w), np.cos(w), np.ones_like(w)]), q[last], rcond=None)
        amplitude = float(math.hypot(a, b) / (v0 / omega))
    n = mpm.solver.numPoints
    h = mpm.h
    summary = {
        "omega_numeric": omegaNum, "omega_analytic": omega,
        "rel_error": abs(omegaNum - omega) / omega if omegaNum else None,
        "amplitude_ratio": amplitude, "amplitude_rel_error": abs(amplitude - 1) if amplitude is not None else None,
        "transfer": mpm.transfer, "stress_update": mpm.stressUpdate,
        "particles": int(n), "steps": steps, "wall_time_s": wall,
        "particle_steps_per_s": n * steps / wall if wall > 0 else float("nan"),
        "cells_along_bar": cells, "h_m": h, "shape": shape, "ppc": ppc, "dt_s": O.dt,
        "dt_fraction_of_critical": dtFraction, "periods": periods, **end.summary(),
    }
    return summary, (t, q, utip, v0, omega, float(np.mean(record.phi[record.tip]))), end


def plot(out, series):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t, q, utip, v0, omega, phiTip = series
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(1e3 * t, 1e6 * utip, label="EigenMPM, tip (mean of the points in the last cell)")
    ax.plot(1e3 * t, 1e6 * v0 / omega * phiTip * np.sin(omega * t), "--",
            label="closed form, mode 1, at the same points")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("tip displacement (um)")
    ax.set_title("Fixed-free bar, first mode")
    ax.legend()
    fig.tight_layout()
    path = os.path.join(out, "tip_displacement.png")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv):
    argv, resume, every = checkpointArgs("vibrating_bar", argv)
    opts, out, _ = scriptArgs("vibrating_bar", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    summary, series, end = run(**opts, checkpoints=os.path.join(out, "checkpoints"), checkpointEvery=every,
                               resume=resume)
    report(out, summary, (lambda: plot(out, series)) if opts["plot"] else None)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
