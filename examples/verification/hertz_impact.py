"""A rigid YADE sphere striking an elastic MPM half-space slowly, against Hertz (issue 16;
doc/contact.md): contact time and peak force of a quasi-static elastic impact.

Hertz for a rigid sphere (radius R, mass m, speed v) on an elastic half-space (E, nu;
E* = E / (1 - nu^2)), with R* = R:

    delta_max = (15 m v^2 / (16 E* sqrt(R)))^(2/5),    F_max = 4/3 E* sqrt(R) delta_max^(3/2),
    t_c = 2.943 (delta_max / v)  (= 2.87 (m^2 / (R E*^2 v))^(1/5))

The model is a quarter: the block x, z in [0, L], y in [-L, 0] (3D MPM, E, nu = 0.3, rho =
1000 kg/m3) with symmetry (roller) planes x = 0 and z = 0 and its bottom fixed; the sphere
(YADE ``utils.sphere``, centre on the axis x = z = 0) has a quarter of the mass (its density
rho_s / 4) and moves along y only (blockedDOFs 'xzXYZ'), so that the quarter of the contact
force it receives decelerates it as the whole force would a whole sphere. The sphere is much
stiffer than the block (rigid). ``eigenmpm.BodyContact`` (frictionless) couples the two. Slow:
the contact time is many times the block's wave transit L / c.

Run::

    yade -n -x examples/verification/hertz_impact.py [--quick] [--out DIR] [param=value ...]

params h_mm, L_mm, R_mm, v0, E, rhoSphere, dtFraction, plot. Writes DIR/summary.json:
peak_force_N (whole sphere: 4 times the quarter's), hertz_peak_force_N, peak_force_over_hertz,
peak_force_smoothed_N and _over_hertz (the force averaged over windows of t_c / 50: single steps
spike when a new ring of nodes comes into contact), impulse_over_2mv (the force's impulse over
that of an elastic rebound),
contact_time_s (first to last step with a force), hertz_contact_time_s, contact_time_over_hertz,
hertz_max_indentation_m, hertz_contact_radius_m, restitution (rebound over impact speed),
particles, steps, wall_time_s; DIR/force.png (force against time with Hertz's curve).
The defaults (h = 0.5 mm, a 20 mm deep block: 512 000 points, about 10 minutes on one thread)
are the finest run of doc/contact.md; a 10 mm block is stiffer than a half-space by about 6 % in
peak force. --quick: h = 1 mm, L = 10 mm.
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

DEFAULTS = dict(h_mm=0.5, L_mm=20.0, R_mm=5.0, v0=0.2, E=1e6, nu=0.3, rhoSphere=7800.0, dtFraction=0.4,
                plot=True)
QUICK = dict(h_mm=1.0, L_mm=10.0)


def hertz(o):
    """(delta_max, F_max, t_c) of the whole sphere."""
    R = o["R_mm"] * 1e-3
    m = o["rhoSphere"] * 4.0 / 3.0 * math.pi * R ** 3
    Es = o["E"] / (1 - o["nu"] ** 2)
    v = o["v0"]
    delta = (15 * m * v ** 2 / (16 * Es * math.sqrt(R))) ** 0.4
    force = 4.0 / 3.0 * Es * math.sqrt(R) * delta ** 1.5
    return delta, force, 2.9432 * delta / v


def hertzCurve(o, t):
    """Hertz's force against time: the quasi-static impact solved by integrating
    m delta'' = -k delta^(3/2) (a fine explicit integration, enough for a plot)."""
    R = o["R_mm"] * 1e-3
    m = o["rhoSphere"] * 4.0 / 3.0 * math.pi * R ** 3
    k = 4.0 / 3.0 * o["E"] / (1 - o["nu"] ** 2) * math.sqrt(R)
    d, v, dt, out, tt = 0.0, o["v0"], t[-1] / 20000, [], 0.0
    for target in t:
        while tt < target:
            a = -k * max(d, 0) ** 1.5 / m
            v += a * dt
            d += v * dt
            tt += dt
        out.append(k * max(d, 0) ** 1.5)
    return np.array(out)


class Record:
    """(time, force on the sphere (whole), sphere velocity) every call."""

    def __init__(self, contact, ball):
        self.contact, self.ball = contact, ball
        self.series = []

    def __call__(self):
        b = O.bodies[self.ball]
        self.series.append((O.time, 4.0 * float(self.contact.force(self.ball)[1]), float(b.state.vel[1])))


def build(o):
    h, L, R = o["h_mm"] * 1e-3, o["L_mm"] * 1e-3, o["R_mm"] * 1e-3
    mpm = em.MpmEngine(dim=3, h=h, label="halfspace", domain=((-3 * h, -L - 3 * h, -3 * h), (L + 3 * h, 2 * R, L + 3 * h)))
    mpm.fill(pack.inAlignedBox((0, -L, 0), (L, 0, L)), em.ElasticMaterial(E=o["E"], nu=o["nu"], rho=1000.0))
    eps = 1e-3 * h
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (eps, 1, 1)), components="x", label="symmetry_x")
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, 1, eps)), components="z", label="symmetry_z")
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, -L + eps, 1)), label="bottom")
    sphereMat = O.materials.append(FrictMat(density=o["rhoSphere"] / 4.0, young=1e3 * o["E"], frictionAngle=0))
    ball = O.bodies.append(utils.sphere((0, R + 0.5 * h, 0), R, material=sphereMat))
    b = O.bodies[ball]
    b.state.vel = (0, -o["v0"], 0)
    b.state.blockedDOFs = "xzXYZ"
    contact = em.BodyContact(engine=mpm, friction=0.0)
    O.engines = [ForceResetter(), mpm, contact, NewtonIntegrator(damping=0)]
    O.dt = o["dtFraction"] * mpm.criticalTimeStep()
    return mpm, contact, ball


def summarize(record, o):
    t, f, v = (np.array(c) for c in zip(*record.series))
    delta, fmax, tc = hertz(o)
    touching = np.nonzero(f > 0)[0]
    duration = float(t[touching[-1]] - t[touching[0]]) if len(touching) else 0.0
    R = o["R_mm"] * 1e-3
    # The force of single steps spikes when a new ring of nodes comes into contact (each first
    # touch is an inelastic impulse): the smoothed peak averages it over windows of t_c / 50.
    window = max(1, int(round(tc / 50 / O.dt)))
    mass = o["rhoSphere"] * 4.0 / 3.0 * math.pi * R ** 3  # the whole sphere
    smooth = np.convolve(f, np.ones(window) / window, mode="same")
    return {"peak_force_N": float(f.max()), "hertz_peak_force_N": fmax, "peak_force_over_hertz": float(f.max()) / fmax,
            "peak_force_smoothed_N": float(smooth.max()), "peak_force_smoothed_over_hertz": float(smooth.max()) / fmax,
            "impulse_over_2mv": float(np.sum(f) * O.dt / (2 * mass * o["v0"])),
            "contact_time_s": duration, "hertz_contact_time_s": tc, "contact_time_over_hertz": duration / tc,
            "hertz_max_indentation_m": delta, "hertz_contact_radius_m": math.sqrt(R * delta),
            "restitution": float(v[-1] / o["v0"])}


def plot(out, record, o):
    t, f, _ = (np.array(c) for c in zip(*record.series))
    touching = np.nonzero(f > 0)[0]
    t = t - (t[touching[0]] if len(touching) else 0.0)
    after = t >= 0
    hertzForce = np.zeros_like(t)
    hertzForce[after] = hertzCurve(o, t[after])
    return plots.series(os.path.join(out, "force.png"), t,
                        {"EigenMPM half-space, YADE sphere": f, "Hertz (quasi-static)": hertzForce},
                        xlabel="time from first contact (ms)", ylabel="contact force (N)", tscale=1e3,
                        title=f"Sphere on an elastic half-space, h = {o['h_mm']} mm")


def main(argv):
    o, out, _ = scriptArgs("hertz_impact", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    mpm, contact, ball = build(o)
    record = Record(contact, ball)
    O.engines = list(O.engines) + [em.callEvery(record, iterPeriod=1)]
    _, _, tc = hertz(o)
    gap = 0.5 * o["h_mm"] * 1e-3 / o["v0"]  # the time to close the initial gap
    start = time.time()
    end = runSteps(int(math.ceil((gap + 1.6 * tc) / O.dt)))
    wall_time = time.time() - start
    n = mpm.solver.numPoints
    summary = {**summarize(record, o), "h_m": o["h_mm"] * 1e-3, "v0_m_s": o["v0"], "particles": int(n),
               "steps": int(mpm.solver.steps), "wall_time_s": wall_time, **end.summary()}
    report(out, summary, (lambda: plot(out, record, o)) if o["plot"] else None)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
