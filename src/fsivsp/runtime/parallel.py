"""MPI-distributed runs (``mpirun -np N fsivsp ...``): which rank this is, what rank 0 alone does, and
how a case and its mesh reach every rank.

Rank 0 reads the case and meshes; `geometry.distribute` hands every rank its part of the mesh, which it refines
(NGSolve keeps rank 0 free of cells, so N ranks assemble on N − 1 parts), and each rank assembles and solves its
part (NGSolve's ``ParallelMatrix``/``ParallelVector``). Without ``mpirun``, or with one rank, MPI is never
imported and every helper here is the serial identity.
"""
from __future__ import annotations

import functools
import os
import sys
import traceback
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")

#: What MPI launchers set to the number of ranks (Open MPI, MPICH/Hydra and Intel MPI).
SIZE_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE")


def launched_size() -> int:
    """The number of ranks the launcher started (1 without one), read before MPI is initialised."""
    for name in SIZE_VARIABLES:
        if os.environ.get(name, "").isdigit():
            return int(os.environ[name])
    return 1


#: Open MPI settings for our ranks unless the user sets them: waiting ranks yield their core instead of
#: spinning (NGSolve's rank 0 mostly waits; on 2 busy cores a step of benchmarks/mpi_scaling.py took 1.7 s
#: instead of 4.1 s).
MPI_DEFAULTS = {"OMPI_MCA_mpi_yield_when_idle": "1"}


@functools.cache
def world():
    """MPI.COMM_WORLD of a run on more than one rank, else None (MPI not imported)."""
    if launched_size() <= 1:
        return None
    for name, value in MPI_DEFAULTS.items():
        os.environ.setdefault(name, value)
    from mpi4py import MPI
    return MPI.COMM_WORLD


def size() -> int:
    return 1 if world() is None else world().size


def rank() -> int:
    return 0 if world() is None else world().rank


def is_root() -> bool:
    """True on rank 0, which writes files and prints (and on a serial run)."""
    return rank() == 0


def distributed() -> bool:
    return size() > 1


def start() -> None:
    """Before anything prints: on ranks other than 0, Python's stdout and stderr go to /dev/null, so
    that progress bars, results and errors appear once (tracebacks of `abort` still reach the terminal)."""
    if distributed() and not is_root():
        sys.stdout = sys.stderr = open(os.devnull, "w")


def abort(error: BaseException, code: int = 1) -> None:
    """An error on some ranks only (a bug: the others may wait in a collective): print its traceback to the
    real stderr and end every rank (MPI_Abort), so that none is left running."""
    traceback.print_exception(error, file=sys.__stderr__)
    sys.__stderr__.flush()
    world().Abort(code)


def settle(code: int) -> int:
    """The exit code every rank takes: the largest of the ranks' codes (they wait for each other here, so that
    none exits while another still works). Serial: ``code``."""
    comm = world()
    return code if comm is None else max(comm.allgather(code))


def on_root(build: Callable[..., T], *args) -> T | None:
    """``build(*args)`` on rank 0 only (a mesh to `distribute`), None on the other ranks; an exception it raises is
    raised on every rank. Serial: ``build(*args)``."""
    if world() is None:
        return build(*args)
    kept = []
    shared(lambda: kept.append(build(*args)))  # broadcasts None, or the error
    return kept[0] if kept else None


def shared(build: Callable[..., T], *args) -> T:
    """``build(*args)`` on rank 0 only, its result on every rank; an exception it raises is raised on
    every rank (so that every rank takes the same exit). Serial: ``build(*args)``."""
    comm = world()
    if comm is None:
        return build(*args)
    result = error = None
    if comm.rank == 0:
        try:
            result = build(*args)
        except Exception as caught:  # re-raised on every rank just below
            error = caught
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise error
    return result


def together(work: Callable[..., T], *args) -> T:
    """``work(*args)`` on every rank (each its own part: a file, a check); if it raises on any rank, the lowest
    such rank's exception is raised on every rank, so that all take the same exit. Serial: ``work(*args)``."""
    comm = world()
    if comm is None:
        return work(*args)
    result = error = None
    try:
        result = work(*args)
    except Exception as caught:  # re-raised on every rank just below
        error = caught
    first = next((e for e in comm.allgather(error) if e is not None), None)
    if first is not None:
        raise first
    return result


def per_node(measure: Callable[[], T]) -> list[tuple[int, T]]:
    """(its number of ranks, ``measure()`` on its first rank) for every node, the ranks grouped by the memory they
    share (``MPI.COMM_TYPE_SHARED``), in the order of their first ranks, on every rank. Serial: one node."""
    comm = world()
    if comm is None:
        return [(1, measure())]
    from mpi4py import MPI

    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    try:
        mine = (node.size, measure()) if node.rank == 0 else None
    finally:
        node.Free()
    return [item for item in comm.allgather(mine) if item is not None]


def owners(found):
    """For a boolean array (the same length on every rank): the lowest rank where each entry is True, −1 where
    none is. Serial: 0 where True."""
    import numpy as np
    found = np.asarray(found, dtype=bool)
    ranks = np.array(gather(np.where(found, rank(), size())))
    lowest = ranks.min(axis=0)
    return np.where(lowest < size(), lowest, -1)


def total(values):
    """The sum over the ranks of a numpy array (the same shape on every rank). Serial: the array."""
    comm = world()
    return values if comm is None else comm.allreduce(values)


def gather(value: T) -> list[T]:
    """``value`` of every rank, in rank order, on every rank. Serial: ``[value]``."""
    comm = world()
    return [value] if comm is None else comm.allgather(value)


def gather_on_root(value: T) -> list[T] | None:
    """``value`` of every rank, in rank order, on rank 0; None on the others. Serial: ``[value]``."""
    comm = world()
    return [value] if comm is None else comm.gather(value, root=0)


def scatter(values: list[T] | None) -> T:
    """Rank r's item of rank 0's list ``values`` (one item per rank). Serial: the only item."""
    comm = world()
    return values[0] if comm is None else comm.scatter(values, root=0)
