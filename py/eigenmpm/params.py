"""Parameters declared once: name, default, unit, allowed values and docstring.

An engine or material lists its parameters in a ``params`` tuple of :class:`Param`; a method or
a function declares its arguments with :func:`takes`. A parameter that means the same elsewhere
reuses the declaration (:func:`declared`, :meth:`Param.replace`). From that one declaration come
- the validation: :func:`apply` / :func:`values` check every value before anything is built
  and fail with ``EigenMPM: <name> = <value> is invalid; allowed: <range>``, then convert it
  to a plain Python type (so numpy scalars and YADE vectors are accepted); an assignment
  ``obj.name = value`` afterwards is checked the same way (:func:`declare`), and refused for a
  parameter declared ``fixed`` (one the object was built from);
- the docstring (:func:`declare`, :func:`takes`), so ``help(eigenmpm.MpmEngine)`` shows the table;
- the reference pages ``doc/reference/<Name>.md`` (``tools/paramdoc.py``).
The C++ core takes every value from here and has no defaults of its own.
"""
import functools
import inspect
import math
import numbers
import re
import weakref

import numpy as np

KINDS = ("float", "int", "bool", "str", "vector", "box", "points", "object")

_INTERVAL = re.compile(r"^\s*([\[(])\s*([^,\s]+)\s*,\s*([^,\s]+)\s*([\])])\s*$")


def _fmt(x):
    """A bound as written by hand: 0, 0.5, 64, 1e-14."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else repr(float(x))


def _shown(value):
    """repr of a value, with numpy scalars shown as the Python number they hold."""
    if hasattr(value, "item") and getattr(value, "shape", None) == ():
        return repr(value.item())
    return repr(value)


class Param:
    """One user parameter.

    Param(name, default, unit, doc, kind=None, bounds=None, choices=None, required=False,
          function=False, accepts=None, check=None, fixed=False, keywords=None)

    name      the keyword the user writes
    default   the value when the keyword is not given; None means "automatic" (the doc says
              what that is) unless `required`
    unit      SI unit ('' for none)
    doc       one sentence or two: what it is, what it changes
    kind      one of KINDS; inferred from the default when it is a bool, int, float, str or a
              tuple of numbers (vector)
                float   finite real number (numpy scalars accepted) -> float
                int     integer (an integral float such as 2.0 too, never 2.7) -> int
                bool    True or False (numpy bool accepted) -> bool
                str     a string; with `choices` matched case-insensitively -> the declared spelling
                vector  2 or 3 finite components (Vector3, tuple, list, array) -> 3-tuple of floats
                box     (lo, hi), two vectors -> (3-tuple, 3-tuple)
                points  a list of vectors -> list of 3-tuples
                object  anything `check` accepts (an engine, a predicate, ids, a stream)
    bounds    interval of a number, written "(0, inf)", "[1, 64]", "(-1, 0.5)", "[0, 1)":
              round brackets are open ends, square ones closed
    choices   the allowed values (strings compared case-insensitively)
    required  no default: the user must give it
    function  a function may be given instead (e.g. velocity(t)); it is kept as is
    accepts   the allowed values in words, where bounds and choices do not say it
    check     function(value) -> bool, for `object` and for rules the kind cannot express
    fixed     the object is built from the value (a solver, a law's constants): assigning it
              after construction raises AttributeError instead of being silently ignored
    keywords  strings a number may be replaced by (matched case-insensitively -> the declared
              spelling), e.g. alpha = 'griffith': a value computed by the object itself

    A parameter named ``label`` is a YADE label, a name the user looks the object up by: when
    its default is taken by a live object, the default becomes the first free one of label1,
    label2, ... (see :func:`apply`).
    """

    def __init__(self, name, default, unit, doc, kind=None, bounds=None, choices=None, required=False,
                 function=False, accepts=None, check=None, fixed=False, keywords=None):
        self._declared = dict(name=name, default=default, unit=unit, doc=doc, kind=kind, bounds=bounds,
                              choices=choices, required=required, function=function, accepts=accepts,
                              check=check, fixed=fixed, keywords=keywords)
        self.keywords = tuple(keywords) if keywords else ()
        self.name, self.default, self.unit, self.doc = name, default, unit, doc
        self.fixed, self.unique = fixed, name == "label"
        self.kind = kind or self._inferKind(default)
        if self.kind not in KINDS:
            raise ValueError(f"Param {name}: kind {self.kind!r} is not one of {KINDS}")
        self.required, self.function, self.accepts, self.checker = required, function, accepts, check
        self.choices = tuple(choices) if choices is not None else None
        self.bounds = self._parseBounds(bounds) if bounds is not None else None
        if self.bounds and self.kind not in ("float", "int"):
            raise ValueError(f"Param {name}: bounds need kind float or int, not {self.kind}")
        if required and default is not None:
            raise ValueError(f"Param {name}: a required parameter has no default")
        if self.kind == "object" and check is None:
            raise ValueError(f"Param {name}: kind object needs check=")
        if default is not None:
            self.default = self.validate(default, f"declaration of {name}")  # a bad default fails at import

    def replace(self, **changes):
        """The same declaration with some fields changed, for a parameter that means the same
        elsewhere: e.g. ``nu.replace(default=None, required=True)`` or ``.replace(name='fraction')``.
        The kind stays that of this declaration."""
        return Param(**dict(self._declared, kind=self.kind, **changes))

    @staticmethod
    def _inferKind(default):
        if isinstance(default, bool):
            return "bool"
        if isinstance(default, numbers.Integral):
            return "int"
        if isinstance(default, numbers.Real):
            return "float"
        if isinstance(default, str):
            return "str"
        if isinstance(default, tuple):
            return "vector"
        raise ValueError(f"Param: give kind= for a default of {default!r}")

    def _parseBounds(self, text):
        m = _INTERVAL.match(text)
        if not m:
            raise ValueError(f"Param {self.name}: bounds {text!r} is not an interval like '(0, inf)' or '[1, 64]'")
        lo, hi = float(m.group(2)), float(m.group(3))
        if not lo < hi:
            raise ValueError(f"Param {self.name}: bounds {text!r} is empty")
        return lo, m.group(1) == "[", hi, m.group(4) == "]"

    # --- the allowed values in words ---------------------------------------------------------
    def rangeText(self):
        """The allowed values as the messages and the docs write them, e.g. '-1 < nu < 0.5'."""
        if self.accepts:
            return self.accepts
        if self.choices is not None:
            *first, last = [repr(c) for c in self.choices]
            text = f"{', '.join(first)} or {last}" if first else last
            return text + " (any case)" if self.kind == "str" else text
        if self.bounds:
            lo, loIn, hi, hiIn = self.bounds
            n = self.name
            if math.isinf(hi):
                text = f"{n} {'>=' if loIn else '>'} {_fmt(lo)}"
            elif math.isinf(lo):
                text = f"{n} {'<=' if hiIn else '<'} {_fmt(hi)}"
            else:
                text = f"{_fmt(lo)} {'<=' if loIn else '<'} {n} {'<=' if hiIn else '<'} {_fmt(hi)}"
            return f"integer, {text}" if self.kind == "int" else text
        return {"float": "finite number", "int": "integer", "bool": "True or False", "str": "string",
                "vector": "vector of 2 or 3 finite components", "box": "(lo, hi), two vectors",
                "points": "list of vectors"}[self.kind]

    def allowed(self):
        """rangeText plus the alternatives: keywords, None (automatic) and a function."""
        text = self.rangeText()
        for k in self.keywords:
            text += f", or {k!r}"
        if self.function:
            text += ", or a function of time returning one"
        if self.default is None and not self.required:
            text += ", or None"
        return text

    # --- validation --------------------------------------------------------------------------
    def _refuse(self, value, owner, error=ValueError):
        unit = f" [{self.unit}]" if self.unit else ""
        raise error(f"EigenMPM: {self.name} = {_shown(value)} is invalid; allowed: {self.allowed()}{unit} "
                    f"({owner})")

    def validate(self, value, owner):
        """The value converted to a plain Python type; ValueError or TypeError naming the parameter,
        the value and the allowed range when it is not allowed."""
        if value is None:
            if self.default is None and not self.required:
                return None
            self._refuse(value, owner, TypeError)
        if self.function and callable(value):
            return value
        if self.keywords and isinstance(value, str):
            for k in self.keywords:
                if value.lower() == k.lower():
                    return k
            self._refuse(value, owner, TypeError)  # another string where a number is meant
        v = getattr(self, "_" + self.kind)(value, owner)
        if self.choices is not None:
            v = self._choose(v, value, owner)
        if self.bounds:
            lo, loIn, hi, hiIn = self.bounds
            if not ((lo <= v if loIn else lo < v) and (v <= hi if hiIn else v < hi)):
                self._refuse(value, owner)
        if self.checker is not None and not self.checker(v):
            self._refuse(value, owner, TypeError if self.kind == "object" else ValueError)
        return v

    def _choose(self, v, value, owner):
        for c in self.choices:
            if v == c or (isinstance(v, str) and v.lower() == c.lower()):
                return c
        self._refuse(value, owner)

    def _float(self, value, owner):
        if isinstance(value, str) or _isBool(value) or not isinstance(value, numbers.Real):
            self._refuse(value, owner, TypeError)
        v = float(value)
        if not math.isfinite(v):
            self._refuse(value, owner)
        return v

    def _int(self, value, owner):
        if isinstance(value, str) or _isBool(value) or not isinstance(value, numbers.Real):
            self._refuse(value, owner, TypeError)
        if isinstance(value, numbers.Integral):
            return int(value)
        v = float(value)
        if not (math.isfinite(v) and v.is_integer()):
            self._refuse(value, owner)
        return int(v)

    def _bool(self, value, owner):
        if not _isBool(value):
            self._refuse(value, owner, TypeError)
        return bool(value)

    def _str(self, value, owner):
        if not isinstance(value, str):
            self._refuse(value, owner, TypeError)
        return str(value)

    def _sequence(self, value, owner):
        """The items of a list-like value; a string or a scalar is refused (TypeError)."""
        if isinstance(value, str):
            self._refuse(value, owner, TypeError)
        try:
            return list(value)
        except TypeError:
            self._refuse(value, owner, TypeError)

    def _vector(self, value, owner):
        items = self._sequence(value, owner)
        if len(items) not in (2, 3):
            self._refuse(value, owner)
        if any(isinstance(c, str) or _isBool(c) or not isinstance(c, numbers.Real) for c in items):
            self._refuse(value, owner, TypeError)
        if not all(math.isfinite(c) for c in items):
            self._refuse(value, owner)
        return tuple(float(c) for c in items) + (0.0,) * (3 - len(items))

    def _box(self, value, owner):
        try:
            lo, hi = value
        except (TypeError, ValueError):
            self._refuse(value, owner, TypeError)
        return self._whole(value, owner, lambda: (self._vector(lo, owner), self._vector(hi, owner)))

    def _points(self, value, owner):
        items = self._sequence(value, owner)
        return self._whole(value, owner, lambda: [self._vector(p, owner) for p in items])

    def _whole(self, value, owner, convert):
        """convert(), refused in the name of the whole value (not of the one vector that failed)."""
        try:
            return convert()
        except (TypeError, ValueError) as err:
            self._refuse(value, owner, type(err))

    def _object(self, value, owner):
        return value

    # --- documentation -----------------------------------------------------------------------
    def defaultText(self):
        return "required" if self.required else repr(self.default)

    def notes(self):
        """What the declaration adds to the doc: a default label made unique, a fixed value."""
        out = []
        if self.unique:
            out.append(f"A default already taken by a live object becomes {self.default!r}1, "
                       f"{self.default!r}2, ...")
        if self.fixed:
            out.append("Fixed once built: assigning it later is refused.")
        return " ".join(out)

    def line(self):
        unit = f" [{self.unit}]" if self.unit else ""
        notes = f" {self.notes()}" if self.notes() else ""
        return f"{self.name} = {self.defaultText()}{unit}; allowed: {self.allowed()}\n    {self.doc}{notes}"


def _isBool(value):
    return isinstance(value, (bool, np.bool_))


def _documented(doc, params):
    """A docstring followed by the parameter table."""
    return (inspect.cleandoc(doc or "") + "\n\nParameters (name = default [unit]; allowed):\n"
            + "\n".join(p.line() for p in params) + "\n")


def _signature(params, first=(), positional=0):
    """The signature: `first` (e.g. self), then the parameters, the first `positional` of them
    by position or keyword, the others by keyword only."""
    P = inspect.Parameter
    return inspect.Signature(list(first) + [
        P(p.name, P.POSITIONAL_OR_KEYWORD if i < positional else P.KEYWORD_ONLY,
          default=P.empty if p.required else p.default) for i, p in enumerate(params)])


def declare(cls):
    """Builds the class docstring (the text before the table is kept as ``cls.description`` for
    the reference pages) and the signature help() shows from ``cls.params`` (keywords, except the
    first ``cls.positional``, default 0, which may also be given by position and are then validated
    by :func:`arguments`), and makes every
    assignment of a declared parameter (``obj.ppc = 3``) go through its declaration: validated
    and converted as in the constructor, and refused for a fixed one once it is set."""
    cls.description = inspect.cleandoc(cls.__doc__ or "")
    cls.__doc__ = _documented(cls.__doc__, cls.params)
    cls.__signature__ = _signature(cls.params, positional=getattr(cls, "positional", 0))
    declared = {p.name: p for p in cls.params}
    owner = cls.__name__

    def __setattr__(self, name, value):
        p = declared.get(name)
        if p is not None:
            if p.fixed and name in vars(self):
                raise AttributeError(f"EigenMPM: {name} = {_shown(value)} cannot be assigned; {name} is fixed "
                                     f"once the {owner} is built (it is {getattr(self, name)!r}): build a new "
                                     f"{owner} with {name}={_shown(value)} ({owner})")
            value = p.validate(value, owner)
        super(cls, self).__setattr__(name, value)

    cls.__setattr__ = __setattr__
    return cls


def declared(owner, name):
    """The declaration of parameter `name` of `owner` (a declared class, or a method or function
    declared with :func:`takes`), to reuse it where a parameter means the same."""
    for p in owner.params:
        if p.name == name:
            return p
    raise KeyError(f"{getattr(owner, '__qualname__', owner)} declares no parameter {name!r}")


def values(params, kwargs, owner):
    """Every declared parameter from kwargs or its default, validated and converted; unknown
    names raise TypeError, a missing required one TypeError, a bad value ValueError/TypeError."""
    names = {p.name for p in params}
    unknown = [k for k in kwargs if k not in names]
    if unknown:
        raise TypeError(f"EigenMPM: unknown parameter(s) {', '.join(unknown)} ({owner}); "
                        f"known: {', '.join(sorted(names))}")
    out = {}
    for p in params:
        if p.name not in kwargs:
            if p.required:
                raise TypeError(f"EigenMPM: {p.name} is required ({owner}): {p.doc}; "
                                f"allowed: {p.allowed()}" + (f" [{p.unit}]" if p.unit else ""))
            out[p.name] = p.default
        else:
            out[p.name] = p.validate(kwargs[p.name], owner)
    return out


# The live objects with a label (weakly: an object no one holds frees its label), for the
# default labels. An engine whose scene was reset is marked `_released` and frees its label too,
# as does an engine of a scene that a load replaced (`_sceneEnded`, engines._sceneReplaced),
# unless it is in O.engines again.
_labelled = weakref.WeakSet()


def _labelsInUse():
    objs = list(_labelled)
    ended = [getattr(o, "_released", False) or getattr(o, "_sceneEnded", False) for o in objs]
    if any(ended):  # (only YADE's engines are released or ended)
        from yade import O
        scene = {id(e) for e in O.engines}
        objs = [o for o, gone in zip(objs, ended) if not gone or id(o) in scene]
    return {o.label for o in objs}


def freeLabel(default):
    """`default`, or if a live object has it, the first of default1, default2, ... that none has."""
    taken = _labelsInUse()
    if default not in taken:
        return default
    return next(f"{default}{k}" for k in range(1, len(taken) + 2) if f"{default}{k}" not in taken)


def apply(obj, params, kwargs, owner):
    """Sets every declared parameter on obj from kwargs or its default (see :func:`values`). A
    default label already used by a live object is replaced by a free one (:func:`freeLabel`), so
    that two engines built with defaults can be told apart (YADE binds each label to a name)."""
    given = values(params, kwargs, owner)
    for p in params:
        v = given[p.name]
        if p.unique and p.name not in kwargs and v is not None:
            v = freeLabel(v)
        setattr(obj, p.name, v)
    if any(p.unique for p in params):
        _labelled.add(obj)


def arguments(params, args, kwargs, owner, positional=None):
    """:func:`values` of arguments given by position (the first `positional` of params, default
    all, in the declared order) and by keyword."""
    positional = len(params) if positional is None else positional
    if len(args) > positional:
        raise TypeError(f"EigenMPM: {owner} takes {positional} positional argument(s), {len(args)} given")
    given = dict(zip([p.name for p in params], args))
    twice = [k for k in kwargs if k in given]
    if twice:
        raise TypeError(f"EigenMPM: {owner} got {', '.join(twice)} twice")
    given.update(kwargs)
    return values(params, given, owner)


def takes(*params):
    """Declares the arguments of a method (its first argument is ``self``) or of a function: its
    signature (in the order given, so required ones first; by position or keyword), the
    validation and conversion of every argument before the body runs, and the parameter table in
    its docstring. The method or function is written without defaults."""
    def wrap(body):
        owner = body.__qualname__
        P = inspect.Parameter
        if next(iter(inspect.signature(body).parameters), None) == "self":
            def call(self, *args, **kwargs):
                return body(self, **arguments(params, args, kwargs, owner))
            first = [P("self", P.POSITIONAL_OR_KEYWORD)]
        else:
            def call(*args, **kwargs):
                return body(**arguments(params, args, kwargs, owner))
            first = []
        call = functools.wraps(body)(call)
        call.__signature__ = _signature(params, first, positional=len(params))
        call.params = params
        call.description = inspect.cleandoc(body.__doc__ or "")
        call.__doc__ = _documented(body.__doc__, params)
        return call
    return wrap


def vec3(v, what):
    """A 3-tuple of floats from YADE's Vector3, a tuple, a list or a numpy array (2 or 3 long),
    for values computed while running (e.g. velocity(t)); parameters use Param(kind='vector')."""
    try:
        items = [float(c) for c in v]
    except TypeError:
        raise TypeError(f"EigenMPM: {what} must be a vector (Vector3, tuple or list), got {v!r}") from None
    if len(items) not in (2, 3):
        raise ValueError(f"EigenMPM: {what} = {v!r} is invalid; allowed: 2 or 3 components")
    return tuple(items + [0.0] * (3 - len(items)))
