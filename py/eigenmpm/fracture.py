"""Eigenerosion fracture engine (paper Section 3.3.2)."""
import math
import warnings

import numpy as np
from yade import O, PyRunner

from . import _eigenmpm, parallel
from .engines import ENGINE, _register, _Released, findEngine, mpmEngines
from .params import Param, apply, declare


def linked(x, seed, radius):
    """Boolean mask of the rows of x (n x dim) linked to row `seed` through chains of points no
    farther apart than `radius`: the connected component of `seed` in the graph of the pairs
    within `radius` (scipy's k-d tree finds the pairs, scipy.sparse.csgraph the components)."""
    from scipy.spatial import cKDTree
    pairs = cKDTree(x).query_pairs(radius, output_type="ndarray")
    label = _components(len(x), pairs)
    return label == label[seed]


def _components(n, pairs):
    """Component label of each of n nodes joined by the rows of `pairs` (k x 2 node numbers)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def _planarOrigin(origin, dim, label):
    if dim == 2 and origin[2] != 0.0:
        raise ValueError(f"EigenMPM: origin = {tuple(origin)!r} is invalid in 2D: the z component does not apply; "
                         f"allowed: (x, y) or (x, y, 0) (EigenErosion {label!r})")


def sameStage(a, b):
    """Whether two erosion stages are the same C++ object. A stage restored from a saved state
    (eigenmpm.state) gets a new Python wrapper at each access, so `is` cannot tell."""
    if a is None or b is None or isinstance(a, _Released) or isinstance(b, _Released):
        return a is b
    return a.address == b.address


def kappaRange(h, dim):
    """Appendix A (Eq A3): the sensible range of kappa for cell size h, as (low, high)."""
    f = math.sqrt(2.0) if dim == 2 else 6.0 ** (1.0 / 3.0)
    return 0.5 * f * h, f * h


def griffithAlpha(mpm, label="EigenErosion"):
    """alpha = 1 / initiationRatio (mode I, neighbourhood centred on the tip) for the materials of
    MpmEngine `mpm`: Eq 24 then starts a sharp crack at G = Gc (doc/fracture.md, "Initiation at
    Griffith's energy"). Refused when the engine has no material yet or materials whose values
    differ (one alpha per erosion stage)."""
    mats = [m for m, _ in mpm._materials.values()]
    if not mats:
        raise ValueError(f"EigenMPM: alpha = 'griffith' needs the material: MpmEngine {mpm.label!r} has no points "
                         f"yet; add the points before EigenErosion {label!r} first acts")
    values = {}
    for m in mats:
        r = _eigenmpm.initiationRatio(mpm.dim, m.E, m.nu, m.planeStress, m.split)
        values[round(1.0 / r, 12)] = m
    if len(values) > 1:
        listed = ", ".join(f"{a:.6g} ({m!r})" for a, m in values.items())
        raise ValueError(f"EigenMPM: alpha = 'griffith' is one value per erosion stage, but the materials of "
                         f"MpmEngine {mpm.label!r} give {listed}; allowed: materials with the same nu, plane "
                         f"condition and split, or a numeric alpha")
    return next(iter(values))


@declare
class EigenErosion(PyRunner):
    """Crack growth by eigenerosion for an MpmEngine. After the stress update of each step, a
    point erodes when G_p = alpha kappa (sum m_q H_q)/(sum m_q) over the intact points within
    kappa (Eq 23) reaches Gc (Eq 24); H = max psi+ over time (Eq 22). All points qualifying in
    a step erode together; an eroded point keeps only its compressive stress sigma-. No
    neighbour search runs while alpha kappa max H < Gc.

    The work happens inside the solver's step, and only while this engine is in O.engines (and
    not dead): the MpmEngine attaches the stage at each step it finds the engine there, and
    detaches it otherwise. The engine records the crack's diagnostics every iterPeriod:
    dissipated energy (Eq 33), eroded count, crack tips and tip speed (see :meth:`tips`).

    Example::

        mpm = em.MpmEngine(h=0.25e-3, label='plate')
        crack = em.EigenErosion(engine=mpm, Gc=135, alpha=2.0, kappaOverH=1.1)
        O.engines = [mpm, crack, em.PlotRecorder(iterPeriod=100)]
    """

    params = (
        Param("label", "erosion", "", "YADE label of the engine; it prefixes the keys of plotData()"),
        Param(ENGINE.name, ENGINE.default, ENGINE.unit, ENGINE.doc, kind=ENGINE.kind, accepts=ENGINE.accepts,
              check=ENGINE.checker, fixed=True),
        Param("Gc", None, "J/m2", "critical energy release rate", kind="float", bounds="(0, inf)",
              required=True, fixed=True),
        Param("alpha", 1.5, "", "normalising constant of Eq 23 (paper: 1 to 2), or 'griffith': the "
                                "constant that starts a sharp crack at G = Gc for the engine's material "
                                "(1 / initiationRatio, doc/fracture.md)", bounds="(0, inf)",
              keywords=("griffith",), fixed=True),
        Param("kappa", None, "m", "neighbourhood radius (give kappa or kappaOverH)", kind="float",
              bounds="(0, inf)", fixed=True),
        Param("kappaOverH", None, "", "neighbourhood radius as a multiple of the cell size h", kind="float",
              bounds="(0, inf)", fixed=True),
        Param("origin", None, "m", "crack origin for tip tracking (e.g. the pre-crack tip); "
                                   "default: the first eroded point", kind="vector", fixed=True),
        Param("throughAxis", None, "", "3D only: the axis along which crack fronts run through a plate's "
                                       "thickness; tips, the front distance and the tip speed are then "
                                       "measured in the plane normal to it (the eroded points projected on it), "
                                       "so that one front through the thickness is one tip; default: distances "
                                       "in 3D", kind="str", choices=("x", "y", "z"), fixed=True),
        Param("tipWindow", None, "s", "erosions within this time before a record can be tips, and "
                                      "the window of the tip speed; default 50 O.dt", kind="float",
              bounds="(0, inf)"),
        Param("iterPeriod", 100, "iterations", "period of the diagnostics record", bounds="[1, inf)"),
    )

    def __init__(self, **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "EigenErosion")
        if (self.kappa is None) == (self.kappaOverH is None):
            raise TypeError("EigenMPM: give exactly one of kappa (m) or kappaOverH (EigenErosion)")
        self.initRun = True
        self.command = _register(self)
        self.core = None
        self.history = []  # (time, dissipated J, eroded count, front distance m, tip positions)
        self._origin = None if self.origin is None else np.array(self.origin)
        self._mpm = None
        if self.engine is not None and not isinstance(self.engine, str):
            self._prepare(self.engine)  # checks kappa against the engine now; acts from O.engines

    def attach(self, mpm=None):
        """Attaches the erosion stage to the solver of `mpm` (the MpmEngine does it at each step
        while this engine is in O.engines, and detaches it otherwise). Returns the MpmEngine."""
        mpm = findEngine(mpm if mpm is not None else self.engine)
        self._prepare(mpm)
        if self.core is None:  # alpha = 'griffith' before any material: refused with the reason
            griffithAlpha(mpm, self.label)
        attached = mpm.solver.erosion
        if sameStage(attached, self.core):
            return mpm
        if attached is not None:
            other = [e.label for e in mpm.physics.values() if e is not self]
            raise ValueError(f"EigenMPM: EigenErosion {self.label!r} cannot act on MpmEngine {mpm.label!r}: "
                             f"EigenErosion {', '.join(map(repr, other)) or '(detached)'} already does; "
                             "allowed: one EigenErosion per MpmEngine in O.engines")
        mpm.solver.setErosion(self.core)
        mpm.physics[self.label] = self
        return mpm

    def detach(self, mpm):
        """Removes the erosion stage from the solver of `mpm` (this engine left O.engines)."""
        if sameStage(mpm.solver.erosion, self.core):
            mpm.solver.setErosion(None)
        for label, e in list(mpm.physics.items()):
            if e is self:
                del mpm.physics[label]

    def _release(self):
        """Frees the erosion state (O.reset(), see engines._wrapReset)."""
        self.core = _Released(f"the erosion state of EigenErosion {self.label!r}")
        self.history, self._mpm, self._released = [], None, True

    def _prepare(self, mpm):
        """The erosion state for `mpm`, made once: kappa from kappaOverH, checked against the
        point spacing and the range of Appendix A."""
        if getattr(self, "_released", False):
            self.core._fail()
        if self.core is not None:
            if self._mpm is not mpm:
                raise ValueError(f"EigenMPM: EigenErosion {self.label!r} was built for MpmEngine "
                                 f"{self._mpm.label!r}, not {mpm.label!r}; build one per engine")
            return
        if self.origin is not None:
            _planarOrigin(self.origin, mpm.dim, self.label)
        if self.throughAxis is not None and mpm.dim == 2:
            raise ValueError(f"EigenMPM: throughAxis = {self.throughAxis!r} is invalid for the 2D MpmEngine "
                             f"{mpm.label!r}: a 2D crack's distances are already in its plane; allowed: None "
                             f"in 2D, 'x', 'y' or 'z' in 3D (EigenErosion {self.label!r})")
        kappa = self.kappa if self.kappa is not None else self.kappaOverH * mpm.h
        low, high = kappaRange(mpm.h, mpm.dim)
        spacing = mpm.h / mpm.ppc
        if kappa < spacing:
            warnings.warn(f"EigenErosion: kappa = {kappa:.4g} m is below the point spacing "
                          f"{spacing:.4g} m, so the neighbourhood holds only the point itself "
                          f"(single-point erosion); Appendix A suggests {low:.4g} to {high:.4g} m",
                          stacklevel=3)
        elif not low <= kappa <= high:
            warnings.warn(f"EigenErosion: kappa = {kappa:.4g} m is outside the range "
                          f"{low:.4g} to {high:.4g} m of Appendix A (Eq A3) for h = {mpm.h:.4g} m",
                          stacklevel=3)
        if isinstance(self.alpha, str) and not mpm._materials:
            return  # 'griffith' needs the material: made when the engine first acts (attach)
        alpha = griffithAlpha(mpm, self.label) if isinstance(self.alpha, str) else float(self.alpha)
        cls = _eigenmpm.Erosion2 if mpm.dim == 2 else _eigenmpm.Erosion3
        self.core = cls(Gc=self.Gc, alpha=alpha, kappa=kappa)
        self._mpm = mpm

    def _action(self):
        mpm = findEngine(self.engine)
        if not any(mpm is e for e in mpmEngines()):  # (O.engines read only after a change)
            raise ValueError(f"EigenMPM: engine = MpmEngine {mpm.label!r} is invalid; allowed: an MpmEngine in "
                             f"O.engines (EigenErosion {self.label!r} acts only on an engine of the scene)")
        # The MpmEngine attaches this stage at its step while this engine is in O.engines and not
        # dead; attach() (which finds the engine and checks the state again) only when it has not
        # yet (this engine before it in O.engines, at the first iteration). A record follows a
        # step, when every Python call runs cold (doc/performance.md, "Session 33").
        if not (self._mpm is mpm and sameStage(mpm.solver.erosion, self.core)):
            mpm = self.attach(mpm)
        self.record(mpm)

    # --- diagnostics ----------------------------------------------------------------------
    def dissipatedEnergy(self):
        """Gc / (2 kappa) times the eroded volume (Eq 33), J."""
        return self.core.dissipatedEnergy if self.core else 0.0

    def erodedCount(self):
        return self.core.erodedCount if self.core else 0

    def tips(self, mpm=None):
        """Crack tips now, as a list of positions (numpy arrays). A tip is a recently eroded point
        (within tipWindow of simulated time) that is a local maximum of the distance from the
        crack origin: no eroded point within R = 6 kappa of it lies farther from the origin.
        Tips closer than R to a farther tip are merged into it. A straight crack has one tip;
        after branching each branch has its own; erosion behind the front (the band widening)
        is never a tip. Only the crack grown from the origin counts (see _mainCrack). With
        throughAxis (a 3D plate), the points are projected on the plane normal to that axis first,
        so that a front through the thickness is one tip (its component along the axis is 0)."""
        mpm = mpm or self._mpm
        return self._tipsOf(mpm, self._crack(mpm))

    def _crack(self, mpm):
        """What the crack diagnostics of one moment share: (the events' times, the eroded points'
        positions (projected with throughAxis), the origin, which of them form the main crack,
        their positions unprojected, the main crack's positions and their squared distances from
        the origin), or None before the first erosion. Under mpiexec only the eroded points'
        positions travel between the ranks (parallel.positionsOf), not every point's, and every
        rank must call it."""
        ids = self.core.eventPoints() if self.core else np.zeros(0, np.int64)
        if not len(ids):
            return None
        raw = parallel.positionsOf(mpm, ids)
        x = self._inPlane(raw)
        origin = self._originPoint(x)
        main, xm, r = self._mainCrackPoints(x, origin)
        return self.core.eventTimes(), x, origin, main, raw, xm, r

    def _tipsOf(self, mpm, crack):
        """tips() from a _crack() state. Whether a recent point has a farther neighbour within R
        is one C++ search over cells of size R (``_eigenmpm.crackFartherWithin``: the squared
        distance against R^2, summed as numpy sums, as in the plain loop it replaces,
        tests/python/test_erosion.py). A recent point with a farther neighbour is no tip; the
        others, few, are merged in order."""
        if crack is None:
            return []
        times, x, origin, main, _, xm, r = crack
        window = self.tipWindow if self.tipWindow else 50 * O.dt
        recent = main & (times >= mpm.solver.time - window)
        if not np.any(recent):
            return []
        R = 6.0 * self.core.kappa
        R2 = R ** 2
        xr = x[recent]
        rr = np.sum((xr - origin) ** 2, axis=1)
        return self._mergedTips(xr, rr, _eigenmpm.crackFartherWithin(xm, r, xr, rr, R, R2), R2)

    @staticmethod
    def _mergedTips(xr, rr, farther, R2):
        """The tips among the recent points xr (squared distances rr from the origin): those
        without a farther neighbour, from the farthest (of two at the same distance, the first
        row first), each merged into a farther tip within squared distance R2 of it."""
        order = np.argsort(-rr, kind="stable")
        tips = []
        for k in order[~farther[order]]:
            p = xr[k]
            if all(np.sum((p - t) ** 2) > R2 for t in tips):
                tips.append(p.copy())
        return tips

    def _inPlane(self, x):
        """x (one row per point) projected on the plane normal to throughAxis (unchanged without)."""
        if self.throughAxis is None:
            return x
        x = np.array(x, dtype=float)
        x[..., "xyz".index(self.throughAxis)] = 0.0
        return x

    def _originPoint(self, x):
        """The crack origin (projected as the points are): given, or where the first eroded point
        (x[0]) was when first asked."""
        if self._origin is None:
            self._origin = x[0].copy()
        return self._inPlane(self._origin)

    def frontDistance(self, mpm=None):
        """Largest distance from the crack origin to an eroded point, m (0 before cracking)."""
        mpm = mpm or self._mpm
        return self._frontOf(self._crack(mpm))

    @staticmethod
    def _frontOf(crack):
        if crack is None:
            return 0.0
        return float(np.sqrt(np.max(crack[6])))  # (the main crack's squared distances)

    def frontProfile(self, mpm=None):
        """The front through the thickness (needs throughAxis): the eroded points of the main
        crack in layers of one point spacing (h / ppc) along throughAxis, and in each layer the
        largest in-plane distance from the origin. Returns (each layer's mean coordinate along
        the axis, m; its front distance, m), both empty before cracking. A straight front gives
        equal distances; a tunnelling one leads inside. Under mpiexec every rank must call it."""
        mpm = mpm or self._mpm
        if self.throughAxis is None:
            raise ValueError(f"EigenMPM: frontProfile needs throughAxis; EigenErosion {self.label!r} has "
                             "throughAxis = None; allowed: 'x', 'y' or 'z' (3D)")
        crack = self._crack(mpm)
        if crack is None:
            return np.array([]), np.array([])
        _, x, origin, main, raw, _, r2 = crack
        along = raw[main, "xyz".index(self.throughAxis)]
        r = np.sqrt(r2)
        layer = np.rint((along - along.min()) / (mpm.h / mpm.ppc)).astype(np.int64)
        keys = np.unique(layer)
        return np.array([along[layer == k].mean() for k in keys]), np.array([r[layer == k].max() for k in keys])

    def _mainCrack(self, x, origin):
        """Which eroded points (at x, one row each) belong to the crack grown from the origin:
        those linked to the eroded point nearest the origin through eroded points in neighbouring
        cells of size R = 6 kappa (the 3^3 cells around a cell; in 2D z = 0 throughout). Erosion
        elsewhere (under a support, a second crack) is left out of the tips and the front, so that
        it cannot make the front jump. The occupied cells are searched in C++
        (``_eigenmpm.crackMain``: a flood fill over the occupied cells, found through a table of
        the cells' box, or a hash map when that box is large)."""
        return self._mainCrackPoints(x, origin)[0]

    def _mainCrackPoints(self, x, origin):
        """(_mainCrack's mask, the main crack's rows of x, their squared distances from the
        origin), the distances bitwise np.sum((x[mask] - origin) ** 2, axis=1)."""
        return _eigenmpm.crackMain(np.ascontiguousarray(x, dtype=float), np.asarray(origin, dtype=float),
                                   6.0 * self.core.kappa)

    def record(self, mpm=None):
        mpm = mpm or self._mpm
        solver = mpm.solver
        if self.core and solver.ranks == 1:
            front, tips = self._recordOfOneProcess(mpm, solver)
        else:  # (under mpiexec the eroded points' positions travel between the ranks: _crack)
            crack = self._crack(mpm)
            front, tips = self._frontOf(crack), [t.tolist() for t in self._tipsOf(mpm, crack)]
        self.history.append((solver.time, self.dissipatedEnergy(), self.erodedCount(), front, tips))

    def _recordOfOneProcess(self, mpm, solver):
        """record()'s front and tips (as lists) in one process: _crack's, _frontOf's and
        _tipsOf's numbers from one C++ call (solver.crackRecord, the same operations on the same
        numbers), which also merges the tips as _mergedTips does (here only for a NaN distance).
        A record follows a step, when the interpreter runs cold: the numpy steps took about 260
        us per record in the branching plate (doc/performance.md, "Session 31"), the merge's
        numpy calls about 70-100 us ("Session 35"). test_erosion.py compares both ways bit for
        bit."""
        if self._origin is None:
            ids = self.core.eventPoints()
            if not len(ids):
                return 0.0, []
            self._origin = self._inPlane(solver.positionsAt(ids[:1]))[0].copy()
        R = 6.0 * self.core.kappa
        R2 = R ** 2
        window = self.tipWindow if self.tipWindow else 50 * O.dt
        axis = -1 if self.throughAxis is None else "xyz".index(self.throughAxis)
        front, tips, xr, rr, farther = solver.crackRecord(self.core, self._inPlane(self._origin), axis,
                                                          solver.time - window, R, R2)
        if tips is None:
            tips = [t.tolist() for t in self._mergedTips(xr, rr, farther, R2)]
        return front, tips

    def tipSpeed(self, window=None):
        """Crack tip speed over the recorded history, as (times, speeds in m/s): the rate of
        change of the front distance (largest distance from the origin to an eroded point) over
        a sliding window of simulated time (default: tipWindow or 5 records), which smooths the
        steps of one point spacing that erosion advances by."""
        if len(self.history) < 2:
            return np.array([]), np.array([])
        t = np.array([h[0] for h in self.history])
        d = np.array([h[3] for h in self.history])
        w = window or self.tipSpeedWindow()
        times, speeds = [], []
        j = 0
        for i in range(1, len(t)):
            while j + 1 < i and t[i] - t[j + 1] >= w:
                j += 1
            if t[i] - t[j] >= w * (1 - 1e-9):
                times.append(0.5 * (t[i] + t[j]))
                speeds.append((d[i] - d[j]) / (t[i] - t[j]))
        return np.array(times), np.array(speeds)

    def tipSpeedWindow(self):
        """The window of :meth:`tipSpeed` by default, and so of ``max_tip_speed_m_s`` in
        :meth:`summary`, s: tipWindow, or 5 record periods (None before two records)."""
        if self.tipWindow:
            return self.tipWindow
        if len(self.history) < 2:
            return None
        return 5 * (self.history[1][0] - self.history[0][0])

    def initiationTime(self):
        """Time of the first erosion, s (None before)."""
        ev = self.core.events() if self.core else []
        return ev[0][2] if ev else None

    def branchingTime(self, sustain=5):
        """First recorded time from which the crack has two or more tips for `sustain`
        consecutive records, s (None if it never branches)."""
        n = [len(h[4]) for h in self.history]
        for i in range(len(n) - sustain + 1):
            if all(k >= 2 for k in n[i:i + sustain]):
                return self.history[i][0]
        return None

    def summary(self):
        """Scalars for summary.json: dissipated energy (J), eroded count, initiation time (us),
        maximum tip speed (m/s) over windows of tip_speed_window_us (:meth:`tipSpeedWindow`; a
        figure of tipSpeed() with the same window shows the same maximum) and the current tips (m)."""
        _, v = self.tipSpeed()
        w = self.tipSpeedWindow()
        t0 = self.initiationTime()
        return {"dissipated_energy_J": self.dissipatedEnergy(), "eroded_count": self.erodedCount(),
                "initiation_time_us": None if t0 is None else 1e6 * t0,
                "branching_time_us": None if self.branchingTime() is None else 1e6 * self.branchingTime(),
                "max_tip_speed_m_s": float(np.max(v)) if len(v) else 0.0,
                "tip_speed_window_us": None if w is None else 1e6 * w,
                "crack_front_distance_m": self.history[-1][3] if self.history else 0.0,
                "crack_tips_m": self.history[-1][4] if self.history else []}

    def plotData(self):
        return {f"{self.label}_Ef": self.dissipatedEnergy(), f"{self.label}_eroded": self.erodedCount(),
                f"{self.label}_front": self.history[-1][3] if self.history else 0.0}
