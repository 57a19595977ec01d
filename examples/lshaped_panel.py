"""L-shaped concrete panel (Winkler's test, paper Section 5.1).

A 500 x 500 mm square without its lower-right 250 x 250 mm quarter (re-entrant corner at
(250, 250) mm), 100 mm thick, plane stress. The bottom edge of the left leg is fixed; the
underside of the right arm is pushed upward 30 mm from its right end (x = 470 mm) at a constant
0.01 m/s. E = 25.85 GPa, nu = 0.18, rho = 2500 kg/m3, Gc = 89 N/m. Paper: h = 5 mm (30 000
points), alpha and kappa as in Table 1 (alpha = 1.5, kappa = 1.1 h here by default).

Choices (parameters): the load is a velocity condition on the grid nodes nearest to the points
within h/2 of (470, 250) mm in x and h/2 above the underside (`loadWidth_mm` changes the
width); the load is that condition's reaction force; the displacement is the imposed one,
v t. The run is dynamic (explicit), so the load carries inertial oscillations.

Run::

    yade -n -x examples/lshaped_panel.py [--quick] [--out DIR] [param=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]
    yade-batch table.txt examples/lshaped_panel.py        # a column per parameter (and quick)

--checkpoint-every N saves the scene every N iterations into DIR/checkpoints (eigenmpm.Checkpoint,
doc/restart.md); --resume DIR/checkpoints continues from the newest of them (give the same
parameters) to the end state of the uninterrupted run, the load record included, and writes the
outputs as usual (wall_time_s then counts the resumed part only; the VTK series continues in the
first run's folder).

params: h_mm, ppc, shape, alpha, kappaOverH, velocity_m_s, endDisplacement_mm, rampTime_ms (the
velocity ramps up over this time, paper Eq 34; 0: applied suddenly), smoothWindow_ms (the load is
the reaction's moving average over this window: the run is dynamic and the reaction carries the
panel's vibrations), dtFraction, loadWidth_mm, E, nu, rho, Gc, transfer (the particle-grid transfer
of MpmEngine: FLIP, the paper's and the default, or APIC, which needs shape=uGIMP) and stressUpdate
(smallStrain, the paper's and the default, or corotational; doc/stability.md), distributedSetup
(default 1: under mpiexec each rank builds only its share of the points, doc/parallel.md
"Memory"; 0: every rank builds the whole scene first; the same results either way).
Writes DIR/summary.json (peak_load_kN and displacement_at_peak_mm: the maximum of the smoothed
load; initiation_load_kN and initiation_displacement_mm: at the first erosion; transfer,
stress_update, ...), DIR/load_displacement.csv,
DIR/eroded.csv (positions of the eroded points at the end, mm),
DIR/load_displacement.png (with the experimental band), DIR/damage.png and DIR/vtk/.
--quick: h = 10 mm.
"""
import csv
import json
import os
import sys
import time

import numpy as np
from yade import O, pack, plot

import eigenmpm as em
from eigenmpm import plots
from eigenmpm.cli import checkpointArgs, finish, runSteps, scriptArgs
from eigenmpm.ramp import rampDisplacement, rampTimeTo

DEFAULTS = dict(h_mm=5.0, ppc=2, shape="uGIMP", alpha=1.5, kappaOverH=1.1, velocity_m_s=0.01,
                endDisplacement_mm=0.5, rampTime_ms=0.0, smoothWindow_ms=0.2, dtFraction=0.8, loadWidth_mm=0.0, E=25.85e9, nu=0.18, rho=2500.0, Gc=89.0,
                transfer="FLIP", stressUpdate="smallStrain", distributedSetup=True)
QUICK = dict(h_mm=10.0)
# The paper's critical (vertical displacement mm, load kN): Table 1 at h = 5 mm by (alpha, kappa/h),
# and Table 2's loads at alpha = 1.5, kappa = 1.1 h by h (mm).
PAPER_TABLE1 = {(1.0, 0.9): (0.284, 17.300), (1.0, 1.1): (0.284, 17.230), (1.0, 1.25): (0.291, 17.577),
                (1.5, 0.9): (0.245, 15.100), (1.5, 1.1): (0.245, 15.082), (1.5, 1.25): (0.251, 15.394),
                (2.0, 0.9): (0.222, 13.737), (2.0, 1.1): (0.222, 13.758), (2.0, 1.25): (0.223, 14.046)}
PAPER_TABLE2_LOAD = {10.0: 16.14, 5.0: 15.08, 2.5: 14.50}
# Under `yade -x` __file__ names yade itself; sys.argv[0] is this script.
DATA = os.path.join(os.path.dirname(os.path.abspath(sys.argv[0])), "data")


def experiment():
    """Winkler's experimental load-displacement band, shipped with the examples
    (examples/data/winkler_lpanel_experiment.csv), as rows (displacement mm, lower kN, upper kN)."""
    with open(os.path.join(DATA, "winkler_lpanel_experiment.csv")) as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    return np.array([[float(c) for c in r] for r in rows[1:]])  # after the line of column names


class LoadCurve:
    """Records the load point (a callEvery): `curve`, rows of time, imposed displacement (the
    velocity ramp, paper Eq 34) and the load condition's reaction. A class at the top level, not
    a local function, so that a checkpoint saves it with its record and --resume continues it."""

    def __init__(self, mpm, load, velocity, rampTime):
        self.mpm, self.load, self.velocity, self.rampTime = mpm, load, velocity, rampTime
        self.curve = []

    def __call__(self):
        t = self.mpm.solver.time
        self.curve.append((t, rampDisplacement(t, self.velocity, self.rampTime), self.load.reaction[1]))


def build(o):
    h = o["h_mm"] * 1e-3
    a = 0.25
    panel = pack.inAlignedBox((0, 0, 0), (2 * a, 2 * a, 0)) - pack.inAlignedBox((a, -1, -1), (1, a, 1))
    mpm = em.MpmEngine(dim=2, h=h, ppc=o["ppc"], shape=o["shape"], thickness=0.1, label="panel",
                       transfer=o["transfer"], stressUpdate=o["stressUpdate"], distributedSetup=o["distributedSetup"])
    concrete = em.ElasticMaterial(E=o["E"], nu=o["nu"], rho=o["rho"], planeStress=True)
    mpm.fill(panel, concrete)
    mpm.fix(points=pack.inAlignedBox((-1, -1, -1), (a, 0.5 * h, 1)), label="base")
    half = 0.5 * max(o["loadWidth_mm"] * 1e-3, h)
    load = mpm.velocityBC(points=pack.inAlignedBox((0.47 - half, a, -1), (0.47 + half, a + 0.5 * h, 1)),
                          components="y", velocity=(0, o["velocity_m_s"], 0), rampTime=o["rampTime_ms"] * 1e-3,
                          label="load")
    crack = em.EigenErosion(engine=mpm, Gc=o["Gc"], alpha=o["alpha"], kappaOverH=o["kappaOverH"],
                            origin=(a, a, 0), iterPeriod=100)
    return mpm, crack, load


def main(argv):
    argv, resume, checkpointEvery = checkpointArgs("lshaped_panel", argv)
    o, out, quick = scriptArgs("lshaped_panel", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    plot.reset()
    v, t0 = o["velocity_m_s"], o["rampTime_ms"] * 1e-3
    if resume:  # the scene, its engines and the load record as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        mpm = em.findEngine("panel")
        (crack,) = mpm.physics.values()
        (recorder,) = [e.function for e in O.engines if isinstance(getattr(e, "function", None), LoadCurve)]
        steps = int(round(rampTimeTo(o["endDisplacement_mm"] * 1e-3, v, t0) / O.dt))
    else:
        mpm, crack, load = build(o)
        O.dt = o["dtFraction"] * mpm.criticalTimeStep()
        steps = int(round(rampTimeTo(o["endDisplacement_mm"] * 1e-3, v, t0) / O.dt))
        every = max(1, steps // 2000)
        recorder = LoadCurve(mpm, load, v, t0)
        O.engines = [mpm, crack, em.callEvery(recorder, iterPeriod=every),
                     em.VTKRecorder(fileName=os.path.join(out, "vtk", "panel-"), iterPeriod=max(1, steps // 20)),
                     em.Progress(endIter=steps, realPeriod=30)]
        if checkpointEvery:
            O.engines = ([em.Checkpoint(directory=os.path.join(out, "checkpoints"), iterPeriod=checkpointEvery)]
                         + list(O.engines))
    curve = recorder.curve
    start = time.time()
    end = runSteps(steps - O.iter)  # Ctrl-C, SIGTERM or a solver error: outputs up to the stop, then finish()
    steps = mpm.solver.steps
    wall = time.time() - start
    tc = np.array([c[0] for c in curve])
    u = np.array([c[1] for c in curve])
    F = np.array([c[2] for c in curve])
    # The raw reaction carries the panel's elastic vibrations (the explicit run is dynamic; the
    # vibrations are strongest with a sudden start): the load is its moving average over smoothWindow_ms
    # (centred; shorter at the ends), and the peak is that average's maximum.
    k = max(1, int(round(o["smoothWindow_ms"] * 1e-3 / max(tc[1] - tc[0], 1e-300)))) if len(tc) > 1 else 1
    Fs = np.array([F[max(0, i - k // 2):i + k // 2 + 1].mean() for i in range(len(F))])
    ip = int(np.argmax(Fs))
    t_init = crack.initiationTime()
    i_init = int(np.searchsorted(tc, t_init)) if t_init is not None else None
    if i_init is not None and i_init >= len(tc):
        i_init = len(tc) - 1
    n = mpm.numPoints()  # (all points: under mpiexec a rank's solver holds its part)
    summary = dict(peak_load_kN=float(Fs[ip]) / 1e3, displacement_at_peak_mm=float(u[ip]) * 1e3,
                   initiation_load_kN=None if i_init is None else float(Fs[i_init]) / 1e3,
                   initiation_displacement_mm=None if i_init is None else float(u[i_init]) * 1e3,
                   peak_load_raw_kN=float(np.max(F)) / 1e3, particles=n, steps=steps, wall_time_s=wall,
                   particle_steps_per_s=n * steps / wall, dt_s=O.dt, transfer=mpm.transfer,
                   stress_update=mpm.stressUpdate, parameters=o, quick=quick, **end.summary())
    summary.update({k: v for k, v in crack.summary().items() if k != "crack_tips_m"})
    x, damage = (em.parallel.gather(mpm, a) for a in (mpm.solver.positions(), mpm.solver.damage()))
    plots.damageMap(mpm, os.path.join(out, "damage.png"))  # (every rank: it sums a raster over the ranks)
    if not em.parallel.isRoot():  # under mpiexec rank 0 writes the outputs (doc/parallel.md)
        finish(end, out)
        return summary
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    with open(os.path.join(out, "load_displacement.csv"), "w") as f:
        f.write("displacement_mm,load_kN,load_smoothed_kN\n")
        for ui, Fi, Si in zip(u, F, Fs):
            f.write(f"{ui * 1e3:.6g},{Fi / 1e3:.6g},{Si / 1e3:.6g}\n")
    np.savetxt(os.path.join(out, "eroded.csv"), 1e3 * x[damage <= 0][:, :2], fmt="%.6g", delimiter=",",
               header="x_mm,y_mm", comments="")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(u * 1e3, F / 1e3, color="0.7", lw=0.6, label="EigenMPM, reaction")
    ax.plot(u * 1e3, Fs / 1e3, "b-", label="EigenMPM, smoothed")
    band = experiment()
    ax.fill_between(band[:, 0], band[:, 1], band[:, 2], color="orange", alpha=0.4, label="experiment (Winkler)")
    paper = PAPER_TABLE1.get((o["alpha"], o["kappaOverH"])) if o["h_mm"] == 5.0 else None
    if paper:
        ax.plot(*paper, "k*", ms=12, label="paper, Table 1 (critical point)")
    elif o["alpha"] == 1.5 and o["kappaOverH"] == 1.1 and o["h_mm"] in PAPER_TABLE2_LOAD:
        ax.axhline(PAPER_TABLE2_LOAD[o["h_mm"]], color="k", ls="--", lw=0.8, label="paper, Table 2 (critical load)")
    if i_init is not None:
        ax.plot(u[i_init] * 1e3, Fs[i_init] / 1e3, "rv", label="EigenMPM, first erosion")
    ax.set_xlabel("vertical displacement (mm)")
    ax.set_ylabel("load (kN)")
    ax.set_title(f"L-shaped panel, h = {o['h_mm']:g} mm, alpha = {o['alpha'] if isinstance(o['alpha'], str) else format(o['alpha'], 'g')}, kappa = {o['kappaOverH']:g} h")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "load_displacement.png"), dpi=130)
    plt.close(fig)
    print(json.dumps({k: v for k, v in summary.items() if k != "parameters"}, indent=2))
    print("outputs in", out)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
