"""YADE engines of EigenMPM.

YADE calls the ``action`` of its own C++ engines only; the engine that runs Python inside the
loop is ``PyRunner``. Our engines are therefore ``PyRunner`` subclasses whose command calls
back into the engine object (looked up through this module, not through ``__main__``, whose
namespace differs between ``yade script.py``, ``yade -x`` and plain Python).
"""
import itertools
import weakref

import numpy as np
from yade import O, PyRunner

from . import _eigenmpm
from .params import Param, apply, declare, takes, vec3

# Engine objects by key, for their commands. Weak: an engine in O.engines is held by YADE (which
# holds the Python object of a Python subclass), one that no one holds is freed.
_registry = weakref.WeakValueDictionary()
_keys = itertools.count()


def _register(engine):
    key = next(_keys)
    _registry[key] = engine
    return f"import eigenmpm.engines as _m; _m._registry[{key}]._action()"


class _Released:
    """What an engine holds in place of its solver (or erosion state) once O.reset() freed it:
    any use says so instead of failing obscurely."""

    def __init__(self, what):
        object.__setattr__(self, "_what", what)

    def _fail(self, *_):
        raise RuntimeError(f"EigenMPM: {self._what} was freed by O.reset(); read the results before "
                           "O.reset(), or build the scene again")

    __getattr__ = __setattr__ = __bool__ = __len__ = __iter__ = __call__ = _fail


def _wrapReset():
    """Makes O.reset() free our engines of the scene it ends. YADE keeps every Python engine that
    was ever assigned to O.engines alive (one reference per assignment, and its label in
    builtins), so the engines cannot be freed; their heavy state (the solver, the erosion state)
    is released instead (``_release``). Released: the engines in O.engines at the reset and those
    that stepped."""
    from yade.wrapper import Omega
    original = getattr(Omega.reset, "_eigenmpmOriginal", Omega.reset)

    def reset(self, *args, **kwargs):
        scene = {id(e) for e in O.engines}
        ending = [e for e in list(_registry.values())
                  if hasattr(e, "_release") and (id(e) in scene or getattr(e, "_started", False))]
        original(self, *args, **kwargs)
        for e in ending:
            e._release()

    reset._eigenmpmOriginal = original
    reset.__doc__ = original.__doc__
    Omega.reset = reset


_wrapReset()


def mpmEngines():
    """The EigenMPM solver engines in ``O.engines``."""
    return [e for e in O.engines if isinstance(e, MpmEngine)]


def findEngine(engine=None):
    """The solver engine given by object or label, or the only one in ``O.engines``."""
    if isinstance(engine, MpmEngine):
        return engine
    found = mpmEngines()
    if engine is not None:
        found = [e for e in found if e.label == engine]
    if len(found) != 1:
        raise ValueError(f"EigenMPM: {len(found)} MpmEngine(s) match {engine!r} in O.engines; "
                         "give the engine or its label")
    return found[0]


def criticalTimeStep(engine=None):
    """Critical (CFL) time step of one solver engine, or the smallest of all in O.engines, in s."""
    if engine is not None:
        return findEngine(engine).criticalTimeStep()
    steps = [e.criticalTimeStep() for e in mpmEngines()]
    if not steps:
        raise ValueError("EigenMPM: no MpmEngine in O.engines")
    return min(steps)


def _mask(components, dim):
    axes = "xyz"[:dim]
    if not set(components) <= set(axes):  # the declaration allows 'z'; a 2D engine does not
        raise ValueError(f"EigenMPM: components = {components!r} is invalid; allowed: letters of "
                         f"{axes!r} in {dim}D")
    return sum(1 << axes.index(c) for c in set(components))


class VelocityBC:
    """A velocity condition on grid nodes, returned by :meth:`MpmEngine.velocityBC`.

    ``reaction`` is the force (N, Vector3) the condition exerted on the body in the last step.
    """

    def __init__(self, engine, cid, label, velocity, rampTime):
        # Weak: the engine holds its conditions, and a reference cycle through a YADE engine is
        # never collected (Boost.Python does not show the engine's attributes to the collector).
        self._engine, self.id, self.label = weakref.proxy(engine), cid, label
        self.velocity, self.rampTime = velocity, rampTime

    @property
    def reaction(self):
        return _vector(self._engine.solver.reaction(self.id))

    def _update(self, t):
        if callable(self.velocity):
            self._engine.solver.setConditionVelocity(self.id, vec3(self.velocity(t), "velocity(t)"), 0.0)


def _vector(t):
    try:
        from yade import Vector3
        return Vector3(*t)
    except ImportError:
        return tuple(t)


_SELECTION = "a predicate (yade.pack or a callable pred(x, pad)) or a list of ids"


def _isSelection(sel):
    if callable(sel) or hasattr(sel, "aabb"):
        return True
    ids = np.asarray(sel)
    return ids.ndim == 1 and (ids.size == 0 or np.issubdtype(ids.dtype, np.integer))


# Arguments shared by the velocity conditions (velocityBC and fix).
_REGION = Param("region", None, "", "the grid nodes: a predicate on node positions or node indices, "
                                    "chosen once", kind="object", accepts=_SELECTION, check=_isSelection)
_POINTS = Param("points", None, "", "the points whose nearest nodes are prescribed each step: a "
                                    "predicate on the points' initial positions or point ids",
                kind="object", accepts=_SELECTION, check=_isSelection)
_COMPONENTS = Param("components", None, "", "the prescribed components, e.g. 'x' or 'xy'; default: all",
                    kind="str", accepts="non-empty string of the letters x, y (and z in 3D)",
                    check=lambda c: c != "" and set(c) <= set("xyz"))
_RAMP = Param("rampTime", 0.0, "s", "time over which the value rises linearly from 0 (paper Eq 34)",
              bounds="[0, inf)")
_LABEL = Param("label", None, "", "name of the condition in bcs and plotData; default 'bc<id>'", kind="str")


# (dim, shape name in lower case) -> solver class, for every configuration the core is built for
# (pkg/Configurations.hpp), and the shape names in their user's spelling.
_SOLVERS = dict(_eigenmpm.solvers)
_SHAPES = tuple(_eigenmpm.shapes)


@declare
class MpmEngine(PyRunner):
    """Explicit MPM/GIMP solver for linear elastic continua (paper Sections 3.1-3.2, 4.1) as a
    YADE engine. It advances by ``O.dt`` each iteration, on ``O.numThreads`` OpenMP threads.

    Example::

        import eigenmpm as em
        from yade import pack
        mpm = em.MpmEngine(dim=2, h=0.01, ppc=2, label='mpm')
        steel = em.ElasticMaterial(E=200e9, nu=0.3, rho=7850)
        mpm.fill(pack.inAlignedBox((0, 0, 0), (1, 0.1, 0)), steel)
        mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (0.001, 1, 1)))
        O.engines = [mpm]
        O.dt = 0.5 * mpm.criticalTimeStep()
        O.run(1000, True)
    """

    params = (
        Param("label", "mpm", "", "YADE label of the engine; it prefixes the keys of plotData()"),
        Param("dim", 2, "", "spatial dimension (2D runs native 2D kernels)", choices=(2, 3)),
        Param("h", None, "m", "cell size of the background grid", kind="float", bounds="(0, inf)",
              required=True),
        Param("ppc", 2, "", "material points per cell per direction used by fill() and by the "
                            "uGIMP particle half-width h/(2 ppc)", bounds="[1, 64]"),
        Param("shape", "uGIMP", "", "shape functions: 'uGIMP' (paper Eq 16) or 'linear' (standard MPM)",
              choices=_SHAPES),
        Param("thickness", 1.0, "m", "out-of-plane thickness of a 2D model (point volume = area x "
                                     "thickness; forces and energies are for this thickness)",
              bounds="(0, inf)"),
        Param("gravity", (0.0, 0.0, 0.0), "m/s2", "body force per unit mass"),
        Param("domain", None, "m", "(lo, hi) corners of the grid; default: bounding box of the points "
                                   "plus `padding` cells, fixed at the first step", kind="box"),
        Param("padding", 3, "cells", "cells added around the points when the grid is sized automatically",
              bounds="[1, inf)"),
        Param("massCutoff", 1e-14, "", "nodes lighter than this fraction of the mean point mass carry "
                                      "no velocity (small-mass cut-off)", bounds="[0, 1)"),
        Param("threads", None, "", "OpenMP threads; default O.numThreads (yade -j N)", kind="int",
              bounds="[1, inf)"),
    )

    def __init__(self, **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "MpmEngine")
        self.solver = _SOLVERS[(self.dim, self.shape.lower())](h=self.h, ppc=self.ppc, massCutoff=self.massCutoff,
                                                               padding=self.padding, gravity=self.gravity)
        if self.domain is not None:
            self.solver.setDomain(*self.domain)
        self.iterPeriod, self.initRun = 1, True
        self.command = _register(self)
        self.bcs = {}
        self.recorders = []
        self.physics = {}  # label -> physics engine acting on this solver (EigenErosion, ...)
        self._materials = {}
        self._started = False

    def _release(self):
        """Frees the solver and what refers to the scene (O.reset(), see _wrapReset)."""
        self.solver = _Released(f"the solver of MpmEngine {self.label!r}")
        self.bcs, self.recorders, self.physics, self._materials = {}, [], {}, {}
        self._released = True

    # --- specimen -------------------------------------------------------------------------
    def material(self, mat):
        """Solver id of an ElasticMaterial, registering it on first use."""
        key = id(mat)
        if key not in self._materials:
            self._materials[key] = (mat, self.solver.addMaterial(float(mat.E), float(mat.nu),
                                                                 float(mat.rho), bool(mat.planeStress),
                                                                 str(mat.split)))
        return self._materials[key][1]

    def addPoints(self, positions, material, volumes, velocities=None):
        """Adds points at `positions` (n x 3, m) with `volumes` (m^3; in 2D area x thickness).
        Returns the ids of the new points."""
        pos = np.ascontiguousarray(np.asarray(positions, dtype=float).reshape(-1, 3))
        n = len(pos)
        vol = np.ascontiguousarray(np.broadcast_to(np.asarray(volumes, dtype=float), (n,)))
        vel = np.zeros((n, 3)) if velocities is None else np.asarray(velocities, dtype=float)
        vel = np.ascontiguousarray(np.broadcast_to(vel, (n, 3)))
        first = self.solver.addPoints(pos, vel, vol, self.material(material))
        return np.arange(first, first + n)

    def fill(self, predicate, material, velocity=(0, 0, 0)):
        """Fills a ``yade.pack`` predicate (or any callable ``pred(point, pad)``) with points on
        the regular lattice of ppc points per cell per direction, aligned with the grid (points at
        cell fractions (i + 1/2)/ppc). In 2D the predicate is evaluated in the plane z = middle of
        its bounding box (z = 0 if unbounded). Returns the ids of the new points."""
        from .builders import latticePoints
        pos = latticePoints(predicate, self.h, self.ppc, self.dim)
        if len(pos) == 0:
            raise ValueError(f"EigenMPM: the predicate {predicate!r} holds no lattice point at h = "
                             f"{self.h}, ppc = {self.ppc}; check its extent")
        vol = (self.h / self.ppc) ** self.dim * (self.thickness if self.dim == 2 else 1.0)
        return self.addPoints(pos, material, vol, vec3(velocity, "velocity"))

    def pointsIn(self, predicate, pad=0.0):
        """Ids of the points whose current position satisfies ``predicate(x, pad)``."""
        from .builders import select
        return select(self.solver.positions(), predicate, pad, self.dim)

    def nodesIn(self, predicate, pad=None):
        """Indices of the grid nodes inside ``predicate``; pad defaults to -1e-6 h, so nodes on the
        region's faces count as inside."""
        from .builders import select
        pad = -1e-6 * self.h if pad is None else pad
        return select(self.solver.nodePositions(), predicate, pad, self.dim)

    # --- boundary conditions --------------------------------------------------------------
    @takes(_REGION, _POINTS, _COMPONENTS,
           Param("velocity", (0.0, 0.0, 0.0), "m/s", "the prescribed velocity, or a function of the time "
                                                    "t (s) returning it", function=True),
           _RAMP, _LABEL)
    def velocityBC(self, region, points, components, velocity, rampTime, label):
        """Prescribes the velocity (m/s) of grid nodes on the given components. Nodes are chosen by
        `region` once, or by `points`: then each step the node nearest to each of these points.
        With rampTime t0 > 0 the velocity rises linearly from 0 to its value over t0 (paper
        Eq 34). Returns a VelocityBC whose ``reaction`` is the force it exerts."""
        return self._velocityCondition(region, points, components, velocity, rampTime, label)

    @takes(_REGION, _POINTS, _COMPONENTS, _LABEL)
    def fix(self, region, points, components, label):
        """Zero velocity on the given components: a fixed support (all components) or a
        symmetry/roller plane (the normal component only). Returns a VelocityBC."""
        return self._velocityCondition(region, points, components, (0.0, 0.0, 0.0), 0.0, label)

    def _velocityCondition(self, region, points, components, velocity, rampTime, label):
        if (region is None) == (points is None):
            raise ValueError("EigenMPM: velocityBC needs exactly one of region= or points=")
        nodes = [] if region is None else self._indices(region, self.nodesIn)
        pts = [] if points is None else self._indices(points, self.pointsIn)
        if len(nodes) == 0 and len(pts) == 0:
            raise ValueError(f"EigenMPM: velocityBC {label!r} selects no node and no point; check the region")
        mask = _mask(components or "xyz"[:self.dim], self.dim)
        v0 = (0.0, 0.0, 0.0) if callable(velocity) else velocity
        cid = self.solver.addVelocityCondition([int(i) for i in nodes], [int(i) for i in pts], mask, v0, rampTime)
        label = label or f"bc{cid}"
        bc = VelocityBC(self, cid, label, velocity, rampTime)
        self.bcs[label] = bc
        return bc

    @takes(Param("points", None, "", "the loaded boundary points: a predicate on their current "
                                     "positions (yade.pack) or point ids", kind="object",
                 accepts=_SELECTION, check=_isSelection, required=True),
           Param("traction", None, "Pa", "the traction vector", kind="vector", required=True),
           _RAMP,
           Param("layer", None, "m", "thickness of the band of points selected at the surface; "
                                     "default: the cell size h", kind="float", bounds="(0, inf)"))
    def traction(self, points, traction, rampTime, layer):
        """Applies a traction on boundary points as the nodal force N t V_p / layer of paper Eq 28.
        Returns the id of the condition."""
        pts = self._indices(points, self.pointsIn)
        if len(pts) == 0:
            raise ValueError("EigenMPM: traction selects no point; check the predicate")
        return self.solver.addTraction([int(i) for i in pts], traction, rampTime, self.h if layer is None else layer)

    @takes(Param("vertices", None, "m", "in 2D a segment or polyline (2 or more points), in 3D a planar "
                                       "polygon (3 or more points), in scene coordinates (z ignored in 2D)",
                 kind="points", required=True))
    def crack(self, vertices):
        """Adds a pre-existing crack (phantom nodes, paper Section 3.3.1). An edge notch starts on
        (or beyond) the body's boundary, an interior crack inside it; several cracks are allowed.
        The crack then moves with the material. Returns the crack id."""
        return self.solver.addCrack(vertices)

    def crackVertices(self, crackId=0):
        """Current vertices of a crack (they move with the material)."""
        return [_vector(v) for v in self.solver.crackVertices(crackId)]

    @staticmethod
    def _indices(sel, finder):
        if callable(sel) or hasattr(sel, "aabb"):
            return finder(sel)
        return np.asarray(sel, dtype=int).ravel()

    # --- stepping -------------------------------------------------------------------------
    def criticalTimeStep(self):
        """h / (wave speed + max point speed): the largest O.dt this engine accepts, in s."""
        return self.solver.criticalTimeStep()

    def _syncPhysics(self):
        """A physics engine (EigenErosion, ...) acts only while it is in O.engines and not dead:
        each step, those there that work for this engine attach their stage, and any other
        attached one is detached. Returns O.engines."""
        engines = O.engines
        active = [e for e in engines if e is not self and callable(getattr(type(e), "attach", None))
                  and not e.dead and findEngine(e.engine) is self]
        for e in list(self.physics.values()):
            if not any(e is a for a in active):
                e.detach(self)
        for e in active:
            e.attach(self)
        return engines

    def _action(self):
        engines = self._syncPhysics()
        self._started = True
        t = O.time
        self.solver.time = t
        for bc in self.bcs.values():
            bc._update(t)
        threads = self.threads if self.threads else O.numThreads
        try:
            self.solver.step(O.dt, int(threads))
        except Exception as err:
            for rec in self.recorders:
                if any(rec is e for e in engines) and not rec.dead:
                    rec.onFailure(self, err)
            raise

    # --- diagnostics ----------------------------------------------------------------------
    def kineticEnergy(self):
        """Sum of m v^2 / 2 over the points, J."""
        return self.solver.kineticEnergy()

    def elasticEnergy(self):
        """Sum of V (c psi+ + psi-) over the points (paper Eq 32), J."""
        return self.solver.elasticEnergy()

    def plotData(self):
        """Scalars for ``yade.plot.addData``: kinetic and elastic energy (J) and the reaction force
        components (N) of every velocity condition, keys prefixed with the engine's label."""
        d = {f"{self.label}_Ek": self.kineticEnergy(), f"{self.label}_Ee": self.elasticEnergy()}
        for name, bc in self.bcs.items():
            r = self.solver.reaction(bc.id)
            for k in range(self.dim):
                d[f"{self.label}_{name}_R{'xyz'[k]}"] = r[k]
        for phys in self.physics.values():
            d.update(phys.plotData())
        return d


# The engine a physics or output engine works for, shared by their declarations.
ENGINE = Param("engine", None, "", "the MpmEngine (object or label); default: the only one in O.engines",
               kind="object", accepts="an MpmEngine or its label",
               check=lambda e: isinstance(e, (MpmEngine, str)))


class _Call(PyRunner):
    """The PyRunner of callEvery: a Python object, so that YADE holds the function with it."""

    def __init__(self, function, label):
        PyRunner.__init__(self, initRun=True, label=label)
        self._function = function
        self.command = _register(self)

    def _action(self):
        self._function()

    def _release(self):
        self._function = _Released("the function of callEvery")
        self._released = True


def callEvery(function, iterPeriod=1, virtPeriod=0.0, label=""):
    """A PyRunner that calls ``function()`` every iterPeriod iterations (or virtPeriod seconds),
    starting at the first iteration. Unlike a command string it needs no name in ``__main__``."""
    r = _Call(function, label)
    r.iterPeriod, r.virtPeriod = int(iterPeriod), float(virtPeriod)
    return r
