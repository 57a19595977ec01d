"""A YADE steel sphere strikes a notched glass beam resting on two YADE spheres: dynamic
three-point bending with real contact (issue 16 showcase; doc/contact.md).

The beam (2D, plane stress, 100 x 25 mm, thickness 10 mm; glass E = 72 GPa, nu = 0.22, rho =
2440 kg/m3, Gc = 135 N/m, eigenerosion alpha = 2, kappa = 1.1 h) has a sharp 5 mm notch at the
middle of its lower edge (a phantom-node crack whose faces touch, crackContact=True). It rests on
two fixed YADE spheres (supports, radius 4 mm, 80 mm apart); a steel sphere (radius 5 mm,
7800 kg/m3) flies down onto the middle of its upper edge at v0. ``eigenmpm.BodyContact``
(friction mu) couples the beam with the three spheres; YADE's ``NewtonIntegrator`` moves the
impactor; the supports may separate from the beam (contact, not bilateral conditions).

Run::

    yade -n -x examples/impact.py [--quick] [--out DIR] [param=value ...]

params h_mm, v0, mu, endTime_us, alpha, kappaOverH, vtkPeriod_us, Gc. Writes DIR/summary.json
(crack_initiation_time_us (first erosion), eroded_count, dissipated_energy_J, notch_crack_length_mm
(the eroded points linked to the notch tip: their largest height above it), impactor_velocity_end_m_s,
peak_impact_force_N, energies at the start and the end: impactor kinetic, beam kinetic and elastic,
dissipated, and their sum, particles, steps, wall_time_s), DIR/damage.png, DIR/energy.png (the
energies of both sides over time), DIR/energy.csv, and VTK for ParaView: DIR/vtk/beam-*.vtp
(our points), DIR/vtk/spheres-spheres.*.vtu (YADE's own VTKRecorder) and DIR/scene.pvd, one
collection holding both (open it in ParaView: part 0 the beam, part 1 the spheres; render the
spheres with the Glyph filter, scale by `radius`). --quick: h = 1 mm, 60 us.
"""
import math
import os
import re
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np
from yade import O, pack, utils
from yade.wrapper import ForceResetter, FrictMat, NewtonIntegrator, VTKRecorder

import eigenmpm as em
from eigenmpm import plots
from eigenmpm.cli import finish, report, runSteps, scriptArgs
from eigenmpm.fracture import linked

DEFAULTS = dict(h_mm=0.5, v0=20.0, mu=0.2, endTime_us=120.0, alpha=2.0, kappaOverH=1.1, vtkPeriod_us=5.0,
                Gc=135.0)
QUICK = dict(h_mm=1.0, endTime_us=60.0)
L, D, T, NOTCH = 0.1, 0.025, 0.01, 0.005  # beam length, depth, thickness, notch depth (m)
SPAN, R_SUPPORT, R_BALL = 0.08, 0.004, 0.005


def build(o, out):
    h = o["h_mm"] * 1e-3
    mpm = em.MpmEngine(dim=2, h=h, thickness=T, label="beam", crackContact=True,
                       domain=((-0.01, -0.02, 0), (L + 0.01, D + 0.02, 0)))
    glass = em.ElasticMaterial(E=72e9, nu=0.22, rho=2440.0, planeStress=True)
    mpm.fill(pack.inAlignedBox((0, 0, -1), (L, D, 1)), glass)
    mpm.crack([(L / 2, -h, 0), (L / 2, NOTCH, 0)])
    erosion = em.EigenErosion(engine=mpm, Gc=o["Gc"], alpha=o["alpha"], kappaOverH=o["kappaOverH"],
                              origin=(L / 2, NOTCH, 0), iterPeriod=10)
    steel = O.materials.append(FrictMat(density=7800, young=2e11, frictionAngle=math.atan(o["mu"])))
    supports = [O.bodies.append(utils.sphere((L / 2 + s * SPAN / 2, -R_SUPPORT, 0), R_SUPPORT, material=steel,
                                             fixed=True)) for s in (-1, 1)]
    ball = O.bodies.append(utils.sphere((L / 2, D + R_BALL + 0.3 * h, 0), R_BALL, material=steel))
    O.bodies[ball].state.vel = (0, -o["v0"], 0)
    contact = em.BodyContact(engine=mpm, friction=o["mu"])
    O.dt = 0.4 * mpm.criticalTimeStep()
    every = max(1, int(round(o["vtkPeriod_us"] * 1e-6 / O.dt)))
    beamVtk = em.VTKRecorder(fileName=os.path.join(out, "vtk", "beam-"), iterPeriod=every)
    sphereVtk = VTKRecorder(fileName=os.path.join(out, "vtk", "spheres-"), recorders=["spheres", "velocity"],
                            iterPeriod=every)
    O.engines = [ForceResetter(), mpm, erosion, contact, NewtonIntegrator(damping=0), beamVtk, sphereVtk,
                 em.PlotRecorder(iterPeriod=10)]
    return mpm, erosion, contact, ball, supports, beamVtk


class Energies:
    """(t, impactor kinetic, beam kinetic, beam elastic, dissipated, impactor force y) every call."""

    def __init__(self, mpm, erosion, contact, ball):
        self.mpm, self.erosion, self.contact, self.ball = mpm, erosion, contact, ball
        self.series = []

    def __call__(self):
        b = O.bodies[self.ball]
        ek = 0.5 * b.state.mass * b.state.vel.squaredNorm() + 0.5 * b.state.inertia[0] * b.state.angVel.squaredNorm()
        e = self.mpm.energyBalance()
        self.series.append((self.mpm.solver.time, ek, e["Ek"], e["Ee"], self.erosion.dissipatedEnergy(),
                            float(self.contact.force(self.ball)[1])))


def writeScene(out, beamVtk):
    """DIR/scene.pvd: at each time both the beam's .vtp (part 0) and YADE's spheres .vtu (part 1)
    of the same iteration."""
    spheres = {}
    for name in os.listdir(os.path.join(out, "vtk")):
        m = re.match(r"spheres-spheres\.(\d+)\.vtu$", name)
        if m:
            spheres[int(m.group(1))] = name
    root = ET.Element("VTKFile", type="Collection", version="0.1")
    collection = ET.SubElement(root, "Collection")
    for t, path in beamVtk.files:
        m = re.search(r"beam-(\d+)\.vtp$", path)
        if not m or int(m.group(1)) not in spheres:
            continue
        for part, name in ((0, os.path.basename(path)), (1, spheres[int(m.group(1))])):
            ET.SubElement(collection, "DataSet", timestep=f"{t:.12g}", part=str(part), file=os.path.join("vtk", name))
    ET.indent(root)
    path = os.path.join(out, "scene.pvd")
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path


def summarize(mpm, erosion, rec, ball, o):
    t, ek, ekb, ee, ef, fy = (np.array(c) for c in zip(*rec.series))
    events = erosion.core.events() if erosion.core else []
    x0 = mpm.referencePositions
    length = 0.0
    if events:
        ids = np.array([p for p, _, _ in events])
        tip = np.array([L / 2, NOTCH])
        near = ids[np.argmin(np.sum((x0[ids, :2] - tip) ** 2, axis=1))]
        mask = linked(x0[ids, :2], int(np.nonzero(ids == near)[0][0]), 2 * erosion.core.kappa)
        if np.min(np.sum((x0[ids[mask], :2] - tip) ** 2, axis=1)) < (2 * erosion.core.kappa) ** 2:
            length = float(np.max(x0[ids[mask], 1]) - NOTCH)
    total = ek + ekb + ee + ef
    return {"crack_initiation_time_us": 1e6 * events[0][2] if events else None, "eroded_count": len(events),
            "dissipated_energy_J": float(ef[-1]), "notch_crack_length_mm": 1e3 * length,
            "impactor_velocity_end_m_s": float(O.bodies[ball].state.vel[1]),
            "peak_impact_force_N": float(np.max(np.abs(fy))),
            "energy_start_J": {"impactor": float(ek[0]), "beam_kinetic": float(ekb[0]), "beam_elastic": float(ee[0]),
                               "dissipated": float(ef[0]), "total": float(total[0])},
            "energy_end_J": {"impactor": float(ek[-1]), "beam_kinetic": float(ekb[-1]), "beam_elastic": float(ee[-1]),
                             "dissipated": float(ef[-1]), "total": float(total[-1])}}


def main(argv):
    o, out, quick = scriptArgs("impact", DEFAULTS, QUICK, argv)
    os.makedirs(os.path.join(out, "vtk"), exist_ok=True)
    O.reset()
    mpm, erosion, contact, ball, supports, beamVtk = build(o, out)
    rec = Energies(mpm, erosion, contact, ball)
    steps = int(math.ceil(o["endTime_us"] * 1e-6 / O.dt))
    O.engines = list(O.engines) + [em.callEvery(rec, iterPeriod=5), em.Progress(endIter=steps, realPeriod=20)]
    start = time.time()
    end = runSteps(steps)
    wall = time.time() - start
    n = mpm.solver.numPoints
    summary = {**summarize(mpm, erosion, rec, ball, o), "particles": int(n), "steps": int(mpm.solver.steps),
               "wall_time_s": wall, "particle_steps_per_s": n * mpm.solver.steps / wall if wall > 0 else None,
               "parameters": o, "quick": quick, **end.summary()}
    t, ek, ekb, ee, ef, _ = (np.array(c) for c in zip(*rec.series))
    np.savetxt(os.path.join(out, "energy.csv"), np.column_stack([1e6 * t, ek, ekb, ee, ef, ek + ekb + ee + ef]),
               delimiter=",", header="t_us,impactor_kinetic_J,beam_kinetic_J,beam_elastic_J,dissipated_J,total_J",
               comments="", fmt="%.9g")
    plots.damageMap(mpm, os.path.join(out, "damage.png"))
    beamVtk.finalRecord()
    print("scene:", writeScene(out, beamVtk))
    report(out, summary, lambda: plots.series(
        os.path.join(out, "energy.png"), t,
        {"impactor kinetic (YADE)": ek, "beam kinetic": ekb, "beam elastic": ee, "dissipated (Eq 33)": ef,
         "total": ek + ekb + ee + ef}, ylabel="energy (J)", title="Sphere on a notched glass beam"))
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
