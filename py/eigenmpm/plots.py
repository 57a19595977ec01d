"""Figures for reports: damage map, energies, crack tip speed (matplotlib, Agg backend). Each
function writes its figure and closes it, also when drawing fails: a script that draws many
figures leaves none open."""
import contextlib
import os

import numpy as np

from . import parallel


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


@contextlib.contextmanager
def _figure(path, figsize):
    """The axes of a new figure, saved to path when the block ends and closed in any case. Under
    mpiexec only rank 0 saves it (every rank draws: the data may need every rank)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=figsize)
    try:
        yield ax
        if not parallel.isRoot():
            return
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        fig.tight_layout()
        fig.savefig(path, dpi=130)
    finally:
        plt.close(fig)


def _damageRaster(x, intact, lo, hi, n, dx):
    """damageMap's raster of `n` points (every rank's; x, intact: this rank's, projected) with
    lattice spacing dx: about one pixel per point spacing, and never below dx (in 3D several
    layers project on one pixel), 0 empty, 1 intact, 2 eroded (eroded wins in a pixel), rows along
    the second axis. The pixel counts are summed over the ranks. Every rank must call it."""
    span = np.maximum(hi - lo, 1e-30)
    spacing = max(np.sqrt(span[0] * span[1] / n), dx)
    nx, ny = (int(min(2000, max(10, v / spacing))) for v in span[:2])
    rng = [[lo[0], hi[0]], [lo[1], hi[1]]]
    full = parallel.total(np.histogram2d(x[:, 0], x[:, 1], bins=(nx, ny), range=rng)[0])
    broken = parallel.total(np.histogram2d(x[~intact, 0], x[~intact, 1], bins=(nx, ny), range=rng)[0])
    return np.where(broken > 0, 2, np.where(full > 0, 1, 0)).T


def damageRaster(mpm, plane="xy", scale=1e3):
    """The raster damageMap draws for many points (see _damageRaster), of every rank's points."""
    axes = ["xyz".index(c) for c in plane]
    x = mpm.solver.positions()[:, axes] * scale
    lo, hi = parallel.bounds(x)
    return _damageRaster(x, mpm.solver.damage() > 0, lo, hi, mpm.numPoints(), mpm.h / mpm.ppc * scale)


def damageMap(mpm, path, title=None, scale=1e3, unit="mm", plane="xy"):
    """The points of a 2D MpmEngine at their current positions, intact blue and eroded red (like
    the paper's Figures 8, 16, 20, 24), with the pre-existing cracks as black lines. In 3D the
    points (and crack polygons) are projected on `plane` ('xy', 'xz' or 'yz')."""
    axes = ["xyz".index(c) for c in plane]
    n = mpm.numPoints()
    few = n <= 8000  # markers; beyond, tiny markers leave moire gaps: a raster
    x = mpm.solver.positions()[:, axes] * scale  # this rank's points (few: every rank's)
    intact = mpm.solver.damage() > 0
    if few:
        x = parallel.gather(mpm, x)
        intact = parallel.gather(mpm, intact)
    # Under mpiexec a raster is summed over the ranks: no rank gathers the points.
    lo, hi = parallel.bounds(x)
    eroded = int((~intact).sum())
    if not few:
        eroded = int(parallel.total(eroded))
    span = np.maximum(hi - lo, 1e-30)
    width = 7.0
    if not few:
        img = _damageRaster(x, intact, lo, hi, n, mpm.h / mpm.ppc * scale)
    with _figure(path, (width, max(2.0, min(12.0, width * span[1] / span[0])))) as ax:
        if few:
            size = max(0.3, 2.0e4 / max(len(x), 1))
            ax.scatter(x[intact, 0], x[intact, 1], s=size, c="#1f4e9c", marker="s", linewidths=0, label="intact")
            ax.scatter(x[~intact, 0], x[~intact, 1], s=3 * size, c="#d62728", marker="s", linewidths=0,
                       label="eroded")
        else:
            from matplotlib.colors import ListedColormap
            ax.imshow(img, origin="lower", extent=(lo[0], hi[0], lo[1], hi[1]), interpolation="nearest",
                      cmap=ListedColormap(["white", "#1f4e9c", "#d62728"]), vmin=0, vmax=2)
        for c in range(mpm.solver.numCracks):
            v = np.array([list(p) for p in mpm.solver.crackVertices(c)])[:, axes] * scale
            ax.plot(np.append(v[:, 0], v[0, 0]) if mpm.dim == 3 else v[:, 0],
                    np.append(v[:, 1], v[0, 1]) if mpm.dim == 3 else v[:, 1], "k-", lw=1.2,
                    label="pre-existing crack" if c == 0 else None)
        ax.set_aspect("equal")
        ax.set_xlabel(f"{plane[0]} ({unit})")
        ax.set_ylabel(f"{plane[1]} ({unit})")
        ax.set_title(title or f"damage at t = {mpm.solver.time * 1e6:.1f} us ({eroded} points eroded)")
    return path


def series(path, t, curves, xlabel="time (us)", ylabel="", title="", tscale=1e6, hlines=()):
    """Line plot of several curves {label: values} against t (scaled by tscale); hlines are
    (value, label) reference lines."""
    with _figure(path, (7, 4)) as ax:
        for label, y in curves.items():
            ax.plot(np.asarray(t) * tscale, y, label=label)
        for value, label in hlines:
            ax.axhline(value, ls="--", lw=0.8, color="k")
            ax.annotate(label, (ax.get_xlim()[0], value), va="bottom", fontsize=8)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        if title:
            ax.set_title(title)
        if curves:
            ax.legend()
    return path
