"""Dynamic crack branching in 3D: the glass plate of examples/crack_branching.py (paper Section
5.2) with a thickness, for runs on several processes (doc/parallel.md, issue 17).

Plate 100 mm along x, 40 mm along z (the loading direction), `thickness_mm` along y; soda-lime
glass E = 72 GPa, nu = 0.22, rho = 2440 kg/m3, Gc = 135 N/m, alpha = 2, kappa = 1.1 h; traction
12 MPa on the faces z = 0 and z = 40 mm, applied suddenly. The pre-crack is a planar polygon by
phantom nodes through the whole thickness, from just outside the face x = 0 to the centre at
mid-height z = 20 mm. The points are divided between ranks in slabs along z (or, with
rankColumns, in blocks along z and x). The 2D plate runs plane stress; this one
is the 3D continuum with free faces y = 0 and y = thickness.

The crack's tips, front distance and tip speed are measured in the x-z plane
(`EigenErosion(throughAxis="y")`): one front through the thickness is one tip, as in the 2D plate.

Run::

    yade -n -x examples/plate3d.py [--quick] [--out DIR] [param=value ...]
    mpiexec -n 2 yade -n -j1 -x examples/plate3d.py [...]        # on 2 processes

with params h_mm, thickness_mm, ppc, kappaOverH, alpha, endTime_us, dt_us, vtkPeriod_us, Gc,
traction_MPa, distributedSetup (default 1: under mpiexec each rank builds only its share of the
points, doc/parallel.md "Memory"; 0: every rank builds the whole scene first), columnCells and
rankColumns (default 0 and 1: slabs along z; rankColumns=C columnCells=2 puts the ranks in C
columns along x times N / C rows along z, doc/parallel.md "Decomposition in two directions").
Writes (rank 0)
DIR/summary.json (initiation_time_us, branching_time_us, as in crack_branching.py's summary;
eroded_points, dissipated_energy_J, particles, steps, ranks, wall_time_s, particle_steps_per_s;
front_profile_mm: for each layer of points through the thickness, its y and the crack front's
distance from the pre-crack tip there, mm), DIR/damage.png (projected on the x-z plane) and the VTK series
DIR/vtk/plate-*.pvtp or .vtp. Default: h = 1 mm, thickness 4 mm (128 000 points), 80 us.
--quick: h = 2 mm, 40 us (16 000 points). --checkpoint-every N and --resume DIR as in the other
examples (doc/restart.md).
"""
import json
import os
import sys
import time

from yade import O, pack

import eigenmpm as em
from eigenmpm import plots
from eigenmpm.cli import checkpointArgs, finish, runSteps, scriptArgs

DEFAULTS = dict(h_mm=1.0, thickness_mm=4.0, ppc=2, kappaOverH=1.1, alpha=2.0, endTime_us=80.0, dt_us=0.04,
                vtkPeriod_us=10.0, Gc=135.0, traction_MPa=12.0, distributedSetup=True, columnCells=0, rankColumns=1)
QUICK = dict(h_mm=2.0, endTime_us=40.0, dt_us=0.08)


def build(o):
    h, T = o["h_mm"] * 1e-3, o["thickness_mm"] * 1e-3
    L, W = 0.1, 0.04
    mpm = em.MpmEngine(dim=3, h=h, ppc=o["ppc"], label="plate", distributedSetup=o["distributedSetup"],
                       columnCells=o["columnCells"], rankColumns=o["rankColumns"],
                       domain=((-0.005, -2 * h, -0.005), (L + 0.005, T + 2 * h, W + 0.005)))
    glass = em.ElasticMaterial(E=72e9, nu=0.22, rho=2440.0)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (L, T, W)), glass)
    zc = 0.5 * W
    mpm.crack([(-h, -h, zc), (0.5 * L, -h, zc), (0.5 * L, T + h, zc), (-h, T + h, zc)])
    t = o["traction_MPa"] * 1e6
    mpm.traction(points=pack.inAlignedBox((-1, -1, W - h), (1, 1, 1)), traction=(0, 0, t))
    mpm.traction(points=pack.inAlignedBox((-1, -1, -1), (1, 1, h)), traction=(0, 0, -t))
    crack = em.EigenErosion(engine=mpm, Gc=o["Gc"], alpha=o["alpha"], kappaOverH=o["kappaOverH"],
                            origin=(0.5 * L, 0.5 * T, zc), throughAxis="y",
                            iterPeriod=max(1, int(round(0.1 / o["dt_us"]))))
    return mpm, crack


def main(argv):
    argv, resume, every = checkpointArgs("plate3d", argv)
    o, out, quick = scriptArgs("plate3d", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    if resume:
        em.checkpoint.resume(resume)
        mpm = em.findEngine("plate")
        (crack,) = mpm.physics.values()
    else:
        mpm, crack = build(o)
        O.dt = o["dt_us"] * 1e-6
    steps = int(round(o["endTime_us"] / o["dt_us"]))
    if not resume:
        vtk = em.VTKRecorder(fileName=os.path.join(out, "vtk", "plate-"),
                             iterPeriod=max(1, int(round(o["vtkPeriod_us"] / o["dt_us"]))), float32=True)
        O.engines = [mpm, crack, vtk, em.Progress(endIter=steps, realPeriod=20)]
        if every:
            O.engines = [em.Checkpoint(directory=os.path.join(out, "checkpoints"), iterPeriod=every)] + list(O.engines)
    n = mpm.numPoints()  # (all points: a rank's solver holds its part)
    start = time.time()
    end = runSteps(steps - O.iter)
    wall = time.time() - start
    summary = dict(crack.summary())
    summary.pop("crack_tips_m")
    along, front = crack.frontProfile()  # the front through the thickness, layer by layer
    summary.update(front_profile_mm=[[1e3 * a, 1e3 * f] for a, f in zip(along, front)])
    summary.update(eroded_points=crack.erodedCount(), particles=n, steps=mpm.solver.steps, ranks=mpm.solver.ranks,
                   wall_time_s=wall, particle_steps_per_s=n * mpm.solver.steps / wall, parameters=o, quick=quick,
                   **end.summary())
    plots.damageMap(mpm, os.path.join(out, "damage.png"), plane="xz")
    if em.parallel.isRoot():
        with open(os.path.join(out, "summary.json"), "w") as f:
            json.dump(summary, f, indent=2)
        print(json.dumps({k: v for k, v in summary.items() if k != "parameters"}, indent=2))
        print("outputs in", out)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
