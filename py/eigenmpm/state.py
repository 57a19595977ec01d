"""YADE's save and load carry the whole EigenMPM state.

``O.save``/``O.load`` and ``O.saveTmp``/``O.loadTmp`` keep YADE's own objects only: our engines
come back as plain ``PyRunner``s with their command strings and none of their state. Importing
eigenmpm wraps these four methods of ``yade.wrapper.Omega`` (at class level, so ``O`` and any
other handle get them):

- saving takes a snapshot of every EigenMPM engine in ``O.engines`` (and every ``callEvery``
  runner): each solver's whole state as bytes (``Solver::saveState``: points and all their
  fields, grid, materials, conditions, tractions, cracks at their current position, erosion
  state), and the Python state of the engines (parameters, conditions, recorders and their
  series, crack-tip histories), pickled, and ``yade.plot``'s data and plots. ``O.save(f)`` writes it beside the scene as
  ``f + '.eigenmpm'`` (written to a temporary file, then renamed); ``O.saveTmp(mark)`` keeps it
  in memory. A marker in ``O.tags`` records that the scene has a snapshot.
- loading puts the engines back in their places in ``O.engines``, with their state and YADE's
  periodic counters, so that continuing gives bitwise the results of the run that was saved.

What cannot be restored is refused loudly: at save time, a Python function that is not
importable by name (a lambda, a local function) driving a condition or a ``callEvery``, or a
grid condition with no saved form; at load time, a missing or damaged snapshot, one of another
version, or a scene whose EigenMPM engines were saved without one. ``MpmEngine`` also refuses
to step when ``O.iter`` went back behind the solver (a scene reloaded without its snapshot).
"""
import io
import json
import os
import pickle
import weakref

import yade.wrapper
from yade import O, PyRunner

from . import _eigenmpm, parallel, params

VERSION = 1
TAG = "eigenmpm"
SUFFIX = ".eigenmpm"
_tmp = {}  # O.saveTmp mark -> snapshot bytes


class StateError(RuntimeError):
    """The EigenMPM state cannot be saved or restored."""


def _engines():
    """(index in O.engines, registered object) for every EigenMPM runner in O.engines."""
    from .engines import registered
    out = []
    for i, e in enumerate(O.engines):
        obj = registered(e)
        if obj is not None:
            out.append((i, obj))
    return out


def _isSolver(x):
    return type(x) in _SOLVER_TYPES


def _isErosion(x):
    return type(x) in (_eigenmpm.Erosion2, _eigenmpm.Erosion3)


def _isContact(x):
    return type(x) in (_eigenmpm.Contact2, _eigenmpm.Contact3)


_SOLVER_TYPES = tuple(_eigenmpm.solvers.values())
_PROXIES = (weakref.ProxyType, weakref.CallableProxyType)


class _Pickler(pickle.Pickler):
    """Engines by their place, solvers as their saved bytes, erosion stages by their solver."""

    def __init__(self, f, engines, solvers):
        super().__init__(f, protocol=pickle.HIGHEST_PROTOCOL)
        self._engines = {id(obj): i for i, obj in engines}
        self._byIndex = dict(engines)
        self._solvers = solvers  # list of (solver, bytes)

    def persistent_id(self, obj):
        if type(obj) in _PROXIES:  # a weak reference to an engine (VelocityBC -> its MpmEngine)
            command = getattr(obj, "command", None)
            for i, e in self._byIndex.items():
                if command is not None and getattr(e, "command", None) == command:
                    return ("engineproxy", i)
            raise StateError(f"EigenMPM: cannot save a weak reference to {obj!r}, which is not an engine "
                             "of O.engines")
        if isinstance(obj, PyRunner) and id(obj) in self._engines:
            return ("engine", self._engines[id(obj)])
        if _isSolver(obj):
            for k, (s, _) in enumerate(self._solvers):
                if s is obj:
                    return ("solver", k)
            self._solvers.append((obj, obj.saveState()))
            return ("solver", len(self._solvers) - 1)
        if _isErosion(obj):
            for k, (s, _) in enumerate(self._solvers):
                if s.erosion is not None and s.erosion.address == obj.address:
                    return ("erosion", k)
            raise StateError("EigenMPM: cannot save an erosion stage that no saved solver holds")
        if _isContact(obj):  # refilled from O.bodies before every step: only its setting matters
            return ("contact", (type(obj) is _eigenmpm.Contact2, obj.friction))
        if type(obj) is _eigenmpm.BodyCache:  # YADE's objects of this process: read again after a load
            return ("bodycache", None)
        return None


class _Unpickler(pickle.Unpickler):
    def __init__(self, f, engines, solvers):
        super().__init__(f)
        self._engines, self._solvers = engines, solvers

    def persistent_load(self, pid):
        kind, k = pid
        if kind == "engine":
            return self._engines[k]
        if kind == "engineproxy":
            e = self._engines[k]
            return None if e is None else weakref.proxy(e)
        if kind == "solver":
            return self._solvers[k]
        if kind == "erosion":
            return self._solvers[k].erosion
        if kind == "contact":
            planar, friction = k
            return (_eigenmpm.Contact2 if planar else _eigenmpm.Contact3)(friction=friction)
        if kind == "bodycache":
            return None
        raise StateError(f"EigenMPM: the snapshot refers to an unknown object {pid!r}")


def _describe(obj):
    label = getattr(obj, "label", "")
    return f"{type(obj).__name__} {label!r}" if label else type(obj).__name__


def _picklable(entries, solvers, path, value):
    """Raises StateError naming `path` when value cannot be pickled (the first culprit)."""
    try:
        _Pickler(io.BytesIO(), entries, list(solvers)).dump(value)
    except StateError:
        raise
    except Exception as err:
        if isinstance(value, dict):
            for k, v in value.items():
                _picklable(entries, solvers, f"{path}[{k!r}]", v)
        elif isinstance(value, (list, tuple)):
            for k, v in enumerate(value):
                _picklable(entries, solvers, f"{path}[{k}]", v)
        elif hasattr(value, "__dict__") and not callable(value):
            for k, v in vars(value).items():
                _picklable(entries, solvers, f"{path}.{k}", v)
        raise StateError(f"EigenMPM: cannot save {path} = {value!r}: {err}. A function that drives "
                         "a condition or a callEvery must be importable by name (defined at the top "
                         "level of a module), not a lambda or a local function") from None


def snapshot():
    """The EigenMPM state of the scene as bytes, or None when O.engines has no EigenMPM engine."""
    entries = _engines()
    if not entries:
        return None
    table = []
    for i, obj in entries:
        if isinstance(obj, PyRunner) and obj is O.engines[i]:
            table.append((i, "engine", type(obj), dict(vars(obj))))
        else:
            table.append((i, "call", None, obj))  # a callEvery runner: its call object
    solvers = []
    buf = io.BytesIO()
    try:
        _Pickler(buf, entries, solvers).dump(table)
    except StateError:
        raise
    except Exception:
        for i, kind, _, state in table:
            owner = _describe(O.engines[i])
            if kind == "engine":
                for k, v in state.items():
                    _picklable(entries, solvers, f"{owner}.{k}", v)
            else:
                _picklable(entries, solvers, f"{owner} (callEvery)", state)
        raise
    head = json.dumps({"version": VERSION, "engines": [i for i, _ in entries]}).encode()
    out = io.BytesIO()
    pickle.dump((head, [b for _, b in solvers], buf.getvalue(), _plotState()), out,
                protocol=pickle.HIGHEST_PROTOCOL)
    return out.getvalue()


def _plotState():
    """yade.plot's series (PlotRecorder fills them; YADE's save does not keep them)."""
    from yade import plot
    return {"data": {k: list(v) for k, v in plot.data.items()}, "plots": dict(plot.plots)}


def restore(data):
    """Puts the engines of a snapshot back in O.engines (which holds plain PyRunners in their
    places after YADE's load), with their state and YADE's periodic counters."""
    from .engines import _register
    try:
        head, solverBytes, table, plotState = pickle.loads(data)
        meta = json.loads(head.decode())
    except Exception as err:
        raise StateError(f"EigenMPM: the saved EigenMPM state is damaged ({err})") from None
    if meta.get("version") != VERSION:
        raise StateError(f"EigenMPM: the saved EigenMPM state has version {meta.get('version')!r}; "
                         f"this EigenMPM reads version {VERSION}")
    engines = list(O.engines)
    if max(meta["engines"]) >= len(engines):
        raise StateError("EigenMPM: the saved EigenMPM state does not match O.engines (fewer engines)")
    solvers = [_eigenmpm.solverFromState(b) for b in solverBytes]
    # Peek at the classes, then create the engine objects so that references between them resolve.
    placeholders = {}
    classes = {}
    for i, kind, cls, _ in _Unpickler(io.BytesIO(table), _Lazy(placeholders), solvers).load():
        classes[i] = (kind, cls)
    for i, (kind, cls) in classes.items():
        loaded = engines[i]
        if kind == "engine":
            obj = cls.__new__(cls)
            PyRunner.__init__(obj)
            for name, value in loaded.dict().items():
                if name != "command":
                    setattr(obj, name, value)
            placeholders[i] = obj
        else:
            placeholders[i] = loaded
    for i, kind, cls, state in _Unpickler(io.BytesIO(table), placeholders, solvers).load():
        obj = placeholders[i]
        if kind == "engine":
            obj.__dict__.update(state)
            if any(p.unique for p in getattr(type(obj), "params", ())):
                params._labelled.add(obj)  # (its label is taken, as apply() does for a new engine)
            if hasattr(obj, "_restored"):
                obj._restored()
            obj.command = _register(obj)
        else:
            obj.command = _register(state)
        engines[i] = obj
    O.engines = engines
    from yade import plot
    plot.data = {k: list(v) for k, v in plotState["data"].items()}
    plot.plots = dict(plotState["plots"])


class _Lazy(dict):
    """Engine references during the first pass: any object (only the classes are read)."""

    def __missing__(self, key):
        return None


def _save(self, fileName, *args, **kw):
    data = snapshot()
    if data is None:
        _tags(self).pop()
        return _original["save"](self, fileName, *args, **kw)
    # Under mpiexec every rank writes its part beside the scene, and rank 0 the scene; the tag
    # names the parts with "{rank}" (doc/parallel.md).
    ranks = parallel.worldSize()
    part = "" if ranks == 1 else f".r{{rank}}of{ranks}"
    side = fileName + part.format(rank=parallel.rank()) + SUFFIX
    tmp = side + ".tmp"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, side)
    _tags(self).set(os.path.basename(fileName + part + SUFFIX))
    if not parallel.isRoot():
        return None
    return _original["save"](self, fileName, *args, **kw)


def _sceneReplaced(before):
    from .engines import _sceneReplaced as replaced
    replaced(before)


def _load(self, fileName, *args, **kw):
    before = list(O.engines)
    result = _original["load"](self, fileName, *args, **kw)
    _sceneReplaced(before)
    mark = _tags(self).get()
    if mark is None:
        _refuseOrphans(f"the file {fileName}")
        return result
    side = os.path.join(os.path.dirname(os.path.abspath(fileName)), mark.replace("{rank}", str(parallel.rank())))
    try:
        with open(side, "rb") as f:
            data = f.read()
    except OSError as err:
        raise StateError(f"EigenMPM: {fileName} was saved with its EigenMPM state in {side}, which "
                         f"cannot be read ({err.strerror}); keep the two files together") from None
    restore(data)
    return result


def _saveTmp(self, mark="", *args, **kw):
    data = snapshot()
    if data is None:
        _tags(self).pop()
        _tmp.pop(mark, None)
    else:
        _tmp[mark] = data
        _tags(self).set(f"tmp:{mark}")
    return _original["saveTmp"](self, mark, *args, **kw)


def _loadTmp(self, mark="", *args, **kw):
    before = list(O.engines)
    result = _original["loadTmp"](self, mark, *args, **kw)
    _sceneReplaced(before)
    tag = _tags(self).get()
    if tag is None:
        _refuseOrphans(f"the in-memory save {mark!r}")
        return result
    if mark not in _tmp:
        raise StateError(f"EigenMPM: the in-memory save {mark!r} has no EigenMPM state in this process")
    restore(_tmp[mark])
    return result


def _refuseOrphans(what):
    """A scene with EigenMPM runners but no snapshot (saved without eigenmpm imported, or by an
    older version) cannot continue: refuse instead of running stale engines."""
    from .engines import COMMAND_PREFIX, LEGACY_PREFIXES
    if any(isinstance(e, PyRunner) and e.command.startswith((COMMAND_PREFIX,) + LEGACY_PREFIXES) for e in O.engines):
        raise StateError(f"EigenMPM: {what} holds EigenMPM engines but no EigenMPM state (saved "
                         "without eigenmpm imported, or by an older version); rebuild the scene")


class _tags:
    """The snapshot marker in O.tags (a YADE string map without get/pop)."""

    def __init__(self, omega):
        self.o = omega

    def get(self):
        try:
            return self.o.tags[TAG] or None
        except KeyError:
            return None

    def set(self, value):
        self.o.tags[TAG] = value

    def pop(self):
        if self.get() is not None:
            self.o.tags[TAG] = ""


_original = {}


def install():
    """Wraps Omega's save, load, saveTmp and loadTmp (once)."""
    if _original:
        return
    cls = yade.wrapper.Omega
    for name, wrapper in (("save", _save), ("load", _load), ("saveTmp", _saveTmp), ("loadTmp", _loadTmp)):
        _original[name] = getattr(cls, name)
        wrapper.__doc__ = (getattr(cls, name).__doc__ or "") + "\n\nEigenMPM: carries the EigenMPM state too."
        setattr(cls, name, wrapper)
