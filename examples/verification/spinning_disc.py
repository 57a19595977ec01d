"""A free disc spinning as a rigid body (issue 14; doc/stability.md, "Rotating and flying
fragments"): nothing loads it, so eigenerosion must not fire, its angular momentum must hold,
and its stress must ring about the closed-form steady solution of a spinning plane-stress disc,
sigma_r = sigma_theta = (3 + nu)/8 rho omega^2 R^2 at the centre.

Glass (E = 72 GPa, nu = 0.22, rho = 2440 kg/m3), plane stress, radius R, cell size h, 2 points
per cell, spinning at a rim speed of `rim` times the plane-stress dilatational wave speed
sqrt(E / (rho (1 - nu^2))); eigenerosion with alpha, kappa = kappaOverH h and Gc (Gc = 0: four
times the closed-form steady alpha kappa psi+ at the centre, i.e. twice the steady stress stays
below the threshold). With the paper's FLIP transfer and small-strain update (transfer=FLIP
stressUpdate=smallStrain) the disc of the defaults erodes from its rim after about a third of a
revolution; with APIC and the co-rotational update it does not.

Run::

    yade -n -x examples/verification/spinning_disc.py [--quick] [--out DIR] [param=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]

params R_mm, h_mm, rim, revolutions, Gc, alpha, kappaOverH, transfer, stressUpdate, recordEvery
(iterations between records), plot. Writes DIR/summary.json (centre_stress_mean_over_steady,
centre_stress_peak_over_steady, eroded_points, first_erosion_revolution, max_angular_momentum_change
(|L - L0| / L0 over the records), steady_centre_stress_Pa, omega_rad_s, particles, steps,
wall_time_s, ...) and DIR/centre_stress.png. --quick: R = 10 mm, rim 0.1, Gc = 0. The defaults
are the issue's disc (R = 50 mm, h = 1 mm, rim 0.02, Gc = 135 N/m: 31 428 points, about 69 000
steps per revolution). --checkpoint-every N / --resume as in the other examples (doc/restart.md).
"""
import math
import os
import sys
import time

import numpy as np
from yade import O, pack

import eigenmpm as em
from eigenmpm.cli import checkpointArgs, finish, report, runSteps, scriptArgs

DEFAULTS = dict(R_mm=50.0, h_mm=1.0, rim=0.02, revolutions=1.0, Gc=135.0, alpha=2.0, kappaOverH=1.1,
                transfer="APIC", stressUpdate="corotational", recordEvery=20, plot=True)
QUICK = dict(R_mm=10.0, rim=0.1, Gc=0.0)
GLASS = dict(E=72e9, nu=0.22, rho=2440.0)


def steadyCentreStress(omega, R):
    """sigma_r = sigma_theta at the centre of a spinning plane-stress disc, Pa."""
    return (3 + GLASS["nu"]) / 8 * GLASS["rho"] * omega ** 2 * R ** 2


def build(R, h, rim, transfer, stressUpdate, Gc=0.0, alpha=2.0, kappaOverH=1.1):
    """The spinning disc and its erosion engine in O.engines, O.dt at half the critical step.
    Returns (engine, erosion, omega)."""
    mpm = em.MpmEngine(dim=2, h=h, thickness=h, transfer=transfer, stressUpdate=stressUpdate, label="disc",
                       domain=((-2 * R, -2 * R, 0), (2 * R, 2 * R, 0)))
    E, nu, rho = GLASS["E"], GLASS["nu"], GLASS["rho"]
    ids = mpm.fill(pack.inCylinder((0, 0, -1), (0, 0, 1), R), em.ElasticMaterial(planeStress=True, **GLASS))
    omega = rim * math.sqrt(E / (rho * (1 - nu ** 2))) / R
    x = mpm.solver.positions()
    mpm.solver.setVelocities(np.ascontiguousarray(np.column_stack([-omega * x[:, 1], omega * x[:, 0], 0 * x[:, 0]])))
    if mpm.transfer == "APIC":  # the rotation's velocity gradient: the first transfer carries it exactly
        mpm.setVelocityGradient(ids, [[0, -omega], [omega, 0]])
    if Gc <= 0:  # four times alpha kappa psi+ of the steady centre stress (equibiaxial: psi = 2 s^2 (1 - nu) / E)
        Gc = 4 * alpha * kappaOverH * h * 2 * steadyCentreStress(omega, R) ** 2 * (1 - nu) / E
    erosion = em.EigenErosion(engine=mpm, Gc=Gc, alpha=alpha, kappaOverH=kappaOverH)
    O.engines = [mpm, erosion]
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm, erosion, omega


class Record:
    """(revolutions, mean centre stress / steady, |L - L0| / L0, eroded points) every call (a
    callEvery; a top-level class, so that a checkpoint saves it with its series)."""

    def __init__(self, mpm, erosion, omega, R):
        self.mpm, self.erosion, self.omega = mpm, erosion, omega
        x0 = mpm.solver.positions()
        self.centre = np.where(np.hypot(x0[:, 0], x0[:, 1]) < 0.25 * R)[0]
        self.steady = steadyCentreStress(omega, R)
        self.L0 = mpm.angularMomentum()[2]
        self.series = []

    def __call__(self):
        s = self.mpm.solver.stress()[self.centre]
        mean = float(np.mean(0.5 * (s[:, 0, 0] + s[:, 1, 1])))
        dL = abs(self.mpm.angularMomentum()[2] - self.L0) / abs(self.L0)
        self.series.append((self.mpm.solver.time * self.omega / (2 * math.pi), mean / self.steady, dL,
                            self.erosion.erodedCount()))


def revolve(record, revolutions, recordEvery=20, checkpoints=None, checkpointEvery=0, resume=False):
    """Runs to `revolutions` (from the current iteration); returns how the run ended."""
    if checkpointEvery and not resume:
        O.engines = [em.Checkpoint(directory=checkpoints, iterPeriod=checkpointEvery)] + list(O.engines)
    steps = int(math.ceil(revolutions * 2 * math.pi / record.omega / O.dt))
    return runSteps(steps - O.iter)


def summarize(record):
    """The summary's physics from the record."""
    rev, ratio, dL, eroded = (np.array(c) for c in zip(*record.series))
    first = np.nonzero(eroded > 0)[0]
    return {"centre_stress_mean_over_steady": float(np.mean(ratio)),
            "centre_stress_peak_over_steady": float(np.max(np.abs(ratio))),
            "eroded_points": int(eroded[-1]),
            "first_erosion_revolution": float(rev[first[0]]) if len(first) else None,
            "max_angular_momentum_change": float(np.max(dL)), "revolutions_run": float(rev[-1]),
            "steady_centre_stress_Pa": record.steady, "omega_rad_s": record.omega}


def plot(out, record):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rev, ratio, _, eroded = zip(*record.series)
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(rev, ratio, label="EigenMPM, mean over the points within R/4 of the centre")
    ax.axhline(1.0, ls="--", color="k", label="steady closed form (3 + nu)/8 rho omega^2 R^2")
    ax.set_xlabel("revolutions")
    ax.set_ylabel("mean stress / steady")
    ax.set_title(f"Spinning disc ({record.mpm.transfer}, {record.mpm.stressUpdate}), eroded: {eroded[-1]}")
    ax.legend()
    fig.tight_layout()
    path = os.path.join(out, "centre_stress.png")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv):
    argv, resume, every = checkpointArgs("spinning_disc", argv)
    o, out, _ = scriptArgs("spinning_disc", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    R, h = o["R_mm"] * 1e-3, o["h_mm"] * 1e-3
    if resume:  # the scene and its record as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        (record,) = [e.function for e in O.engines if isinstance(getattr(e, "function", None), Record)]
    else:
        mpm, erosion, omega = build(R, h, o["rim"], o["transfer"], o["stressUpdate"], o["Gc"], o["alpha"],
                                    o["kappaOverH"])
        record = Record(mpm, erosion, omega, R)
        O.engines = list(O.engines) + [em.callEvery(record, iterPeriod=o["recordEvery"])]
    start = time.time()
    end = revolve(record, o["revolutions"], o["recordEvery"], os.path.join(out, "checkpoints"), every, bool(resume))
    wall = time.time() - start
    mpm = record.mpm
    n, steps = mpm.solver.numPoints, mpm.solver.steps
    summary = {**summarize(record), "transfer": mpm.transfer, "stress_update": mpm.stressUpdate,
               "Gc_J_m2": record.erosion.Gc, "R_m": R, "h_m": h, "rim_speed_over_c": o["rim"],
               "particles": int(n), "steps": int(steps), "wall_time_s": wall,
               "particle_steps_per_s": n * steps / wall if wall > 0 else float("nan"), **end.summary()}
    report(out, summary, (lambda: plot(out, record)) if o["plot"] else None)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
