"""Solvers of step 1 of the scheme (5.1), behind one interface (`StepSolver`).

- `direct`: factorise the step matrix once, apply the factors at every step (`DirectSolver`);
- `iterative`: MinRes with a block preconditioner built once (`IterativeSolver`), for sizes where a
  factorisation no longer fits or pays;
- `petsc`: PETSc's FGMRES with a fieldsplit preconditioner (BoomerAMG on the velocity, the least-squares
  commutator on the pressure; `PETScSolver`), options from the case file's ``[solver.petsc]``;
- `distributed`: the same MinRes with a preconditioner NGSolve runs over MPI ranks (`DistributedSolver`),
  taken for every name in `DISTRIBUTED_SOLVERS` when the mesh is distributed (``mpirun``).

`step_solver` picks one by name: ``"auto"`` (the default, `auto_solver`) takes the direct solver below
`AUTO_ITERATIVE_DOFS` free unknowns (per dimension) and PETSc's above and under mpirun (the NGSolve-native
iterative solver where petsc4py does not import); ``"direct"`` the fastest safe direct method (MUMPS under
mpirun); ``"iterative"``; ``"petsc"``; or a direct method by name (`METHODS`).
"""
from __future__ import annotations

from typing import Protocol

import ngsolve as ngs

from .direct import METHODS, DirectSolver, available_methods, default_method, factorise
from .sparse import SolverError, compact, free_mask, is_symmetric, to_ngsolve, to_scipy_csr
from .distributed import DISTRIBUTED_SOLVERS, DistributedSolver, distributed_solver, unsupported
from .iterative import MAX_ITERATIONS, TOLERANCE, IterativeSolver, NotConverged

__all__ = [
    "AUTO_ITERATIVE_DOFS", "DISTRIBUTED_SOLVERS", "auto_solver", "solver_kind", "METHODS", "MAX_ITERATIONS", "TOLERANCE", "DirectSolver",
    "DistributedSolver", "IterativeSolver",
    "NotConverged", "SolverError", "StepSolver", "available_methods", "compact", "default_method",
    "factorise", "free_mask", "is_symmetric", "solver_names", "step_solver", "to_ngsolve", "to_scipy_csr",
    "unsupported",
]

#: ``"auto"`` takes an iterative solver from this many free unknowns on (by dimension). Memory decides, not
#: time: on 535 830 unknowns of the 3D ball (MINI) the factorisation took 13.4 GiB against 1.86 GiB for the
#: whole iterative run, and on 151 059 of the 3D solid ball with Taylor–Hood k = 2 5.0 GiB against 1.3 GiB,
#: though its steps are faster (BENCHMARKS.md, "Scale"); in 2D the fill stays small.
AUTO_ITERATIVE_DOFS = {2: 1_000_000, 3: 150_000}


def auto_solver(unknowns: int, dim: int, distributed: bool = False) -> str:
    """What ``"auto"`` runs for ``unknowns`` free unknowns: ``"direct"`` below `AUTO_ITERATIVE_DOFS` (serial),
    else ``"petsc"`` where petsc4py imports, else ``"iterative"``. PETSc, not the NGSolve-native solver: its
    iterations stay flat where the other's break down (the 3D tube of benchmarks/tube.py: 23–32 against 55 up
    to 430 568 unknowns and 452 at 1.4 million), and it runs on every rank; the NGSolve-native solver is faster
    per step on the 3D fluid ball (535 830 unknowns: 4.3 against 4.9 s; docs/solvers.md, "PETSc")."""
    from .petsc import available

    if not distributed and unknowns < AUTO_ITERATIVE_DOFS[dim]:
        return "direct"
    return "petsc" if available() is None else "iterative"


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
    if distributed and name not in DISTRIBUTED_SOLVERS:
        raise ValueError(unsupported(name, "interpolation"))
    kind = solver_kind(name, spaces.free_dofs(), spaces.mesh.dim, distributed)
    if kind == "petsc":
        from .petsc import MUMPS, PETScSolver

        options = {**MUMPS, **(petsc_options or {})} if name == "direct" else petsc_options
        return PETScSolver(matrix, spaces, materials, dt, tol, maxiter, options)
    if kind == "iterative":
        if distributed:
            return distributed_solver(matrix, spaces, materials, dt, "iterative", tol, maxiter)
        return IterativeSolver(matrix, spaces, materials, dt, tol, maxiter)
    return factorise(matrix, spaces.mixed.FreeDofs(), method=None if name in ("auto", "direct") else name)


def solver_kind(name: str, unknowns: int, dim: int, distributed: bool = False) -> str:
    """What ``name`` runs on ``unknowns``: ``"petsc"`` (also MUMPS: ``"direct"`` under mpirun), ``"iterative"``
    (NGSolve's MinRes; `distributed` under mpirun) or ``"direct"`` (a serial factorisation)."""
    if name == "auto":
        name = auto_solver(unknowns, dim, distributed)
    if name == "petsc" or (distributed and name == "direct"):
        return "petsc"
    return "iterative" if name == "iterative" or distributed else "direct"
