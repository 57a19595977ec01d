"""Notched concrete beam in three-point bending, modelled in one run by YADE's DEM (CPM spheres,
or JCFpm) and by EigenMPM, side by side (eigenmpm.dem.DemMpmPair).

Beam 450 x 100 mm, thickness 50 mm (plane stress), span 400 mm between two bottom supports
(x = 25 and 425 mm), a notch 50 mm deep at midspan (x = 225 mm), the top midspan pushed down at
velocity_m_s (ramped over rampTime_ms) to endDisplacement_mm. Concrete: E = 30 GPa, nu = 0.2,
rho = 2400 kg/m3, Gc = 100 N/m, tensile strength ft = 3 MPa (the DEM's; eigenerosion has no
strength parameter).

- MPM: h_mm cells, 2 x 2 points per cell, EigenErosion (alpha, kappaOverH), the notch a
  phantom-node crack (sharp).
- DEM: an hcp slab of `layers` layers of spheres of radius radius_mm beside the MPM beam
  (x + 562 mm); the notch: the spheres within 1.01 r of the notch line removed (2 to 4 r wide,
  ending within r of the MPM notch's tip). DEM forces and energies are scaled from the slab's represented thickness
  (layers x 1.633 r) to the 50 mm (`dem_force_scale` in the summary). Micro-parameters from
  eigenmpm.dem.calibrate; with calibrate=N > 0, N corrections from the DEM uniaxial tension test
  (measured numbers in summary.json under calibration.history).
- Conditions on both: rollers (y fixed) under the bottom row within supportWidth_mm / 2 of the
  supports (DEM: the bottom row of spheres within that + r), the load on the top row within
  loadWidth_mm / 2 of midspan (DEM: + r). The load is the reaction of the load condition.

Run::

    yade -n -x examples/dem_three_point_bending.py [--quick] [--out DIR] [param=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]
    yade-batch table.txt examples/dem_three_point_bending.py

--checkpoint-every N saves the whole scene (both models, the DEM's bodies, bonds and engines
with YADE's O.save, the MPM with its EigenMPM state, and the records of both) every N iterations
into DIR/checkpoints (eigenmpm.Checkpoint, doc/restart.md); --resume DIR/checkpoints continues
from the newest of them (give the same parameters; the calibration is not run again, the
checkpoint holds its result) and writes the outputs as usual (wall_time_s, cpu_time_s and the
engine times then count the resumed part only). The MPM continues bitwise; the DEM to round-off
(YADE's collider rebuilds its lists after a load, so contacts are summed in another order).
Both need model=jcfpm: YADE does not save the damage and shear strain of CPM bonds.

params: h_mm, radius_mm, layers, model ('cpm' or 'jcfpm'), calibrate, velocity_m_s, rampTime_ms,
endDisplacement_mm, dtFraction, demDamping, alpha, kappaOverH, supportWidth_mm, loadWidth_mm,
notch_mm, E, nu, rho, Gc, ft. Writes DIR/summary.json (mpm_/dem_peak_load_N, displacements,
dissipated energies, broken bonds, eroded points, mpm_/dem_wall_s, particles, steps,
wall_time_s, particle_steps_per_s, calibration), DIR/load_displacement.csv/.png and
DIR/crack_patterns.png.
--quick: h = 10 mm, r = 5 mm, endDisplacement 0.25 mm.
"""
import os
import sys
import time

from yade import O, pack

import eigenmpm as em
from eigenmpm import dem
from eigenmpm.cli import checkpointArgs, finish, scriptArgs

DEFAULTS = dict(h_mm=5.0, radius_mm=3.0, layers=3, model="cpm", calibrate=1, velocity_m_s=0.02,
                rampTime_ms=1.0, endDisplacement_mm=0.4, dtFraction=0.8, demDamping=0.0, alpha=1.5,
                kappaOverH=1.1, supportWidth_mm=10.0, loadWidth_mm=10.0, notch_mm=50.0,
                E=30e9, nu=0.2, rho=2400.0, Gc=100.0, ft=3e6)
QUICK = dict(h_mm=10.0, radius_mm=5.0, endDisplacement_mm=0.25)
LENGTH, DEPTH, SPAN, THICKNESS = 0.45, 0.1, 0.4, 0.05
CPM_NOT_SAVED = ("YADE's save does not keep the state of CPM bonds (CpmPhys.kappaD, omega, epsT: read-only "
                 "and not saved), so a resumed CPM run would restart every bond undamaged and unsheared")


def build(o):
    h, r = o["h_mm"] * 1e-3, o["radius_mm"] * 1e-3
    cal = None
    if o["calibrate"] > 0:
        cal = dem.calibrateMeasured(o["model"], o["E"], o["nu"], o["ft"], o["Gc"], r, o["rho"],
                                    layers=o["layers"], iterations=o["calibrate"])
    O.reset()
    beam = pack.inAlignedBox((0, 0, 0), (LENGTH, DEPTH, 0))
    pair = em.DemMpmPair(beam, E=o["E"], nu=o["nu"], rho=o["rho"], Gc=o["Gc"], ft=o["ft"], h=h, radius=r,
                         thickness=THICKNESS, model=o["model"], calibration=cal, layers=o["layers"],
                         alpha=o["alpha"], kappaOverH=o["kappaOverH"], damping=o["demDamping"])
    mid = 0.5 * LENGTH
    pair.notch([(mid, -h, 0), (mid, o["notch_mm"] * 1e-3, 0)])
    s, row = h / 2, 3 ** 0.5 * r
    ws, wl = 0.5 * o["supportWidth_mm"] * 1e-3, 0.5 * o["loadWidth_mm"] * 1e-3
    for name, x in (("left", mid - 0.5 * SPAN), ("right", mid + 0.5 * SPAN)):
        pair.fix(name, points=pack.inAlignedBox((x - ws, -1, -1), (x + ws, s, 1)),
                 demRegion=pack.inAlignedBox((x - ws - r, -1, -1), (x + ws + r, row, 1)), components="y")
    pair.velocityBC("load", points=pack.inAlignedBox((mid - wl, DEPTH - s, -1), (mid + wl, 1, 1)),
                    demRegion=pack.inAlignedBox((mid - wl - r, DEPTH - row, -1), (mid + wl + r, 1, 1)),
                    components="y", velocity=(0, -o["velocity_m_s"], 0), rampTime=o["rampTime_ms"] * 1e-3)
    return pair


def main(argv):
    argv, resume, every = checkpointArgs("dem_three_point_bending", argv)
    o, out, quick = scriptArgs("dem_three_point_bending", DEFAULTS, QUICK, argv)
    if (resume or every) and o["model"] != "jcfpm":
        raise SystemExit(f"dem_three_point_bending: --checkpoint-every and --resume need model=jcfpm, not "
                         f"{o['model']!r}: {CPM_NOT_SAVED}")
    os.makedirs(out, exist_ok=True)
    cpu0 = time.process_time()
    pair = dem.resumePair(resume) if resume else build(o)  # resumed: the scene, both models, their records
    title = (f"notched beam, 3-point bending: MPM h = {o['h_mm']:g} mm, DEM {o['model'].upper()} "
             f"r = {o['radius_mm']:g} mm x {pair.layers} layers")
    summary, end = dem.runToDisplacement(pair, out, "load", o["endDisplacement_mm"] * 1e-3, o["velocity_m_s"],
                                         o["rampTime_ms"] * 1e-3, o["dtFraction"], title=title, sign=-1.0,
                                         extra=dict(parameters=o, quick=quick), cpu0=cpu0,
                                         checkpoints=os.path.join(out, "checkpoints"), checkpointEvery=every,
                                         resumed=bool(resume))
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
