"""Specimens from ``yade.pack`` predicates: lattice filling and selections."""
import math

import numpy as np


def _aabb(predicate):
    lo, hi = predicate.aabb()
    return np.array([lo[0], lo[1], lo[2]], float), np.array([hi[0], hi[1], hi[2]], float)


def zPlane(predicate):
    """The plane z in which a 2D scene evaluates a predicate: the middle of its z-range (0 where
    that is unbounded), so that a box given with z from 0 to 0 or from -1 to 1 both count."""
    lo, hi = _aabb(predicate)
    return 0.5 * (lo[2] + hi[2]) if np.isfinite(lo[2]) and np.isfinite(hi[2]) else 0.0


def latticePoints(predicate, h, ppc, dim, share=None):
    """Points of the lattice x = (i + 1/2) h/ppc (aligned with the grid nodes at multiples of h)
    inside the predicate's bounding box for which ``predicate(x, 0)`` holds, x fastest. With
    share = (k, m), only those among the k-th of m nearly equal contiguous parts of the lattice
    (each part is built and tested alone: a run distributed at set-up)."""
    if not hasattr(predicate, "aabb"):
        raise TypeError(f"EigenMPM: {predicate!r} is not a yade.pack predicate (it has no aabb())")
    lo, hi = _aabb(predicate)
    if not (np.all(np.isfinite(lo[:dim])) and np.all(np.isfinite(hi[:dim]))):
        raise ValueError(f"EigenMPM: the predicate's bounding box {lo}..{hi} is unbounded; "
                         "intersect it with a box")
    dx = h / ppc
    axes = []
    for d in range(dim):
        first = math.ceil(lo[d] / dx - 0.5 - 1e-9)
        last = math.floor(hi[d] / dx - 0.5 + 1e-9)
        axes.append((np.arange(first, last + 1) + 0.5) * dx)
    if dim == 2:
        axes.append(np.array([zPlane(predicate)]))
    shape = tuple(len(a) for a in axes)
    total = int(np.prod(shape))
    k, m = share if share is not None else (0, 1)
    index = np.unravel_index(np.arange(total * k // m, total * (k + 1) // m), shape, order="F")
    pts = np.stack([a[i] for a, i in zip(axes, index)], axis=1)
    keep = np.fromiter((bool(predicate(tuple(p), 0.0)) for p in pts), dtype=bool, count=len(pts))
    out = pts[keep]
    if dim == 2:
        out[:, 2] = 0.0
    return out


def nodeBox(solver, h, predicate, pad, dim):
    """The nodes of the solver's grid (spacing h) that can lie in a yade.pack predicate's bounding
    box (grown by pad and a node each way): their indices, ascending, and their positions (as
    Solver::nodePosition gives them), or None for a predicate without bounds. nodesIn tests only
    these, not every node of the grid (a large grid's positions need not exist at once)."""
    if not hasattr(predicate, "aabb"):
        return None
    lo, hi = _aabb(predicate)
    shape, origin = solver.gridShape(), solver.gridOrigin()
    tol = abs(pad) + 1e-12
    axes, ranges = [], []
    for d in range(dim):
        first, last = 0, shape[d] - 1
        if np.isfinite(lo[d]):
            first = max(first, int(math.floor((lo[d] - tol - origin[d]) / h)) - 1)
        if np.isfinite(hi[d]):
            last = min(last, int(math.ceil((hi[d] + tol - origin[d]) / h)) + 1)
        if last < first:
            return np.zeros(0, dtype=int), np.zeros((0, 3))
        ranges.append(np.arange(first, last + 1))
        axes.append(origin[d] + ranges[-1] * h)  # (origin + i h, as the core computes it)
    grids = np.meshgrid(*axes, indexing="ij")
    x = np.zeros((grids[0].size, 3))
    for d in range(dim):
        x[:, d] = grids[d].ravel(order="F")
    stride = np.cumprod([1] + list(shape[:dim - 1]))
    idx = np.meshgrid(*ranges, indexing="ij")
    index = sum(stride[d] * idx[d].ravel(order="F") for d in range(dim))
    return index, x


def select(positions, predicate, pad, dim):
    """Indices of the rows of `positions` (n x 3) inside the predicate (yade.pack predicate
    evaluated as predicate(x, pad), or a callable of the point alone)."""
    pos = np.asarray(positions)
    if hasattr(predicate, "aabb"):
        lo, hi = _aabb(predicate)
        if dim == 2:
            pos = pos.copy()
            pos[:, 2] = zPlane(predicate)
        tol = abs(pad) + 1e-12
        near = np.all((pos[:, :dim] >= lo[:dim] - tol) & (pos[:, :dim] <= hi[:dim] + tol), axis=1)
        cand = np.nonzero(near)[0]
        return np.array([i for i in cand if predicate(tuple(pos[i]), pad)], dtype=int)
    return np.array([i for i in range(len(pos)) if predicate(tuple(pos[i]))], dtype=int)
