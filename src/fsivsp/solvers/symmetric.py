"""Solves with a symmetric positive (semi)definite matrix A, set up once and applied many times: the Gram matrices
of the error norms (`fsivsp.projection`) and the coarsest levels of the multigrids (`multigrid`, `schur`).

- `factorised`: A's factors on its free dofs, solves bit-identical from one process to the next: NGSolve's
  sparsecholesky on one thread; under more (`threads.using`), where its factors and solves vary at round-off,
  UMFPACK, else SuperLU (sequential); on a distributed matrix (mpirun) MUMPS over the ranks
  (`mumps`).
- `symmetric_solver`: load ↦ A⁺ load on the used dofs, by those factors (`Factorised`; a singular A, whose kernel
  is known, shifted and refined) or, given a preconditioner, by conjugate gradients (`ConjugateGradients`; the
  kernel cleared from the preconditioner's output, so that the iterates stay clear of it). A singular A must be
  consistent for the loads (a load ∫ Cε(E):Cε(w) of the stress norm, whose kernel is the rigid motions).
"""
from __future__ import annotations

import numpy as np
import ngsolve as ngs
import scipy.sparse as sp
from ngsolve.krylovspace import CGSolver

from ..threads import current
from .direct import ScipyLUInverse, available_methods
from .mumps import MumpsInverse
from .sparse import to_ngsolve, to_scipy_csr

#: CG stops when the preconditioned residual is below this fraction of the load's: the error norms then equal the
#: factorised projections' to 1e-9 relative (tests/test_norms.py).
TOLERANCE = 1e-13
MAX_ITERATIONS = 2000
#: The shift of a singular A's diagonal for its factorisation, relative to the diagonal; `REFINEMENT_STEPS` of
#: iterative refinement with A then remove its effect on the solution.
SINGULAR_SHIFT, REFINEMENT_STEPS = 1e-10, 3

#: The kernel of A: an orthonormal basis (columns) on the dofs (a slice or an index array) it names.
Kernel = tuple[np.ndarray, slice | np.ndarray]


def factorised(matrix: ngs.BaseMatrix, freedofs: ngs.BitArray, shift: float = 0.0) -> ngs.BaseMatrix:
    """The inverse of A + ``shift`` diag(A) (A SPD there) on ``freedofs``, by the module's factorisations."""
    if isinstance(matrix, ngs.la.ParallelMatrix):
        return MumpsInverse(matrix, freedofs, shift)
    if shift:
        csr = to_scipy_csr(matrix)
        matrix = to_ngsolve(csr + shift * sp.diags(csr.diagonal()))
    if current() == 1:
        return matrix.Inverse(freedofs, inverse="sparsecholesky")
    if "umfpack" in available_methods():
        return matrix.Inverse(freedofs, inverse="umfpack")
    return ScipyLUInverse(matrix, freedofs)


class Factorised:
    """load, out ↦ out = A⁻¹ load by `factorised` on the ``used`` dofs; if ``singular``, the factors of
    A + `SINGULAR_SHIFT` diag(A) followed by `REFINEMENT_STEPS` of iterative refinement with A."""

    def __init__(self, matrix: ngs.BaseMatrix, used: ngs.BitArray, singular: bool):
        self.matrix, self.steps = matrix, REFINEMENT_STEPS if singular else 0
        self.inverse = factorised(matrix, used, SINGULAR_SHIFT if singular else 0.0)

    def __call__(self, load: ngs.BaseVector, out: ngs.BaseVector) -> None:
        out.data = self.inverse * load
        residual = load.CreateVector()
        for _ in range(self.steps):
            residual.data = load - self.matrix * out
            out.data += self.inverse * residual


class ConjugateGradients:
    """load, out ↦ out = A⁺ load by CG from zero with ``preconditioner`` to `TOLERANCE` (`NotConverged` after
    `MAX_ITERATIONS`); ``kernel`` (a `Kernel`, or None) is cleared from the preconditioner's output.
    ``iterations``: those of each solve."""

    def __init__(self, matrix: ngs.BaseMatrix, preconditioner: ngs.BaseMatrix, kernel: Kernel | None = None):
        if kernel is not None:
            clear = KernelClearing(*kernel, matrix.height)
            preconditioner = clear @ preconditioner @ clear
        self.preconditioner = preconditioner
        self.solver = CGSolver(mat=matrix, pre=preconditioner, tol=TOLERANCE, maxiter=MAX_ITERATIONS)
        self.iterations: list[int] = []

    def __call__(self, load: ngs.BaseVector, out: ngs.BaseVector) -> None:
        solver = self.solver
        out[:] = 0.0
        solver.Solve(rhs=load, sol=out, initialize=False)
        if solver.residuals[-1] > TOLERANCE * solver.residuals[0]:
            from .iterative import NotConverged  # iterative imports multigrid, which imports this module

            raise NotConverged(f"symmetric solve: CG did not reach {TOLERANCE:g} in {MAX_ITERATIONS} iterations")
        self.iterations.append(solver.iterations)


def symmetric_solver(matrix: ngs.BaseMatrix, used: ngs.BitArray, kernel: Kernel | None = None,
                     preconditioner: ngs.BaseMatrix | None = None) -> Factorised | ConjugateGradients:
    """load, out ↦ out = A⁺ load on the ``used`` dofs: `ConjugateGradients` with ``preconditioner`` (which acts
    on the used dofs only) if one is given, else `Factorised`; ``kernel``: A's (a `Kernel`), None if A is SPD."""
    if preconditioner is None:
        return Factorised(matrix, used, kernel is not None)
    return ConjugateGradients(matrix, preconditioner, kernel)


class KernelClearing(ngs.BaseMatrix):
    """x ↦ x − K Kᵀ x on the ``dofs`` (a slice or an index array) of K's columns; the other dofs are copied."""

    def __init__(self, kernel: np.ndarray, dofs: slice | np.ndarray, size: int):
        super().__init__()
        self.kernel, self.dofs, self.size = kernel, dofs, size

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        values = x.FV().NumPy()[self.dofs]
        y.data = x
        y.FV().NumPy()[self.dofs] = values - self.kernel @ (self.kernel.T @ values)

    def IsComplex(self) -> bool:
        return False

    def Height(self) -> int:
        return self.size

    def Width(self) -> int:
        return self.size
