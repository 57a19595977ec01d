"""Convergence of the vibrating-bar frequency under grid refinement.

Runs examples/verification/vibrating_bar.py's scene at several resolutions for uGIMP and
linear shape functions, and writes DIR/convergence.md (a Markdown table with the relative
error and the observed order between successive resolutions), DIR/convergence.json and
DIR/convergence.png (error against h, log-log).

    yade -n -x examples/verification/bar_convergence.py [--quick] [--out DIR] [cells=10,20,40,80,160]
        [--checkpoint-every N] [--resume DIR/checkpoints]

--quick: cells=10,20,40 (seconds; the observed order is already about 2 for uGIMP).

--checkpoint-every N: each run of the sweep saves its scene every N iterations, and once more at
its end, into its own folder DIR/checkpoints/<shape>-<cells> (eigenmpm.Checkpoint, doc/restart.md).
--resume DIR/checkpoints continues an interrupted sweep (give the same cells): a run whose folder
holds a checkpoint continues from the newest one (a finished run from that of its end: nothing
runs, its results are read from it), the others run from the start, checkpointed into the same
folders at the same period (that of the resumed runs' Checkpoint, or N if given). The table is
the one of the uninterrupted sweep; only the wall times, which count the resumed part, differ.
"""
import json
import math
import os
import sys

# Under `yade -x` __file__ names yade itself; sys.argv[0] is this script.
sys.path.insert(0, os.path.dirname(os.path.abspath(sys.argv[0])))
import vibrating_bar  # noqa: E402
from yade import O  # noqa: E402

import eigenmpm as em  # noqa: E402
from eigenmpm.cli import checkpointArgs, finish  # noqa: E402


def study(cells=(10, 20, 40, 80, 160), shapes=("uGIMP", "linear"), checkpoints=None, every=0, resume=False):
    """The rows of the table, and how the last run ended: a run stopped early (Ctrl-C, a solver
    error) ends the study with the rows completed before it. With the folder `checkpoints`, each
    run is checkpointed into checkpoints/<shape>-<cells> every `every` iterations and at its end;
    with resume, a run whose folder holds a checkpoint continues from its newest one, and the
    others are checkpointed at the period of the resumed ones (unless `every` is given)."""
    rows = []
    for shape in shapes:
        prev = None
        for c in cells:
            kw = {}
            if checkpoints:
                folder = os.path.join(checkpoints, f"{shape}-{c}")
                if resume and em.checkpoint.latest(folder):
                    kw = dict(resume=folder, saveEnd=True)
                elif every:
                    kw = dict(checkpoints=folder, checkpointEvery=every, saveEnd=True)
                else:
                    raise SystemExit(f"bar_convergence: {checkpoints} holds no checkpoint of the first run; give "
                                     "--checkpoint-every N")
            s, _, end = vibrating_bar.run(cells=c, shape=shape, **kw)
            if checkpoints and not every:  # the period of the sweep, for the runs it starts anew
                (every,) = [e.period for e in O.engines if isinstance(e, em.Checkpoint)]
            if end.early:
                return rows, end
            order = math.log(prev["rel_error"] / s["rel_error"]) / math.log(c / prev["cells_along_bar"]) \
                if prev else float("nan")
            rows.append(dict(shape=shape, cells=c, h_m=s["h_m"], particles=s["particles"], steps=s["steps"],
                             rel_error=s["rel_error"], order=order, wall_time_s=s["wall_time_s"]))
            prev = s
    return rows, end


CELLS, QUICK_CELLS = (10, 20, 40, 80, 160), (10, 20, 40)


def main(argv):
    argv, resume, every = checkpointArgs("bar_convergence", argv)
    out, cells = "out/bar_convergence", CELLS
    it = iter(argv)
    for a in it:
        if a == "--quick":
            cells = QUICK_CELLS
        elif a == "--out":
            out = next(it)
        elif a.startswith("cells="):
            cells = tuple(int(c) for c in a[6:].split(","))
        else:
            raise SystemExit(f"bar_convergence: unknown argument {a}")
    os.makedirs(out, exist_ok=True)
    checkpoints = resume or (os.path.join(out, "checkpoints") if every else None)
    rows, end = study(cells, checkpoints=checkpoints, every=every, resume=bool(resume))
    lines = ["| shape | cells along L | h (m) | points | steps | rel. error of omega1 | observed order |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        order = "" if math.isnan(r["order"]) else f"{r['order']:.2f}"
        lines.append(f"| {r['shape']} | {r['cells']} | {r['h_m']:.5g} | {r['particles']} | {r['steps']} | "
                     f"{r['rel_error']:.3e} | {order} |")
    if end.early:
        lines.append(f"\nIncomplete: the run at the next resolution {end.note()}.")
    table = "\n".join(lines)
    print(table)
    with open(os.path.join(out, "convergence.md"), "w") as f:
        f.write(table + "\n")
    with open(os.path.join(out, "convergence.json"), "w") as f:
        json.dump(rows, f, indent=2)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    for shape in sorted({r["shape"] for r in rows}):
        rs = [r for r in rows if r["shape"] == shape]
        ax.loglog([r["h_m"] for r in rs], [r["rel_error"] for r in rs], "o-", label=shape)
    h = [r["h_m"] for r in rows if r["shape"] == "uGIMP"]
    if h:
        e0 = [r["rel_error"] for r in rows if r["shape"] == "uGIMP"][0]
        ax.loglog(h, [e0 * (x / h[0]) ** 2 for x in h], "k--", lw=0.8, label="slope 2")
    ax.set_xlabel("cell size h (m), bar length 1 m")
    ax.set_ylabel("relative error of omega1")
    ax.set_title("Vibrating bar: convergence under refinement")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "convergence.png"), dpi=120)
    plt.close(fig)
    print("written:", out)
    finish(end, out)


if __name__ == "__main__":
    main(sys.argv[1:])
