"""Solves with a symmetric positive (semi)definite matrix A, set up once and applied many times: the Gram matrices
of the error norms (`experiments.projection`).

- `factorised`: A's factors on its free dofs, solves bit-identical from one process to the next: NGSolve's
  sparsecholesky on one thread; under more (`threads.using`), where its factors and solves vary at round-off,
  UMFPACK, else SuperLU (sequential); on a distributed matrix (mpirun) MUMPS over the ranks (`mumps`).
- `symmetric_solver`: load ↦ A⁺ load on the used dofs, by those factors (`Factorised`; a singular A, whose kernel
  is known, shifted and refined) or by PETSc's conjugate gradients with BoomerAMG (`PETScCG`; the kernel attached
  as A's null space, so that the iterates stay clear of it). A singular A must be consistent for the loads (a load
  ∫ Cε(E):Cε(w) of the stress norm, whose kernel is the rigid motions).
"""
from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..runtime.threads import current, idle
from .base import NotConverged
from .direct import ScipyLUInverse, available_methods
from .mumps import MumpsInverse
from .petsc_init import petsc, register, unregister
from .sparse import free_mask, to_ngsolve, to_scipy_csr

#: CG stops when the preconditioned residual is below this fraction of the load's: the error norms then equal the
#: factorised projections' to 1e-9 relative (tests/experiments/test_norms.py).
TOLERANCE = 1e-13
MAX_ITERATIONS = 2000
#: The shift of a singular A's diagonal for its factorisation, relative to the diagonal; `REFINEMENT_STEPS` of
#: iterative refinement with A then remove its effect on the solution. BoomerAMG's matrix is shifted by
#: `PRECONDITIONER_SHIFT` (the preconditioner only: CG iterates with A).
SINGULAR_SHIFT, REFINEMENT_STEPS, PRECONDITIONER_SHIFT = 1e-10, 3, 1e-6

#: The kernel of A: an orthonormal basis (columns) on the dofs (a slice or an index array) it names.
Kernel = tuple[np.ndarray, slice | np.ndarray]


def shifted(csr: sp.csr_matrix, shift: float) -> sp.csr_matrix:
    """A + ``shift`` diag(A)."""
    return csr + shift * sp.diags(csr.diagonal()) if shift else csr


def factorised(matrix: ngs.BaseMatrix, freedofs: ngs.BitArray, shift: float = 0.0) -> ngs.BaseMatrix:
    """The inverse of A + ``shift`` diag(A) (A SPD there) on ``freedofs``, by the module's factorisations."""
    if isinstance(matrix, ngs.la.ParallelMatrix):
        return MumpsInverse(matrix, freedofs, shift)
    if shift:
        matrix = to_ngsolve(shifted(to_scipy_csr(matrix), shift))
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


class PETScCG:
    """load, out ↦ out = A⁺ load on the ``used`` dofs (zero elsewhere) by PETSc's CG from zero, preconditioned by one
    BoomerAMG cycle, or if A has a ``kernel`` one GAMG cycle with the kernel as its near-nullspace (on A +
    `PRECONDITIONER_SHIFT` diag(A): the stress norm's Gram matrix of Taylor–Hood k = 1 on the paper's level 3 took
    219 iterations and 4.4 s with BoomerAMG, 42 and 1.5 s with GAMG), to `TOLERANCE`; `NotConverged`
    after `MAX_ITERATIONS`. ``kernel`` (a `Kernel`, or None) is A's null space: removed from the load and from
    every preconditioned residual. ``iterations``: those of each solve. Serial matrices only."""

    def __init__(self, matrix: ngs.BaseMatrix, used: ngs.BitArray, kernel: Kernel | None = None):
        self.PETSc = PETSc = petsc()
        mask = free_mask(used, matrix.height)
        self._dofs = np.flatnonzero(mask)
        csr = to_scipy_csr(matrix)[self._dofs][:, self._dofs].tocsr()
        self.A = self._aij(csr)
        self.P = self._aij(shifted(csr, PRECONDITIONER_SHIFT)) if kernel is not None else self.A
        self.nullspace = None
        if kernel is not None:
            self.nullspace = self._nullspace(kernel, mask)
            self.A.setNullSpace(self.nullspace)
        self.ksp = PETSc.KSP().create(comm=PETSc.COMM_SELF)
        self.ksp.setOperators(self.A, self.P)
        self.ksp.setType("cg")
        if kernel is None:
            self.ksp.getPC().setType("hypre")
        else:   # the kernel as GAMG's near-nullspace
            self.P.setNearNullSpace(self.nullspace)
            self.ksp.getPC().setType("gamg")
        self.ksp.setTolerances(rtol=TOLERANCE, atol=0.0, max_it=MAX_ITERATIONS)
        self.ksp.setUp()
        self._b, self._x = self.A.createVecs()
        self.iterations: list[int] = []
        register(self)

    def _aij(self, csr: sp.csr_matrix):
        PETSc = self.PETSc
        return PETSc.Mat().createAIJ(size=csr.shape, csr=(csr.indptr.astype(PETSc.IntType),
                                                          csr.indices.astype(PETSc.IntType), csr.data),
                                     comm=PETSc.COMM_SELF)

    def _nullspace(self, kernel: Kernel, mask: np.ndarray):
        """A's kernel as a PETSc null space on the used dofs."""
        basis, dofs = kernel
        position = np.cumsum(mask) - 1
        rows = position[np.arange(len(mask))[dofs]]
        vectors = []
        for column in basis.T:
            vector = self.PETSc.Vec().createSeq(len(self._dofs), comm=self.PETSc.COMM_SELF)
            vector.set(0.0)
            vector.setValues(rows.astype(self.PETSc.IntType), column)
            vector.assemble()
            vector.normalize()
            vectors.append(vector)
        self._kernel = vectors
        return self.PETSc.NullSpace().create(vectors=vectors, comm=self.PETSc.COMM_SELF)

    def __call__(self, load: ngs.BaseVector, out: ngs.BaseVector) -> None:
        self._b.setArray(load.FV().NumPy()[self._dofs])
        if self.nullspace is not None:
            self.nullspace.remove(self._b)
        self._x.set(0.0)
        with idle():
            self.ksp.solve(self._b, self._x)
        if self.ksp.getConvergedReason() < 0:
            raise NotConverged(f"symmetric solve: CG did not reach {TOLERANCE:g} in {MAX_ITERATIONS} iterations "
                               f"(PETSc reason {self.ksp.getConvergedReason()})")
        self.iterations.append(self.ksp.getIterationNumber())
        values = out.FV().NumPy()
        values[:] = 0.0
        values[self._dofs] = self._x.getArray()

    def destroy(self) -> None:
        """Free the PETSc objects (at exit: `petsc_init.register`)."""
        for obj in (self.ksp, self.A, self.P, self._b, self._x, self.nullspace, *getattr(self, "_kernel", ())):
            if obj is not None:
                obj.destroy()
        unregister(self)


def symmetric_solver(matrix: ngs.BaseMatrix, used: ngs.BitArray, kernel: Kernel | None = None,
                     iterate: bool = False) -> Factorised | PETScCG:
    """load, out ↦ out = A⁺ load on the ``used`` dofs: `PETScCG` if ``iterate`` (a serial matrix), else `Factorised`;
    ``kernel``: A's (a `Kernel`), None if A is SPD."""
    if iterate and not isinstance(matrix, ngs.la.ParallelMatrix):
        return PETScCG(matrix, used, kernel)
    return Factorised(matrix, used, kernel is not None)
