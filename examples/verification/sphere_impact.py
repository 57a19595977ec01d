"""A YADE sphere striking a free elastic MPM block, frictionless (issue 16; doc/contact.md): the
total energy of both sides (the sphere's kinetic energy, the block's kinetic and elastic
energy) and their total momentum must hold through the impact.

A 2D block W x H (plane strain, E, nu = 0.3, rho = 1000 kg/m3, thickness t) floats free (no
conditions, no gravity); a steel sphere (YADE ``utils.sphere``, radius R, 7800 kg/m3) centred in
the plane z = 0 moves down onto its top face at v0. ``eigenmpm.BodyContact(friction=0)``
couples the two; YADE's NewtonIntegrator (damping 0) moves the sphere. The run ends when the
sphere has left the block for `after` contact durations.

Run::

    yade -n -x examples/verification/sphere_impact.py [--quick] [--out DIR] [param=value ...]

params h_mm, W_mm, H_mm, t_mm, R_mm, v0, E, dtFraction, plot. Writes DIR/summary.json:
energy_change_rel ((E_end - E_0) / E_0, E = sphere kinetic + block EkStep + Ee),
momentum_change_rel (|P_end - P_0| / |P_0|, sphere and block, in the plane), contact_time_s
(from the first to the last step with a contact force), rebound_velocity_m_s (the sphere's y
velocity at the end), peak_force_N, particles, steps, wall_time_s; DIR/energy.png. --quick:
h = 1 mm.
"""
import math
import os
import sys
import time

import numpy as np
from yade import O, pack, utils
from yade.wrapper import FrictMat, ForceResetter, NewtonIntegrator

import eigenmpm as em
from eigenmpm import plots
from eigenmpm.cli import finish, report, runSteps, scriptArgs

DEFAULTS = dict(h_mm=0.5, W_mm=40.0, H_mm=20.0, t_mm=10.0, R_mm=5.0, v0=5.0, E=1e8, dtFraction=0.4,
                after=1.0, plot=True)
QUICK = dict(h_mm=1.0)


class Record:
    """(time, sphere kinetic energy, block EkStep, block Ee, force y, sphere momentum y, block
    momentum y) every call."""

    def __init__(self, mpm, contact, ball):
        self.mpm, self.contact, self.ball = mpm, contact, ball
        self.series = []

    def __call__(self):
        b = O.bodies[self.ball]
        ek = 0.5 * b.state.mass * b.state.vel.squaredNorm() + 0.5 * b.state.inertia[0] * b.state.angVel.squaredNorm()
        e = self.mpm.energyBalance()
        self.series.append((self.mpm.solver.time, ek, e["Ek"], e["Ee"], float(self.contact.force(self.ball)[1]),
                            b.state.mass * b.state.vel[1], self.mpm.linearMomentum()[1]))


def build(o):
    h, W, H, R = o["h_mm"] * 1e-3, o["W_mm"] * 1e-3, o["H_mm"] * 1e-3, o["R_mm"] * 1e-3
    mpm = em.MpmEngine(dim=2, h=h, thickness=o["t_mm"] * 1e-3, label="block",
                       domain=((-W, -W, 0), (2 * W, H + 4 * R, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, -1), (W, H, 1)), em.ElasticMaterial(E=o["E"], nu=0.3, rho=1000.0))
    steel = O.materials.append(FrictMat(density=7800, young=2e11, frictionAngle=0))
    ball = O.bodies.append(utils.sphere((W / 2, H + R + h, 0), R, material=steel))
    O.bodies[ball].state.vel = (0, -o["v0"], 0)
    contact = em.BodyContact(engine=mpm, friction=0.0)
    O.engines = [ForceResetter(), mpm, contact, NewtonIntegrator(damping=0)]
    O.dt = o["dtFraction"] * mpm.criticalTimeStep()
    return mpm, contact, ball


def summarize(record):
    t, ek, ekb, ee, fy, pb, pm = (np.array(c) for c in zip(*record.series))
    total = ek + ekb + ee
    touching = np.nonzero(np.abs(fy) > 0)[0]
    return {"energy_initial_J": float(total[0]), "energy_final_J": float(total[-1]),
            "energy_change_rel": float((total[-1] - total[0]) / total[0]),
            "energy_min_rel": float((total.min() - total[0]) / total[0]),
            "momentum_change_rel": float(abs(pb[-1] + pm[-1] - pb[0] - pm[0]) / abs(pb[0] + pm[0])),
            "contact_time_s": float(t[touching[-1]] - t[touching[0]]) if len(touching) else 0.0,
            "peak_force_N": float(np.max(np.abs(fy))), "rebound_velocity_m_s": float(pb[-1] / O.bodies[record.ball].state.mass),
            "sphere_energy_final_over_initial": float(ek[-1] / ek[0])}


def plot(out, record):
    t, ek, ekb, ee, _, _, _ = (np.array(c) for c in zip(*record.series))
    return plots.series(os.path.join(out, "energy.png"), t,
                        {"sphere kinetic": ek, "block kinetic": ekb, "block elastic": ee, "total": ek + ekb + ee},
                        ylabel="energy (J)", title="YADE sphere on an EigenMPM block, frictionless")


def main(argv):
    o, out, _ = scriptArgs("sphere_impact", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    mpm, contact, ball = build(o)
    record = Record(mpm, contact, ball)
    O.engines = list(O.engines) + [em.callEvery(record, iterPeriod=1)]
    start = time.time()
    # Until the sphere has left the block for `after` contact durations (or 50 transits of H).
    H, c = o["H_mm"] * 1e-3, math.sqrt(o["E"] / 1000.0)
    limit, chunk = int(50 * H / c / O.dt), 200
    end = None
    while O.iter < limit:
        end = runSteps(chunk)
        if end.early:
            break
        fy = [r[4] for r in record.series]
        touched = [i for i, f in enumerate(fy) if f != 0]
        if touched and record.series[-1][5] > 0:
            duration = record.series[touched[-1]][0] - record.series[touched[0]][0]
            if record.series[-1][0] - record.series[touched[-1]][0] > o["after"] * duration:
                break
    wall_time = time.time() - start
    n = mpm.solver.numPoints
    summary = {**summarize(record), "h_m": o["h_mm"] * 1e-3, "v0_m_s": o["v0"], "particles": int(n),
               "steps": int(mpm.solver.steps), "wall_time_s": wall_time, **end.summary()}
    report(out, summary, (lambda: plot(out, record)) if o["plot"] else None)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
