"""Parameters declared once: name, default, unit and docstring.

Engines list their parameters in a ``params`` tuple; :func:`declare` builds the class
docstring from it (so ``help(eigenmpm.MpmEngine)`` and the reference in ``doc/`` agree with
the code) and :func:`apply` sets them on an instance from keyword arguments, refusing unknown
names.
"""


class Param:
    """One user parameter: its name, default value, unit (may be empty) and description."""

    def __init__(self, name, default, unit, doc):
        self.name, self.default, self.unit, self.doc = name, default, unit, doc

    def line(self):
        unit = f" [{self.unit}]" if self.unit else ""
        return f"    {self.name} = {self.default!r}{unit}\n        {self.doc}"


def declare(cls):
    """Appends the parameter table to the class docstring."""
    table = "\n".join(p.line() for p in cls.params)
    cls.__doc__ = (cls.__doc__ or "").rstrip() + "\n\n    Parameters (name = default [unit]):\n" + table + "\n"
    return cls


def apply(obj, params, kwargs, owner):
    """Sets every declared parameter from kwargs or its default; unknown names raise TypeError."""
    names = {p.name for p in params}
    unknown = [k for k in kwargs if k not in names]
    if unknown:
        raise TypeError(f"{owner}: unknown parameter(s) {', '.join(unknown)}; "
                        f"known: {', '.join(sorted(names))}")
    for p in params:
        setattr(obj, p.name, kwargs.get(p.name, p.default))


def vec3(v, what):
    """A 3-tuple of floats from YADE's Vector3, a tuple, a list or a numpy array (2 or 3 long)."""
    try:
        items = [float(c) for c in v]
    except TypeError:
        raise TypeError(f"EigenMPM: {what} must be a vector (Vector3, tuple or list), got {v!r}") from None
    if len(items) not in (2, 3):
        raise ValueError(f"EigenMPM: {what} = {v!r} is invalid; allowed: 2 or 3 components")
    return tuple(items + [0.0] * (3 - len(items)))
