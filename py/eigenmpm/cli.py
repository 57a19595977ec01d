"""Command line of the example scripts: ``[--quick] [--out DIR] [name=value ...]``, and the
parameter tables of ``yade-batch`` (``readParamsFromTable``).

Precedence, lowest first: the script's defaults, its quick-mode values (``--quick`` or a table
column ``quick`` set to 1), a yade-batch table line, then ``name=value`` on the command line.
Under yade-batch the output goes to ``DIR/<description of the table line>``.
"""
import os
import sys


def scriptArgs(name, defaults, quick=None, argv=None, out=None):
    """Returns (params, outDir, quick) for the example `name` with the given defaults (a dict
    name -> value; the type of each default converts the value given) and quick-mode values."""
    argv = sys.argv[1:] if argv is None else list(argv)
    quick = quick or {}
    outDir = out or os.path.join("out", name)
    isQuick, given = False, {}
    it = iter(argv)
    for a in it:
        if a == "--quick":
            isQuick = True
        elif a == "--out":
            try:
                outDir = next(it)
            except StopIteration:
                raise SystemExit(f"{name}: --out needs a directory") from None
        elif "=" in a:
            k, v = a.split("=", 1)
            if k not in defaults:
                raise SystemExit(f"{name}: unknown parameter {k}; known: {', '.join(sorted(defaults))}")
            given[k] = _convert(defaults[k], v, k, name)
        else:
            raise SystemExit(f"{name}: unknown argument {a!r}; usage: [--quick] [--out DIR] [name=value ...]")
    table = _batchTable(defaults)
    if table.get("quick"):
        isQuick = True
    params = dict(defaults)
    if isQuick:
        params.update(quick)
    params.update({k: v for k, v in table.items() if k != "quick"})
    params.update(given)
    if os.environ.get("YADE_BATCH"):
        from yade import O
        outDir = os.path.join(outDir, _tag(O, "description", "batch").replace("/", "_"))
    return params, outDir, isQuick


def _convert(default, text, key, name):
    try:
        if isinstance(default, bool):
            return text.lower() in ("1", "true", "yes")
        return type(default)(text)
    except ValueError:
        raise SystemExit(f"{name}: {key} = {text!r} is not a {type(default).__name__}") from None


def _batchTable(defaults):
    """Explicitly assigned values of the yade-batch table line ({} outside yade-batch)."""
    if not os.environ.get("YADE_BATCH"):
        return {}
    from yade import O
    from yade.utils import readParamsFromTable
    readParamsFromTable(noTableOk=True, quick=0, **defaults)
    from yade.params import table
    assigned = [kv.split("=", 1)[0] for kv in _tag(O, "params", "").split(",") if "=" in kv]
    return {k: getattr(table, k) for k in assigned}


def _tag(O, key, default):
    """O.tags[key], or default (O.tags is not a dict: it has no get)."""
    try:
        return O.tags[key]
    except KeyError:
        return default


def runSteps(steps):
    """O.run(steps, True) that keeps what was computed when the solver stops the run with an
    error (a point leaving the grid, a non-finite value): it prints the message and returns it,
    so the example can still write its summary and figures. Returns None after a normal run."""
    from yade import O
    try:
        O.run(steps, True)
    except RuntimeError as err:
        message = str(err).split("ERROR:")[-1].split("STACK TRACE:")[0].strip()
        print("run stopped early:", message, flush=True)
        return message
    return None
