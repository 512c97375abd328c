"""Solvers of step 1 of the scheme (5.1), behind one interface (`StepSolver`, `base`).

- `direct`: factorise the step matrix once, apply the factors at every step (`DirectSolver`: PARDISO, UMFPACK,
  SuperLU, sparsecholesky);
- `petsc`: PETSc's FGMRES with a fieldsplit preconditioner (BoomerAMG on the velocity, the least-squares
  commutator on the pressure, `petsc_schur`; `PETScSolver`), serial or over every MPI rank (`petsc_layout`), options
  from the case file's ``[solver.petsc]``; under mpirun ``"direct"`` is its MUMPS (`mumps`).

`step_solver` takes a `SolverSpec` (`spec`) and runs the backend of `BACKENDS` that `solver_kind` names:
``"auto"`` (the default, `auto_solver`) takes the direct solver below `AUTO_ITERATIVE_DOFS` free unknowns (per
dimension) and PETSc's above and under mpirun; ``"iterative"`` and ``"petsc"`` are PETSc's; ``"direct"`` the
fastest safe direct method (MUMPS under mpirun); or a direct method by name (`METHODS`). Every other linear solve
goes through here too: `symmetric` (SPD matrices: the error norms' Gram matrices) and `mumps`. PETSc's start-up
and clean-up are `petsc_init`'s.
"""
from __future__ import annotations

import logging

import ngsolve as ngs

from .base import (
    AUTO,
    MAX_ITERATIONS,
    START_REDUCTION,
    TOLERANCE,
    UNDAMPED_REDUCTION,
    NotConverged,
    SolverError,
    StepSolver,
    auto_target,
)
from .direct import METHODS, DirectSolver, available_methods, default_method, factorise
from .petsc_init import available as petsc_available
from .sparse import compact, free_mask, is_symmetric, to_ngsolve, to_scipy_csr
from .spec import SolverSpec, read_petsc_options, solver_names

__all__ = [
    "AUTO", "AUTO_ITERATIVE_DOFS", "BACKENDS", "DISTRIBUTED_SOLVERS", "METHODS", "MAX_ITERATIONS", "START_REDUCTION",
    "TOLERANCE", "UNDAMPED_REDUCTION", "DirectSolver", "NotConverged", "SolverError", "SolverSpec", "StepSolver",
    "auto_solver", "auto_target", "available_methods", "compact", "default_method", "factorise", "free_mask",
    "is_symmetric", "petsc_available", "read_petsc_options", "solver_kind", "solver_names", "step_solver", "to_ngsolve",
    "to_scipy_csr", "unsupported",
]

log = logging.getLogger(__name__)

#: ``"auto"`` takes an iterative solver from this many free unknowns on (by dimension). Memory decides, not
#: time: on 535 830 unknowns of the 3D ball (MINI) the factorisation took 13.4 GiB against 1.86 GiB for the
#: whole iterative run, and on 151 059 of the 3D solid ball with Taylor–Hood k = 2 5.0 GiB against 1.3 GiB,
#: though its steps are faster (BENCHMARKS.md, "Scale"); in 2D the fill stays small.
AUTO_ITERATIVE_DOFS = {2: 1_000_000, 3: 150_000}

#: The solver names a distributed mesh takes: PETSc's solvers over all ranks (``direct``: MUMPS).
DISTRIBUTED_SOLVERS = ("auto", "iterative", "petsc", "direct")


def auto_solver(unknowns: int, dim: int, distributed: bool = False) -> str:
    """What ``"auto"`` runs for ``unknowns`` free unknowns: ``"direct"`` below `AUTO_ITERATIVE_DOFS` (serial),
    else ``"petsc"``: its iterations stay flat where a geometric multigrid's broke down (the 3D tube of
    benchmarks/tube.py: 23–32 iterations up to 1.4 million unknowns), and it runs on every rank. Where petsc4py does
    not import, a serial run takes the direct solver and says so in one line."""
    if not distributed and unknowns < AUTO_ITERATIVE_DOFS[dim]:
        return "direct"
    if distributed or (reason := petsc_available()) is None:
        return "petsc"
    log.warning("solver auto: %d unknowns would take PETSc, which is unavailable (%s); using the direct solver",
                unknowns, reason)
    return "direct"


def unsupported(solver: str | None, initial_velocity: str) -> str | None:
    """Why a distributed run cannot take these options (one line naming the option), or None."""
    if solver not in (None, *DISTRIBUTED_SOLVERS):
        return f"solver: {solver!r} does not run under mpirun; expected one of {', '.join(DISTRIBUTED_SOLVERS)}"
    if (reason := petsc_available()) is not None:
        what = "solver" if initial_velocity != "projection" else "initial_velocity"
        return f"{what}: a run under mpirun needs PETSc, and {reason}"
    return None


def direct_backend(matrix: ngs.BaseMatrix, spaces, materials, dt: float, spec: SolverSpec) -> StepSolver:
    """A serial factorisation: the method named, else the fastest safe one (`factorise`)."""
    return factorise(matrix, spaces.mixed.FreeDofs(), method=None if spec.method in ("auto", "direct") else spec.method)


def petsc_backend(matrix: ngs.BaseMatrix, spaces, materials, dt: float, spec: SolverSpec) -> StepSolver:
    """PETSc's FGMRES (`PETScSolver`); ``"direct"`` (under mpirun): its MUMPS, under the spec's options."""
    from .petsc import MUMPS, PETScSolver

    options = {**MUMPS, **spec.petsc} if spec.method == "direct" else dict(spec.petsc)
    return PETScSolver(matrix, spaces, materials, dt, spec.tolerance, spec.max_iterations, options)


#: The backends by `solver_kind`: factories ``(matrix, spaces, materials, dt, spec) -> StepSolver``.
BACKENDS = {"direct": direct_backend, "petsc": petsc_backend}


def step_solver(matrix: ngs.BaseMatrix, spaces, materials, dt: float, spec: SolverSpec | None = None) -> StepSolver:
    """The backend of ``spec`` (None: the default `SolverSpec`) for the step matrix; a serial method on a
    distributed run raises ValueError."""
    spec = SolverSpec() if spec is None else spec
    if spec.distributed and spec.method not in DISTRIBUTED_SOLVERS:
        raise ValueError(unsupported(spec.method, "interpolation"))
    return BACKENDS[solver_kind(spec, spaces.free_dofs(), spaces.mesh.dim)](matrix, spaces, materials, dt, spec)


def solver_kind(spec: SolverSpec, unknowns: int, dim: int) -> str:
    """What ``spec`` runs on ``unknowns``: ``"petsc"`` (PETSc's FGMRES for ``"iterative"`` and ``"petsc"``, its
    MUMPS for ``"direct"`` under mpirun) or ``"direct"`` (a serial factorisation)."""
    name = auto_solver(unknowns, dim, spec.distributed) if spec.method == "auto" else spec.method
    if name in ("petsc", "iterative") or (spec.distributed and name == "direct"):
        return "petsc"
    return "direct"
