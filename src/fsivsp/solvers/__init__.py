"""Solvers of step 1 of the scheme (5.1), behind one interface (`StepSolver`).

- `direct`: factorise the step matrix once, apply the factors at every step (`DirectSolver`);
- `iterative`: MinRes with a block preconditioner built once (`IterativeSolver`), for sizes where a
  factorisation no longer fits or pays;
- `petsc`: PETSc's FGMRES with a fieldsplit preconditioner (BoomerAMG on the velocity, the least-squares
  commutator on the pressure; `PETScSolver`), options from the case file's ``[solver.petsc]``;
- `distributed`: the same MinRes with a preconditioner NGSolve runs over MPI ranks (`DistributedSolver`),
  taken for every name in `DISTRIBUTED_SOLVERS` when the run is distributed (``mpirun``: `SolverSpec.distributed`).

`step_solver` takes a `SolverSpec` (`spec`) and runs the backend of `BACKENDS` that `solver_kind` names:
``"auto"`` (the default, `auto_solver`) takes the direct solver below `AUTO_ITERATIVE_DOFS` free unknowns (per
dimension) and PETSc's above and under mpirun (the NGSolve-native iterative solver where petsc4py does not
import); ``"direct"`` the fastest safe direct method (MUMPS under mpirun); ``"iterative"``; ``"petsc"``; or a
direct method by name (`METHODS`).
"""
from __future__ import annotations

from typing import Protocol

import ngsolve as ngs

from .direct import METHODS, DirectSolver, available_methods, default_method, factorise
from .sparse import SolverError, compact, free_mask, is_symmetric, to_ngsolve, to_scipy_csr
from .distributed import DISTRIBUTED_SOLVERS, DistributedSolver, distributed_solver, unsupported
from .iterative import MAX_ITERATIONS, TOLERANCE, IterativeSolver, NotConverged
from .spec import SolverSpec, read_petsc_options, solver_names

__all__ = [
    "AUTO_ITERATIVE_DOFS", "BACKENDS", "DISTRIBUTED_SOLVERS", "METHODS", "MAX_ITERATIONS", "TOLERANCE",
    "DirectSolver", "DistributedSolver", "IterativeSolver", "NotConverged", "SolverError", "SolverSpec",
    "StepSolver", "auto_solver", "available_methods", "compact", "default_method", "factorise", "free_mask",
    "is_symmetric", "read_petsc_options", "solver_kind", "solver_names", "step_solver", "to_ngsolve",
    "to_scipy_csr", "unsupported",
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
    may run concurrently with other work of the scheme (not when it communicates between MPI ranks); ``threaded``:
    whether its solve runs under NGSolve's TaskManager (`marching.march`)."""

    method: str
    factor_seconds: float
    overlap: bool
    threaded: bool

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
                   guess: ngs.BaseVector | None = None) -> None: ...

    def progress(self) -> str: ...

    def statistics(self) -> dict: ...


def direct_backend(matrix: ngs.BaseMatrix, spaces, materials, dt: float, spec: SolverSpec) -> StepSolver:
    """A serial factorisation: the method named, else the fastest safe one (`factorise`)."""
    return factorise(matrix, spaces.mixed.FreeDofs(), method=None if spec.method in ("auto", "direct") else spec.method)


def iterative_backend(matrix: ngs.BaseMatrix, spaces, materials, dt: float, spec: SolverSpec) -> StepSolver:
    """NGSolve's MinRes with the block preconditioner (`IterativeSolver`)."""
    return IterativeSolver(matrix, spaces, materials, dt, spec.tolerance, spec.max_iterations)


def petsc_backend(matrix: ngs.BaseMatrix, spaces, materials, dt: float, spec: SolverSpec) -> StepSolver:
    """PETSc's FGMRES (`PETScSolver`); ``"direct"`` (under mpirun): its MUMPS, under the spec's options."""
    from .petsc import MUMPS, PETScSolver

    options = {**MUMPS, **spec.petsc} if spec.method == "direct" else dict(spec.petsc)
    return PETScSolver(matrix, spaces, materials, dt, spec.tolerance, spec.max_iterations, options)


def distributed_backend(matrix: ngs.BaseMatrix, spaces, materials, dt: float, spec: SolverSpec) -> StepSolver:
    """NGSolve's MinRes over MPI ranks (`distributed_solver`)."""
    return distributed_solver(matrix, spaces, materials, dt, "iterative", spec.tolerance, spec.max_iterations)


#: The backends by `solver_kind`: factories ``(matrix, spaces, materials, dt, spec) -> StepSolver``.
BACKENDS = {"direct": direct_backend, "iterative": iterative_backend, "petsc": petsc_backend,
            "distributed": distributed_backend}


def step_solver(matrix: ngs.BaseMatrix, spaces, materials, dt: float, spec: SolverSpec | None = None) -> StepSolver:
    """The backend of ``spec`` (None: the default `SolverSpec`) for the step matrix; a serial method on a
    distributed run raises ValueError."""
    spec = SolverSpec() if spec is None else spec
    if spec.distributed and spec.method not in DISTRIBUTED_SOLVERS:
        raise ValueError(unsupported(spec.method, "interpolation"))
    kind = solver_kind(spec, spaces.free_dofs(), spaces.mesh.dim)
    return BACKENDS["distributed" if spec.distributed and kind == "iterative" else kind](matrix, spaces, materials,
                                                                                         dt, spec)


def solver_kind(spec: SolverSpec, unknowns: int, dim: int) -> str:
    """What ``spec`` runs on ``unknowns``: ``"petsc"`` (also MUMPS: ``"direct"`` under mpirun), ``"iterative"``
    (NGSolve's MinRes; its ``"distributed"`` backend under mpirun) or ``"direct"`` (a serial factorisation)."""
    name = auto_solver(unknowns, dim, spec.distributed) if spec.method == "auto" else spec.method
    if name == "petsc" or (spec.distributed and name == "direct"):
        return "petsc"
    return "iterative" if name == "iterative" or spec.distributed else "direct"
