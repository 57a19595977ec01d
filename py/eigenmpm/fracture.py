"""Eigenerosion fracture engine (paper Section 3.3.2)."""
import math
import warnings

import numpy as np
from yade import O, PyRunner

from . import _eigenmpm
from .engines import _register, findEngine
from .params import Param, apply, declare, vec3


def kappaRange(h, dim):
    """Appendix A (Eq A3): the sensible range of kappa for cell size h, as (low, high)."""
    f = math.sqrt(2.0) if dim == 2 else 6.0 ** (1.0 / 3.0)
    return 0.5 * f * h, f * h


@declare
class EigenErosion(PyRunner):
    """Crack growth by eigenerosion for an MpmEngine. After the stress update of each step, a
    point erodes when G_p = alpha kappa (sum m_q H_q)/(sum m_q) over the intact points within
    kappa (Eq 23) reaches Gc (Eq 24); H = max psi+ over time (Eq 22). All points qualifying in
    a step erode together; an eroded point keeps only its compressive stress sigma-. No
    neighbour search runs while alpha kappa max H < Gc.

    The work happens inside the solver's step; this engine, placed in O.engines, attaches it
    and records the crack's diagnostics every iterPeriod: dissipated energy (Eq 33), eroded
    count, crack tips and tip speed (see :meth:`tips`).

    Example::

        mpm = em.MpmEngine(h=0.25e-3, label='plate')
        crack = em.EigenErosion(engine=mpm, Gc=135, alpha=2.0, kappaOverH=1.1)
        O.engines = [mpm, crack, em.PlotRecorder(iterPeriod=100)]
    """

    params = (
        Param("engine", None, "", "the MpmEngine (object or label; default: the only one)"),
        Param("Gc", None, "J/m2", "critical energy release rate; Gc > 0"),
        Param("alpha", 1.5, "", "normalising constant of Eq 23 (paper: 1 to 2); alpha > 0"),
        Param("kappa", None, "m", "neighbourhood radius; kappa > 0 (give kappa or kappaOverH)"),
        Param("kappaOverH", None, "", "neighbourhood radius as a multiple of the cell size h"),
        Param("origin", None, "m", "crack origin for tip tracking (e.g. the pre-crack tip); "
                                   "default: the first eroded point"),
        Param("tipWindow", None, "s", "erosions within this time before a record form the active "
                                      "tips; default 20 O.dt"),
        Param("iterPeriod", 100, "iterations", "period of the diagnostics record"),
    )

    def __init__(self, label="erosion", **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "EigenErosion")
        if self.Gc is None:
            raise TypeError("EigenErosion: parameter Gc (J/m2) is required")
        if (self.kappa is None) == (self.kappaOverH is None):
            raise TypeError("EigenErosion: give exactly one of kappa (m) or kappaOverH")
        for name in ("Gc", "alpha", "kappa", "kappaOverH"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"EigenErosion: {name} = {v!r} is invalid; allowed: {name} > 0")
        self.label, self.initRun = label, True
        self.iterPeriod = int(self.iterPeriod)
        self.command = _register(self)
        self.core = None
        self.history = []  # (time, dissipated J, eroded count, front distance m, tip positions)
        self._origin = None if self.origin is None else np.array(vec3(self.origin, "origin"))
        if self.engine is not None and not isinstance(self.engine, str):
            self.attach(self.engine)

    def attach(self, mpm=None):
        """Attaches the erosion stage to the solver of `mpm` (done automatically)."""
        mpm = findEngine(mpm if mpm is not None else self.engine)
        if self.core is not None and mpm.solver.erosion is self.core:
            return mpm
        kappa = self.kappa if self.kappa is not None else self.kappaOverH * mpm.h
        low, high = kappaRange(mpm.h, mpm.dim)
        spacing = mpm.h / mpm.ppc
        if kappa < spacing:
            warnings.warn(f"EigenErosion: kappa = {kappa:.4g} m is below the point spacing "
                          f"{spacing:.4g} m, so the neighbourhood holds only the point itself "
                          f"(single-point erosion); Appendix A suggests {low:.4g} to {high:.4g} m",
                          stacklevel=2)
        elif not low <= kappa <= high:
            warnings.warn(f"EigenErosion: kappa = {kappa:.4g} m is outside the range "
                          f"{low:.4g} to {high:.4g} m of Appendix A (Eq A3) for h = {mpm.h:.4g} m",
                          stacklevel=2)
        cls = _eigenmpm.Erosion2 if mpm.dim == 2 else _eigenmpm.Erosion3
        self.core = cls(Gc=float(self.Gc), alpha=float(self.alpha), kappa=float(kappa))
        mpm.solver.setErosion(self.core)
        mpm.physics[self.label] = self
        self._mpm = mpm
        return mpm

    def _action(self):
        mpm = self.attach()
        self.record(mpm)

    # --- diagnostics ----------------------------------------------------------------------
    def dissipatedEnergy(self):
        """Gc / (2 kappa) times the eroded volume (Eq 33), J."""
        return self.core.dissipatedEnergy if self.core else 0.0

    def erodedCount(self):
        return self.core.erodedCount if self.core else 0

    def tips(self, mpm=None):
        """Crack tips now. The points eroded within the last tipWindow of time are grouped into
        clusters (points closer than 2 kappa are linked); the tip of a cluster is its point
        farthest from the crack origin. A straight crack has one active cluster; after branching
        each branch has its own. Returns a list of positions (numpy arrays)."""
        mpm = mpm or self._mpm
        events = self.core.events() if self.core else []
        if not events:
            return []
        window = self.tipWindow if self.tipWindow else 20 * O.dt
        now = mpm.solver.time
        recent = [p for p, _, t in events if t >= now - window]
        if not recent:
            return []
        x = mpm.solver.positions()
        origin = self._originPoint(x, events)
        pts = x[recent]
        link = 2.0 * self.core.kappa
        label = -np.ones(len(pts), dtype=int)
        clusters = 0
        for i in range(len(pts)):
            if label[i] >= 0:
                continue
            label[i] = clusters
            stack = [i]
            while stack:
                j = stack.pop()
                near = np.nonzero((label < 0) & (np.sum((pts - pts[j]) ** 2, axis=1) <= link * link))[0]
                label[near] = clusters
                stack.extend(near.tolist())
            clusters += 1
        tips = []
        for c in range(clusters):
            members = pts[label == c]
            tips.append(members[np.argmax(np.sum((members - origin) ** 2, axis=1))])
        return tips

    def _originPoint(self, x, events):
        if self._origin is None:
            self._origin = x[events[0][0]].copy()
        return self._origin

    def frontDistance(self, mpm=None):
        """Largest distance from the crack origin to an eroded point, m (0 before cracking)."""
        mpm = mpm or self._mpm
        events = self.core.events() if self.core else []
        if not events:
            return 0.0
        x = mpm.solver.positions()
        ids = [p for p, _, _ in events]
        return float(np.sqrt(np.max(np.sum((x[ids] - self._originPoint(x, events)) ** 2, axis=1))))

    def record(self, mpm=None):
        mpm = mpm or self._mpm
        self.history.append((mpm.solver.time, self.dissipatedEnergy(), self.erodedCount(),
                             self.frontDistance(mpm), [t.tolist() for t in self.tips(mpm)]))

    def tipSpeed(self):
        """Crack tip speed over the recorded history: (times, speeds), the speed being the rate of
        change of the front distance between successive records (m/s)."""
        if len(self.history) < 2:
            return np.array([]), np.array([])
        t = np.array([h[0] for h in self.history])
        d = np.array([h[3] for h in self.history])
        return 0.5 * (t[1:] + t[:-1]), np.diff(d) / np.diff(t)

    def plotData(self):
        return {f"{self.label}_Ef": self.dissipatedEnergy(), f"{self.label}_eroded": self.erodedCount(),
                f"{self.label}_front": self.history[-1][3] if self.history else 0.0}
