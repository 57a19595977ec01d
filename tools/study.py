"""Speed/accuracy study: one example scene run across chosen knobs, each configuration in its
own YADE process, with its cost, its error against a reference, a table and a Pareto plot.

Run from the repository root (the study needs no YADE itself, only its runs do)::

    yade -n -x tools/study.py SCENE knob=v1,v2,... [knob=v ...] [--out DIR]
        [--reference finest|closed-form|RUN_DIR] [--cost cpu|loop|psteps] [--quick] [--rerun]
        [--timeout S] [--dry-run]
    yade -n -x tools/study.py --combine STUDY_DIR [STUDY_DIR ...] --out DIR [--cost ...]
    /usr/bin/python3.11 tools/study.py ...       # the same

The example scripts are found in the repository this file lies in (tools/..); a relative --out
is taken from the working directory by the study and from the repository root by its runs,
hence the repository root as working directory.

SCENE: ``vibrating_bar`` (or ``bar``), ``lshaped_panel`` (``lpanel``), ``crack_branching``
(``branching``). Knobs: the generic ``h`` (cell size, mm), ``ppc``, ``shape`` (linear or
uGIMP), ``kappaOverH``, ``alpha``, ``dtFraction`` (time step / critical step), where the
scene has them, and any parameter of the example script under its own name (``cells``,
``velocity_m_s``, ``endTime_us``, ...). A knob with several values is swept; every combination
of the swept values is run (full factorial). ``--quick`` passes the script's quick mode.

Each run is ``yade -n -x SCRIPT --out DIR/runs/run_NNN [--quick] name=value ...``. Its cost is
the CPU time (user + system) of that process, start-up included, taken from the kernel's
account of the finished child: the primary cost measure, because the machine may be shared
and wall time then depends on the other jobs. Wall time and the script's own particle-steps/s
(time-stepping loop only) are recorded too. ``--cost loop`` (the loop's wall time) or ``--cost
psteps`` (points x steps, machine-independent) rank and plot by those instead.

Errors (relative, dimensionless) against the reference:

- vibrating_bar: ``freq`` = |omega - omega_ref| / omega_ref, the first-mode angular frequency;
  omega_ref is the closed form (``--reference closed-form``, default) or the reference run's.
- lshaped_panel: ``peak`` = relative error of the peak load (smoothed, as in the summary);
  ``path`` = the crack path distance: the symmetric mean nearest-neighbour distance between
  the eroded points of the run and those of the reference (mean over the run's points of the
  distance to the nearest reference point and vice versa, averaged), divided by the length of
  the reference crack (its front distance from the re-entrant corner).
- crack_branching: ``branch`` = relative error of the branching time; ``energy`` = relative
  error of the dissipated energy per unit thickness (the script's plate is h thick, so its
  energies in J scale with h; they are divided by h before comparing). A run that never
  branches has no branching error (NaN, shown as "no branching").

``error`` is the largest of a scene's errors. ``finest`` is the successful run with the most
particle-steps (points x steps), which is the finest when the sweep refines h, ppc or dt;
RUN_DIR is any directory with a summary.json (and eroded.csv for the L-panel), e.g. a finer
run made separately. The reference run itself is left out of the plot (its error is 0).

Writes DIR/study.csv, DIR/study.md (table, Pareto front, the cheapest run within 1 %, 5 %,
20 %), DIR/study.json and DIR/pareto.png (error against CPU time, log axes, one panel per
error, the Pareto front highlighted). Default DIR: out/study/SCENE. Runs already made with
the same command line and the same script (its SHA-1 in run.json) are reused unless --rerun.

``--combine STUDY_DIR ... --out DIR`` puts several finished studies of one scene, all against
the same reference (e.g. an h sweep and a ppc sweep given ``--reference`` the h sweep's finest
run), into one table and plot; their runs are named SWEEP/run_NNN.
"""
import csv
import itertools
import json
import math
import os
import resource
import subprocess
import sys
import time


def _root():
    """The repository this file lies in (tools/..). Under ``yade -x`` ``__file__`` names YADE's
    launcher, so the path is taken from this code's own file name."""
    return os.path.dirname(os.path.dirname(os.path.realpath(_root.__code__.co_filename)))


ROOT = _root()
SHAPES = ("linear", "uGIMP")
GENERIC = ("h", "ppc", "shape", "kappaOverH", "alpha", "dtFraction")
TARGETS = (0.01, 0.05, 0.2)
COSTS = {"cpu": ("cpu_s", "CPU time per run (s)"),
         "loop": ("loop_wall_s", "wall time of the time-stepping loop (s)"),
         "psteps": ("particle_steps", "particle-steps (points x steps)")}


class StudyError(ValueError):
    """A bad scene, knob, value or option (the message names it and what is allowed)."""


# --- scenes ---------------------------------------------------------------------------------
def _barH(h_mm):
    cells = 1000.0 / h_mm  # the bar is L = 1 m long
    if abs(cells - round(cells)) > 1e-6 * cells or round(cells) < 1:
        raise StudyError(f"knob h = {h_mm:g} mm does not divide the bar length 1000 mm; allowed: 1000/N mm "
                         f"(N cells, e.g. 50, 25, 12.5)")
    return "cells", int(round(cells))


SCENES = {
    "vibrating_bar": dict(script="examples/verification/vibrating_bar.py", fixed=["plot=0"],
                          knobs={"h": _barH, "ppc": "ppc", "shape": "shape", "dtFraction": "dtFraction"},
                          errors=("freq",), reference="closed-form"),
    "lshaped_panel": dict(script="examples/lshaped_panel.py", fixed=[],
                          knobs={"h": "h_mm", "ppc": "ppc", "shape": "shape", "kappaOverH": "kappaOverH",
                                 "alpha": "alpha", "dtFraction": "dtFraction"},
                          errors=("peak", "path"), reference="finest"),
    "crack_branching": dict(script="examples/crack_branching.py", fixed=[],
                            knobs={"h": "h_mm", "ppc": "ppc", "shape": "shape", "kappaOverH": "kappaOverH",
                                   "alpha": "alpha", "dtFraction": "dtFraction"},
                            errors=("branch", "energy"), reference="finest"),
}
ALIASES = {"bar": "vibrating_bar", "lpanel": "lshaped_panel", "branching": "crack_branching"}
ERROR_LABELS = {"freq": "first-mode frequency", "peak": "peak load", "path": "crack path",
                "branch": "branching time", "energy": "dissipated energy per thickness"}


def scene(name):
    """The canonical scene name for `name` (or an alias)."""
    key = ALIASES.get(name, name)
    if key not in SCENES:
        raise StudyError(f"unknown scene {name!r}; allowed: {', '.join(SCENES)} "
                         f"(or {', '.join(f'{a} = {b}' for a, b in ALIASES.items())})")
    return key


def scriptDefaults(script):
    """The DEFAULTS dict of an example script, read from its source (no YADE needed)."""
    import ast
    tree = ast.parse(open(os.path.join(ROOT, script)).read())
    for node in tree.body:
        if (isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "DEFAULTS" for t in node.targets)
                and isinstance(node.value, ast.Call)):
            return {k.arg: ast.literal_eval(k.value) for k in node.value.keywords}
    raise StudyError(f"{script} has no DEFAULTS = dict(...)")


def convert(sceneName, knob, text):
    """(script parameter, value) for `knob` = `text` in the scene; StudyError naming the knob and
    the allowed values when either is bad."""
    sc = SCENES[sceneName]
    defaults = scriptDefaults(sc["script"])
    target = sc["knobs"].get(knob, knob if knob in defaults else None)
    if target is None:
        generic = [k for k in GENERIC if k in sc["knobs"]]
        missing = [k for k in GENERIC if k not in sc["knobs"]]
        raise StudyError(f"unknown knob {knob!r} for {sceneName}; allowed: {', '.join(generic)}"
                         + (f" (not {', '.join(missing)}: the scene has no fracture)" if missing else "")
                         + f", or a parameter of {sc['script']}: {', '.join(sorted(defaults))}")
    if knob == "shape" or target == "shape":
        match = [s for s in SHAPES if s.lower() == text.strip().lower()]
        if not match:
            raise StudyError(f"knob shape = {text!r} is invalid; allowed: {' or '.join(SHAPES)}")
        return "shape", match[0]
    try:
        value = float(text)
    except ValueError:
        raise StudyError(f"knob {knob} = {text!r} is not a number; allowed: " + _allowed(knob)) from None
    if not math.isfinite(value) or not _ok(knob, value):
        raise StudyError(f"knob {knob} = {text!r} is invalid; allowed: " + _allowed(knob))
    if callable(target):
        return target(value)
    default = defaults[target]
    if isinstance(default, bool):
        return target, int(value != 0)
    if isinstance(default, int):
        if value != int(value):
            raise StudyError(f"knob {knob} = {text!r} is not an integer; allowed: " + _allowed(knob))
        return target, int(value)
    return target, value


def _ok(knob, v):
    if knob == "ppc":
        return v >= 1 and v == int(v)
    if knob == "dtFraction":
        return 0 < v <= 1
    if knob in ("h", "kappaOverH", "alpha"):
        return v > 0
    return True


def _allowed(knob):
    return {"ppc": "an integer >= 1", "dtFraction": "0 < dtFraction <= 1 (of the critical step)",
            "h": "h > 0 (mm)", "kappaOverH": "kappaOverH > 0", "alpha": "alpha > 0"}.get(knob, "a number")


def configurations(sceneName, knobArgs):
    """The runs of a sweep: a list of (config, args) with config the knob values as given (in
    the order given) and args the script's name=value arguments. knobArgs: ["knob=v1,v2", ...]."""
    sweep = []
    for a in knobArgs:
        knob, _, values = a.partition("=")
        texts = [v for v in values.split(",") if v.strip()]
        if not knob or not texts:
            raise StudyError(f"bad knob argument {a!r}; usage: knob=v1,v2,...")
        if knob in [k for k, _ in sweep]:
            raise StudyError(f"knob {knob} given twice")
        sweep.append((knob, [(t.strip(), convert(sceneName, knob, t.strip())) for t in texts]))
    runs = []
    for combo in itertools.product(*[vals for _, vals in sweep]):
        config = {k: t for (k, _), (t, _) in zip(sweep, combo)}
        args = [f"{p}={v}" for _, (p, v) in combo]
        runs.append((config, args))
    return runs


# --- running --------------------------------------------------------------------------------
def runOne(script, outDir, args, quick=False, timeout=None, rerun=False, yade="yade"):
    """Runs one configuration in its own YADE process; returns its record (cmd, returncode,
    cpu_s, wall_s, load_avg, summary). Reuses outDir/run.json made by the same command with the
    same script (its SHA-1; the commit is recorded too) when that run completed or a solver error
    stopped it (a repeatable result), not when it was interrupted or crashed. A run stopped early
    exits non-zero but writes its summary (stopped_early), which is kept."""
    import hashlib
    cmd = [yade, "-n", "-x", os.path.join(ROOT, script), "--out", outDir] + (["--quick"] if quick else []) + args
    with open(os.path.join(ROOT, script), "rb") as f:
        digest = hashlib.sha1(f.read()).hexdigest()
    record = os.path.join(outDir, "run.json")
    if not rerun and os.path.exists(record):
        with open(record) as f:
            old = json.load(f)
        stopped = (old.get("summary") or {}).get("stopped_early")
        final = old.get("returncode") == 0 or (stopped is not None and stopped != "interrupted")
        if old.get("cmd") == cmd and final and old.get("script_sha1") == digest:
            old["reused"] = True
            return old
    os.makedirs(outDir, exist_ok=True)
    path = os.path.join(outDir, "summary.json")
    # A summary left by an earlier run must not pass for this run's (a crash writes none): remove
    # it first. (Comparing its mtime with the start time is not safe: the kernel stamps files with
    # a clock coarser than time.time(), so a fresh file can look a few ms older than the start.)
    if os.path.exists(path):
        os.remove(path)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [os.path.join(ROOT, "build", "python"), env.get("PYTHONPATH")]))
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        res = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout,
                             stdin=subprocess.DEVNULL)
        code, log = res.returncode, res.stdout + res.stderr
    except subprocess.TimeoutExpired as e:
        code, log = "timeout", f"timed out after {timeout} s\n{e.stdout or ''}"
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    with open(os.path.join(outDir, "log.txt"), "w") as f:
        f.write(log if isinstance(log, str) else log.decode(errors="replace"))
    summary = None
    if os.path.exists(path):
        with open(path) as f:
            summary = json.load(f)
    out = dict(cmd=cmd, returncode=code, cpu_s=cpu, wall_s=wall, load_avg=load, summary=summary, reused=False,
               script_sha1=digest, commit=_commit())
    with open(record, "w") as f:
        json.dump(out, f, indent=2)
    return out


def _commit():
    """The repository's HEAD commit (with '+' when the tree has changes), or None."""
    try:
        head = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return (head + ("+" if dirty else "")) or None
    except (OSError, subprocess.SubprocessError):
        return None


# --- errors ---------------------------------------------------------------------------------
def readPoints(runDir):
    """The eroded points (n x 2, mm) a run wrote to eroded.csv, or None."""
    import numpy as np
    path = os.path.join(runDir, "eroded.csv")
    if not os.path.exists(path):
        return None
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2).reshape(-1, 2)


def pathDistance(a, b):
    """Symmetric mean nearest-neighbour distance between point sets a and b (n x 2): the mean,
    over a's points, of the distance to the nearest point of b, averaged with the same from b to
    a. NaN when either set is empty."""
    import numpy as np
    from scipy.spatial import cKDTree
    if a is None or b is None or len(a) == 0 or len(b) == 0:
        return float("nan")
    dab = cKDTree(b).query(a)[0]
    dba = cKDTree(a).query(b)[0]
    return 0.5 * (float(np.mean(dab)) + float(np.mean(dba)))


def _rel(x, ref):
    if x is None or ref is None or not ref:
        return float("nan")
    return abs(x - ref) / abs(ref)


def errors(sceneName, summary, runDir, ref, refDir):
    """The scene's relative errors of one run (dict name -> value) against the reference: a
    summary dict, or the string 'closed-form' (vibrating bar)."""
    if sceneName == "vibrating_bar":
        target = summary["omega_analytic"] if ref == "closed-form" else ref["omega_numeric"]
        return {"freq": _rel(summary["omega_numeric"], target)}
    if sceneName == "lshaped_panel":
        length = 1e3 * ref.get("crack_front_distance_m", 0.0)
        d = pathDistance(readPoints(runDir), readPoints(refDir))
        return {"peak": _rel(summary["peak_load_kN"], ref["peak_load_kN"]),
                "path": d / length if length > 0 else float("nan"), "path_mm": d}
    if sceneName == "crack_branching":
        def perThickness(s):
            return s["dissipated_energy_J"] / (1e-3 * s["parameters"]["h_mm"])
        return {"branch": _rel(summary.get("branching_time_us"), ref.get("branching_time_us")),
                "energy": _rel(perThickness(summary), perThickness(ref))}
    raise StudyError(f"no error measure for scene {sceneName}")


def paretoFront(costs, errs):
    """Boolean list: True where the point is not dominated, i.e. no other point has cost <= and
    error <= with at least one of them strictly smaller. NaN points are never on the front."""
    pts = list(zip(costs, errs))
    front = []
    for i, (c, e) in enumerate(pts):
        if not (math.isfinite(c) and math.isfinite(e)):
            front.append(False)
            continue
        front.append(not any(math.isfinite(c2) and math.isfinite(e2) and c2 <= c and e2 <= e and (c2 < c or e2 < e)
                             for j, (c2, e2) in enumerate(pts) if j != i))
    return front


def recommend(rows, targets=TARGETS, key="error"):
    """For each target error, the cheapest row (by its cost) with rows[key] <= target (or None)."""
    out = {}
    for t in targets:
        ok = [r for r in rows if r.get(key) is not None and math.isfinite(r[key]) and r[key] <= t]
        out[t] = min(ok, key=lambda r: r["cost"]) if ok else None
    return out


# --- the study ------------------------------------------------------------------------------
def study(sceneName, knobArgs, out=None, reference=None, quick=False, rerun=False, timeout=None,
          dryRun=False, cost="cpu", log=print, command=None):
    """Runs the sweep and writes its table and plot; returns the rows (list of dicts)."""
    sceneName = scene(sceneName)
    sc = SCENES[sceneName]
    reference = reference or sc["reference"]
    if reference == "closed-form" and sceneName != "vibrating_bar":
        raise StudyError(f"--reference closed-form exists only for vibrating_bar; allowed for {sceneName}: "
                         f"finest or a run directory")
    if reference not in ("finest", "closed-form") and not os.path.exists(os.path.join(reference, "summary.json")):
        raise StudyError(f"--reference {reference!r}: allowed: finest, closed-form (vibrating_bar) or a "
                         f"directory with a summary.json")
    if cost not in COSTS:
        raise StudyError(f"--cost {cost!r} is invalid; allowed: {', '.join(COSTS)}")
    configs = configurations(sceneName, knobArgs)
    out = out or os.path.join("out", "study", sceneName)
    knobs = list(configs[0][0]) if configs else []
    rows = []
    for i, (config, args) in enumerate(configs):
        runDir = os.path.join(out, "runs", f"run_{i:03d}")
        if dryRun:
            log(" ".join(["yade", "-n", "-x", sc["script"], "--out", runDir] + (["--quick"] if quick else [])
                         + sc["fixed"] + args))
            continue
        rec = runOne(sc["script"], runDir, sc["fixed"] + args, quick=quick, timeout=timeout, rerun=rerun)
        s = rec["summary"] or {}
        params = s.get("parameters", {})
        dt = s["dt_s"] * 1e6 if "dt_s" in s else params.get("dt_us")
        h = s["h_m"] * 1e3 if "h_m" in s else params.get("h_mm")
        rows.append(dict(run=f"run_{i:03d}", dir=runDir, config=config, status=_status(rec, s),
                         h_mm=h, dt_us=dt, particles=s.get("particles"), steps=s.get("steps"),
                         cpu_s=rec["cpu_s"], wall_s=rec["wall_s"], loop_wall_s=s.get("wall_time_s"),
                         particle_steps_per_s=s.get("particle_steps_per_s"), load_avg=rec["load_avg"],
                         particle_steps=(s.get("particles") or 0) * (s.get("steps") or 0), summary=s))
        rows[-1]["cost"] = rows[-1][COSTS[cost][0]] or float("nan")
        log(f"{rows[-1]['run']} {config}: {rows[-1]['status']}, CPU {rec['cpu_s']:.1f} s, wall {rec['wall_s']:.1f} s"
            + (" (reused)" if rec.get("reused") else ""))
    if dryRun:
        return []
    good = [r for r in rows if r["status"] == "ok"]
    if not good:
        raise StudyError("no run succeeded; see the runs' log.txt")
    if reference == "finest":
        refRow = max(good, key=lambda r: r["particle_steps"])
        ref, refDir = refRow["summary"], refRow["dir"]
        refName = f"finest run of the sweep, {refRow['run']} {refRow['config']}"
        refShort = f"finest run, h = {refRow['h_mm']:g} mm" if refRow["h_mm"] else f"finest run, {refRow['run']}"
    elif reference == "closed-form":
        refRow, ref, refDir, refName = None, "closed-form", None, "closed form"
        refShort = refName
    else:
        with open(os.path.join(reference, "summary.json")) as f:
            refRow, ref, refDir, refName = None, json.load(f), reference, f"run in {reference}"
        h = ref.get("h_m", 0) * 1e3 or ref.get("parameters", {}).get("h_mm")
        refShort = f"run in {reference}" + (f", h = {h:g} mm" if h else "")
    for r in rows:
        r["reference"] = r is refRow
        errs = errors(sceneName, r["summary"], r["dir"], ref, refDir) if r["status"] == "ok" else {}
        r["errors"] = errs
        vals = [errs.get(k, float("nan")) for k in sc["errors"]]
        r["error"] = max(vals) if all(math.isfinite(v) for v in vals) else float("nan")
    meta = dict(scene=sceneName, script=sc["script"], reference=refName, knobs=knobs, quick=quick,
                errors=list(sc["errors"]), command=command, cost=cost, reference_short=refShort,
                reference_dir=os.path.normpath(refDir) if refDir else "closed-form")
    return finish(out, meta, rows, log)


def finish(out, meta, rows, log=print):
    """Marks the Pareto fronts (each error and the largest) and writes the table, plot and JSON."""
    candidates = [r for r in rows if not r["reference"]]
    for r in rows:
        r["pareto"] = {}
    for name in list(meta["errors"]) + ["error"]:
        errs = [r["error"] if name == "error" else r["errors"].get(name, float("nan")) for r in candidates]
        flags = paretoFront([r["cost"] for r in candidates], errs)
        for r, f in zip(candidates, flags):
            r["pareto"][name] = f
    os.makedirs(out, exist_ok=True)
    writeTables(out, meta, rows)
    plot(os.path.join(out, "pareto.png"), meta, rows)
    with open(os.path.join(out, "study.json"), "w") as f:
        json.dump(dict(meta, rows=rows), f, indent=2, default=str)
    log(f"wrote {out}/study.csv, study.md, study.json, pareto.png")
    return rows


def combine(dirs, out, cost=None, log=print, command=None):
    """One table and plot for several studies of the same scene against the same reference
    (their study.json): runs are named SWEEP/run_NNN, knobs are the union (blank where a sweep
    left the script's default), the reference run appears once."""
    studies = []
    for d in dirs:
        path = os.path.join(d, "study.json")
        if not os.path.exists(path):
            raise StudyError(f"--combine: {d} has no study.json")
        with open(path) as f:
            studies.append((d, json.load(f)))
    first = studies[0][1]
    for d, st in studies[1:]:
        for key in ("scene", "reference_dir"):
            if st.get(key) != first.get(key):
                raise StudyError(f"--combine: {d} has {key} {st.get(key)!r}, {dirs[0]} has {first.get(key)!r}; "
                                 f"allowed: studies of one scene against one reference")
    cost = cost or first.get("cost", "cpu")
    if cost not in COSTS:
        raise StudyError(f"--cost {cost!r} is invalid; allowed: {', '.join(COSTS)}")
    knobs, rows, seen = [], [], set()
    for d, st in studies:
        knobs += [k for k in st["knobs"] if k not in knobs]
        for r in st["rows"]:
            if r["reference"] and os.path.normpath(r["dir"]) in seen:
                continue
            seen.add(os.path.normpath(r["dir"]))
            r = dict(r, run=f"{os.path.basename(os.path.normpath(d))}/{r['run']}")
            r["cost"] = r.get(COSTS[cost][0]) or float("nan")
            rows.append(r)
    refs = [r for r in rows if r["reference"]]  # none when the reference run is outside the sweeps
    meta = dict(first, knobs=knobs, cost=cost, command=command)
    if not refs and first["reference_dir"] != "closed-form":
        meta["reference"] = meta["reference_short"] = f"run in {first['reference_dir']}"
    return finish(out, meta, rows, log)


def _status(rec, s):
    if s and s.get("stopped_early"):
        return "stopped early"
    if rec["returncode"] != 0:
        return f"failed ({rec['returncode']})"
    if not s:
        return "no summary"
    return "ok"


def _fmt(v, pct=False):
    if v is None:
        return ""
    if isinstance(v, float):
        if not math.isfinite(v):
            return "n/a"
        return f"{100 * v:.3g}" if pct else f"{v:.4g}"
    return str(v)


def _columns(meta):
    errs = meta["errors"]
    cols = [("run", lambda r: r["run"])] + [(k, (lambda k: lambda r: r["config"].get(k))(k)) for k in meta["knobs"]]
    cols += [("h_mm", lambda r: r["h_mm"]), ("dt_us", lambda r: r["dt_us"]), ("particles", lambda r: r["particles"]),
             ("steps", lambda r: r["steps"]), ("cpu_s", lambda r: r["cpu_s"]), ("wall_s", lambda r: r["wall_s"]),
             ("loop_wall_s", lambda r: r["loop_wall_s"]),
             ("particle_steps_per_s", lambda r: r["particle_steps_per_s"])]
    cols += [(f"err_{k}", (lambda k: lambda r: r["errors"].get(k))(k)) for k in errs]
    if "path" in errs:
        cols.append(("path_mm", lambda r: r["errors"].get("path_mm")))
    cols += [("error", lambda r: r["error"]), ("pareto", lambda r: int(bool(r["pareto"].get("error")))),
             ("reference", lambda r: int(r["reference"])), ("status", lambda r: r["status"]),
             ("load_avg", lambda r: r["load_avg"])]
    return cols


def writeTables(out, meta, rows):
    cols = _columns(meta)
    with open(os.path.join(out, "study.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow([c for c, _ in cols])
        for r in rows:
            values = (g(r) for _, g in cols)
            w.writerow(["" if v is None else (f"{v:.6g}" if isinstance(v, float) else v) for v in values])
    with open(os.path.join(out, "study.md"), "w") as f:
        f.write(markdown(meta, rows))


def markdown(meta, rows):
    """The study as Markdown: what was run, the table (errors in %), front and recommendations."""
    errs = meta["errors"]
    head = ["run"] + meta["knobs"] + ["h (mm)", "dt (us)", "points", "steps", "CPU (s)", "wall (s)",
                                      "loop Mpts/s"] + [f"{ERROR_LABELS[k]} err (%)" for k in errs]
    if "path" in errs:
        head.append("path dist (mm)")
    head += ["error (%)", "front"]
    lines = [f"Scene `{meta['scene']}` ({meta['script']}{', --quick' if meta['quick'] else ''}); "
             f"reference: {meta['reference']}.", ""]
    if meta.get("command"):
        lines += [f"Command: `{meta['command']}`", ""]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        pps = r["particle_steps_per_s"]
        cells = [r["run"] + (" (ref)" if r["reference"] else "")] + [str(r["config"].get(k, "")) for k in meta["knobs"]]
        cells += [_fmt(r["h_mm"]), _fmt(r["dt_us"]), _fmt(r["particles"]), _fmt(r["steps"]), f"{r['cpu_s']:.1f}",
                  f"{r['wall_s']:.1f}", f"{pps / 1e6:.2f}" if pps else ""]
        for k in errs:
            v = r["errors"].get(k)
            cells.append("no branching" if k == "branch" and r["status"] == "ok" and
                         r["summary"].get("branching_time_us") is None else _fmt(v, pct=True))
        if "path" in errs:
            cells.append(_fmt(r["errors"].get("path_mm")))
        cells += [_fmt(r["error"], pct=True) if not r["reference"] else "0 (ref)",
                  "yes" if r["pareto"].get("error") else ""]
        if r["status"] != "ok":
            cells[-1] = r["status"]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "CPU: CPU time of the run's YADE process (start-up included). Loop Mpts/s: the script's "
              "particle-steps per second of its time-stepping loop (wall time). error = the largest of the "
              f"errors; front = on the Pareto front of error against {COSTS[meta.get('cost', 'cpu')][1]}.", ""]
    for t, r in recommend([r for r in rows if not r["reference"]]).items():
        lines.append(f"- error <= {100 * t:g} %: " + (f"{r['run']} {r['config']} ({_fmt(r['error'], True)} %, "
                                                      f"{r['cpu_s']:.1f} s CPU)" if r else "no run of the sweep"))
    if meta.get("cost", "cpu") != "cpu":
        lines.append(f"- (cheapest by {COSTS[meta['cost']][1]}; front likewise)")
    return "\n".join(lines) + "\n"


def _ticks(axis, values):
    """Plain-number labels on a log axis; minor ticks labelled too when it spans < 1.5 decades."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    fmt = FuncFormatter(lambda v, _: f"{v:.3g}")
    axis.set_major_formatter(fmt)
    lo, hi = min(values), max(values)
    if hi < 30 * lo:
        axis.set_minor_locator(LogLocator(subs=(2, 3, 5)))
        axis.set_minor_formatter(fmt)
    else:
        axis.set_minor_formatter(NullFormatter())


def _labels(rows, knobs):
    """Short point labels: h and each swept knob whose value differs from its most common one
    (shape as its name, dtFraction as dt=)."""
    from collections import Counter
    varied = [k for k in knobs if len({str(r["config"].get(k)) for r in rows}) > 1]
    common = {k: Counter(str(r["config"].get(k)) for r in rows).most_common(1)[0][0] for k in varied}
    out = []
    for r in rows:
        parts = []
        for k in varied:
            v = r["config"].get(k)
            if v is not None and (k == "h" or str(v) != common[k]):
                parts.append(str(v) if k == "shape" else f"{'dt' if k == 'dtFraction' else k}={v}")
        out.append(" ".join(parts) or r["run"])
    return out


def plot(path, meta, rows):
    """Error against CPU time (log axes), one panel per error measure; the Pareto front of each
    panel drawn as a line through its points, the others grey."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    errs = meta["errors"]
    labels = dict(zip((r["run"] for r in rows), _labels(rows, meta["knobs"])))
    fig, axes = plt.subplots(1, len(errs), figsize=(5.2 * len(errs), 4.2), squeeze=False)
    for ax, name in zip(axes[0], errs):
        pts = [(r["cost"], r["errors"].get(name, float("nan")), r) for r in rows
               if not r["reference"] and r["status"] == "ok"]
        pts = [(c, e, r) for c, e, r in pts if math.isfinite(e) and e > 0]
        if pts:
            front = paretoFront([c for c, _, _ in pts], [e for _, e, _ in pts])
            ax.scatter([c for c, _, _ in pts], [100 * e for _, e, _ in pts], c="0.6", s=22, label="runs", zorder=2)
            fp = sorted((c, e) for (c, e, _), f in zip(pts, front) if f)
            ax.plot([c for c, _ in fp], [100 * e for _, e in fp], "o-", color="#d62728", ms=6, lw=1.5,
                    label="Pareto front", zorder=3)
            # Front points first; a label is left out when it repeats one (the same configuration in
            # two sweeps) or would overlap a drawn label (within 0.3 decades to the side, 0.06 decades
            # up or down; the table has all).
            drawn, at = set(), []
            onFront = {id(r) for (_, _, r), f in zip(pts, front) if f}
            for c, e, r in sorted(pts, key=lambda p: id(p[2]) not in onFront):
                x, y = math.log10(c), math.log10(e)
                if labels[r["run"]] in drawn or any(abs(x - u) < 0.3 and abs(y - v) < 0.06 for u, v in at):
                    continue
                drawn.add(labels[r["run"]])
                at.append((x, y))
                ax.annotate(labels[r["run"]], (c, 100 * e), textcoords="offset points", xytext=(4, 3), fontsize=6.5)
            ax.set_xscale("log")
            ax.set_yscale("log")
            _ticks(ax.xaxis, [c for c, _, _ in pts])
            _ticks(ax.yaxis, [100 * e for _, e, _ in pts])
            ax.margins(0.15)
        else:
            ax.text(0.5, 0.5, "no positive finite error", transform=ax.transAxes, ha="center")
        ax.set_xlabel(COSTS[meta.get("cost", "cpu")][1])
        ax.set_ylabel(f"{ERROR_LABELS[name]} error (%)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{meta['scene']}: error against cost (reference: {meta.get('reference_short', meta['reference'])})",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


# --- command line ---------------------------------------------------------------------------
USAGE = ("usage: study.py SCENE knob=v1,v2,... [knob=v ...] [--out DIR] [--reference finest|closed-form|RUN_DIR] "
         "[--cost cpu|loop|psteps] [--quick] [--rerun] [--timeout S] [--dry-run]; "
         "or study.py --combine STUDY_DIR [STUDY_DIR ...] --out DIR [--cost cpu|loop|psteps]")


def parse(argv):
    """(scene, knobArgs, options dict) from the command line; StudyError on a bad one."""
    argv = list(argv)
    if not argv or argv[0].startswith("-"):
        raise StudyError("no scene given; " + USAGE)
    name, knobArgs, opts = scene(argv[0]), [], dict(out=None, reference=None, quick=False, rerun=False,
                                                    timeout=None, dryRun=False, cost="cpu")
    it = iter(argv[1:])
    for a in it:
        if a in ("--out", "--reference", "--timeout"):
            try:
                v = next(it)
            except StopIteration:
                raise StudyError(f"{a} needs a value; " + USAGE) from None
            if a == "--timeout":
                try:
                    opts["timeout"] = float(v)
                except ValueError:
                    raise StudyError(f"--timeout {v!r} is not a number of seconds") from None
            else:
                opts[a[2:]] = v
        elif a == "--cost":
            opts["cost"] = next(it, None)
        elif a in ("--quick", "--rerun"):
            opts[a[2:]] = True
        elif a == "--dry-run":
            opts["dryRun"] = True
        elif "=" in a and not a.startswith("-"):
            knobArgs.append(a)
        else:
            raise StudyError(f"unknown argument {a!r}; " + USAGE)
    return name, knobArgs, opts


def parseCombine(argv):
    """(study directories, out, cost) from ``--combine DIR [DIR ...] --out DIR [--cost C]``."""
    dirs, out, cost = [], None, None
    it = iter(argv[1:])
    for a in it:
        if a in ("--out", "--cost"):
            v = next(it, None)
            if v is None:
                raise StudyError(f"{a} needs a value; " + USAGE)
            out, cost = (v, cost) if a == "--out" else (out, v)
        elif a.startswith("-"):
            raise StudyError(f"unknown argument {a!r} with --combine; " + USAGE)
        else:
            dirs.append(a)
    if not dirs or not out:
        raise StudyError("--combine needs study directories and --out DIR; " + USAGE)
    return dirs, out, cost


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    prog = ("yade -n -x " if "yade" in sys.modules else "python3 ") + os.path.relpath(sys.argv[0] or "study.py")
    command = " ".join([prog] + argv)
    try:
        if argv[:1] == ["--combine"]:
            dirs, out, cost = parseCombine(argv)
            rows = combine(dirs, out, cost, command=command)
        else:
            name, knobArgs, opts = parse(argv)
            out = opts["out"] or os.path.join("out", "study", name)
            rows = study(name, knobArgs, command=command, **opts)
    except StudyError as e:
        raise SystemExit(f"study: {e}") from None
    if rows:
        with open(os.path.join(out, "study.md")) as f:
            print(f.read())
    return rows


if __name__ == "__main__":
    main()
