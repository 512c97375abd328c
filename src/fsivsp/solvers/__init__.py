"""Solvers of step 1 of the scheme (5.1), behind one interface (`StepSolver`).

- `direct`: factorise the step matrix once, apply the factors at every step (`DirectSolver`);
- `iterative`: MinRes with a block preconditioner built once (`IterativeSolver`), for sizes where a
  factorisation no longer fits or pays;
- `petsc`: PETSc's FGMRES with a fieldsplit preconditioner (BoomerAMG on the velocity, the least-squares
  commutator on the pressure; `PETScSolver`), options from the case file's ``[solver.petsc]``;
- `distributed`: the same MinRes with a preconditioner NGSolve runs over MPI ranks (`DistributedSolver`),
  taken for every name in `DISTRIBUTED_SOLVERS` when the mesh is distributed (``mpirun``).

`step_solver` picks one by name: ``"auto"`` (the default) takes the direct solver below
`AUTO_ITERATIVE_DOFS` free unknowns (per dimension) and the iterative one above (PETSc's is not yet faster
there: docs/solvers.md, "PETSc"); ``"direct"`` the fastest safe direct method; ``"iterative"``; ``"petsc"``;
or a direct method by name (`METHODS`).
"""
from __future__ import annotations

from typing import Protocol

import ngsolve as ngs

from .direct import (METHODS, DirectSolver, SolverError, available_methods, compact,
                     default_method, factorise, free_mask, is_symmetric, to_ngsolve, to_scipy_csr)
from .distributed import DISTRIBUTED_SOLVERS, DistributedSolver, distributed_solver, unsupported
from .iterative import MAX_ITERATIONS, TOLERANCE, IterativeSolver, NotConverged

__all__ = [
    "AUTO_ITERATIVE_DOFS", "DISTRIBUTED_SOLVERS", "METHODS", "MAX_ITERATIONS", "TOLERANCE", "DirectSolver",
    "DistributedSolver", "IterativeSolver",
    "NotConverged", "SolverError", "StepSolver", "available_methods", "compact", "default_method",
    "factorise", "free_mask", "is_symmetric", "solver_names", "step_solver", "to_ngsolve", "to_scipy_csr",
    "unsupported",
]

#: ``"auto"`` takes the iterative solver from this many free unknowns on (by dimension). Memory decides, not
#: time: on 535 830 unknowns of the 3D ball (MINI) the factorisation took 13.4 GiB against 1.86 GiB for the
#: whole iterative run, and on 151 059 of the 3D solid ball with Taylor–Hood k = 2 5.0 GiB against 1.3 GiB,
#: though its steps are faster (BENCHMARKS.md, "Scale"); in 2D the fill stays small.
AUTO_ITERATIVE_DOFS = {2: 1_000_000, 3: 150_000}


class StepSolver(Protocol):
    """What the scheme needs of a solver: ``out = boundary + A_ff⁻¹ rhs`` (``guess``: the previous
    step's solution, a start for an iterative method) and a record for reports; ``overlap``: whether a solve
    may run concurrently with other work of the scheme (not when it communicates between MPI ranks)."""

    method: str
    factor_seconds: float
    overlap: bool

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
                   guess: ngs.BaseVector | None = None) -> None: ...

    def progress(self) -> str: ...

    def statistics(self) -> dict: ...


def solver_names() -> list[str]:
    """The names `step_solver` accepts here."""
    return ["auto", "direct", "iterative", "petsc", *available_methods()]


def step_solver(matrix: ngs.BaseMatrix, spaces, materials, dt: float, name: str | None = "auto",
                tol: float = TOLERANCE, maxiter: int = MAX_ITERATIONS,
                petsc_options: dict | None = None) -> StepSolver:
    """The solver ``name`` (see the module's docstring; None is ``"auto"``) for the step matrix."""
    name = "auto" if name is None else name
    if name not in solver_names():
        raise ValueError(f"solver: expected one of {', '.join(solver_names())}, got {name!r}")
    distributed = isinstance(matrix, ngs.la.ParallelMatrix)  # a distributed mesh (mpirun)
    if name == "petsc" or (distributed and name == "direct"):
        from .petsc import MUMPS, PETScSolver

        options = {**MUMPS, **(petsc_options or {})} if name == "direct" else petsc_options
        return PETScSolver(matrix, spaces, materials, dt, tol, maxiter, options)
    if distributed:
        return distributed_solver(matrix, spaces, materials, dt, name, tol, maxiter)
    if name == "auto":
        name = "iterative" if spaces.free_dofs() >= AUTO_ITERATIVE_DOFS[spaces.mesh.dim] else "direct"
    if name == "iterative":
        return IterativeSolver(matrix, spaces, materials, dt, tol, maxiter)
    return factorise(matrix, spaces.mixed.FreeDofs(), method=None if name == "direct" else name)
