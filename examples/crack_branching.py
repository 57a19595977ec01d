"""Dynamic crack branching in a pre-cracked glass plate (paper Section 5.2).

Plate 100 x 40 mm (plane stress, thickness h as in the paper), a pre-crack from the left edge
to the centre at mid-height, soda-lime glass E = 72 GPa, nu = 0.22, rho = 2440 kg/m3,
Gc = 135 N/m, traction 12 MPa on the top and bottom edges applied suddenly, alpha = 2,
kappa = 1.1 h. Paper: h = 0.25 mm (256 000 points), dt = 0.01 us; initiation about 12 us,
branching about 32 us, cut through at 68 us.

The pre-crack is a sharp crack modelled by phantom nodes (Section 3.3.1), from just outside
the left edge to the centre (phantom=1, default); phantom=0 uses instead an open notch
`notchWidthOverH` cells wide with no points in it. Choices: the traction acts on the points
within one layer h of the edges (paper Eq 28).

Run::

    yade -n -x examples/crack_branching.py [--quick] [--out DIR] [param=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]

--checkpoint-every N saves the scene every N iterations into DIR/checkpoints (eigenmpm.Checkpoint,
doc/restart.md); --resume DIR/checkpoints continues from the newest of them to the end state of
the uninterrupted run (give the same parameters), and writes the outputs as usual (wall_time_s
then counts the resumed part only).
    yade-batch table.txt examples/crack_branching.py      # a column per parameter (and quick)
    mpiexec -n 2 yade -n -j1 -x examples/crack_branching.py --quick   # on 2 processes (doc/parallel.md)

with params h_mm, ppc, shape, kappaOverH, alpha, endTime_us, dt_us, dtFraction (if > 0: the time step
as this fraction of the critical step, instead of dt_us), phantom, notchWidthOverH, vtkPeriod_us, split
(the tension/compression split of the strain energy: spectral, the paper's and the default; volumetric;
none; see doc/fracture.md), E, nu, rho, Gc, traction_MPa, transfer (the particle-grid transfer of
MpmEngine: FLIP, the paper's and the default, or APIC, which needs shape=uGIMP) and stressUpdate
(smallStrain, the paper's and the default, or corotational; doc/stability.md), distributedSetup
(default 1: under mpiexec each rank builds only its share of the points, doc/parallel.md
"Memory"; 0: every rank builds the whole scene first; the same results either way), columnCells
and rankColumns (default 0 and 1: slabs along y; rankColumns=C columnCells=2 puts the ranks in C
columns along x times N / C rows along y, doc/parallel.md "Decomposition in two directions"). Writes
DIR/summary.json (initiation_time_us, branching_time_us, cut_through_time_us (the first time
the crack grown from the pre-crack tip reaches the right edge; right_edge_time_upper_us and
_lower_us per branch, branches_at_right_edge), max_tip_speed_m_s, dissipated_energy_J,
external_work_J (work of the tractions at the end), energy_balance_final_J (Ek + Ee + Ef - Wext
at the end, MpmEngine.energyBalance) and energy_balance_max_abs_J (the largest change of that
balance from its first record), transfer, stress_update, particles, steps, wall_time_s,
particle_steps_per_s, ...), DIR/damage.png, DIR/energy.png (elastic, kinetic and dissipated
energy, and the balance Ek + Ee + Ef - Wext with Ek at the elastic energy's time level),
DIR/energy.csv (t_us and, in J at each record, Ek at the step, Ee, Ef, Wext, balance),
DIR/tip_speed.png (over the same windows as max_tip_speed_m_s, tip_speed_window_us),
DIR/eroded.csv (positions of the eroded points at the end, mm) and a VTK series
DIR/vtk/plate-*.vtp. --quick: h = 1 mm, 40 us.
"""
import json
import math
import os
import sys
import time

import numpy as np
from yade import O, pack, plot

import eigenmpm as em
from eigenmpm import plots
from eigenmpm.cli import checkpointArgs, finish, runSteps, scriptArgs
from eigenmpm.fracture import linked

DEFAULTS = dict(h_mm=0.25, ppc=2, shape="uGIMP", kappaOverH=1.1, alpha=2.0, endTime_us=80.0, dt_us=0.01,
                dtFraction=0.0, phantom=1.0, notchWidthOverH=2.0, vtkPeriod_us=10.0, E=72e9, nu=0.22, rho=2440.0,
                Gc=135.0, traction_MPa=12.0, split="spectral", transfer="FLIP", stressUpdate="smallStrain",
                distributedSetup=True, columnCells=0, rankColumns=1)
QUICK = dict(h_mm=1.0, endTime_us=40.0, dt_us=0.04)


def build(o):
    h = o["h_mm"] * 1e-3
    L, W = 0.1, 0.04
    plate = pack.inAlignedBox((0, 0, 0), (L, W, 0))
    if not o["phantom"]:
        notch = 0.5 * o["notchWidthOverH"] * h
        plate = plate - pack.inAlignedBox((-1, 0.5 * W - notch, -1), (0.5 * L, 0.5 * W + notch, 1))
    # The grid leaves 5 mm around the plate: after cut-through the halves fly apart.
    mpm = em.MpmEngine(dim=2, h=h, ppc=o["ppc"], shape=o["shape"], thickness=h, label="plate",
                       domain=((-0.005, -0.005, 0), (L + 0.005, W + 0.005, 0)),
                       transfer=o["transfer"], stressUpdate=o["stressUpdate"], distributedSetup=o["distributedSetup"],
                       columnCells=o["columnCells"], rankColumns=o["rankColumns"])
    glass = em.ElasticMaterial(E=o["E"], nu=o["nu"], rho=o["rho"], planeStress=True, split=o["split"])
    mpm.fill(plate, glass)
    if o["phantom"]:
        mpm.crack([(-h, 0.5 * W, 0), (0.5 * L, 0.5 * W, 0)])
    t = o["traction_MPa"] * 1e6
    mpm.traction(points=pack.inAlignedBox((-1, W - h, -1), (1, 1, 1)), traction=(0, t, 0))
    mpm.traction(points=pack.inAlignedBox((-1, -1, -1), (1, h, 1)), traction=(0, -t, 0))
    crack = em.EigenErosion(engine=mpm, Gc=o["Gc"], alpha=o["alpha"], kappaOverH=o["kappaOverH"],
                            origin=(0.5 * L, 0.5 * W, 0), iterPeriod=max(1, int(round(0.1e-6 / (o["dt_us"] * 1e-6)))))
    return mpm, crack


def edgeArrivals(x0, events, L, W, spacing, radius):
    """When the crack reaches the right edge: the erosion events of the crack connected (within
    `radius`, in the reference positions x0 of the events' points, a row each) to the eroded point
    nearest the pre-crack tip, and among them the first eroded within one point spacing of the
    right edge x = L, above and below mid-height.
    Returns (cut-through time, [upper branch time, lower branch time]) in s, None where not
    reached. The plate is cut through when the first branch reaches the edge."""
    if not events:
        return None, [None, None]
    t = np.array([e[2] for e in events])
    x = np.asarray(x0)[:, :2]
    main = linked(x, int(np.argmin(np.sum((x - (0.5 * L, 0.5 * W)) ** 2, axis=1))), radius)
    edge = main & (x[:, 0] >= L - spacing)
    times = [float(t[edge & side].min()) if np.any(edge & side) else None
             for side in (x[:, 1] >= 0.5 * W, x[:, 1] < 0.5 * W)]
    reached = [v for v in times if v is not None]
    return (min(reached) if reached else None), times


def main(argv):
    argv, resume, every = checkpointArgs("crack_branching", argv)
    o, out, quick = scriptArgs("crack_branching", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    plot.reset()
    if resume:  # the scene, its engines and their records as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        mpm = em.findEngine("plate")
        (crack,) = mpm.physics.values()
        o["dt_us"] = O.dt * 1e6
    else:
        mpm, crack = build(o)
        if o["dtFraction"] > 0:  # the time step as a fraction of the critical one, instead of dt_us
            o["dt_us"] = o["dtFraction"] * mpm.criticalTimeStep() * 1e6
            crack.iterPeriod = max(1, int(round(0.1 / o["dt_us"])))
        O.dt = o["dt_us"] * 1e-6
    steps = int(round(o["endTime_us"] / o["dt_us"]))
    if not resume:
        vtk = em.VTKRecorder(fileName=os.path.join(out, "vtk", "plate-"),
                             iterPeriod=max(1, int(round(o["vtkPeriod_us"] / o["dt_us"]))))
        O.engines = [mpm, crack, em.PlotRecorder(iterPeriod=crack.iterPeriod), vtk,
                     em.Progress(endIter=steps, realPeriod=20)]
        if every:
            O.engines = [em.Checkpoint(directory=os.path.join(out, "checkpoints"), iterPeriod=every)] + list(O.engines)
    n = mpm.numPoints()  # (all points: under mpiexec a rank's solver holds its part, doc/parallel.md)
    start = time.time()
    end = runSteps(steps - O.iter)  # Ctrl-C, SIGTERM or a solver error: outputs up to the stop, then finish()
    steps = mpm.solver.steps
    wall = time.time() - start
    summary = dict(crack.summary())
    summary.pop("crack_tips_m")
    h = o["h_mm"] * 1e-3
    events = crack.core.events()
    cut, sides = edgeArrivals(mpm.referenceOf([e[0] for e in events]), events, 0.1, 0.04, h / o["ppc"],
                              2 * o["kappaOverH"] * h)
    summary.update(cut_through_time_us=None if cut is None else 1e6 * cut,
                   right_edge_time_upper_us=None if sides[0] is None else 1e6 * sides[0],
                   right_edge_time_lower_us=None if sides[1] is None else 1e6 * sides[1],
                   branches_at_right_edge=sum(v is not None for v in sides))
    # The energy balance Ek + Ee + Ef - Wext (MpmEngine.energyBalance, recorded by PlotRecorder):
    # its change from the first record is the scheme's error plus what erosion books differently.
    balance = np.array(plot.data.get("plate_balance", []))
    summary.update(external_work_J=mpm.externalWork(), energy_balance_final_J=mpm.energyBalance()["balance"],
                   energy_balance_max_abs_J=float(np.max(np.abs(balance - balance[0]))) if len(balance) else None,
                   transfer=mpm.transfer, stress_update=mpm.stressUpdate)
    summary.update(particles=n, steps=steps, wall_time_s=wall, particle_steps_per_s=n * steps / wall,
                   elastic_energy_J=mpm.elasticEnergy(), kinetic_energy_J=mpm.kineticEnergy(),
                   tips_at_end=len(crack.history[-1][4]) if crack.history else 0,
                   parameters=o, quick=quick, **end.summary())
    x, damage = (em.parallel.gather(mpm, a) for a in (mpm.solver.positions(), mpm.solver.damage()))
    plots.damageMap(mpm, os.path.join(out, "damage.png"))  # (every rank: it sums a raster over the ranks)
    t = np.array(plot.data["t"])
    keys = ("plate_EkStep", "plate_Ee", "erosion_Ef", "plate_Wext", "plate_balance")
    if em.parallel.isRoot():  # under mpiexec rank 0 writes the files (the figures save themselves there)
        with open(os.path.join(out, "summary.json"), "w") as f:
            json.dump(summary, f, indent=2)
        np.savetxt(os.path.join(out, "eroded.csv"), 1e3 * x[damage <= 0][:, :2], fmt="%.6g", delimiter=",",
                   header="x_mm,y_mm", comments="")
        np.savetxt(os.path.join(out, "energy.csv"), np.column_stack([1e6 * t] + [plot.data[k] for k in keys]),
                   fmt="%.9g", delimiter=",", header="t_us,Ek_J,Ee_J,Ef_J,Wext_J,balance_J", comments="")
    plots.series(os.path.join(out, "energy.png"), t, {"elastic (Eq 32)": plot.data["plate_Ee"],
                                                      "kinetic": plot.data["plate_Ek"],
                                                      "dissipated (Eq 33)": plot.data["erosion_Ef"],
                                                      "external work": plot.data["plate_Wext"],
                                                      "balance Ek+Ee+Ef-Wext": plot.data["plate_balance"]},
                 ylabel="energy (J)", title="Crack branching: energies")
    ts, v = crack.tipSpeed()  # the window of max_tip_speed_m_s in summary.json
    w = summary["tip_speed_window_us"]
    plots.series(os.path.join(out, "tip_speed.png"), ts, {"EigenMPM": v}, ylabel="tip speed (m/s)",
                 title="Crack tip speed" + (f" (front advance over {w:.2g} us windows)" if w else ""),
                 hlines=((1580, "experimental maximum 1580 m/s"), (3160, "Rayleigh speed ~3160 m/s")))
    if em.parallel.isRoot():
        print(json.dumps({k: v for k, v in summary.items() if k != "parameters"}, indent=2))
        print("outputs in", out)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
