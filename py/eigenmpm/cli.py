"""Command line of the example scripts: ``[--quick] [--out DIR] [name=value ...]``, and the
parameter tables of ``yade-batch`` (``readParamsFromTable``).

Precedence, lowest first: the script's defaults, its quick-mode values (``--quick`` or a table
column ``quick`` set to 1), a yade-batch table line, then ``name=value`` on the command line.
Under yade-batch the output goes to ``DIR/<description of the table line>``.

A run and its end (:func:`runSteps`, :func:`finish`): SIGINT (Ctrl-C) or SIGTERM during the run
stops it at the end of the current step; a solver error stops it too. The example then writes its
summary (``stopped_early``, ``stopped_early_time_s``), CSVs and figures as usual, and
:func:`finish` adds the final VTK records, marks the run's figures as stopped early and exits
non-zero, so that yade-batch and shell scripts see that the run did not complete.
"""
import os
import signal
import sys
import threading
import time


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


def checkpointArgs(name, argv=None):
    """Splits the checkpoint options off an example's command line:
    ``--checkpoint-every N`` (save a checkpoint every N iterations into DIR/checkpoints, where DIR
    is the example's --out) and ``--resume DIR`` (continue from the newest checkpoint in DIR,
    e.g. out/crack_branching/checkpoints). Returns (the other arguments, resume folder or None,
    N or 0)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    rest, resume, every = [], None, 0
    it = iter(argv)
    for a in it:
        if a in ("--resume", "--checkpoint-every"):
            try:
                value = next(it)
            except StopIteration:
                raise SystemExit(f"{name}: {a} needs a value") from None
            if a == "--resume":
                resume = value
            else:
                try:
                    every = int(value)
                except ValueError:
                    every = -1
                if every < 1:
                    raise SystemExit(f"{name}: --checkpoint-every = {value!r} is invalid; allowed: an "
                                     "integer >= 1 (iterations)")
        else:
            rest.append(a)
    return rest, resume, every


# Names a numeric script parameter may be given instead of a number (EigenErosion's alpha).
KEYWORDS = {"alpha": ("griffith",)}


def _convert(default, text, key, name):
    for word in KEYWORDS.get(key, ()):
        if text.lower() == word:
            return word
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


# Exit status of a run stopped by a solver error; an interrupted run exits with 128 + the
# signal's number (130 for SIGINT, 143 for SIGTERM, 138 for SIGUSR1), as a shell reports a
# process killed by it.
SOLVER_ERROR_STATUS = 1
_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1)


class RunEnd:
    """How :func:`runSteps` ended.

    reason    None (every step ran, or the script paused the run itself), ``"interrupted"``
              (SIGINT or SIGTERM) or the solver's error message
    signal    the signal's name when interrupted (``"SIGINT"``, ``"SIGTERM"``), else None
    time      O.time at the end, s (after the last complete step)
    iter      O.iter at the end
    started   wall-clock time (time.time()) when the run began
    """

    def __init__(self, reason, signalName, started):
        from yade import O
        self.reason, self.signal, self.started = reason, signalName, started
        self.time, self.iter = O.time, O.iter

    @property
    def early(self):
        return self.reason is not None

    @property
    def exitStatus(self):
        if self.reason is None:
            return 0
        if self.signal:
            return 128 + int(getattr(signal, self.signal))
        return SOLVER_ERROR_STATUS

    def summary(self):
        """The keys every example's summary.json carries about the end of its run, and which
        build of the compiled module ran it (eigenmpm.isa: the same results, not the same speed)."""
        from . import isa
        return dict(stopped_early=self.reason, stopped_early_time_s=self.time if self.early else None,
                    instruction_set=isa)

    def note(self):
        """One line for figures and the log, e.g. 'stopped early at t = 23.4 us (iteration 2340):
        interrupted (SIGINT)'; '' after a complete run."""
        if not self.early:
            return ""
        why = f"interrupted ({self.signal})" if self.signal else self.reason
        return f"stopped early at t = {_seconds(self.time)} (iteration {self.iter}): {why}"

    def check(self):
        """Raises what a plain ``O.run(steps, True)`` would have: KeyboardInterrupt when
        interrupted, RuntimeError with the message after a solver error. For runs with nothing
        to save (calibrations, set-up)."""
        if self.signal:
            raise KeyboardInterrupt(self.note())
        if self.early:
            raise RuntimeError(self.reason)
        return self


def _sayLine(text):
    """Prints one line in a single write, newline included: under mpiexec the ranks share one
    output, and a line whose newline came in a second write could be split by another rank's
    line (the tests read these lines back, rank by rank)."""
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def _seconds(t):
    for unit, scale in (("us", 1e-6), ("ms", 1e-3)):
        if abs(t) < 1e3 * scale:
            return f"{t / scale:.4g} {unit}"
    return f"{t:.4g} s"


def runSteps(steps, poll=0.05):
    """``O.run(steps, True)`` that a signal or a solver error stops without losing the run.

    YADE runs the loop in a thread of its own, and Python handles a signal only when the main
    thread runs Python code: a plain ``O.run(steps, True)`` holds off Ctrl-C until the end of
    the run. Here the loop is waited for in a helper thread while the main thread wakes every
    `poll` seconds; SIGINT and SIGTERM (handlers installed for the run, the previous ones put
    back after it; SIGUSR1 too, which Open MPI's mpiexec passes on to every rank) make it call
    ``O.pause()``, which stops the loop at the end of the current step. Under mpiexec the ranks
    stop together instead: the rank that received the signal asks for the stop, and every rank
    ends the first step after which the distributed MpmEngines find it asked for on any rank
    (:func:`eigenmpm.parallel.agreeOnStop`). A solver error (a point leaving the grid, a
    non-finite value) ends the run with its message. Either way the state stays as the last
    complete step left it, so the example can write its summary and figures. After a signal,
    every :class:`eigenmpm.Checkpoint` in O.engines first saves that state, so that nothing is
    lost and ``--resume`` continues from the stop. Returns a :class:`RunEnd`. With steps <= 0 (a
    run resumed from a checkpoint of its end) nothing runs: YADE's ``O.run(0)`` would run
    without end."""
    from yade import O
    from . import parallel
    started = time.time()
    if steps <= 0:
        return RunEnd(None, None, started)
    parallel.resetStop()
    together = parallel.worldSize() > 1 and _distributedEngines(O)
    if threading.current_thread() is not threading.main_thread():  # signals reach the main thread only
        message = _run(O, steps)
        if message is None:
            _awaitStepEnd(O)
        return RunEnd(message, None, started)
    caught = []

    def onSignal(signum, frame):
        if not caught:
            where = f"rank {parallel.rank()}: " if together else ""
            _sayLine(f"{where}{signal.Signals(signum).name}: stopping the run at the end of the current step"
                     + (" (all ranks together)" if together else ""))
        caught.append((signal.Signals(signum).name, time.time()))
        if together:
            parallel.requestStop(signum)

    outcome = {}
    worker = threading.Thread(target=lambda: outcome.update(result=_run(O, steps, outcome)),
                              name="eigenmpm-run", daemon=True)
    previous = {s: signal.signal(s, onSignal) for s in _SIGNALS}
    try:
        worker.start()
        paused = False
        while worker.is_alive():
            worker.join(poll)
            if caught and not paused and not together:
                O.pause()
                paused = True
        if outcome.get("result") is None and "raised" not in outcome:
            _awaitStepEnd(O)
    finally:
        if worker.is_alive():  # only when this thread was stopped by something else
            O.pause()
            worker.join()
        for s, handler in previous.items():
            signal.signal(s, handler)
    if "raised" in outcome:
        raise outcome["raised"]
    if together:  # what the ranks agreed on, the same on every rank (a late signal: nothing)
        agreed = parallel.agreedStop()
        stop = (signal.Signals(agreed).name, caught[0][1] if caught else None) if agreed else None
    else:
        stop = caught[0] if caught else None
    if stop:
        after = f", {time.time() - stop[1]:.3f} s after {stop[0]}" if stop[1] is not None else f" ({stop[0]} on another rank)"
        where = f"rank {parallel.rank()}: " if together else ""
        _sayLine(f"{where}run stopped at iteration {O.iter}, t = {_seconds(O.time)}{after}")
    if outcome.get("result") is not None:
        return RunEnd(outcome["result"], None, started)
    if stop:
        _checkpointAtStop(O)
        return RunEnd("interrupted", stop[0], started)
    return RunEnd(None, None, started)


def _distributedEngines(O):
    """Whether O.engines holds an MpmEngine (under mpiexec each distributes itself and agrees on
    stops after its steps)."""
    from .engines import MpmEngine, registered
    return any(isinstance(registered(e), MpmEngine) for e in O.engines)


def _checkpointAtStop(O):
    """Saves the state where a signal stopped the run with every Checkpoint engine of O.engines
    (under mpiexec on every rank together), unless one was saved at this iteration already."""
    from . import parallel
    from .checkpoint import Checkpoint
    from .engines import registered
    for e in O.engines:
        c = registered(e)
        if isinstance(c, Checkpoint) and c._iterLast != O.iter:
            path = c.save()
            if parallel.isRoot():
                print(f"checkpoint at the stop: {path}", flush=True)


def _awaitStepEnd(O, poll=0.002):
    """Returns when no iteration is in progress. After ``O.pause()`` (ours, or a script's own from
    an engine) O.run returns at once while the loop thread still finishes the current
    iteration: reading the state then would race with it. YADE's O.subStep is -1 between
    iterations and >= 0 inside one."""
    while O.subStep != -1:
        time.sleep(poll)


def _run(O, steps, outcome=None):
    """O.run(steps, True); returns None or the message of the error that stopped it. Any other
    exception is kept in outcome['raised'] (re-raised by the main thread) or raised."""
    try:
        O.run(steps, True)
    except RuntimeError as err:
        message = str(err).split("ERROR:")[-1].split("STACK TRACE:")[0].strip()
        print("run stopped early:", message, flush=True)
        return message
    except BaseException as err:  # raised in the helper thread: the main thread re-raises it
        if outcome is None:
            raise
        outcome["raised"] = err
    return None


def report(out, summary, plot=None):
    """Writes an example's summary to out/summary.json and prints it; then, when given, draws
    its figure (plot() returns the file's path) and prints the path. Returns the summary's path."""
    import json
    path = os.path.join(out, "summary.json")
    with open(path, "w") as f:
        json.dump(summary, f, indent=2)
    print(json.dumps(summary, indent=2))
    if plot is not None:
        print("plot:", plot())
    print("summary:", path)
    return path


def finish(end, out=None):
    """Ends an example once it has written its outputs. Writes the final state to every
    VTKRecorder in O.engines (unless already recorded). After a complete run it returns; after a
    run stopped early it marks the figures (``*.png`` under `out` written since the run began)
    with a banner saying so, with the time, and exits with ``end.exitStatus`` (non-zero)."""
    from yade import O
    from .recorders import VTKRecorder
    for e in O.engines:
        if isinstance(e, VTKRecorder):
            e.finalRecord()
    if not end.early:
        return
    from . import parallel
    note = end.note()
    try:
        if out is not None and parallel.isRoot():  # the root writes the figures (doc/parallel.md)
            for path in sorted(_figuresSince(out, end.started)):
                markStoppedEarly(path, note)
        print(f"run {note}; outputs written; exit status {end.exitStatus}", flush=True)
    finally:
        if parallel.worldSize() > 1:
            # mpiexec aborts the job when a rank exits non-zero: the others wait for the root.
            from mpi4py import MPI
            MPI.COMM_WORLD.Barrier()
    sys.exit(end.exitStatus)


def _figuresSince(out, started):
    for folder, _, names in os.walk(out):
        for n in names:
            path = os.path.join(folder, n)
            if n.endswith(".png") and os.path.getmtime(path) >= started - 1.0:  # coarse file clocks
                yield path


def markStoppedEarly(path, note):
    """Adds a red band with `note` above the PNG image at `path` (the image itself is kept pixel
    for pixel); the file is replaced when the new one is complete."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle
    img = plt.imread(path)
    h, w = img.shape[:2]
    band, dpi = max(28, h // 16), 100
    total = h + band
    fig = plt.figure(figsize=(w / dpi, total / dpi), dpi=dpi)
    fig.figimage(img, xo=0, yo=0, origin="upper")
    top = 1.0 - band / total
    fig.add_artist(Rectangle((0, top), 1, 1 - top, transform=fig.transFigure, facecolor="#b00020",
                             linewidth=0, antialiased=False))  # no edge: it would cover the image's top row
    size = 0.45 * band * 72 / dpi
    room = max(10, int(w / (0.6 * size * dpi / 72)))  # characters that fit across the image
    text = note if len(note) <= room else note[:room - 3] + "..."
    fig.text(0.5, 0.5 * (1 + top), text.upper()[:1] + text[1:], ha="center", va="center", color="white",
             fontsize=size, fontweight="bold")
    root, ext = os.path.splitext(path)
    partial = f"{root}.part{ext}"
    fig.savefig(partial, dpi=dpi)
    plt.close(fig)
    os.replace(partial, path)
    return path


# --- Ctrl-C in any script -------------------------------------------------------------------
_originalRun = None


def _interruptibleRun(self, nSteps=-1, wait=False):
    """``O.run`` whose ``wait=True`` lets Ctrl-C through. YADE's own waits in C++ on the main
    thread, where Python cannot handle a signal until the run ends. Here the main thread waits
    in Python (the run in a helper thread) and, on KeyboardInterrupt, pauses the loop, lets the
    current step end, and raises KeyboardInterrupt at that step boundary: the state is the last
    complete step's. Errors of the run (a solver error, dt refused) are raised as before.
    Under mpiexec, where Ctrl-C reaches the ranks as SIGTERM, it is :func:`runSteps` that runs
    (every rank stops at the same step; KeyboardInterrupt is raised there on every rank)."""
    if not wait or threading.current_thread() is not threading.main_thread():
        return _originalRun(self, nSteps, wait)
    from . import parallel
    if nSteps > 0 and parallel.worldSize() > 1 and _distributedEngines(self):
        end = runSteps(nSteps)
        if end.signal:
            raise KeyboardInterrupt(end.note())
        if end.early:
            raise RuntimeError(end.reason)
        return None
    outcome = {}

    def work():
        try:
            _originalRun(self, nSteps, True)
        except BaseException as err:  # re-raised by the main thread
            outcome["raised"] = err

    worker = threading.Thread(target=work, name="eigenmpm-O.run", daemon=True)
    try:
        worker.start()
        while worker.is_alive():
            worker.join(0.05)
    except KeyboardInterrupt:
        if worker.ident is None:  # Ctrl-C before the run began
            raise
        self.pause()
        worker.join(0.1)
        while worker.is_alive():
            # A Ctrl-C that came before YADE's loop had started found nothing to pause; pause the
            # loop once it runs (only then: pausing a pausing loop slows it down).
            if self.running:
                self.pause()
            worker.join(0.1)
        _awaitStepEnd(self)
        raise
    if "raised" in outcome:
        raise outcome["raised"]


def installInterruptibleRun():
    """Wraps Omega.run at class level (once): Ctrl-C stops ``O.run(n, True)`` at a step
    boundary in any script (the examples' runSteps also write their outputs then)."""
    global _originalRun
    if _originalRun is not None:
        return
    import yade.wrapper
    _originalRun = yade.wrapper.Omega.run
    _interruptibleRun.__doc__ = (_originalRun.__doc__ or "") + "\n\nEigenMPM: " + _interruptibleRun.__doc__
    yade.wrapper.Omega.run = _interruptibleRun
