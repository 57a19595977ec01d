"""YADE engines of EigenMPM.

YADE calls the ``action`` of its own C++ engines only; the engine that runs Python inside the
loop is ``PyRunner``. Our engines are therefore ``PyRunner`` subclasses whose command calls
back into the engine object, looked up through this module by a function it puts in Python's
builtins (``_eigenmpm_engine(key)``): not through ``__main__``, whose namespace differs between
``yade script.py``, ``yade -x`` and plain Python, and without an import statement in the
command, which YADE compiles and runs at every call (inside ``O.run``, after the step has left
the interpreter's code out of the caches, the import cost about 20 us per iteration,
doc/performance.md "Session 28").
"""
import builtins
import functools
import itertools
import math
import sys
import warnings
import weakref

import numpy as np
from yade import O, PyRunner

from . import _eigenmpm, parallel
from .materials import ElasticMaterial
from .params import Param, apply, declare, takes, vec3

# Engine objects by key, for their commands. Weak: an engine in O.engines is held by YADE (which
# holds the Python object of a Python subclass), one that no one holds is freed.
_registry = weakref.WeakValueDictionary()
_keys = itertools.count()
# id(MpmEngine) -> (a weak reference to it, what its attachments depend on, the stages with a
# per-step part, those with an after-step part): MpmEngine._syncPhysics. Kept outside the
# engines, whose state is saved; a plain dict, read without a Python-level call (a
# WeakKeyDictionary's get is one), its entry removed when its engine goes.
_attached = {}
# What the engines of the scene are: a count that every way Python has to change them raises
# (watchEngines): O.engines assigned, an engine's `dead` set (or any attribute through
# updateAttrs), and the Omega methods that load, reset or switch the scene. While it stands,
# MpmEngine._syncPhysics knows its attachments are current without reading O.engines (inside
# O.run that read and the `dead` flags cost about 30 us per step, doc/performance.md
# "Session 34").
_enginesVersion = [0]
# Omega's methods that replace, reset or switch the scene (and with it O.engines or O.iter).
_SCENE_METHODS = ("load", "loadTmp", "reload", "reset", "resetAllScenes", "resetCurrentScene", "resetThisScene",
                  "resetTime", "stringToScene", "switchScene", "switchToScene")
_CALL = "_eigenmpm_engine"
COMMAND_PREFIX = _CALL + "("
# The commands of earlier versions (state._refuseOrphans recognises them in a loaded scene).
LEGACY_PREFIXES = ("import eigenmpm.engines as _m; _m._registry[",)


# key -> a weak reference to the engine: _act's lookup without a Python-level call (the
# WeakValueDictionary's __getitem__ is one; inside O.run it runs cold, doc/performance.md
# "Session 33"). An entry goes with its engine.
_refs = {}


@functools.lru_cache(maxsize=None)
def _numThreads():
    """O.numThreads (YADE's -j), fixed for the process: read once, not at every step."""
    return O.numThreads


def _act(key):
    """What an engine's command calls: the engine registered under `key` acts."""
    _refs[key]()._action()


setattr(builtins, _CALL, _act)


def _register(engine):
    key = next(_keys)
    _registry[key] = engine
    _refs[key] = weakref.ref(engine, lambda _, key=key: _refs.pop(key, None))
    return f"{COMMAND_PREFIX}{key})"


def registered(runner):
    """The object a PyRunner's command calls into (our engine itself, or a callEvery's call),
    or None for any other engine."""
    command = getattr(runner, "command", "")
    if not isinstance(runner, PyRunner) or not command.startswith(COMMAND_PREFIX):
        return None
    try:
        return _registry.get(int(command[len(COMMAND_PREFIX):].split(")", 1)[0]))
    except ValueError:
        return None


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
    is released instead (``_release``). Released: the engines in O.engines at the reset, those
    that stepped, those of a scene that a load replaced (_sceneReplaced), and those that worked
    for a released MpmEngine."""
    from yade.wrapper import Omega
    original = getattr(Omega.reset, "_eigenmpmOriginal", Omega.reset)

    def reset(self, *args, **kwargs):
        # (after YADE's own load, O.engines holds plain PyRunners whose commands call our objects)
        scene = {id(e) for e in O.engines} | {id(registered(e)) for e in O.engines}
        ending = [e for e in list(_registry.values())
                  if hasattr(e, "_release") and (id(e) in scene or getattr(e, "_started", False)
                                                 or getattr(e, "_sceneEnded", False))]
        # and those that worked for an MpmEngine that ends (an EigenErosion taken out of
        # O.engines before the reset would otherwise keep its label taken)
        ends = {id(e) for e in ending}
        ending += [e for e in list(_registry.values())
                   if hasattr(e, "_release") and id(e) not in ends
                   and any(isinstance(m, MpmEngine) and id(m) in ends
                           for m in (getattr(e, "_mpm", None), getattr(e, "engine", None)))]
        original(self, *args, **kwargs)
        for e in ending:
            e._release()

    reset._eigenmpmOriginal = original
    reset.__doc__ = original.__doc__
    Omega.reset = reset


_wrapReset()


def watchMethod(cls, name, bump):
    """Wraps method `name` of class `cls` once, at class level, so that every call of it calls
    bump() afterwards (also when it raises); a method already wrapped calls this bump too."""
    original = getattr(cls, name)
    bumps = getattr(original, "_eigenmpmBumps", None)
    if bumps is not None:
        if bump not in bumps:
            bumps.append(bump)
        return
    bumps = [bump]

    def method(self, *args, **kwargs):
        try:
            return original(self, *args, **kwargs)
        finally:
            for b in bumps:
                b()

    method._eigenmpmBumps = bumps
    method.__name__, method.__doc__, method.__wrapped__ = name, original.__doc__, original
    if hasattr(original, "_eigenmpmOriginal"):  # (what the reset wrapper finds YADE's reset by)
        method._eigenmpmOriginal = original._eigenmpmOriginal
    setattr(cls, name, method)


def watchSetter(cls, name, bump):
    """Wraps the setter of property `name` of class `cls` once, at class level, so that every
    assignment calls bump() afterwards (also when it raises); a setter already wrapped calls this
    bump too."""
    p = cls.__dict__[name]
    bumps = getattr(p.fset, "_eigenmpmBumps", None)
    if bumps is not None:
        if bump not in bumps:
            bumps.append(bump)
        return
    bumps = [bump]

    def fset(self, value):
        try:
            p.fset(self, value)
        finally:
            for b in bumps:
                b()

    fset._eigenmpmBumps, fset.__wrapped__ = bumps, p.fset
    setattr(cls, name, property(p.fget, fset, p.fdel, p.__doc__))


def watchEngines():
    """Makes every Python path that can change the scene's engines raise _enginesVersion: the
    O.engines and Engine.dead setters, Serializable.updateAttrs, and Omega's scene methods
    (_SCENE_METHODS), each wrapped once at class level around YADE's own (or the wrapper already
    there: eigenmpm.state's load, this module's reset). The package calls it at import, after
    its other wrappers."""
    from yade.wrapper import Engine, Omega, Serializable

    def bump():
        _enginesVersion[0] += 1

    watchSetter(Omega, "engines", bump)
    watchSetter(Engine, "dead", bump)
    watchMethod(Serializable, "updateAttrs", bump)
    for name in _SCENE_METHODS:
        watchMethod(Omega, name, bump)


def _releaseLabel(engine):
    """The _release of an engine that holds nothing heavy (the recorders, Checkpoint): it only
    marks the engine so that its default label is free for the next scene's."""
    engine._released = True


def _sceneReplaced(before):
    """After O.load or O.loadTmp replaced the scene (eigenmpm.state): our engines of the scene it
    replaced (`before`, its O.engines), now in none, are marked `_sceneEnded`. Their default
    labels are free again (params.freeLabel), and the next O.reset() releases them with the
    scene's own, as if they had been in O.engines at that reset."""
    now = {id(e) for e in O.engines}
    for e in before:
        if id(e) not in now and registered(e) is e:
            e._sceneEnded = True


# (engines' version, weak references to the MpmEngines of O.engines then): mpmEngines reads
# O.engines only after a change of the engines (the recorders ask at every record, after the step
# has left the interpreter's code and data out of the caches, doc/performance.md "Session 35").
_mpmFound = [None, ()]


def mpmEngines():
    """The EigenMPM solver engines in ``O.engines``."""
    if _mpmFound[0] != _enginesVersion[0]:
        _mpmFound[:] = [_enginesVersion[0], tuple(weakref.ref(e) for e in O.engines if isinstance(e, MpmEngine))]
    found = [r() for r in _mpmFound[1]]
    if any(e is None for e in found):  # (freed since: read them again)
        _mpmFound[0] = None
        return mpmEngines()
    return found


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
            v = vec3(self.velocity(t), "velocity(t)")
            owner = f"velocity condition {self.label!r}"
            if not all(math.isfinite(c) for c in v):
                raise ValueError(f"EigenMPM: velocity(t) = {v!r} at t = {t!r} s is invalid; allowed: finite "
                                 f"components ({owner})")
            _planar(v, "velocity(t)", self._engine.dim, owner)
            self._engine.solver.setConditionVelocity(self.id, v, 0.0)


def _vector(t):
    try:
        from yade import Vector3
        return Vector3(*t)
    except ImportError:
        return tuple(t)


def _planar(v, name, dim, owner):
    """Refuses a z component in 2D, where it would be ignored."""
    if dim == 2 and v[2] != 0.0:
        raise ValueError(f"EigenMPM: {name} = {tuple(v)!r} is invalid in 2D: the z component does not apply; "
                         f"allowed: (x, y) or (x, y, 0) ({owner})")


_SELECTION = "a predicate (yade.pack or a callable pred(x, pad)) or a list of ids"


def _isSelection(sel):
    if callable(sel) or hasattr(sel, "aabb"):
        return True
    ids = np.asarray(sel)
    return ids.ndim == 1 and (ids.size == 0 or np.issubdtype(ids.dtype, np.integer))


# Arguments of fill and addPoints, checked as the declared ones are.
_MATERIAL = Param("material", None, "", "the material of the points", kind="object", required=True,
                  accepts="an ElasticMaterial", check=lambda m: isinstance(m, ElasticMaterial))
_VELOCITY = Param("velocity", (0.0, 0.0, 0.0), "m/s", "initial velocity of the points")
_BODY = Param("body", 0, "", "the body the points belong to: points of different bodies do not bond; "
                             "they touch (with bodyFriction) and separate (doc/contact.md)",
              kind="int", bounds="[0, 63]")


def _array(value, name, owner):
    """value as an array of floats; TypeError naming it when it holds no numbers."""
    if isinstance(value, str):
        raise TypeError(f"EigenMPM: {name} = {value!r} is invalid; allowed: numbers ({owner})")
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"EigenMPM: {name} = {value!r} is invalid; allowed: numbers ({owner})") from None


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
        Param("dim", 2, "", "spatial dimension (2D runs native 2D kernels)", choices=(2, 3), fixed=True),
        Param("h", None, "m", "cell size of the background grid", kind="float", bounds="(0, inf)",
              required=True, fixed=True),
        Param("ppc", 2, "", "material points per cell per direction used by fill() and by the "
                            "uGIMP particle half-width h/(2 ppc)", bounds="[1, 64]", fixed=True),
        Param("shape", "uGIMP", "", "shape functions: 'uGIMP' (paper Eq 16) or 'linear' (standard MPM)",
              choices=_SHAPES, fixed=True),
        Param("thickness", 1.0, "m", "out-of-plane thickness of a 2D model (point volume = area x "
                                     "thickness; forces and energies are for this thickness); "
                                     "not given in 3D", bounds="(0, inf)", fixed=True),
        Param("gravity", (0.0, 0.0, 0.0), "m/s2", "body force per unit mass (no z component in 2D); "
                                                 "may be changed between steps"),
        Param("domain", None, "m", "(lo, hi) corners of the grid; default: bounding box of the points "
                                   "plus `padding` cells, fixed at the first step", kind="box", fixed=True),
        Param("padding", 3, "cells", "cells added around the points when the grid is sized automatically",
              bounds="[1, inf)", fixed=True),
        Param("massCutoff", 1e-14, "", "nodes lighter than this fraction of the mean point mass carry "
                                      "no velocity (small-mass cut-off)", bounds="[0, 1)", fixed=True),
        Param("threads", None, "", "OpenMP threads; default O.numThreads (yade -j N)", kind="int",
              bounds="[1, inf)"),
        Param("transfer", "FLIP", "", "particle-grid transfer: 'FLIP' (the paper's, Eqs 25, 30) or 'APIC' "
                                      "(affine: carries linear velocity fields exactly and conserves angular "
                                      "momentum; doc/stability.md)", choices=("FLIP", "APIC"), fixed=True),
        Param("stressUpdate", "smallStrain", "", "'smallStrain' (the paper's Eq 27) or 'corotational' (a "
                                                 "deformation gradient per point, the law on the co-rotated "
                                                 "strain: rotations make no stress; doc/stability.md)",
              choices=("smallStrain", "corotational"), fixed=True),
        Param("crackContact", False, "", "the faces of the pre-existing cracks (crack()) touch: they separate "
                                         "freely but do not pass through each other (doc/contact.md); off: "
                                         "the paper's phantom nodes, whose faces interpenetrate", fixed=True),
        Param("crackFriction", 0.0, "", "Coulomb friction coefficient between the faces of the pre-existing "
                                        "cracks (with crackContact)", bounds="[0, inf)", fixed=True),
        Param("bodyFriction", 0.0, "", "Coulomb friction coefficient between the bodies of this engine "
                                       "(points filled with different body ids)", bounds="[0, inf)", fixed=True),
        Param("rebalance", 1.25, "", "under mpiexec: the ranks' strips of the grid are chosen again when the "
                                     "rank holding most points holds more than this times the mean "
                                     "(doc/parallel.md, 'Load balance'); the results do not change",
              bounds="[1, inf)"),
        Param("rebalancePeriod", 100, "steps", "under mpiexec: how often the balance is checked (0: never)",
              kind="int", bounds="[0, inf)"),
        Param("columnCells", 0, "cells", "the order of the sums at the grid nodes follows columns of this many "
                                         "cells along the first axis (0: none); needed by rankColumns > 1, whose "
                                         "results are bitwise those of one process with the same columnCells and "
                                         "at round-off from one without (doc/parallel.md, 'Decomposition in two "
                                         "directions')", kind="int", bounds="[0, inf)", fixed=True),
        Param("rankColumns", 1, "", "under mpiexec: the ranks form this many columns along the first axis (x) "
                                    "times N / rankColumns rows along the last, each rank a block of the grid; "
                                    "1: slabs along the last axis only (needs a divisor of N, and columnCells "
                                    "> 0 when above 1)", kind="int", bounds="[1, inf)", fixed=True),
        Param("distributedSetup", False, "", "under mpiexec: every rank keeps only its share of the points "
                                             "from fill()/addPoints() on, so that no rank holds the whole "
                                             "scene (doc/parallel.md, 'Memory'); referencePositions is then "
                                             "None (referenceOfPoints() gives this rank's, referenceOf(ids) "
                                             "given points' on every rank); the results do "
                                             "not change", fixed=True),
    )

    def __init__(self, **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "MpmEngine")
        if self.dim == 3 and "thickness" in kw:
            raise ValueError(f"EigenMPM: thickness = {self.thickness!r} is invalid in 3D: it is the "
                             "out-of-plane thickness of a 2D model; allowed: leave it out (MpmEngine)")
        self.solver = _SOLVERS[(self.dim, self.shape.lower())](h=self.h, ppc=self.ppc, massCutoff=self.massCutoff,
                                                               padding=self.padding, gravity=self.gravity,
                                                               transfer=self.transfer, stressUpdate=self.stressUpdate,
                                                               columnCells=self.columnCells)
        if self.domain is not None:
            self.solver.setDomain(*self.domain)
        # Where each point was added (m), by point id: output measures displacement from it. A
        # run distributed at set-up keeps it with the points instead (referenceOfPoints()).
        self.referencePositions = np.zeros((0, 3))
        if self.distributedSetup and parallel.worldSize() > 1:
            self.solver.distributeSetup(self.rankColumns)
            self.referencePositions = None
        if self.crackContact:
            self.solver.setCrackContact(True, self.crackFriction)
        self.solver.setBodyFriction(self.bodyFriction)
        self.iterPeriod, self.initRun = 1, True
        self.command = _register(self)
        self.bcs = {}
        self.recorders = []
        self.physics = {}  # label -> physics engine acting on this solver (EigenErosion, ...)
        self._materials = {}
        self._started = False
        self._lastIter = None
        self._cracksToCheck = []  # ids of cracks not yet checked against the material

    @property
    def gravity(self):
        return tuple(self.solver.gravity) if "solver" in vars(self) else self._gravity

    @gravity.setter
    def gravity(self, g):  # the declaration has validated g (see params.declare)
        _planar(g, "gravity", self.dim, "MpmEngine")
        self._gravity = g
        if "solver" in vars(self):
            self.solver.gravity = g

    def _release(self):
        """Frees the solver and what refers to the scene (O.reset(), see _wrapReset)."""
        self.solver = _Released(f"the solver of MpmEngine {self.label!r}")
        self.bcs, self.recorders, self.physics, self._materials = {}, [], {}, {}
        _attached.pop(id(self), None)
        self._released = True

    # --- specimen -------------------------------------------------------------------------
    def material(self, mat, owner="MpmEngine.material"):
        """Solver id of an ElasticMaterial, registering it on first use. Refused: a plane-stress
        material in 3D, and one whose wave speed gives a critical time step h / c of 0 or infinity
        at this cell size."""
        _MATERIAL.validate(mat, owner)
        if getattr(self, "_released", False):
            self.solver._fail()
        key = id(mat)
        if key not in self._materials:
            if mat.planeStress and self.dim == 3:
                raise ValueError(f"EigenMPM: planeStress = True is invalid in 3D (MpmEngine {self.label!r} has "
                                 f"dim = 3); allowed: False, plane stress is a 2D model ({mat!r})")
            args = (mat.E, mat.nu, mat.rho, mat.planeStress, mat.split)
            # The law's own wave speed, from a scratch solver: a refused material must not stay
            # in this one, where it would set the critical time step.
            scratch = type(self.solver)(h=self.h, ppc=1, massCutoff=0.0, padding=1, gravity=(0.0, 0.0, 0.0))
            c = scratch.materialInfo(scratch.addMaterial(*args))["waveSpeed"]
            dt = self.h / c
            if not (math.isfinite(dt) and dt >= sys.float_info.min):
                low, high = c * sys.float_info.min, c * sys.float_info.max
                allowed = f"h >= {low:.3g} m" if math.isinf(high) else f"{low:.3g} m <= h < {high:.3g} m"
                raise ValueError(f"EigenMPM: h = {self.h!r} is invalid with this material (wave speed c = "
                                 f"{c:.6g} m/s): the critical time step h / c would be {dt!r} s; allowed: {allowed} "
                                 f"(MpmEngine {self.label!r}, {mat!r})")
            self._materials[key] = (mat, self.solver.addMaterial(*args))
        return self._materials[key][1]

    def addPoints(self, positions, material, volumes, velocities=None, body=0, _share=None):
        """Adds points at `positions` (n x 3, or n x 2 in 2D; m) with `volumes` (one value or n
        values, m^3; in 2D area x thickness) and `velocities` (one vector or n x 3, m/s), in body
        `body` (0-63: bodies touch and separate, doc/contact.md). Returns the ids of the new
        points."""
        owner = "MpmEngine.addPoints"
        body = _BODY.validate(body, owner)
        pos = _array(positions, "positions", owner)
        if pos.ndim == 1 and pos.size in (2, 3):
            pos = pos[None, :]
        if pos.ndim != 2 or pos.shape[1] not in (self.dim, 3):
            raise ValueError(f"EigenMPM: positions of shape {pos.shape} is invalid; allowed: an n x 3 array"
                             f"{' (or n x 2)' if self.dim == 2 else ''} of coordinates ({owner})")
        n = len(pos)
        if pos.shape[1] == 2:
            pos = np.hstack([pos, np.zeros((n, 1))])
        vol = _array(volumes, "volumes", owner)
        if vol.ndim > 1 or vol.size not in (1, n):
            raise ValueError(f"EigenMPM: volumes of shape {vol.shape} is invalid; allowed: one volume or {n} "
                             f"(one per point) ({owner})")
        vel = np.zeros(3) if velocities is None else _array(velocities, "velocities", owner)
        if vel.shape not in ((3,), (self.dim,), (n, 3), (n, self.dim)):
            raise ValueError(f"EigenMPM: velocities of shape {vel.shape} is invalid; allowed: one vector or n x 3 "
                             f"with n = {n} ({owner})")
        if vel.shape[-1] == 2:
            vel = np.concatenate([vel, np.zeros(vel.shape[:-1] + (1,))], axis=-1)
        if self.dim == 2 and np.any(vel[..., 2] != 0):
            raise ValueError("EigenMPM: velocities with a non-zero z component are invalid in 2D: it does not "
                             f"apply; allowed: (vx, vy, 0) ({owner})")
        mid = self.material(material, owner)
        rho = material.rho
        with np.errstate(over="ignore"):
            mass = rho * vol
        if vol.size and not np.all(np.isfinite(mass)):
            raise ValueError(f"EigenMPM: volumes up to {float(vol.max())!r} m^3 are invalid with rho = {rho!r} "
                             f"kg/m3: the point mass overflows; allowed: volume < {sys.float_info.max / rho:.3g} "
                             f"m^3 ({owner})")
        vol = np.broadcast_to(vol.reshape(-1), (n,))
        vel = np.broadcast_to(vel, (n, 3))
        if self.referencePositions is None:  # distributed at set-up: this rank's share only
            if _share is not None:  # (fill: the positions are the share already)
                return self._addShare(pos, vel, vol, mid, _share[0], _share[1], body)
            a, b = _shareOf(n)
            return self._addShare(pos[a:b], vel[a:b], vol[a:b], mid, a, n, body)
        pos = np.ascontiguousarray(pos)
        first = self.solver.addPoints(pos, np.ascontiguousarray(vel), np.ascontiguousarray(vol), mid)
        if body:
            self.solver.setPointBodies(first, n, body)
        self.referencePositions = np.concatenate([self.referencePositions, pos])
        return np.arange(first, first + n)

    def _addShare(self, pos, vel, vol, mid, offset, total, body):
        """Adds this rank's share of `total` new points of a run distributed at set-up, the
        first being number `offset` of them. Returns the ids of all `total` points."""
        if body:
            raise ValueError(f"EigenMPM: body = {body} is invalid with distributedSetup: a distributed run "
                             "has one body (doc/parallel.md); allowed: 0 (MpmEngine.addPoints)")
        first = self.solver.addPoints(np.ascontiguousarray(pos), np.ascontiguousarray(vel),
                                      np.ascontiguousarray(vol), mid, offset, total) - offset
        return np.arange(first, first + total)

    def fill(self, predicate, material, velocity=(0, 0, 0), body=0):
        """Fills a ``yade.pack`` predicate (or any callable ``pred(point, pad)``) with points on
        the regular lattice of ppc points per cell per direction, aligned with the grid (points at
        cell fractions (i + 1/2)/ppc). In 2D the predicate is evaluated in the plane z = middle of
        its bounding box (z = 0 if unbounded). Points of different `body` ids (0-63) do not bond:
        they touch, with bodyFriction, and separate (doc/contact.md). Returns the ids of the new
        points."""
        from .builders import latticePoints
        owner = "MpmEngine.fill"
        _MATERIAL.validate(material, owner)
        _BODY.validate(body, owner)
        velocity = _VELOCITY.validate(velocity, owner)
        _planar(velocity, "velocity", self.dim, owner)
        vol = (self.h / self.ppc) ** self.dim * (self.thickness if self.dim == 2 else 1.0)
        if not (math.isfinite(vol) and vol >= sys.float_info.min):
            raise ValueError(f"EigenMPM: h = {self.h!r} is invalid with ppc = {self.ppc}"
                             f"{f', thickness = {self.thickness!r}' if self.dim == 2 else ''}: the point volume "
                             f"(h / ppc)^{self.dim}{' x thickness' if self.dim == 2 else ''} = {vol!r} m^3; "
                             f"allowed: a volume that is finite and not below {sys.float_info.min:.3g} ({owner})")
        if self.referencePositions is None:  # distributed at set-up: this rank's share of the lattice
            pos, offset, total = _latticeShare(predicate, self.h, self.ppc, self.dim)
        else:
            pos = latticePoints(predicate, self.h, self.ppc, self.dim)
            offset, total = 0, len(pos)
        if total == 0:
            raise ValueError(f"EigenMPM: the predicate {predicate!r} holds no lattice point at h = "
                             f"{self.h}, ppc = {self.ppc}; check its extent")
        return self.addPoints(pos, material, vol, velocity, body, _share=(offset, total))

    def pointsIn(self, predicate, pad=0.0):
        """Ids of the points whose current position satisfies ``predicate(x, pad)``. Under
        mpiexec, once the points are distributed, the ids of every rank's (every rank must call it)."""
        from .builders import select
        mine = select(self.solver.positions(), predicate, pad, self.dim)
        if self.solver.ranks == 1:
            return mine
        return parallel.allIds(np.asarray(self.solver.globalIds())[mine])

    def referenceOfPoints(self):
        """Where each of this process's points (the rows of solver.positions()) was added, n x 3 (m)."""
        s = self.solver
        if self.referencePositions is None:
            return np.asarray(s.referencePositions())
        x0 = self.referencePositions
        return x0[s.globalIds()] if s.ranks > 1 else x0

    def referenceOf(self, ids):
        """Where the points with these ids (in the one-process scene, e.g. the eroded points of
        EigenErosion.core.events()) were added, one row each (m), on every rank. Under mpiexec
        with distributedSetup, only these points' rows travel between the ranks, and every rank
        must call it; otherwise it is referencePositions[ids]."""
        if self.referencePositions is not None:
            return self.referencePositions[np.asarray(ids, dtype=np.int64)]
        return parallel.valuesOf(self, ids, self.solver.referencePositions())

    def numPoints(self):
        """The points of the whole scene (under mpiexec: of every rank)."""
        return int(self.solver.numGlobalPoints) if self.solver.ranks > 1 else len(self.solver.positions())

    def nodesIn(self, predicate, pad=None):
        """Indices of the grid nodes inside ``predicate``; pad defaults to -1e-6 h, so nodes on the
        region's faces count as inside."""
        from .builders import nodeBox, select
        pad = -1e-6 * self.h if pad is None else pad
        box = nodeBox(self.solver, self.h, predicate, pad, self.dim)
        if box is None:  # (no bounds to narrow the search)
            return select(self.solver.nodePositions(), predicate, pad, self.dim)
        index, x = box
        return index[select(x, predicate, pad, self.dim)]

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
            which, sel = ("region", region) if region is not None else ("points", points)
            raise ValueError(f"EigenMPM: {which} = {sel!r} selects no {'node' if region is not None else 'point'} "
                             f"of MpmEngine {self.label!r}; allowed: a selection holding one at least (check its "
                             "extent) (MpmEngine.velocityBC)")
        mask = _mask(components or "xyz"[:self.dim], self.dim)
        v0 = (0.0, 0.0, 0.0) if callable(velocity) else velocity
        _planar(v0, "velocity", self.dim, "MpmEngine.velocityBC")
        if label in self.bcs:
            raise ValueError(f"EigenMPM: label = {label!r} is invalid; allowed: a label no other condition of "
                             f"MpmEngine {self.label!r} has (taken: {', '.join(map(repr, self.bcs))})")
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
        _planar(traction, "traction", self.dim, "MpmEngine.traction")
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
        The crack then moves with the material. Returns the crack id. A crack that passes through
        no point's cell (h / ppc wide) gets a warning, at the first step if it is added before."""
        cid = self.solver.addCrack(vertices)
        self._cracksToCheck.append(cid)
        if self._started:
            self._checkCracks()
        return cid

    def _checkCracks(self):
        """Warns of each crack to check that cuts no material: none of the points' cells (of
        width h / ppc about each point) meets it."""
        x = self.solver.positions()[:, :self.dim]
        reach = 0.5 * self.h / self.ppc * (1 + 1e-9)
        for cid in self._cracksToCheck:
            v = np.array([list(p) for p in self.solver.crackVertices(cid)])[:, :self.dim]
            near = len(x) > 0 and bool(_nearCrack(x, v, reach).any())
            if self.solver.ranks > 1:  # (any rank's points)
                near = parallel.anyRank(near)
            if not near:
                warnings.warn(f"EigenMPM: crack {cid} with vertices {v.tolist()} cuts no material: no point of "
                              f"MpmEngine {self.label!r} lies within {reach:.4g} m (half a point spacing) of "
                              "it, so it changes nothing; check its coordinates", UserWarning, stacklevel=2)
        self._cracksToCheck = []

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
        attached one is detached.

        What is attached depends only on O.engines (which engines, in which order, which are
        dead), on this engine's solver and on what it has attached. The first two change only
        through the paths watchEngines counts (_enginesVersion): while that count, the solver
        and the attachments stand, O.engines is not read and only each stage's per-step part
        runs (``beforeStep``: BodyContact reads the bodies). ``attach`` is idempotent apart from
        that part. (Inside O.run, after the step has left the interpreter's code out of the
        caches, reading O.engines and every engine's `dead` flag cost about 30 us per step,
        doc/performance.md "Session 34".) Returns the stages with an after-step part."""
        key = (_enginesVersion[0], id(self.solver), len(self.physics))
        known = _attached.get(id(self))
        if known is not None and known[1] == key and known[0]() is self:
            for e in known[2]:
                e.beforeStep(self)
            return known[3]
        engines = O.engines
        active = [e for e in engines if e is not self and callable(getattr(type(e), "attach", None))
                  and not e.dead and findEngine(e.engine) is self]
        for e in list(self.physics.values()):
            if not any(e is a for a in active):
                e.detach(self)
        for e in active:
            e.attach(self)
        key = (_enginesVersion[0], id(self.solver), len(self.physics))
        me = id(self)
        known = _attached[me] = (weakref.ref(self, lambda _, me=me: _attached.pop(me, None)), key,
                                 [e for e in active if callable(getattr(type(e), "beforeStep", None))],
                                 [e for e in self.physics.values() if callable(getattr(type(e), "afterStep", None))])
        return known[3]

    def _action(self):
        # YADE's O.run thread has no Python thread state of its own: keep the one this call made,
        # so that the PyRunner calls after it (ours and the user's) do not make and delete one
        # each (py/module.cpp, keepThreadState).
        # (This runs at every iteration, after the last step has left the interpreter's code and
        # data out of the caches: each attribute read of YADE's objects costs microseconds here,
        # so each is read once. doc/performance.md, "Session 33".)
        _eigenmpm.keepThreadState()
        after = self._syncPhysics()
        solver = self.solver
        if not self._started:
            self._started = True
            self._checkCracks()
            if parallel.worldSize() > 1 and solver.steps == 0 and solver.ranks == 1:  # mpiexec -n N
                solver.distribute(self.rankColumns)
        # O.iter going back behind this solver means the scene was reloaded without its EigenMPM
        # state (eigenmpm.state): stepping on would continue from a later state, silently wrong.
        # (Forward skips happen: YADE resumes an iteration after an engine that raised.)
        now = O.iter
        if self._lastIter is not None and now <= self._lastIter:
            raise RuntimeError(f"EigenMPM: MpmEngine {self.label!r} last stepped at iteration "
                               f"{self._lastIter} (solver step {solver.steps}) but YADE is at "
                               f"iteration {now}: the scene went back without its EigenMPM state "
                               "(load it with O.load/O.loadTmp after importing eigenmpm, or rebuild it)")
        vars(self)["_lastIter"] = now  # (not through the declared parameters' __setattr__: every step)
        t = O.time
        for bc in self.bcs.values():
            bc._update(t)
        threads = self.threads or _numThreads()
        if parallel.worldSize() > 1 and solver.ranks > 1:  # (a solver of several ranks runs under mpiexec)
            solver.setRebalance(float(self.rebalance), int(self.rebalancePeriod))
        try:
            solver.stepAt(t, O.dt, int(threads))  # (solver.time = t, then the step)
        except Exception as err:
            engines = O.engines
            for rec in self.recorders:
                if any(rec is e for e in engines) and not rec.dead:
                    rec.onFailure(self, err)
            raise
        for phys in after:  # e.g. BodyContact: the forces on YADE's bodies
            phys.afterStep(self)
        if parallel.worldSize() > 1 and parallel.agreeOnStop():  # a signal on any rank: all stop here
            O.pause()

    def _restored(self):
        """After eigenmpm.state restored this engine: materials are keyed by object identity,
        and the objects are new."""
        self._materials = {id(mat): (mat, i) for mat, i in self._materials.values()}
        if self.solver.distributedPart:  # this rank's part of a run under mpiexec: resume it
            self.solver.distribute()

    # --- diagnostics ----------------------------------------------------------------------
    def kineticEnergy(self):
        """Sum of m v^2 / 2 over the points, J."""
        return self.solver.kineticEnergy()

    def elasticEnergy(self):
        """Sum of V (c psi+ + psi-) over the points (paper Eq 32), J."""
        return self.solver.elasticEnergy()

    def kineticEnergyAtStep(self):
        """Kinetic energy at the time level of elasticEnergy() (the last step's t^n), J: sum
        m v^{n-1/2} . v^{n+1/2} / 2 (plus the affine part with transfer='APIC'); 0 before a step."""
        return self.solver.kineticEnergyAtStep()

    def externalWork(self):
        """Work done on the body so far by the velocity conditions' reactions, the tractions and
        gravity, J."""
        return self.solver.externalWork()

    def linearMomentum(self):
        """Total momentum sum m v, kg m/s (a Vector3; z = 0 in 2D)."""
        return _vector(self.solver.linearMomentum())

    def angularMomentum(self):
        """Total angular momentum about the origin, kg m2/s (a Vector3; in 2D only z), with the
        points' affine part when transfer='APIC'."""
        return _vector(self.solver.angularMomentum())

    def energyBalance(self):
        """The energies at one time level (the last step's t^n), J: kinetic 'Ek', elastic 'Ee',
        dissipated by the physics engines 'Ef' (eigenerosion, Eq 33), external work 'Wext', and
        'balance' = Ek + Ee + Ef - Wext, which a conservative scheme keeps at its initial value."""
        return self._balance(self.elasticEnergy())

    def _balance(self, ee):
        """energyBalance with the elastic energy ee given (plotData has it from one pass)."""
        ek, w = self.kineticEnergyAtStep(), self.externalWork()
        ef = sum(p.dissipatedEnergy() for p in self.physics.values() if hasattr(p, "dissipatedEnergy"))
        return {"Ek": ek, "Ee": ee, "Ef": ef, "Wext": w, "balance": ek + ee + ef - w}

    def plotData(self):
        """Scalars for ``yade.plot.addData``, keys prefixed with the engine's label: kinetic
        energy of the point velocities 'Ek' (half step) and elastic energy 'Ee' (J); the energy
        balance at one time level (energyBalance): 'EkStep', 'Wext' and 'balance' (J); the
        total momentum 'Px', 'Py'[, 'Pz'] and angular momentum 'Lz' (2D) or 'Lx', 'Ly', 'Lz' (3D);
        the reaction force components (N) of every velocity condition; then the physics
        engines' own (EigenErosion: 'Ef', 'eroded', 'front')."""
        # (the sums over the points in one pass: solver.diagnostics(), bitwise the four functions')
        ek, ee, p, l = self.solver.diagnostics()
        L, b = self.label, self._balance(ee)
        d = {f"{L}_Ek": ek, f"{L}_Ee": b["Ee"], f"{L}_EkStep": b["Ek"], f"{L}_Wext": b["Wext"],
             f"{L}_balance": b["balance"]}
        for k in range(self.dim):
            d[f"{L}_P{'xyz'[k]}"] = p[k]
        for k in ((2,) if self.dim == 2 else (0, 1, 2)):
            d[f"{L}_L{'xyz'[k]}"] = l[k]
        for name, bc in self.bcs.items():
            r = self.solver.reaction(bc.id)
            for k in range(self.dim):
                d[f"{L}_{name}_R{'xyz'[k]}"] = r[k]
        for phys in self.physics.values():
            d.update(phys.plotData())
        return d

    def setVelocityGradient(self, ids, gradient):
        """transfer='APIC': sets the affine velocity (velocity gradient, 1/s) the points `ids`
        carry, e.g. that of their initial velocity field, so that the first transfer carries it
        exactly. `gradient`: one 3x3 matrix (or DxD) for all, or one per point."""
        ids = np.asarray(ids, dtype=int).ravel()
        g = np.asarray(gradient, dtype=float)
        if g.shape in ((2, 2), (3, 3)):
            g = np.broadcast_to(g, (len(ids),) + g.shape)
        if g.ndim != 3 or g.shape[0] != len(ids) or g.shape[1] != g.shape[2] or g.shape[1] not in (self.dim, 3):
            raise ValueError(f"EigenMPM: gradient of shape {g.shape} is invalid; allowed: a {self.dim}x{self.dim} "
                             f"(or 3x3) matrix, or one per point: {len(ids)} x 3 x 3 (MpmEngine.setVelocityGradient)")
        full = np.zeros((len(ids), 3, 3))
        full[:, :g.shape[1], :g.shape[2]] = g
        if self.dim == 2 and np.any(full[:, 2, :] != 0) or np.any(full[:, :, 2] != 0) and self.dim == 2:
            raise ValueError("EigenMPM: a gradient with z components is invalid in 2D; allowed: a 2x2 matrix "
                             "(MpmEngine.setVelocityGradient)")
        self.solver.setVelocityGradients([int(i) for i in ids], np.ascontiguousarray(full.reshape(len(ids), 9)))


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

    @property
    def function(self):
        """The function (or callable object) it calls: after a load or a resume, the restored
        recorder of an example."""
        return self._function

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


def _shareOf(n):
    """This rank's share [a, b) of n new points of a run distributed at set-up: contiguous,
    nearly equal (the first step sends every point to the rank of its strip)."""
    r, size = parallel.rank(), parallel.worldSize()
    return n * r // size, n * (r + 1) // size


def _latticeShare(predicate, h, ppc, dim):
    """fill()'s lattice points of this rank's share of the candidates (the lattice of the
    predicate's box, in latticePoints' order), the number of points the ranks before it keep,
    and the number all keep: each rank evaluates the predicate on its share only."""
    from .builders import latticePoints
    size = parallel.worldSize()
    pos = latticePoints(predicate, h, ppc, dim, share=(parallel.rank(), size))
    counts = parallel.allCounts(len(pos))
    return pos, int(sum(counts[:parallel.rank()])), int(sum(counts))


def _nearCrack(x, v, reach):
    """Mask of the points x (n x dim) within `reach` of the crack with vertices v: a polyline in
    2D, a planar polygon in 3D."""
    if x.shape[1] == 2:
        near = np.zeros(len(x), bool)
        for a, b in zip(v[:-1], v[1:]):
            ab = b - a
            t = np.clip((x - a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
            near |= np.sum((x - a - t[:, None] * ab) ** 2, axis=1) <= reach * reach
        return near
    # 3D: the normal by Newell's method; points near the plane whose projection lies inside the
    # polygon, or near one of its edges.
    n = np.sum([np.cross(p, q) for p, q in zip(v, np.roll(v, -1, axis=0))], axis=0)
    n = n / max(np.linalg.norm(n), 1e-300)
    e1 = v[1] - v[0]
    e1 = e1 / max(np.linalg.norm(e1), 1e-300)
    e2 = np.cross(n, e1)
    near = np.abs((x - v[0]) @ n) <= reach
    u, w = (x - v[0]) @ e1, (x - v[0]) @ e2
    pu, pw = (v - v[0]) @ e1, (v - v[0]) @ e2
    inside = np.zeros(len(x), bool)
    for k in range(len(v)):
        u0, w0, u1, w1 = pu[k], pw[k], pu[k - 1], pw[k - 1]
        crosses = (w0 > w) != (w1 > w)
        with np.errstate(divide="ignore", invalid="ignore"):
            inside ^= crosses & (u < u0 + (w - w0) * (u1 - u0) / (w1 - w0))
    edges = np.zeros(len(x), bool)
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        ab = b - a
        t = np.clip((x - a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
        edges |= np.sum((x - a - t[:, None] * ab) ** 2, axis=1) <= reach * reach
    return (near & inside) | edges
