"""The solver of step 1 of (5.1) on a distributed mesh (``mpirun``): MinRes with a block preconditioner that
NGSolve applies over MPI ranks.

The step matrix is [[A, −ΔtBᵀ], [−ΔtB, 0]] (`iterative`); the preconditioner is again diag(A⁻¹, S⁻¹) with
Cahouet–Chabard's S⁻¹ ≈ ρ_F/Δt² L_p⁻¹ + 2ν/Δt M_p⁻¹, but its pieces are ones NGSolve distributes:

- A⁻¹ and ρ_F/Δt² L_p⁻¹ together: NGSolve's BDDC of the block-diagonal form A ⊕ Δt²/ρ_F L_p on V_h × Q_h
  (one form, so one preconditioner; the pressure there vanishes on the fluid's boundaries where the velocity is
  free, as in `iterative`);
- 2ν/Δt M_p⁻¹: the inverse diagonal of the pressure mass on every free pressure dof (Jacobi, `jacobi`; NGSolve's
  own, the "local" preconditioner, failed to assemble on 3 ranks, "sparse matrix row full", and its
  ``DiagonalMatrix`` crashed on a distributed vector).

BDDC treats all of the velocity's dofs (MINI's bubbles, Taylor–Hood's higher orders) and needs no refinement
hierarchy. Everything is built once per run; a step costs matrix-vector products and their communication.
"""
from __future__ import annotations

import numpy as np
import ngsolve as ngs

from .. import forms
from ..geometry import FLUID
from ..materials import Materials
from ..spaces import Spaces
from .iterative import MAX_ITERATIONS, TOLERANCE, IterativeSolver

#: The solver names a distributed mesh takes: ``auto`` and ``iterative`` mean `DistributedSolver`; ``petsc`` and
#: ``direct`` (MUMPS) PETSc's solvers over all ranks (`petsc`). No other direct method runs there.
DISTRIBUTED_SOLVERS = ("auto", "iterative", "petsc", "direct")


class DistributedPreconditioner:
    """diag(A⁻¹, S⁻¹) of the step matrix by BDDC and Jacobi (see the module's docstring); ``mat`` is the
    preconditioner as one NGSolve ``BaseMatrix`` on X_h (zero on the non-free dofs)."""

    def __init__(self, matrix: ngs.BaseMatrix, spaces: Spaces, mat: Materials, dt: float):
        mesh, X = spaces.mesh, spaces.mixed
        free = sorted(set(mesh.GetBoundaries()) - set(spaces.dirichlet.split("|")))
        # Q_h with the Laplacian's Dirichlet boundaries: the same dofs in the same order as X_h's pressure
        pressure = ngs.H1(mesh, order=spaces.order, definedon=FLUID, dirichlet="|".join(free))
        product = spaces.velocity * pressure
        (v, p), (w, q) = product.TnT()
        blocks = ngs.BilinearForm(product)
        blocks += forms.velocity_block(v, w, spaces, mat, dt)
        blocks += dt**2 / mat.rho_fluid * forms.pressure_laplacian(p, q)
        bddc = ngs.Preconditioner(blocks, "bddc")
        blocks.Assemble()

        (_, p), (_, q) = X.TnT()
        mass = ngs.BilinearForm(X)
        mass += forms.pressure_mass(p, q)
        mass.Assemble()
        self._keep = (product, blocks, bddc, mass)
        self.mat = bddc.mat + 2 * mat.nu / dt * jacobi(mass.mat, spaces)

    @staticmethod
    def describe() -> dict:
        """Which approximations the two blocks take (for the run's record)."""
        return {"velocity": "BDDC", "pressure": "Cahouet-Chabard (BDDC and Jacobi)"}


def jacobi(matrix: ngs.BaseMatrix, spaces: Spaces) -> ngs.BaseMatrix:
    """The inverse diagonal of a distributed matrix on X_h's free pressure dofs (zero elsewhere): the local
    diagonals summed over the ranks that share a dof."""
    diagonal = matrix.CreateColVector()
    values = diagonal.FV().NumPy()
    values[:] = 0.0
    rows, cols, entries = (np.asarray(a) for a in matrix.local_mat.COO())
    on = rows == cols
    np.add.at(values, rows[on], entries[on])
    diagonal.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
    diagonal.Cumulate()
    free = np.fromiter(spaces.mixed.FreeDofs(), dtype=bool, count=spaces.mixed.ndof)
    free[:spaces.velocity.ndof] = False
    values[:] = np.where(free & (values > 0), 1.0 / np.where(values > 0, values, 1.0), 0.0)
    return Diagonal(diagonal)


class Diagonal(ngs.BaseMatrix):
    """x ↦ d ⊙ x for a cumulated vector d, entry by entry on each rank (x's parallel status is kept)."""

    def __init__(self, diagonal: ngs.BaseVector):
        super().__init__()
        self.diagonal, self._values = diagonal, diagonal.FV().NumPy()

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        y.FV().NumPy()[:] = self._values * x.FV().NumPy()
        if hasattr(x, "GetParallelStatus"):
            y.SetParallelStatus(x.GetParallelStatus())

    def MultTrans(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        self.Mult(x, y)

    def Height(self) -> int:
        return len(self._values)

    def Width(self) -> int:
        return len(self._values)

    def CreateColVector(self) -> ngs.BaseVector:
        return self.diagonal.CreateVector()

    def CreateRowVector(self) -> ngs.BaseVector:
        return self.diagonal.CreateVector()


class DistributedSolver(IterativeSolver):
    """`IterativeSolver` (MinRes, warm starts, the same record) with `DistributedPreconditioner`."""

    method = "distributed"
    overlap = False  # its products and inner products communicate: one MPI call at a time
    threaded = True
    preconditioner_type = DistributedPreconditioner


def unsupported(solver: str | None, initial_velocity: str) -> str | None:
    """Why a distributed run cannot take these options (one line naming the option), or None."""
    if solver not in (None, *DISTRIBUTED_SOLVERS):
        return f"solver: {solver!r} does not run under mpirun; expected one of {', '.join(DISTRIBUTED_SOLVERS)}"
    if initial_velocity == "projection":
        from .petsc import available

        if reason := available():
            return f"initial_velocity: the projection needs MUMPS under mpirun, and {reason}; use interpolation"
    return None


def distributed_solver(matrix: ngs.BaseMatrix, spaces: Spaces, materials: Materials, dt: float, name: str,
                       tol: float = TOLERANCE, maxiter: int = MAX_ITERATIONS) -> DistributedSolver:
    """NGSolve's own solver of a distributed step matrix (``"auto"`` or ``"iterative"``; `solvers.step_solver`
    takes PETSc's for the other names of `DISTRIBUTED_SOLVERS`)."""
    if name not in ("auto", "iterative"):
        raise ValueError(f"solver: {name!r} is not NGSolve's distributed solver; expected 'auto' or 'iterative'")
    return DistributedSolver(matrix, spaces, materials, dt, tol, maxiter)
