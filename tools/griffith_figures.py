"""Figures of examples/verification/griffith_initiation.py runs (issue 15, doc/validation.md).

Reads DIR/summary.json of every run directory given (a directory without one is searched for
summary.json files below it) and draws

- griffith_convergence.png: initiation traction / sigma_G against a/h, one series per geometry
  (centre, edge) and alpha ('griffith' or a number), runs with the tips on the node lines
  (tipShift = 0), the specimen along the grid (angle_deg = 0) and a straight crack; with the
  targets 1 (alpha = 'griffith') and 1 / sqrt(alpha r) for each numeric alpha, r = 1 / alpha_used
  of a 'griffith' run (the initiation ratio of doc/fracture.md);
- griffith_grid_bias.png: the same ratio, over that of the same run with the tips on the node
  lines and the crack along the grid, against the tip shift (cells; centre crack, one series per
  a/h and alpha) and against the angle of the specimen to the grid axes (tipShift = 0,
  alpha = 'griffith', one series per a/h).

Only runs that stop at the first erosion (kinkPoints = 0) with aOverW = 0.1 and a loading
(rampTransits, ratioMax) given by --ramps are drawn; on the
angle panel the turned runs made before the load fix of 2026-12-02 (no traction_layer_over_h in
their summary: the band carried its points' area over h times the traction, 6 % more than W t
at 45 degrees) are drawn dotted. No result is written in this file: every point comes from a
summary.

Usage::

    /usr/bin/python3.11 tools/griffith_figures.py out/prior_20261201 out/g [--outdir doc/img] [--ramps 80:2 60:1.5]
"""
import argparse
import glob
import json
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

DEFAULTS = dict(geometry="centre", tipShift=0.0, angle_deg=0.0, crackAngle_deg=0.0, kinkPoints=0)


def load(dirs, ramps):
    """The runs' summaries that stop at the first erosion (kinkPoints = 0) with the default
    crack length (aOverW = 0.1), each with its parameters completed by the script's defaults
    (older summaries lack the parameters added later), the path it came from and `load`:
    'exact' when the edges carry W times the traction, 'as filled' for a turned specimen run
    before 2026-12-02 (the band's force was its points' area over h times the traction; no
    traction_layer_over_h in the summary)."""
    runs = []
    for d in dirs:
        files = [os.path.join(d, "summary.json")] if os.path.isfile(os.path.join(d, "summary.json")) else \
            sorted(glob.glob(os.path.join(d, "**", "summary.json"), recursive=True))
        for f in files:
            s = json.load(open(f))
            if s.get("initiation_ratio") is None or "a_over_h" not in s:
                continue
            p = dict(DEFAULTS, **s.get("parameters", {}))
            if int(p["kinkPoints"]) != 0 or abs(float(p.get("aOverW", 0.1)) - 0.1) > 1e-12:
                continue
            if (float(p.get("rampTransits", 60)), float(p.get("ratioMax", 1.5))) not in ramps:
                continue
            p["alpha"] = "griffith" if str(p["alpha"]) == "griffith" else f"{float(p['alpha']):g}"
            load = "exact" if float(p["angle_deg"]) == 0 or "traction_layer_over_h" in s else "as filled"
            runs.append(dict(s, p=p, path=f, load=load))
    # One run per parameter set (the first given).
    seen, keep = set(), []
    for r in runs:
        p = r["p"]
        key = (p["geometry"], p["alpha"], round(r["a_over_h"], 6), float(p["tipShift"]), float(p["angle_deg"]),
               float(p["crackAngle_deg"]), p.get("rampTransits"), p.get("ratioMax"), r["load"])
        if key not in seen:
            seen.add(key)
            keep.append(r)
    return keep


def series(runs, select, group, x):
    """{group value: sorted [(x, ratio)]} of the runs that `select` takes."""
    out = {}
    for r in runs:
        if select(r):
            out.setdefault(group(r), []).append((x(r), r["initiation_ratio"]))
    return {k: sorted(v) for k, v in sorted(out.items())}


def straight(r, shift=True, angle=True):
    p = r["p"]
    return float(p["crackAngle_deg"]) == 0 and (not shift or float(p["tipShift"]) == 0) and \
        (not angle or float(p["angle_deg"]) == 0)


def convergence(runs, path):
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    data = series(runs, straight, lambda r: (r["p"]["geometry"], r["p"]["alpha"]), lambda r: r["a_over_h"])
    markers = {"centre": "o", "edge": "s"}
    for (geo, alpha), pts in data.items():
        xs, ys = zip(*pts)
        ax.plot(xs, ys, marker=markers.get(geo, "^"), ls="-" if alpha == "griffith" else "--",
                label=f"{geo}, alpha = {alpha!r}" if alpha == "griffith" else f"{geo}, alpha = {alpha}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.text(min(r["a_over_h"] for r in runs), 1.01, "Griffith", fontsize=8)
    alphaG = [r["alpha_used"] for r in runs if r["p"]["alpha"] == "griffith" and "alpha_used" in r]
    if alphaG:
        for alpha in sorted({a for _, a in data if a != "griffith"}):
            target = 1.0 / math.sqrt(float(alpha) / alphaG[0])
            ax.axhline(target, color="gray", lw=0.8, ls=":")
            ax.text(min(r["a_over_h"] for r in runs), target + 0.01, f"1/sqrt(alpha r), alpha = {alpha}", fontsize=8)
    ax.set_xscale("log", base=2)
    ax.set_xlabel("a / h (half crack length, or edge crack length, over the cell size)")
    ax.set_ylabel("initiation traction / sigma_G")
    ax.set_title("Initiation at a sharp crack against Griffith (kappa = 1.1 h)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def gridBias(runs, path):
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9.6, 4.0), sharey=True)
    shifts = series(runs, lambda r: straight(r, shift=False) and r["p"]["geometry"] == "centre",
                    lambda r: (round(r["a_over_h"], 3), r["p"]["alpha"]), lambda r: float(r["p"]["tipShift"]))
    for (ah, alpha), pts in shifts.items():
        ref = dict(pts).get(0.0)
        if len(pts) > 1 and ref:
            xs, ys = zip(*pts)
            a1.plot(xs, [y / ref for y in ys], marker="o",
                    label=f"a/h = {ah:g}, alpha = {alpha} (1 = {ref:.3f} sigma_G)")
    a1.set_xlabel("tip shift off the node lines (cells)")
    a1.set_ylabel("initiation traction / that of the aligned crack")
    a1.set_title("Tip across one cell (centre crack)")
    angles = {}
    for load in ("exact", "as filled"):
        data = series(runs, lambda r: straight(r, angle=False) and r["p"]["geometry"] == "centre"
                      and r["p"]["alpha"] == "griffith" and (r["load"] == load or float(r["p"]["angle_deg"]) == 0),
                      lambda r: round(r["a_over_h"], 3), lambda r: float(r["p"]["angle_deg"]))
        for ah, pts in data.items():
            ref = dict(pts).get(0.0)
            if len(pts) > 1 and ref:
                xs, ys = zip(*pts)
                line, = a2.plot(xs, [y / ref for y in ys], marker="s" if load == "exact" else "x",
                                ls="-" if load == "exact" else ":", color=angles.get(ah),
                                label=f"a/h = {ah:g} (1 = {ref:.3f} sigma_G)" if load == "exact"
                                else f"a/h = {ah:g}, load as filled (old)")
                angles.setdefault(ah, line.get_color())
    a2.set_xlabel("specimen turned against the grid (deg)")
    a2.set_title("Crack turned against the grid axes (alpha = 'griffith')")
    for a in (a1, a2):
        a.axhline(1.0, color="k", lw=0.8)
        a.axhspan(0.95, 1.05, color="g", alpha=0.08, label="+-5 % (issue 15's target)")
        a.legend(fontsize=7)
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dirs", nargs="+", help="run directories (with summary.json) or folders above them")
    ap.add_argument("--outdir", default=os.path.join(os.path.dirname(__file__), "..", "doc", "img"))
    ap.add_argument("--ramps", nargs="+", default=["80:2", "60:1.5"], metavar="TRANSITS:RATIOMAX",
                    help="the loadings (rampTransits:ratioMax) drawn; runs with another are left out "
                         "(default: the doc's tables, 80:2, and --quick's 60:1.5)")
    args = ap.parse_args(argv)
    ramps = {tuple(float(v) for v in r.split(":")) for r in args.ramps}
    runs = load(args.dirs, ramps)
    if not runs:
        ap.error("no griffith_initiation summary.json with an initiation found")
    os.makedirs(args.outdir, exist_ok=True)
    convergence(runs, os.path.join(args.outdir, "griffith_convergence.png"))
    gridBias(runs, os.path.join(args.outdir, "griffith_grid_bias.png"))
    print(f"{len(runs)} runs -> {args.outdir}/griffith_convergence.png, griffith_grid_bias.png")


if __name__ == "__main__":
    main()
