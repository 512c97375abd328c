"""How many threads a run uses: NGSolve's TaskManager and MKL (PARDISO), set when a run starts.

    with fsivsp.runtime.threads.using(2):
        fsivsp.study(case, range(3))

A run is bit-identical from one process to the next for a given count (spaces, curved geometry and interpolated
initial data made on one thread, `sequential`; integrals summed in the cells' order, `integrate`; PARDISO's
reproducibility mode); between counts it agrees to round-off (docs/solvers.md, "Threads"). Default
(`default_threads`): ``FSIVSP_THREADS`` if set, else the cores this process may use; a count is the node's, divided
among the MPI ranks on it (`per_rank`). A default run takes them only where they pay (`fit`): not for a small
problem, nor for a 2D factorisation.
"""
from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import functools
import os
import sys
from collections.abc import Iterator
from pathlib import Path

import ngsolve as ngs

from ..errors import is_whole

#: What MPI launchers set to the number of ranks on this node (Open MPI, MPICH/Hydra).
LOCAL_SIZE_VARIABLES = ("OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS")
#: The environment's thread count for runs that do not give one (several runs sharing a machine, a batch
#: scheduler's allocation, the test suite's workers): the node's count, like ``--threads``.
VARIABLE = "FSIVSP_THREADS"


def per_rank(threads: int) -> int:
    """A node's ``threads`` divided among the MPI ranks on this node, at least 1."""
    local = next((int(os.environ[v]) for v in LOCAL_SIZE_VARIABLES if os.environ.get(v, "").isdigit()), 1)
    return max(1, threads // max(local, 1))


def default_threads() -> int:
    """The threads of a run that gives none: ``FSIVSP_THREADS`` if set, else the cores this process may use
    (``len(os.sched_getaffinity(0))``), divided among the ranks on this node (`per_rank`)."""
    if (value := os.environ.get(VARIABLE)) is not None:
        return per_rank(check(value, VARIABLE))
    return per_rank(len(os.sched_getaffinity(0)))


class ThreadsError(ValueError):
    """A thread count that is no positive whole number (``--threads``, ``threads =``, ``FSIVSP_THREADS``)."""


def check(value, where: str) -> int:
    """``value`` as a thread count (a whole number ≥ 1), else `ThreadsError` naming ``where``."""
    count = int(value) if isinstance(value, str) and value.strip().isdigit() else value
    if not is_whole(count):
        raise ThreadsError(f"{where}: expected a positive whole number of threads, got {value!r}")
    return count


def current() -> int:
    """The number of NGSolve threads of the running code (`using` sets it)."""
    from pyngcore import GetNumThreads
    return GetNumThreads()


@functools.cache
def mkl_runtime():
    """MKL's runtime library (the one NGSolve's PARDISO loads), or None."""
    for name in ("libmkl_rt.so.3", "libmkl_rt.so.2", "libmkl_rt.so", str(Path(sys.prefix) / "lib" / "libmkl_rt.so.3")):
        with contextlib.suppress(OSError):
            return ctypes.CDLL(name)
    return None


#: MKL's threading layer, chosen before its first call (`pin_mkl_threading`): Intel's OpenMP.
MKL_THREADING_INTEL = 0


def pin_mkl_threading() -> None:
    """Fix MKL's threading layer to Intel's before MKL's first call (at import). Left to itself MKL takes GNU's
    OpenMP whenever libgomp is already loaded, as it is once petsc4py is imported (Debian's PETSc links it), and
    PARDISO's factors then differ in the last bits (3e-14 after 20 steps of the 2D tube): a run would depend on
    whether PETSc was imported before its first factorisation. Pinned, both give the same bits."""
    runtime = mkl_runtime()
    if runtime is not None:
        runtime.MKL_Set_Threading_Layer(MKL_THREADING_INTEL)


def _set_mkl(threads: int) -> int | None:
    """MKL's threads := ``threads`` (mkl-service or the runtime library); the previous count, None without MKL."""
    try:
        import mkl
        previous = mkl.get_max_threads()
        mkl.set_num_threads(threads)
        return previous
    except ImportError:
        pass
    runtime = mkl_runtime()
    if runtime is None:
        os.environ["MKL_NUM_THREADS"] = str(threads)
        return None
    previous = runtime.MKL_Get_Max_Threads()
    runtime.MKL_Set_Num_Threads(threads)
    return previous


#: A default run (no count given) of fewer free unknowns per rank than this runs on one thread (`fit`): below it
#: the products of a step are too short to share (the paper's level 3, 18 000 unknowns: see docs/solvers.md,
#: "Threads"), and on a loaded machine each of them waits for a scheduler tick until the other thread gets a core
#: (the paper's level 1: 0.4 ms a step on one thread, 312 ms on two beside the test suite).
THREADS_MIN_DOFS = 50_000

#: The (dimension, solver kind) whose default runs take one thread at every size (`fit`): their step does not pay
#: for a second one, and a run is mostly steps. A serial 2D factorisation (PARDISO, also UMFPACK and SuperLU):
#: its step is the factors' forward and backward substitution, memory-bound, which MKL does not parallelise, beside
#: products that are short in 2D; the paper's level 4 (72 339 unknowns) stepped 0.91–0.92× as fast on two threads
#: (BENCHMARKS.md, "Threads") and `fsivsp paper --dt 1e-3 --levels 4-4` (1 000 steps) took 36.0 s against 34.8 s
#: with ``--threads 1``: the set-up's gain (0.49 → 0.30 s) is lost again after about 160 steps. 3D factorisations (their
#: set-up 1.8× on two threads, their step 1.00–1.14×) and PETSc keep the count.
ONE_THREAD = {(2, "direct")}


@dataclasses.dataclass
class _Block:
    """A `using` block: its thread ``count``, whether it was the default (``auto``: `fit` may run it on one
    thread) and its running TaskManager (None: stopped, or one thread)."""

    count: int
    auto: bool
    manager: object = None


#: The `using` blocks, innermost last.
_BLOCKS: list[_Block] = []


def _running() -> bool:
    return bool(_BLOCKS) and _BLOCKS[-1].manager is not None


def _started():
    """A running NGSolve TaskManager (of `ngs.SetNumThreads`'s count)."""
    manager = ngs.TaskManager()
    manager.__enter__()
    return manager


def _run_on(block: _Block, threads: int) -> None:
    """Run ``block`` on ``threads`` threads from now on: NGSolve's count and TaskManager, MKL's count."""
    if block.manager is not None and threads == 1:
        block.manager.__exit__(None, None, None)
        block.manager = None
    ngs.SetNumThreads(threads)
    _set_mkl(threads)
    if block.manager is None and threads > 1:
        block.manager = _started()


def default_count(count: int, unknowns: int, dim: int | None = None, solver: str | None = None) -> int:
    """The threads a default block of ``count`` threads gives a problem of ``unknowns`` free unknowns (all ranks') in
    ``dim`` dimensions solved by ``solver`` (`solvers.solver_kind`: ``"direct"`` or ``"petsc"``): one below
    `THREADS_MIN_DOFS` per rank or where the step does not pay for more (`ONE_THREAD`), else ``count``."""
    from . import parallel

    if unknowns < THREADS_MIN_DOFS * max(parallel.size(), 1) or (dim, solver) in ONE_THREAD:
        return 1
    return count


def fit(unknowns: int, dim: int | None = None, solver: str | None = None) -> int:
    """The threads for a problem of ``unknowns`` free unknowns (all ranks') in ``dim`` dimensions solved by
    ``solver`` (`solvers.solver_kind`), set for the rest of the `using` block: in a default block `default_count`
    (one below `THREADS_MIN_DOFS` per rank and for a 2D factorisation, `ONE_THREAD`), else the block's count; a count
    that was given is kept. Called by `Scheme` when it is made (a study's levels each in turn). Returns the count
    now in use."""
    if not _BLOCKS:
        return current()
    block = _BLOCKS[-1]
    wanted = default_count(block.count, unknowns, dim, solver) if block.auto else block.count
    if wanted != current():
        _run_on(block, wanted)
    return wanted


@contextlib.contextmanager
def sequential() -> Iterator[None]:
    """Run the block without NGSolve's TaskManager, on the calling thread alone (the one `using` runs is
    stopped and started again after). A finite element space colours its elements when it is made (`FESpace`
    update), in parallel with locks under the TaskManager, so that the colouring, and with it the order in which
    assembly adds the element matrices, varied from one space and process to the next (1 ulp in some entries).
    Spaces made here are coloured the same in every process; assembly over them may still thread."""
    if not _running():
        yield
        return
    block = _BLOCKS[-1]
    block.manager.__exit__(None, None, None)
    block.manager = None
    try:
        yield
    finally:
        block.manager = _started()


@contextlib.contextmanager
def idle() -> Iterator[None]:
    """Put the TaskManager's workers to sleep for a block the calling thread runs alone (PETSc's solve): running,
    they wait for work on the other cores and take them from the code that has work (one thread's sort of 20 000
    numbers 200 times, 2 threads, load 2: 38 ms without a TaskManager, 50 under it, 44 suspended)."""
    if not _running():
        yield
        return
    from pyngcore import SuspendTaskManager
    with SuspendTaskManager():
        yield


def integrate(cf, mesh: ngs.Mesh, **kwargs) -> float:
    """``ngs.Integrate(cf, mesh, **kwargs)``, the same bits every time: under the TaskManager its element sums are
    added in an order that varies from call to call (1 ulp: 2 values in 30 calls on the paper's level 2), so
    there the cells' integrals are computed in parallel (``element_wise``) and added by numpy in their order; on
    one thread NGSolve's sum as before. On a distributed mesh the ranks' sums are added (``comm.Sum``)."""
    if not _running():
        return ngs.Integrate(cf, mesh, **kwargs)
    import numpy as np
    local = float(np.sum(ngs.Integrate(cf, mesh, element_wise=True, **kwargs).NumPy()))
    return mesh.comm.Sum(local) if mesh.comm.size > 1 else local


@contextlib.contextmanager
def using(threads: int | None = None) -> Iterator[int]:
    """Run the block with ``threads`` threads of this node (None: `default_threads`, and one thread for a small
    problem, `fit`; under mpirun each rank takes its share, `per_rank`): NGSolve's TaskManager (not entered for 1
    thread: the sequential code) and MKL's. Yields the count; restores the previous counts on leaving."""
    count = default_threads() if threads is None else per_rank(check(threads, "threads"))
    before, mkl_before = current(), _set_mkl(count)
    block = _Block(count, auto=threads is None)
    _BLOCKS.append(block)
    _run_on(block, count)
    try:
        yield count
    finally:
        _run_on(block, 1)
        _BLOCKS.pop()
        ngs.SetNumThreads(before)
        if mkl_before is not None:
            _set_mkl(mkl_before)


pin_mkl_threading()
