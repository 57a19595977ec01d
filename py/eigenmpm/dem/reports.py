"""Outputs of a DEM/MPM comparison: the scalars of summary.json, the load-displacement
curves (CSV and plot) and the crack patterns of both models side by side."""
import numpy as np

from ..params import Param, takes


def _isPair(p):
    from .pair import DemMpmPair
    return isinstance(p, DemMpmPair)


# The outputs' parameters, shared by DemMpmPair.summary / curve and runToDisplacement.
PAIR = Param("pair", None, "", "the DemMpmPair", kind="object", accepts="a DemMpmPair", check=_isPair, required=True)
OUT = Param("out", None, "", "directory of summary.json, the curves and the crack patterns", kind="str",
            accepts="non-empty string", check=lambda d: d != "", required=True)
LOAD = Param("load", None, "", "the loading condition (its label), whose reaction component gives the load",
             kind="str", required=True)
COMPONENT = Param("component", 1, "", "the component of the condition's vectors: 0 (x), 1 (y) or 2 (z)",
                  bounds="[0, 2]")
SMOOTH = Param("smooth", 0.01, "", "window of the moving average of the reaction (the peak load), as a "
                                   "fraction of the record", bounds="[0, 1]")
TITLE = Param("title", "", "", "title of the plots")
EXTRA = Param("extra", None, "", "entries added to summary.json (e.g. the script's parameters)", kind="object",
              accepts="a dict", check=lambda e: isinstance(e, dict))
SIGN = Param("sign", 1.0, "", "factor of the written and plotted load and displacement (-1: pushing down "
                              "counts as positive)", choices=(1.0, -1.0))
BAND = Param("band", None, "", "an experimental band drawn under the curves: (label, displacements mm, lower "
                               "loads kN, upper loads kN)", kind="object", accepts="a 4-tuple",
             check=lambda b: isinstance(b, (tuple, list)) and len(b) == 4)


def summary(pair, load, component, smooth):
    """Scalars for summary.json of a DemMpmPair: both models' peak load (N, the given
    condition's reaction component), particles, dissipated energies (J), broken bonds and eroded points, wall times,
    time steps, the calibration and the thickness scale of the DEM. Peak loads are those of
    the reaction averaged over a window of `smooth` x the record (both models carry the
    oscillations of explicit dynamics); *_raw the largest recorded."""
    from yade import O
    out = dict(dem_model=pair.model, dem_spheres=len(pair.dem.ids), dem_layers=pair.layers,
               dem_radius_m=pair.dem.radius, dem_force_scale=pair.dem.scale,
               mpm_points=int(pair.mpm.solver.numPoints), mpm_h_m=pair.mpm.h, dt_s=O.dt,
               steps=O.iter)
    crit = pair.criticalTimeSteps()
    out.update(dem_critical_dt_s=crit[0], mpm_critical_dt_s=crit[1])
    _, nb, nbonds, ed = pair.dem.bondState()
    out.update(dem_bonds=nbonds, dem_broken_bonds=nb, dem_dissipated_energy_J=ed)
    es = pair.erosion.summary()
    out.update(mpm_eroded=es["eroded_count"], mpm_dissipated_energy_J=es["dissipated_energy_J"])
    out.update(pair.wallTimes())
    if load is not None:
        t, um, Fm, ud, Fd = pair.curve(load, component)
        if len(t):
            for name, u, F in (("mpm", um, Fm), ("dem", ud, Fd)):
                Fs = smoothed(np.abs(F), smooth)
                i = int(np.argmax(Fs))
                out.update({f"{name}_peak_load_N": float(Fs[i]), f"{name}_displacement_at_peak_m": float(abs(u[i])),
                            f"{name}_peak_load_raw_N": float(np.max(np.abs(F))),
                            f"{name}_end_displacement_m": float(u[-1])})
    out["calibration"] = pair.calibration
    return out


def smoothed(F, fraction=SMOOTH.default):
    """Moving average over a window of `fraction` of the samples (at least 1)."""
    F = np.asarray(F, float)
    k = max(1, int(round(fraction * len(F))))
    return np.convolve(F, np.ones(k) / k, mode="same") if len(F) else F


@takes(PAIR, OUT, LOAD, COMPONENT, TITLE, EXTRA,
       Param("wall", None, "s", "wall time of the run, for wall_time_s and particle_steps_per_s", kind="float",
             bounds="[0, inf)"),
       Param("cpu", None, "s", "CPU time of the script, for cpu_time_s", kind="float", bounds="[0, inf)"),
       SIGN, BAND)
def report(pair, out, load, component, title, extra, wall, cpu, sign, band):
    """Writes the outputs of a DemMpmPair: its summary, load-displacement curves and crack
    patterns. That is DIR/summary.json (:func:`summary` plus particles, steps, wall_time_s,
    particle_steps_per_s overall and per model, `extra`), DIR/load_displacement.csv and .png
    (both models' reaction of condition `load` against their load-point displacement, in kN and
    mm, times `sign`) and DIR/crack_patterns.png (MPM eroded points, DEM broken bonds, side by
    side). Returns the summary."""
    import json
    import os
    from yade import O
    os.makedirs(out, exist_ok=True)
    s = pair.summary(load, component)
    steps = O.iter
    s.update(particles=s["mpm_points"] + s["dem_spheres"], steps=steps)
    if wall is not None:
        s["wall_time_s"] = wall
        s["particle_steps_per_s"] = s["particles"] * steps / wall if wall > 0 else None
    if cpu is not None:
        s["cpu_time_s"] = cpu
    for name, n in (("mpm", s["mpm_points"]), ("dem", s["dem_spheres"])):
        w = s[f"{name}_wall_s"]
        s[f"{name}_particle_steps_per_s"] = n * steps / w if w > 0 else None
    s.update(extra or {})
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(s, f, indent=2, default=float)
    t, um, Fm, ud, Fd = pair.curve(load, component)
    with open(os.path.join(out, "load_displacement.csv"), "w") as f:
        f.write("t_s,mpm_displacement_mm,mpm_load_kN,dem_displacement_mm,dem_load_kN\n")
        for row in zip(t, um * 1e3 * sign, Fm * 1e-3 * sign, ud * 1e3 * sign, Fd * 1e-3 * sign):
            f.write(",".join(f"{v:.6g}" for v in row) + "\n")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if band is not None:
        ax.fill_between(band[1], band[2], band[3], color="orange", alpha=0.4, label=band[0])
    for name, u, F, c in (("EigenMPM", um, Fm, "b"), (f"DEM ({pair.model.upper()})", ud, Fd, "r")):
        ax.plot(sign * u * 1e3, sign * F * 1e-3, color=c, lw=0.4, alpha=0.35)
        ax.plot(sign * u * 1e3, sign * smoothed(F) * 1e-3, color=c, lw=1.4, label=f"{name} (smoothed)")
    ax.set_xlabel("load-point displacement (mm)")
    ax.set_ylabel(f"load (kN, thickness {pair.constants['thickness'] * 1e3:g} mm)")
    ax.set_title(title or "load-displacement")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "load_displacement.png"), dpi=110)
    plt.close(fig)
    crackPatterns(pair, os.path.join(out, "crack_patterns.png"), title)
    return s


def crackPatterns(pair, path, title=""):
    """The MPM points (eroded red) and the DEM spheres projected on x-y (bonds broken red, at
    their midpoints), both in specimen coordinates, side by side."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    x = pair.mpm.solver.positions() * 1e3
    er = pair.mpm.solver.damage() <= 0
    c, _ = pair.dem.centres()
    c = (c - pair.dem.offset) * 1e3
    b, nb, nbonds, _ = pair.dem.bondState()
    b = (b - pair.dem.offset) * 1e3 if len(b) else b
    lo = np.minimum(x.min(axis=0), c.min(axis=0))
    hi = np.maximum(x.max(axis=0), c.max(axis=0))
    span = hi - lo
    fig, axes = plt.subplots(1, 2, figsize=(11, max(2.5, min(6.0, 5.5 * span[1] / span[0] + 0.8))))
    size = max(0.2, 4e3 / max(len(x), 1))
    axes[0].scatter(x[~er, 0], x[~er, 1], s=size, c="0.75", marker="s", linewidths=0)
    axes[0].scatter(x[er, 0], x[er, 1], s=max(6.0, 3 * size), c="#d62728", marker="s", linewidths=0)
    for k in range(pair.mpm.solver.numCracks):
        v = np.array([list(p) for p in pair.mpm.solver.crackVertices(k)]) * 1e3
        axes[0].plot(v[:, 0], v[:, 1], "k-", lw=1)
    axes[0].set_title(f"EigenMPM: {int(er.sum())} of {len(x)} points eroded", fontsize=9)
    size = max(0.2, 4e3 / max(len(c), 1))
    axes[1].scatter(c[:, 0], c[:, 1], s=size, c="0.75", linewidths=0)
    if len(b):
        axes[1].scatter(b[:, 0], b[:, 1], s=max(6.0, 3 * size), c="#d62728", linewidths=0)
    axes[1].set_title(f"DEM ({pair.model.upper()}): {nb} of {nbonds} bonds broken", fontsize=9)
    for ax in axes:
        ax.set_xlim(lo[0] - 5, hi[0] + 5)
        ax.set_ylim(lo[1] - 5, hi[1] + 5)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
    axes[0].set_ylabel("y (mm)")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
