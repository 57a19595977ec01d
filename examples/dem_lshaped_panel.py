"""L-shaped concrete panel (Winkler's test, paper Section 5.1) modelled in one run by YADE's DEM
(CPM spheres, or JCFpm) and by EigenMPM, side by side (eigenmpm.dem.DemMpmPair).

A 500 x 500 mm square without its lower-right 250 x 250 mm quarter, 100 mm thick, plane stress;
the bottom edge of the left leg fixed, the underside of the right arm pushed up at x = 470 mm at
velocity_m_s (ramped over rampTime_ms) to endDisplacement_mm. E = 25.85 GPa, nu = 0.18,
rho = 2500 kg/m3, Gc = 89 N/m, tensile strength ft = 2.7 MPa (Winkler's concrete; the DEM's,
eigenerosion has no strength parameter).

- MPM: h_mm cells, 2 x 2 points per cell, EigenErosion (alpha, kappaOverH), as
  examples/lshaped_panel.py but at a higher load rate (the DEM is the expensive part).
- DEM: an hcp slab of `layers` layers of spheres of radius radius_mm beside the MPM panel
  (x + 625 mm); forces and energies scaled from the slab's represented thickness (layers x
  1.633 r) to 100 mm (`dem_force_scale`). Micro-parameters from eigenmpm.dem.calibrate; with
  calibrate=N > 0, N corrections from the DEM uniaxial tension test (calibration.history).
- Conditions on both: the base fixed in x and y (MPM: points within h/2 of the bottom of the
  left leg; DEM: the bottom row of spheres), the load in y on the points within loadWidth_mm / 2
  (at least h/2) of x = 470 mm in the bottom row of the right arm (DEM: the bottom row of the arm
  within that + r). The load is the reaction of the load condition.

Run::

    yade -n -x examples/dem_lshaped_panel.py [--quick] [--out DIR] [param=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]
    yade-batch table.txt examples/dem_lshaped_panel.py

--checkpoint-every N saves the whole scene (both models, the DEM's bodies, bonds and engines
with YADE's O.save, the MPM with its EigenMPM state, and the records of both) every N iterations
into DIR/checkpoints (eigenmpm.Checkpoint, doc/restart.md); --resume DIR/checkpoints continues
from the newest of them (give the same parameters; the calibration is not run again, the
checkpoint holds its result) and writes the outputs as usual (wall_time_s, cpu_time_s and the
engine times then count the resumed part only). The MPM continues bitwise; the DEM to round-off
(YADE's collider rebuilds its lists after a load, so contacts are summed in another order).
Both need model=jcfpm: YADE does not save the damage and shear strain of CPM bonds.

params: h_mm, radius_mm, layers, model ('cpm' or 'jcfpm'), calibrate, velocity_m_s, rampTime_ms,
endDisplacement_mm, dtFraction, demDamping, alpha, kappaOverH, loadWidth_mm, E, nu, rho, Gc, ft.
Writes DIR/summary.json (mpm_/dem_peak_load_N, displacements, dissipated energies, broken
bonds, eroded points, mpm_/dem_wall_s, particles, steps, wall_time_s, particle_steps_per_s,
calibration), DIR/load_displacement.csv/.png and DIR/crack_patterns.png.
--quick: h = 20 mm, r = 10 mm.
"""
import os
import sys
import time

from yade import O, pack

import numpy as np

import eigenmpm as em
from eigenmpm import dem
from eigenmpm.cli import checkpointArgs, finish, scriptArgs

DEFAULTS = dict(h_mm=10.0, radius_mm=5.0, layers=3, model="cpm", calibrate=1, velocity_m_s=0.02,
                rampTime_ms=2.0, endDisplacement_mm=0.5, dtFraction=0.8, demDamping=0.0, alpha=1.5,
                kappaOverH=1.1, loadWidth_mm=0.0, E=25.85e9, nu=0.18, rho=2500.0, Gc=89.0, ft=2.7e6)
QUICK = dict(h_mm=20.0, radius_mm=10.0)
A, THICKNESS = 0.25, 0.1
CPM_NOT_SAVED = ("YADE's save does not keep the state of CPM bonds (CpmPhys.kappaD, omega, epsT: read-only "
                 "and not saved), so a resumed CPM run would restart every bond undamaged and unsheared")


def experiment():
    """Winkler's experimental band, shipped with the examples
    (examples/data/winkler_lpanel_experiment.csv), as (label, displacement mm, lower kN, upper kN)."""
    # Under `yade -x` __file__ names yade itself; sys.argv[0] is this script.
    path = os.path.join(os.path.dirname(os.path.abspath(sys.argv[0])), "data", "winkler_lpanel_experiment.csv")
    with open(path) as f:
        rows = [r.split(",") for r in f.read().splitlines() if r and not r.startswith("#")]
    d = np.array([[float(c) for c in r] for r in rows[1:]])  # after the line of column names
    return ("experiment (Winkler)", d[:, 0], d[:, 1], d[:, 2])


def build(o):
    h, r = o["h_mm"] * 1e-3, o["radius_mm"] * 1e-3
    cal = None
    if o["calibrate"] > 0:
        cal = dem.calibrateMeasured(o["model"], o["E"], o["nu"], o["ft"], o["Gc"], r, o["rho"],
                                    layers=o["layers"], iterations=o["calibrate"])
    O.reset()
    panel = pack.inAlignedBox((0, 0, 0), (2 * A, 2 * A, 0)) - pack.inAlignedBox((A, -1, -1), (1, A, 1))
    pair = em.DemMpmPair(panel, E=o["E"], nu=o["nu"], rho=o["rho"], Gc=o["Gc"], ft=o["ft"], h=h, radius=r,
                         thickness=THICKNESS, model=o["model"], calibration=cal, layers=o["layers"],
                         alpha=o["alpha"], kappaOverH=o["kappaOverH"], damping=o["demDamping"])
    row = 3 ** 0.5 * r
    pair.fix("base", points=pack.inAlignedBox((-1, -1, -1), (A, 0.5 * h, 1)),
             demRegion=pack.inAlignedBox((-1, -1, -1), (A, row, 1)), components="xy")
    half = 0.5 * max(o["loadWidth_mm"] * 1e-3, h)
    pair.velocityBC("load", points=pack.inAlignedBox((0.47 - half, A, -1), (0.47 + half, A + 0.5 * h, 1)),
                    demRegion=pack.inAlignedBox((0.47 - half - r, A, -1), (0.47 + half + r, A + row, 1)),
                    components="y", velocity=(0, o["velocity_m_s"], 0), rampTime=o["rampTime_ms"] * 1e-3)
    return pair


def main(argv):
    argv, resume, every = checkpointArgs("dem_lshaped_panel", argv)
    o, out, quick = scriptArgs("dem_lshaped_panel", DEFAULTS, QUICK, argv)
    if (resume or every) and o["model"] != "jcfpm":
        raise SystemExit(f"dem_lshaped_panel: --checkpoint-every and --resume need model=jcfpm, not "
                         f"{o['model']!r}: {CPM_NOT_SAVED}")
    os.makedirs(out, exist_ok=True)
    cpu0 = time.process_time()
    pair = dem.resumePair(resume) if resume else build(o)  # resumed: the scene, both models, their records
    title = (f"L-shaped panel: MPM h = {o['h_mm']:g} mm, DEM {o['model'].upper()} "
             f"r = {o['radius_mm']:g} mm x {pair.layers} layers")
    summary, end = dem.runToDisplacement(pair, out, "load", o["endDisplacement_mm"] * 1e-3, o["velocity_m_s"],
                                         o["rampTime_ms"] * 1e-3, o["dtFraction"], title=title, sign=1.0, band=experiment(),
                                         extra=dict(parameters=o, quick=quick), cpu0=cpu0,
                                         checkpoints=os.path.join(out, "checkpoints"), checkpointEvery=every,
                                         resumed=bool(resume))
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
