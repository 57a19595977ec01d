"""One scene over several processes (doc/parallel.md).

``mpiexec -n N yade -n -x script.py`` runs the same script on N processes (ranks). Every rank
builds the whole scene; at its first step each MpmEngine keeps the points of its rank's strips
of the grid and exchanges the shared node planes, the migrating points and erosion's
neighbours with the ranks beside it (pkg/Distribution.hpp). The results are bitwise those of one
process. Nothing is added to the script: an engine distributes itself when the process was
started by mpiexec (or srun) with more than one rank.

The diagnostics of an engine (energies, momenta, reactions, eroded counts) are sums over the
ranks: every rank must call them, as every rank runs the same script. Arrays of points
(``solver.positions()``, ...) hold this rank's points only; ``solver.globalIds()`` names them
by their index in the one-process scene, and ``gather`` collects such arrays on every rank.
"""
import functools
import os

import numpy as np

# Launchers' variables for the number of processes and this process's rank: Open MPI's mpiexec,
# then MPICH/Hydra and Slurm's srun (PMI).
_SIZE = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_NTASKS")
_RANK = ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "SLURM_PROCID")


def _env(names, default):
    for n in names:
        if n in os.environ:
            return int(os.environ[n])
    return default


@functools.lru_cache(maxsize=None)
def worldSize():
    """Number of processes the launcher started (1 without mpiexec). Read once: the launcher
    sets it before the process starts, and the MpmEngine asks at every step."""
    return _env(_SIZE, 1)


@functools.lru_cache(maxsize=None)
def rank():
    """This process's rank (0 without mpiexec)."""
    return _env(_RANK, 0)


def isRoot():
    """Whether this process is rank 0: the one that writes the summary files and plots."""
    return rank() == 0


def gather(engine, array):
    """The per-point `array` of this rank's points of `engine` (an MpmEngine), collected from
    every rank and ordered by the points' ids in the one-process scene; on one process, the array
    itself. Every rank must call it."""
    array = np.asarray(array)
    solver = engine.solver
    if solver.ranks == 1:
        return array
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    ids = np.concatenate(comm.allgather(solver.globalIds()))
    values = np.concatenate(comm.allgather(array))
    out = np.empty_like(values)
    out[ids] = values
    return out


def positionsOf(engine, ids):
    """Positions (one row each) of the points of `engine` whose ids in the one-process scene
    are `ids`, in that order, on every rank; every rank must call it. Under mpiexec only these
    points' positions are sent (each rank finds its own among them), not every rank's points
    as with ``gather``, and no rank copies its other points' positions (solver.positionsAt):
    the crack diagnostics read the eroded points this way."""
    return _rowsOf(engine, ids, engine.solver.positionsAt)


def valuesOf(engine, ids, values):
    """The rows of `values` (a per-point array of this rank's points of `engine`, in the order of
    solver.positions()) of the points whose ids in the one-process scene are `ids`, in that
    order, on every rank; every rank must call it. Only these rows travel between the ranks."""
    values = np.asarray(values)
    return _rowsOf(engine, ids, lambda k: values[k].reshape((-1,) + values.shape[1:]))


def _rowsOf(engine, ids, rows):
    """valuesOf with rows(k): the rows of this rank's points at the indices k."""
    ids = np.asarray(ids, dtype=np.int64)
    solver = engine.solver
    if solver.ranks == 1:
        return rows(ids)
    mine = np.asarray(solver.globalIds(), dtype=np.int64)  # sorted
    k = np.minimum(np.searchsorted(mine, ids), max(len(mine) - 1, 0))
    here = (mine[k] == ids) if len(mine) else np.zeros(len(ids), dtype=bool)
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    found = np.concatenate(comm.allgather(ids[here]))
    where = np.concatenate(comm.allgather(rows(k[here])))
    order = np.argsort(found)
    at = order[np.searchsorted(found[order], ids)]
    if not np.array_equal(found[at], ids):
        raise ValueError("EigenMPM: some ids name no point of any rank")
    return where[at]


# --- Stopping together ------------------------------------------------------------------------
# A signal reaches the ranks at different moments, and a rank that stopped alone would leave the
# others waiting in the next step's exchange. So a rank that receives one only asks for the
# stop (requestStop); after each of its steps every distributed MpmEngine takes the largest
# signal number asked for on any rank (agreeOnStop, one small allreduce) and, when there is
# one, pauses YADE's loop: every rank ends the same iteration (doc/parallel.md, "Interrupts").
_stop = {"requested": 0, "agreed": 0}


def requestStop(signum):
    """Asks every rank to stop at the end of a coming step, for the signal `signum` (a number)."""
    _stop["requested"] = max(_stop["requested"], int(signum))


def resetStop():
    """Forgets any stop asked for or agreed on (at the start of a run; on every rank)."""
    _stop["requested"] = _stop["agreed"] = 0


def agreeOnStop():
    """The largest signal number for which any rank asked to stop, 0 when none did. Every rank
    must call it at the same point (MpmEngine calls it after each distributed step); once it is
    non-zero it stays so until resetStop."""
    from mpi4py import MPI
    mine = np.array([_stop["requested"]], dtype=np.int64)
    agreed = np.zeros(1, dtype=np.int64)
    MPI.COMM_WORLD.Allreduce(mine, agreed, op=MPI.MAX)
    _stop["agreed"] = max(_stop["agreed"], int(agreed[0]))
    return _stop["agreed"]


def agreedStop():
    """The signal number on which the ranks agreed to stop (0: none since the last resetStop)."""
    return _stop["agreed"]


def allIds(mine):
    """The ids in `mine` (this rank's) of every rank, sorted; on one process, `mine`. Every rank
    must call it."""
    mine = np.asarray(mine, dtype=np.int64)
    if worldSize() == 1:
        return mine
    from mpi4py import MPI
    return np.sort(np.concatenate(MPI.COMM_WORLD.allgather(mine)))


def allCounts(n):
    """Every rank's `n`, in rank order ([n] on one process). Every rank must call it."""
    if worldSize() == 1:
        return [int(n)]
    from mpi4py import MPI
    return MPI.COMM_WORLD.allgather(int(n))


def anyRank(flag):
    """Whether `flag` holds on any rank. Every rank must call it."""
    if worldSize() == 1:
        return bool(flag)
    from mpi4py import MPI
    return bool(MPI.COMM_WORLD.allreduce(bool(flag), op=MPI.LOR))


def total(value):
    """The sum of `value` (a number or a numpy array) over the ranks, on every rank; on one
    process, `value`. Every rank must call it."""
    if worldSize() == 1:
        return value
    from mpi4py import MPI
    if np.isscalar(value):
        return MPI.COMM_WORLD.allreduce(value, op=MPI.SUM)
    out = np.empty_like(np.asarray(value))
    MPI.COMM_WORLD.Allreduce(np.ascontiguousarray(value), out, op=MPI.SUM)
    return out


def bounds(x):
    """Column-wise minimum and maximum of the rows of `x` (n x k) over every rank's rows. Every
    rank must call it."""
    x = np.asarray(x, dtype=float)
    k = x.shape[1]
    local = np.concatenate([-x.min(axis=0), x.max(axis=0)]) if len(x) else np.full(2 * k, -np.inf)
    if worldSize() > 1:
        from mpi4py import MPI
        out = np.empty_like(local)
        MPI.COMM_WORLD.Allreduce(local, out, op=MPI.MAX)
        local = out
    return -local[:k], local[k:]
