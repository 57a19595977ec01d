"""Two equal elastic bars colliding head on (issue 16 item 2; doc/contact.md): the 1D closed form
gives a contact lasting 2 L / c (c = sqrt(E / rho)) and, after it, the bars' velocities
exchanged (each rebounds at the other's speed).

Two bars L x H (plane stress, nu = 0, so the 2D waves are the 1D bar's; E, rho = 1000 kg/m3,
thickness H) touch end to end at x = L, moving towards each other at v0 each. They are two
bodies of one MpmEngine, so that the two bars have their own velocity fields where they meet and
can push but not pull, in either of two ways [interface]:

- ``bodies`` (the default): the bars are filled with different body ids
  (``mpm.fill(..., body=1)``); bodies that meet anywhere touch and separate (doc/contact.md,
  "Bodies in one engine");
- ``crack``: the interface is a phantom-node crack through the whole height with crack-face
  contact (``MpmEngine(crackContact=True)``, ``mpm.crack``): the way when the interface is known.

Run::

    yade -n -x examples/verification/colliding_bars.py [--quick] [--out DIR] [param=value ...]

params h_mm, L_mm, H_mm, v0, E, dtFraction, interface (bodies or crack), plot. Writes DIR/summary.json: contact_time_s (the
impact: first to last step of the first run of steps with a pair of fields in contact), contact_time_over_2L_c, velocity_after_over_v0 (each
bar's mean velocity at 2 x 2L/c, against -1 and +1), energy_change_rel (kinetic plus elastic at
the end against the start), momentum_change_abs, particles, steps, wall_time_s; DIR/velocity.png.
--quick: h = 2 mm.
"""
import math
import os
import sys
import time

import numpy as np
from yade import O, pack

import eigenmpm as em
from eigenmpm import plots
from eigenmpm.cli import finish, report, runSteps, scriptArgs

DEFAULTS = dict(h_mm=0.5, L_mm=50.0, H_mm=10.0, v0=1.0, E=1e9, dtFraction=0.2, interface="bodies", plot=True)
QUICK = dict(h_mm=2.0)


class Record:
    """(time, bar A's mean velocity, bar B's, face pairs in contact) every call."""

    def __init__(self, mpm, a, b):
        self.mpm, self.a, self.b = mpm, np.array(a), np.array(b)
        m = mpm.solver.mass()
        self.ma, self.mb = m[self.a], m[self.b]
        self.series = []

    def __call__(self):
        v = self.mpm.solver.velocities()[:, 0]
        s = self.mpm.solver
        self.series.append((s.time, float(self.ma @ v[self.a] / self.ma.sum()),
                            float(self.mb @ v[self.b] / self.mb.sum()), s.crackContactPairs + s.bodyContactPairs))


def build(o):
    h, L, H = o["h_mm"] * 1e-3, o["L_mm"] * 1e-3, o["H_mm"] * 1e-3
    if o["interface"] not in ("bodies", "crack"):
        raise ValueError(f"EigenMPM: interface = {o['interface']!r} is invalid; allowed: 'bodies' or 'crack' "
                         "(colliding_bars)")
    crack = o["interface"] == "crack"
    mpm = em.MpmEngine(dim=2, h=h, thickness=H, label="bars", crackContact=crack,
                       domain=((-0.2 * L, -H, 0), (2.2 * L, 2 * H, 0)))
    mat = em.ElasticMaterial(E=o["E"], nu=0.0, rho=1000.0, planeStress=True)
    a = mpm.fill(pack.inAlignedBox((0, 0, -1), (L, H, 1)), mat, velocity=(o["v0"], 0, 0))
    b = mpm.fill(pack.inAlignedBox((L, 0, -1), (2 * L, H, 1)), mat, velocity=(-o["v0"], 0, 0), body=0 if crack else 1)
    if crack:
        mpm.crack([(L, -2 * h, 0), (L, H + 2 * h, 0)])  # the interface, beyond both faces
    O.engines = [mpm]
    O.dt = o["dtFraction"] * mpm.criticalTimeStep()
    return mpm, a, b


def main(argv):
    o, out, _ = scriptArgs("colliding_bars", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    mpm, a, b = build(o)
    record = Record(mpm, a, b)
    O.engines = list(O.engines) + [em.callEvery(record, iterPeriod=1)]
    L, v0 = o["L_mm"] * 1e-3, o["v0"]
    T = 2 * L / math.sqrt(o["E"] / 1000.0)
    e0 = mpm.kineticEnergy()
    start = time.time()
    end = runSteps(int(math.ceil(2 * T / O.dt)))
    wall = time.time() - start
    t, va, vb, pairs = (np.array(c) for c in zip(*record.series))
    # The impact: the first run of steps with a pair in contact (after it the ringing bars, still
    # within a cell of each other, may touch again briefly: 2-field pairs, no measurable impulse).
    touch = np.nonzero(pairs > 0)[0]
    after = touch[0] + np.argmax(np.append(pairs[touch[0]:] == 0, True)) if len(touch) else 0
    duration = float(t[after - 1] - t[touch[0]]) if len(touch) else 0.0
    e = mpm.energyBalance()
    m = mpm.solver.mass()
    summary = {"contact_time_s": duration, "closed_form_contact_time_s": T, "contact_time_over_2L_c": duration / T,
               "velocity_after_over_v0": [float(va[-1] / v0), float(vb[-1] / v0)],
               "energy_change_rel": float((e["Ek"] + e["Ee"] - e0) / e0),
               "momentum_change_abs": float(abs(m[a] @ mpm.solver.velocities()[a, 0] + m[b] @ mpm.solver.velocities()[b, 0])),
               "interface": o["interface"], "h_m": o["h_mm"] * 1e-3, "particles": int(mpm.solver.numPoints), "steps": int(mpm.solver.steps),
               "wall_time_s": wall, **end.summary()}
    report(out, summary, (lambda: plots.series(
        os.path.join(out, "velocity.png"), t, {"bar A (mean velocity)": va, "bar B": vb},
        ylabel="velocity (m/s)", title=f"Two bars colliding, h = {o['h_mm']} mm",
        hlines=((v0, "+v0"), (-v0, "-v0")))) if o["plot"] else None)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
