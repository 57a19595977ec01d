"""What BodyContact costs per step (issue 16 item 7): a 2D block of N points under gravity with
B YADE spheres on its top face, pressed into it at --approach m/s (default 0.5), stepped with
and without the contact. Run inside YADE, one thread:

    PYTHONPATH=build/python yade -n -j 1 -x bench/bench_contact.py [--points 1e5] [--bodies 1000]
                                                [--steps 2] [--rounds 15] [--approach 0.5]

With --approach 0 (the scene of sessions before 2026-12-04) the spheres only rest: during the
timed steps the block's top is still falling with them, the contact forces are about 1e-18 N,
and writing the forces back to YADE is skipped for nearly every body, which understates the
cost. Pressed in, the touching spheres receive real forces every step.

Two scenes are built once, side by side in YADE (O.addScene, O.switchToScene): (C)
ForceResetter, MpmEngine, BodyContact, NewtonIntegrator; (N) the same without BodyContact (the
spheres then fall through, which costs YADE nothing measurable with no collider). Each round
steps one scene `steps` steps, then the other, alternating which goes first; the time is the
process's CPU time. Short rounds of two scenes that both stay alive put the machine's slow
spells (seconds long here, 30-40 % slower) on both sides alike: until session 34 each round
built both scenes again and stepped each for longer, and the rounds' ratios spread from 0.9 to
1.9 on a bad day. Printed: the median CPU time per step of each, their ratio and the median of
the rounds' own ratios with its quartiles, the contact's extra time per step and the part of it
spent exchanging with YADE (reading the bodies through YADE's Python API, with the test of
which spheres touch a point, and writing the forces back; the rest is mostly the C++ stage),
and how many of the spheres were read in full (those touching a point) in the last step and
over the rounds. The defaults time steps 20 to 50 of each scene, the window of the earlier
versions (in it 600-680 of the 1 000 spheres touch a point; later they bounce off, and fewer do).
"""
import argparse
import math
import sys
import time

import numpy as np
from yade import O, pack, utils
from yade.wrapper import ForceResetter, NewtonIntegrator

import eigenmpm as em


def scene(points, bodies, contact, approach=0.5, label="block", reset=True):
    if reset:
        O.reset()
    side = math.sqrt(points / 4.0)  # cells per side at ppc = 2 in a square block of 1 m
    h = 1.0 / side
    mpm = em.MpmEngine(dim=2, h=h, thickness=h, gravity=(0, -9.81, 0), label=label,
                       domain=((-0.1, -0.1, 0), (1.1, 1.2, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, -1), (1, 1, 1)), em.ElasticMaterial(E=1e8, nu=0.3, rho=1000))
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (2, 0, 1)), components="xy", label="base")  # it holds the spheres
    r = 0.5 / bodies
    # The spheres start just inside the reach of the top row of points (its top edge, where the
    # points' half-width ends), so that they touch from the first step.
    top = float(np.max(np.array(mpm.solver.positions())[:, 1])) + 0.9 * mpm.solver.halfWidth
    ids = [O.bodies.append(utils.sphere(((i + 0.5) / bodies, top + r, 0), r)) for i in range(bodies)]
    for i in ids:
        O.bodies[i].state.vel = (0, -approach, 0)
    engines = [ForceResetter(), mpm]
    c = None
    if contact:
        c = em.BodyContact(engine=mpm, label=label + "Contact")
        engines.append(c)
    O.engines = engines + [NewtonIntegrator(damping=0, gravity=(0, -9.81, 0))]
    O.dt = 0.4 * mpm.criticalTimeStep()
    return mpm, c, ids


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=float, default=1e5)
    ap.add_argument("--bodies", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=2, help="steps of one scene per round")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--approach", type=float, default=0.5, help="the spheres' initial speed into the block, m/s")
    a = ap.parse_args(argv)
    withScene = O.thisScene
    mpm, c, _ = scene(int(a.points), a.bodies, True, a.approach, "blockC")
    O.run(20, True)  # the grid, and the spheres settle onto the block
    withoutScene = O.addScene()
    O.switchToScene(withoutScene)
    scene(int(a.points), a.bodies, False, a.approach, "blockN", reset=False)
    O.run(20, True)
    per = {True: [], False: []}
    readInFull = []  # (the spheres that touch a point, after each round of the contact scene)
    for k in range(a.rounds):
        for contact in ((True, False) if k % 2 == 0 else (False, True)):
            O.switchToScene(withScene if contact else withoutScene)
            t0 = time.process_time()
            O.run(a.steps, True)
            per[contact].append((time.process_time() - t0) / a.steps)
            if contact:
                readInFull.append(c.core.numBodies)
    O.switchToScene(withScene)
    # The exchange: refill the stage from YADE and hand the forces back, as each step does.
    touching, read, force = c.pointsInContact(), c.core.numBodies, c.totalForce()
    split = []
    for _ in range(5):
        t1 = time.process_time()
        for _ in range(a.steps):
            c._load(mpm)
            c.afterStep(mpm)
        split.append((time.process_time() - t1) / a.steps)
    withC, without = np.median(per[True]), np.median(per[False])
    python = np.median(split)
    # Each round ran both scenes back to back: its ratio is paired against a slow spell of the
    # machine, which the ratio of the medians is not.
    paired = [c / n for c, n in zip(per[True], per[False])]
    q1, q3 = np.percentile(paired, [25, 75])
    print(f"points {int(a.points)}, bodies {a.bodies} ({read} read in full in the last step, "
          f"{min(readInFull)}-{max(readInFull)} over the rounds), points touching {touching}, "
          f"total force on the bodies in the last step {np.linalg.norm(force):.3g} N (approach {a.approach} m/s)")
    print(f"step without contact {1e3 * without:.2f} ms, with {1e3 * withC:.2f} ms: ratio {withC / without:.3f}; "
          f"median of the rounds' ratios {np.median(paired):.3f} (quartiles {q1:.3f}-{q3:.3f})")
    print(f"contact's extra per step {1e3 * (withC - without):.2f} ms, of which the exchange with YADE "
          f"(bodies in, forces out) {1e3 * python:.2f} ms")


if __name__ == "__main__":
    main(sys.argv[1:] if sys.argv[0].endswith(".py") else sys.argv)
