"""Pre-cracked bar pulled apart: phantom nodes (paper Section 3.3.1) against the intact bar.

A 2D bar L x H (plane strain, E, nu, rho) is cut across at mid-length by a straight crack,
given as a segment from one cell below the bar to one cell above it (a through crack). The
nodes nearest to the points of the first and last layer of points are pulled apart along x at
-v and +v, the velocity ramped from 0 over t0 (paper Eq 34). The same bar without the crack is
run alongside. With the crack the two halves must separate freely: the gap between the faces
grows by 2 v (t - t0/2), no force crosses the crack (reaction and sigma_xx at the crack ~ 0),
while the intact bar stretches and carries sigma_xx = E/(1 - nu^2) 2 v (t - t0/2) / L.

Run::

    yade -n -x examples/verification/precracked_bar.py [--quick] [--out DIR] [name=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]
    yade-batch table.txt examples/verification/precracked_bar.py   # a column per parameter

with names cells (along the bar), ppc, transits (duration in wave transits L/c), rampTransits,
dtFraction, velocity, plot. --quick: 20 cells. Writes DIR/summary.json:

- gap_m, gap_expected_m, gap_rel_error: growth of the gap between the faces (smallest x of the
  right half minus largest x of the left half, minus its initial value) and 2 v (t - t0/2);
- reaction_cracked_N, reaction_intact_N: x-reaction of the pulled right end, time mean over the
  second half of the run (the cut halves ring after the ramp; the mean is ~0);
- stress_at_crack_cracked_Pa, stress_at_crack_intact_Pa: mean sigma_xx of the points within
  1.5 h of the crack line at the end; stress_intact_expected_Pa: the closed form above;
- particles (per bar), steps (per bar), wall_time_s, particle_steps_per_s (both bars), twins,
  h_m, duration_s, ramp_time_s, ...

and DIR/precracked_bar.png: both bars at the end (cracked above, intact below), the points at
their positions coloured by sigma_xx, the crack drawn in. Default DIR: out/precracked_bar.

--checkpoint-every N: each bar's run saves its scene every N iterations, and once more at its end,
into its own folder DIR/checkpoints/cracked and DIR/checkpoints/intact (eigenmpm.Checkpoint,
doc/restart.md). --resume DIR/checkpoints continues the pair of runs (give the same parameters): a
bar whose folder holds a checkpoint continues from the newest one (a finished bar from that of
its end: nothing runs, its measurements are made on it), the other runs from the start,
checkpointed into its folder at the same period (that of the resumed bar's Checkpoint, or N if
given). The outputs are those of the uninterrupted runs; only the wall times, which count the
resumed part, differ.
"""
import math
import os
import sys
import time

import numpy as np
from yade import O, pack

import eigenmpm as em
from eigenmpm.cli import checkpointArgs, finish, report, runSteps, scriptArgs
from eigenmpm.ramp import rampDisplacement

DEFAULTS = dict(cells=40, ppc=2, transits=6.0, rampTransits=2.0, dtFraction=0.3, velocity=1.0, plot=True)
QUICK = dict(cells=20)


class Reactions:
    """Records (time, x-reaction of the right end, minus that of the left end) after each step (a
    callEvery) and the number of twin nodes of the last step, and keeps the positions at the start.
    A class at the top level, not a local function, so that a checkpoint saves it with its record
    and a resumed run continues it (a bar read back from the checkpoint of its end runs no step, so
    its solver has counted no twins since the load)."""

    def __init__(self, mpm, left, right):
        self.mpm, self.left, self.right = mpm, left, right
        self.x0 = mpm.solver.positions().copy()
        self.rows = []
        self.twins = 0

    def __call__(self):
        self.rows.append((self.mpm.solver.time, self.right.reaction[0], -self.left.reaction[0]))
        self.twins = int(self.mpm.solver.numTwins)


def pull(cracked, cells=40, ppc=2, transits=6.0, rampTransits=2.0, dtFraction=0.3, velocity=1.0, L=0.2, H=0.05,
         E=1e8, nu=0.2, rho=1000.0, checkpoints=None, checkpointEvery=0, resume=None):
    """Runs one bar; returns its measurements, its final state and how its run ended ("end").
    With checkpointEvery > 0 a Checkpoint engine saves the scene every checkpointEvery iterations,
    and at the end of a complete run, into the folder `checkpoints`; `resume`, a folder of
    checkpoints, continues the run from the newest of them instead of building it."""
    O.reset()
    h = L / cells
    # The crack line lies between two columns of points, off the nodes (any position works; this
    # one splits the bar into equal halves).
    xc = 0.5 * L + 0.13 * h
    crack = [(xc, -h, 0), (xc, H + h, 0)]
    c = math.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu) * rho))  # plane-strain P-wave speed
    t0, duration = rampTransits * L / c, transits * L / c
    if resume:  # the scene and its record as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        mpm = em.findEngine("bar")
        (record,) = [e.function for e in O.engines if isinstance(getattr(e, "function", None), Reactions)]
    else:
        mpm = em.MpmEngine(dim=2, h=h, ppc=ppc, label="bar")
        mat = em.ElasticMaterial(E=E, nu=nu, rho=rho)
        mpm.fill(pack.inAlignedBox((0, 0, 0), (L, H, 0)), mat)
        if cracked:
            mpm.crack(crack)
        layer = 0.5 * h / ppc + 1e-3 * h  # the first layer of points at each end
        left = mpm.velocityBC(points=pack.inAlignedBox((-1, -1, -1), (layer, 1, 1)), components="x",
                              velocity=(-velocity, 0, 0), rampTime=t0, label="left")
        right = mpm.velocityBC(points=pack.inAlignedBox((L - layer, -1, -1), (1, 1, 1)), components="x",
                               velocity=(velocity, 0, 0), rampTime=t0, label="right")
        record = Reactions(mpm, left, right)
        O.engines = [mpm, em.callEvery(record)]
        if checkpointEvery:
            O.engines = [em.Checkpoint(directory=checkpoints, iterPeriod=checkpointEvery)] + list(O.engines)
        O.dt = dtFraction * mpm.criticalTimeStep()
    x0 = record.x0
    isLeft = x0[:, 0] < xc
    near = np.abs(x0[:, 0] - xc) < 1.5 * h
    steps = int(math.ceil(duration / O.dt))
    todo = steps - O.iter  # 0 after a resume from the checkpoint of the end
    start = time.time()
    end = runSteps(todo)
    wall = time.time() - start
    checkpoint = [e for e in O.engines if isinstance(e, em.Checkpoint)]
    if checkpoint and todo > 0 and not end.early:  # the end, which a resumed pair reads back
        checkpoint[0].save()
    steps = mpm.solver.steps
    x = mpm.solver.positions()
    sigma = mpm.solver.stress()
    t = mpm.solver.time
    r = np.array(record.rows)
    second = r[:, 0] >= 0.5 * t
    gap = lambda pos: float(pos[~isLeft, 0].min() - pos[isLeft, 0].max())  # noqa: E731
    pulled = 2 * rampDisplacement(t, velocity, t0)  # both ends moved apart under the ramp (paper Eq 34)
    return {
        "gap_m": gap(x) - gap(x0),
        "gap_expected_m": pulled,
        "reaction_N": float(np.mean(r[second, 1])),
        "reaction_left_N": float(np.mean(r[second, 2])),
        "stress_at_crack_Pa": float(np.mean(sigma[near, 0, 0])),
        "stress_expected_Pa": E / (1 - nu * nu) * pulled / L,
        "particles": int(mpm.solver.numPoints), "steps": steps, "wall_time_s": wall, "time_s": t,
        "twins": record.twins, "h_m": h, "ramp_time_s": t0, "wave_speed_m_s": c,
        "dt_s": O.dt, "crack": crack, "end": end, "checkpointEvery": checkpoint[0].period if checkpoint else 0,
        "state": (x, sigma[:, 0, 0].copy(), mpm.crackVertices(0) if cracked else None),
    }


def run(cells=40, ppc=2, transits=6.0, rampTransits=2.0, dtFraction=0.3, velocity=1.0, checkpoints=None,
        checkpointEvery=0, resume=False, **_):
    """Pulls the cracked and the intact bar; returns the summary, the final states and how the
    runs ended (eigenmpm.cli.RunEnd). When the cracked bar's run stops early (Ctrl-C, a solver
    error) the intact bar is not run and its values are None. With the folder `checkpoints`, each
    bar is checkpointed into checkpoints/cracked and checkpoints/intact every checkpointEvery
    iterations and at its end; with resume, a bar whose folder holds a checkpoint continues from
    its newest one, and the other is checkpointed at the period of the resumed one (unless
    checkpointEvery is given)."""
    kw = dict(cells=cells, ppc=ppc, transits=transits, rampTransits=rampTransits, dtFraction=dtFraction,
              velocity=velocity)
    every = checkpointEvery

    def bar(cracked):
        nonlocal every
        if not checkpoints:
            return pull(cracked, **kw)
        folder = os.path.join(checkpoints, "cracked" if cracked else "intact")
        if resume and em.checkpoint.latest(folder):
            out = pull(cracked, **kw, resume=folder)
        elif every:
            out = pull(cracked, **kw, checkpoints=folder, checkpointEvery=every)
        else:
            raise SystemExit(f"precracked_bar: {checkpoints} holds no checkpoint of the cracked bar; give "
                             "--checkpoint-every N")
        every = every or out["checkpointEvery"]  # the period of the pair, for a bar started anew
        return out

    cut = bar(True)
    whole = bar(False) if not cut["end"].early else None
    end = whole["end"] if whole else cut["end"]
    intact = (lambda key: whole[key]) if whole else (lambda key: None)  # noqa: E731
    bars = [cut] + ([whole] if whole else [])
    wall = sum(b["wall_time_s"] for b in bars)
    summary = {
        "gap_m": cut["gap_m"], "gap_expected_m": cut["gap_expected_m"],
        "gap_rel_error": abs(cut["gap_m"] - cut["gap_expected_m"]) / cut["gap_expected_m"],
        "gap_intact_m": intact("gap_m"),
        "reaction_cracked_N": cut["reaction_N"], "reaction_intact_N": intact("reaction_N"),
        "reaction_ratio": abs(cut["reaction_N"]) / abs(whole["reaction_N"]) if whole else None,
        "stress_at_crack_cracked_Pa": cut["stress_at_crack_Pa"],
        "stress_at_crack_intact_Pa": intact("stress_at_crack_Pa"),
        "stress_intact_expected_Pa": intact("stress_expected_Pa"),
        "stress_ratio": abs(cut["stress_at_crack_Pa"]) / abs(whole["stress_at_crack_Pa"]) if whole else None,
        "particles": cut["particles"], "steps": cut["steps"], "wall_time_s": wall,
        "particle_steps_per_s": sum(b["particles"] * b["steps"] for b in bars) / wall if wall > 0 else float("nan"),
        "twins": cut["twins"], "h_m": cut["h_m"], "cells_along_bar": cells, "ppc": ppc, "dt_s": cut["dt_s"],
        "duration_s": cut["time_s"], "ramp_time_s": cut["ramp_time_s"], "velocity_m_s": velocity,
        "wave_speed_m_s": cut["wave_speed_m_s"], "crack_vertices_initial_m": [list(v) for v in cut["crack"]],
        **end.summary(),
    }
    return summary, (cut["state"], intact("state")), end


def plot(out, states, summary):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    (xc, sc, crack), (xi, si, _) = states[0], states[1] or (None, None, None)
    offset = -0.08  # the intact bar is drawn below the cracked one
    vmax = max(np.abs(si if si is not None else sc).max(), 1.0)
    fig, ax = plt.subplots(figsize=(8, 4.2))
    size = max(0.5, 6e3 / len(xc))
    ax.scatter(1e3 * xc[:, 0], 1e3 * xc[:, 1], c=sc, s=size, marker="s", cmap="coolwarm", vmin=-vmax, vmax=vmax,
               linewidths=0)
    art = ax.scatter(1e3 * xi[:, 0], 1e3 * (xi[:, 1] + offset), c=si, s=size, marker="s", cmap="coolwarm",
                     vmin=-vmax, vmax=vmax, linewidths=0) if xi is not None else None
    if crack:
        ax.plot([1e3 * v[0] for v in crack], [1e3 * v[1] for v in crack], "k--", lw=0.8, label="crack (phantom nodes)")
        ax.legend(loc="upper right", fontsize=8)
    ax.annotate(f"cracked: gap {1e3 * summary['gap_m']:.2f} mm (expected {1e3 * summary['gap_expected_m']:.2f}), "
                f"sigma_xx at crack {summary['stress_at_crack_cracked_Pa'] / 1e3:.2g} kPa",
                (1e3 * xc[:, 0].min(), 1e3 * xc[:, 1].max() + 4), fontsize=8)
    if xi is not None:
        ax.annotate(f"intact: sigma_xx at mid-length {summary['stress_at_crack_intact_Pa'] / 1e6:.2f} MPa "
                    f"(closed form {summary['stress_intact_expected_Pa'] / 1e6:.2f})",
                    (1e3 * xi[:, 0].min(), 1e3 * (xi[:, 1].max() + offset) + 4), fontsize=8)
    fig.colorbar(art or ax.collections[0], ax=ax, label="sigma_xx (Pa)", shrink=0.8)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"Bar pulled apart at +-{summary['velocity_m_s']:g} m/s, t = {1e3 * summary['duration_s']:.2f} ms")
    fig.tight_layout()
    path = os.path.join(out, "precracked_bar.png")
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def main(argv):
    argv, resume, every = checkpointArgs("precracked_bar", argv)
    opts, out, _ = scriptArgs("precracked_bar", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    checkpoints = resume or (os.path.join(out, "checkpoints") if every else None)
    summary, states, end = run(**opts, checkpoints=checkpoints, checkpointEvery=every, resume=bool(resume))
    report(out, summary, (lambda: plot(out, states, summary)) if opts["plot"] else None)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
