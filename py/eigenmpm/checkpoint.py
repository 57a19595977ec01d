"""Checkpoints of long runs: the scene and its EigenMPM state saved periodically, atomically."""
import os
import re
import shutil
import time

from yade import O, PyRunner

from . import parallel
from .engines import _register, _releaseLabel, registered
from .params import Param, apply, declare

SCENE = "scene.yade.bz2"
_NAME = re.compile(r"^checkpoint-(\d{9})$")


@declare
class Checkpoint(PyRunner):
    """Saves the whole scene (YADE's ``O.save`` with the EigenMPM state, see ``eigenmpm.state``)
    at every multiple of ``iterPeriod`` iterations or every ``wallPeriod`` seconds of wall time, keeping the
    last ``keep``. Each checkpoint is a folder ``<directory>/checkpoint-<iteration>`` holding
    ``scene.yade.bz2`` and its ``.eigenmpm`` state; it is written under a temporary name and
    renamed when complete, so an interrupted save never leaves a checkpoint that looks whole.
    :func:`latest` finds the newest one and :func:`resume` loads it.

    It must come before every other engine in ``O.engines``: it then saves the state at the
    start of an iteration, which the loaded scene runs in full (refused otherwise).

    Example::

        O.engines = [em.Checkpoint(directory='out/ckpt', wallPeriod=600), mpm, ...]
        ...
        em.checkpoint.resume('out/ckpt')   # in a new process: the scene as saved
        O.run(remaining, True)
    """

    _release = _releaseLabel  # (O.reset(): the label is free again)

    params = (
        Param("label", "checkpoint", "", "YADE label of the engine"),
        Param("directory", None, "", "folder of the checkpoints (created)", kind="str", required=True),
        Param("iterPeriod", 0, "iterations", "save every iterPeriod iterations (0: not by iterations)",
              bounds="[0, inf)"),
        Param("wallPeriod", 0.0, "s", "save when this much wall time passed since the last save "
                                      "(0: not by wall time)", bounds="[0, inf)"),
        Param("keep", 2, "", "number of checkpoints kept (older ones are removed)", bounds="[1, inf)"),
    )

    def __init__(self, **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "Checkpoint")
        if not (self.iterPeriod or self.wallPeriod):
            raise ValueError("EigenMPM: give iterPeriod or wallPeriod (> 0) (Checkpoint)")
        self._wallLast = time.time()
        self._iterLast = None
        self.saved = []  # paths of the checkpoints written by this engine
        # YADE calls it every iteration; it decides itself (by iterations or wall time). The
        # declared iterPeriod is kept as `period`, YADE's own iterPeriod is 1.
        self.period = self.iterPeriod
        self.iterPeriod, self.initRun = 1, False
        self.command = _register(self)

    def _restored(self):
        self._wallLast = time.time()

    def _action(self):
        # By iterations: at every multiple of the period (so a resumed run keeps the cadence).
        due = self.period and O.iter % self.period == 0
        due = due or (self.wallPeriod and time.time() - self._wallLast >= self.wallPeriod)
        if due and O.iter > 0 and O.iter != self._iterLast:
            self.save()

    def save(self):
        """Writes a checkpoint of the scene now; returns its folder."""
        if O.engines[0] is not self and registered(O.engines[0]) is not self:
            raise RuntimeError("EigenMPM: Checkpoint must be the first engine in O.engines, so that it "
                               "saves the state at the start of an iteration")
        final = os.path.join(self.directory, f"checkpoint-{O.iter:09d}")
        tmp = final + ".tmp"
        # Under mpiexec rank 0 prepares and completes the folder; every rank writes its part into
        # it in between (doc/parallel.md). The barriers keep the steps in that order.
        barrier = _barrier()
        if parallel.isRoot():
            shutil.rmtree(tmp, ignore_errors=True)
            os.makedirs(tmp)
        barrier()
        self._iterLast, self._wallLast = O.iter, time.time()
        O.save(os.path.join(tmp, SCENE))
        barrier()
        if parallel.isRoot():
            shutil.rmtree(final, ignore_errors=True)
            os.replace(tmp, final)
            for old in checkpoints(self.directory)[:-self.keep]:
                shutil.rmtree(old, ignore_errors=True)
        barrier()
        self.saved.append(final)
        return final


def _barrier():
    """A barrier over the ranks under mpiexec; nothing on one process."""
    if parallel.worldSize() == 1:
        return lambda: None
    from mpi4py import MPI
    return MPI.COMM_WORLD.Barrier


def checkpoints(directory):
    """The complete checkpoint folders in `directory`, oldest first."""
    if not os.path.isdir(directory):
        return []
    found = sorted((int(m.group(1)), name) for name in os.listdir(directory) if (m := _NAME.match(name)))
    return [os.path.join(directory, name) for _, name in found
            if os.path.exists(os.path.join(directory, name, SCENE))]


def latest(directory):
    """The newest complete checkpoint folder in `directory`, or None."""
    found = checkpoints(directory)
    return found[-1] if found else None


def resume(directory):
    """Loads the newest checkpoint of `directory` (O.load with its EigenMPM state) and returns its
    folder; raises FileNotFoundError naming the folder when there is none."""
    path = latest(directory)
    if path is None:
        raise FileNotFoundError(f"EigenMPM: no complete checkpoint in {directory!r} (folders "
                                "checkpoint-<iteration> holding scene.yade.bz2)")
    O.load(os.path.join(path, SCENE))
    return path
