"""L-shaped panel: the critical load that the eigenerosion criterion predicts from the elastic
field alone, to separate the criterion from the dynamics of the full run (doc/validation.md).

The panel of examples/lshaped_panel.py is loaded without fracture (Gc huge) by a velocity
ramped to 0.05 m/s over 2 ms, up to a load-point displacement of `u_mm`; then the effective
energy release rate G_p of paper Eq 23 (the erosion engine's own computation, history H =
psi+ at that moment) is evaluated at the points within 3 h of the re-entrant corner for the
given alpha and kappa. The field is linear in the load, so G scales with the load squared and
the criterion G_p = Gc is first met at F_c = F sqrt(Gc / max G_p).

    yade -n -x examples/verification/lpanel_corner.py [--out DIR] [h_mm=5 alpha=1.5 kappaOverH=1.1 u_mm=0.2]
        [--checkpoint-every N] [--resume DIR/checkpoints]

Writes DIR/summary.json: load_kN (at u_mm), max_G_J_m2, critical_load_kN,
critical_displacement_mm (u_mm F_c / F), psi_slope_3_30mm (the exponent s of psi+ ~ r^s from
the corner, 3-30 mm, in the 150-210 deg sector where the crack runs; Williams' leading term for
a 270 deg corner gives -0.91), the paper's Table 1/2 value where there is one.

--checkpoint-every N saves the scene every N iterations into DIR/checkpoints (eigenmpm.Checkpoint,
doc/restart.md); --resume DIR/checkpoints continues from the newest of them (give the same
parameters) to the end state of the uninterrupted run: in the ramp, or in the last 0.2 ms with the
load record (LoadRecord) saved so far. wall_time_s then counts the resumed part only.
"""
import json
import os
import sys
import time

import numpy as np
from yade import O, pack

import eigenmpm as em
from eigenmpm.cli import checkpointArgs, finish, runSteps, scriptArgs
from eigenmpm.ramp import rampDisplacement, rampTimeTo

DEFAULTS = dict(h_mm=5.0, alpha=1.5, kappaOverH=1.1, u_mm=0.2, E=25.85e9, nu=0.18, rho=2500.0, Gc=89.0)
PAPER = {(5.0, 1.5, 1.1): 15.082, (5.0, 1.0, 1.1): 17.230, (5.0, 2.0, 1.1): 13.758, (10.0, 1.5, 1.1): 16.14,
         (2.5, 1.5, 1.1): 14.50}


class LoadRecord:
    """Records the y-reaction of the load condition after each step (a callEvery; it runs after
    the solver in the same iteration). A class at the top level, not a local function, so that a
    checkpoint saves it with its record and a resumed run continues it."""

    def __init__(self, load):
        self.load = load
        self.F = []

    def __call__(self):
        self.F.append(self.load.reaction[1])


def main(argv):
    argv, resume, every = checkpointArgs("lpanel_corner", argv)
    o, out, _ = scriptArgs("lpanel_corner", DEFAULTS, {}, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    h, a, v, t0 = o["h_mm"] * 1e-3, 0.25, 0.05, 2e-3
    if resume:  # the scene, and the load record once the ramp is over, as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        mpm = em.findEngine("panel")
        load = mpm.bcs["load"]
    else:
        panel = pack.inAlignedBox((0, 0, 0), (2 * a, 2 * a, 0)) - pack.inAlignedBox((a, -1, -1), (1, a, 1))
        mpm = em.MpmEngine(dim=2, h=h, ppc=2, thickness=0.1, label="panel")
        mpm.fill(panel, em.ElasticMaterial(E=o["E"], nu=o["nu"], rho=o["rho"], planeStress=True))
        mpm.fix(points=pack.inAlignedBox((-1, -1, -1), (a, 0.5 * h, 1)), label="base")
        load = mpm.velocityBC(points=pack.inAlignedBox((0.47 - h / 2, a, -1), (0.47 + h / 2, a + 0.5 * h, 1)),
                              components="y", velocity=(0, v, 0), rampTime=t0, label="load")
        # Gc so large that nothing erodes: the engine is there for its G_p computation only
        crack = em.EigenErosion(engine=mpm, Gc=1e30, alpha=o["alpha"], kappaOverH=o["kappaOverH"])
        O.dt = 0.8 * mpm.criticalTimeStep()
        O.engines = [mpm, crack]
        if every:
            O.engines = [em.Checkpoint(directory=os.path.join(out, "checkpoints"), iterPeriod=every)] + list(O.engines)
    ramp = int(round(rampTimeTo(o["u_mm"] * 1e-3, v, t0) / O.dt))
    # then the load averaged over the last 0.2 ms (the small vibrations left by the ramp)
    settle = int(0.2e-3 / O.dt)
    record = next((e.function for e in O.engines if isinstance(getattr(e, "function", None), LoadRecord)), None)
    start = time.time()
    if record is None:  # the ramp (a run resumed after it holds its record)
        end = runSteps(ramp - O.iter)
        if not end.early:
            record = LoadRecord(load)
            O.engines = O.engines + [em.callEvery(record)]
    if record is not None:
        end = runSteps(ramp + settle - O.iter)
    F = float(np.mean(record.F if record is not None else [load.reaction[1]]))
    x = mpm.solver.positions()[:, :2]
    near = np.nonzero(np.hypot(x[:, 0] - a, x[:, 1] - a) < 3 * h)[0]
    G = np.asarray(mpm.solver.energyReleaseRate(near.tolist(), bruteForce=False))
    k = int(np.argmax(G))
    # How psi+ falls with the distance r from the corner in the sector where the crack runs
    # (150-210 deg, 3-30 mm; ring means): Williams' leading term gives r^-0.91 for 270 deg.
    d = x - a
    r = np.hypot(d[:, 0], d[:, 1])
    th = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 360
    psi = np.asarray(mpm.solver.psiPlus())
    edges = np.geomspace(3e-3, 30e-3, 8)
    rings = [(np.sqrt(e0 * e1), psi[(r >= e0) & (r < e1) & (th > 150) & (th < 210)]) for e0, e1 in zip(edges[:-1], edges[1:])]
    rings = [(rr, p.mean()) for rr, p in rings if len(p) > 3]
    slope = float(np.polyfit(np.log([q[0] for q in rings]), np.log([q[1] for q in rings]), 1)[0]) if len(rings) > 2 else None
    u = rampDisplacement(mpm.solver.time, v, t0)
    Fc = F * np.sqrt(o["Gc"] / G[k])
    summary = dict(load_kN=F / 1e3, displacement_mm=u * 1e3, max_G_J_m2=float(G[k]),
                   max_G_point_mm=(1e3 * x[near[k]]).tolist(), critical_load_kN=Fc / 1e3,
                   critical_displacement_mm=u * 1e3 * Fc / F,
                   psi_slope_3_30mm=slope, paper_critical_load_kN=PAPER.get((o["h_mm"], o["alpha"], o["kappaOverH"])),
                   particles=mpm.solver.numPoints, steps=mpm.solver.steps, wall_time_s=time.time() - start,
                   parameters=o, **end.summary())
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    print(json.dumps({k: v for k, v in summary.items() if k != "parameters"}, indent=2))
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
