"""An elastic block sliding on a YADE wall with Coulomb friction (issue 16; doc/contact.md):
under gravity g its velocity falls at mu g until it stops at t = v0 / (mu g), and the wall
carries its weight.

A 2D block W x H (plane strain, E, nu = 0.3, rho = 1000 kg/m3, thickness H), cell size h, 2
points per cell, rests on a fixed YADE wall (``utils.wall``, axis y, sense +1) with initial
speed v0 along x; MpmEngine gravity (0, -g). ``eigenmpm.BodyContact(friction=mu)`` couples the
two; the NewtonIntegrator runs for YADE's side (the wall is not dynamic).

Run::

    yade -n -x examples/verification/sliding_block.py [--quick] [--out DIR] [param=value ...]

params h_mm, W_mm, H_mm, E, mu, v0, g, dtFraction, plot. Writes DIR/summary.json:
deceleration_m_s2 (least-squares slope of the mean velocity while it is between 0.9 v0 and
0.1 v0; with mu = 0 over the run after its first tenth), deceleration_over_mu_g, stop_time_s
(first record with a mean speed below 1e-3 v0: the elastic block's last shear vibration
delays it), stop_time_over_closed_form, stop_time_fit_over_closed_form (where the fitted line
reaches 0), mean_normal_force_over_weight (the wall's vertical force in every step, averaged
over the sliding interval), particles, steps, wall_time_s; DIR/velocity.png. --quick: h = 4 mm.
"""
import math
import os
import sys
import time

import numpy as np
from yade import O, pack, utils
from yade.wrapper import ForceResetter, NewtonIntegrator

import eigenmpm as em
from eigenmpm import plots
from eigenmpm.cli import finish, report, runSteps, scriptArgs

DEFAULTS = dict(h_mm=1.0, W_mm=40.0, H_mm=20.0, E=1e6, mu=0.3, v0=0.3, g=9.81, dtFraction=0.4, plot=True)
QUICK = dict(h_mm=4.0)


class Record:
    """(time, mean x velocity, wall force y) every call."""

    def __init__(self, mpm, contact, wall):
        self.mpm, self.contact, self.wall = mpm, contact, wall
        self.mass = float(np.sum(mpm.solver.mass()))
        self.series = []

    def __call__(self):
        v = self.mpm.solver.velocities()
        m = self.mpm.solver.mass()
        self.series.append((self.mpm.solver.time, float(np.sum(m * v[:, 0]) / self.mass),
                            float(self.contact.force(self.wall)[1])))


def build(o):
    h, W, H = o["h_mm"] * 1e-3, o["W_mm"] * 1e-3, o["H_mm"] * 1e-3
    slide = o["v0"] ** 2 / (2 * o["mu"] * o["g"]) if o["mu"] > 0 else 10 * W
    mpm = em.MpmEngine(dim=2, h=h, thickness=H, gravity=(0, -o["g"], 0), label="block",
                       domain=((-2 * h, -2 * h, 0), (W + slide + 4 * h, H + 4 * h, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, -1), (W, H, 1)), em.ElasticMaterial(E=o["E"], nu=0.3, rho=1000.0),
             velocity=(o["v0"], 0, 0))
    wall = O.bodies.append(utils.wall((0, 0, 0), axis=1, sense=1))
    contact = em.BodyContact(engine=mpm, friction=o["mu"])
    O.engines = [ForceResetter(), mpm, contact, NewtonIntegrator(damping=0)]
    O.dt = o["dtFraction"] * mpm.criticalTimeStep()
    return mpm, contact, wall


def summarize(record, o):
    t, v, _ = (np.array(c) for c in zip(*record.series))
    v0, muG = o["v0"], o["mu"] * o["g"]
    # While sliding (with mu = 0: the whole run after its first tenth)
    sliding = (v < 0.9 * v0) & (v > 0.1 * v0) if muG > 0 else t > 0.1 * t[-1]
    fit = np.polyfit(t[sliding], v[sliding], 1) if np.count_nonzero(sliding) > 2 else (float("nan"), float("nan"))
    slope = float(fit[0])
    stopped = np.nonzero(v < 1e-3 * v0)[0]
    stop = float(t[stopped[0]]) if len(stopped) else None
    # The wall's force in every step (BodyContact's history) over the same interval
    ft = np.array([h[0] for h in record.contact.history])
    fy = np.array([h[1][1] for h in record.contact.history])
    window = (ft >= t[sliding].min()) & (ft <= t[sliding].max()) if np.any(sliding) else ft < 0
    weight = record.mass * o["g"]
    return {"deceleration_m_s2": -slope, "deceleration_over_mu_g": -slope / muG if muG > 0 else None,
            "stop_time_s": stop, "stop_time_closed_form_s": v0 / muG if muG > 0 else None,
            "stop_time_over_closed_form": stop * muG / v0 if stop is not None and muG > 0 else None,
            "stop_time_fit_over_closed_form": float(-fit[1] / fit[0]) * muG / v0 if muG > 0 else None,
            "mean_normal_force_over_weight": float(-np.mean(fy[window]) / weight) if np.any(window) else None,
            "weight_N": weight}


def plot(out, record, o):
    t, v, _ = (np.array(c) for c in zip(*record.series))
    return plots.series(os.path.join(out, "velocity.png"), t,
                        {"EigenMPM block on a YADE wall (mean velocity)": v,
                         "v0 - mu g t": np.maximum(o["v0"] - o["mu"] * o["g"] * t, 0)},
                        xlabel="time (ms)", ylabel="velocity (m/s)", tscale=1e3,
                        title=f"Sliding block, mu = {o['mu']}, h = {o['h_mm']} mm")


def main(argv):
    o, out, _ = scriptArgs("sliding_block", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    mpm, contact, wall = build(o)
    record = Record(mpm, contact, wall)
    end_time = 1.3 * o["v0"] / (o["mu"] * o["g"]) if o["mu"] > 0 else 0.05
    steps = int(math.ceil(end_time / O.dt))
    O.engines = list(O.engines) + [em.callEvery(record, iterPeriod=max(1, steps // 400))]
    start = time.time()
    end = runSteps(steps)
    wall_time = time.time() - start
    n = mpm.solver.numPoints
    summary = {**summarize(record, o), "mu": o["mu"], "v0_m_s": o["v0"], "h_m": o["h_mm"] * 1e-3,
               "particles": int(n), "steps": int(mpm.solver.steps), "wall_time_s": wall_time, **end.summary()}
    report(out, summary, (lambda: plot(out, record, o)) if o["plot"] else None)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
