"""A distributed matrix (``ParallelMatrix``, under mpirun) factorised by MUMPS over all ranks, through PETSc: the
direct solves of `direct.factorise` (the initial projection (22)–(23)) and `symmetric.factorised` on a distributed
mesh.

The free dofs are numbered globally by their masters (NGSolve's ``MasterDofs``), rank by rank, the numbers reach
the other ranks that share a dof by a ``Cumulate``, and every rank's local matrix enters as a summand (the local
part of a MATIS, converted to MPIAIJ, as in `petsc`). MUMPS's LU pivots: symmetric indefinite (saddle-point) and
SPD matrices alike.
"""
from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..runtime import parallel
from .base import SolverError
from .petsc_init import petsc, register, unregister
from .petsc_layout import from_summands
from .sparse import free_mask, to_scipy_csr

#: PETSc's options of the factorisation (set on the objects, not in the options database).
KSP_TYPE, PC_TYPE, SOLVER_TYPE = "preonly", "lu", "mumps"


def global_numbers(matrix: ngs.la.ParallelMatrix, free: np.ndarray) -> tuple[np.ndarray, tuple[int, int], int]:
    """The global numbers of this rank's ``free`` dofs (in their local order), the range of them this rank owns
    (its masters'), and the number of free dofs of all ranks."""
    dofs = np.flatnonzero(free)
    master = np.fromiter(matrix.row_pardofs.MasterDofs(), dtype=bool, count=len(free))[dofs]
    counts = parallel.gather(int(master.sum()))
    start = sum(counts[:parallel.rank()])
    vector = matrix.CreateColVector()
    values = vector.FV().NumPy()
    values[:] = 0.0
    values[dofs[master]] = start + np.arange(1, master.sum() + 1)  # number + 1 at the master only, then summed
    vector.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
    vector.Cumulate()
    return np.rint(values[dofs]).astype(np.int64) - 1, (start, start + int(master.sum())), sum(counts)


class MumpsInverse(ngs.BaseMatrix):
    """(A + ``shift`` diag(A))⁻¹ of a distributed A on ``freedofs`` (zero on the other dofs), factorised once by
    MUMPS; ``Mult`` takes a distributed or cumulated vector and returns a cumulated one. A failed factorisation
    or solve raises `SolverError` there (PETSc's reason, the same on every rank)."""

    def __init__(self, matrix: ngs.la.ParallelMatrix, freedofs: ngs.BitArray | None, shift: float = 0.0):
        super().__init__()
        self.PETSc = PETSc = petsc()
        self.matrix = matrix
        local = matrix.local_mat
        free = free_mask(freedofs, local.height)
        self._dofs = np.flatnonzero(free)
        numbers, rows, size = global_numbers(matrix, free)
        self._numbers = numbers.astype(PETSc.IntType)
        self._master = (numbers >= rows[0]) & (numbers < rows[1])
        csr = to_scipy_csr(local)
        csr = (csr + shift * sp.diags(csr.diagonal()) if shift else csr)[self._dofs][:, self._dofs].tocsr()
        self.A = from_summands(PETSc, csr, self._numbers, rows[1] - rows[0], size)
        self.ksp = PETSc.KSP().create(comm=PETSc.COMM_WORLD)
        self.ksp.setOperators(self.A)
        self.ksp.setType(KSP_TYPE)
        pc = self.ksp.getPC()
        pc.setType(PC_TYPE)
        pc.setFactorSolverType(SOLVER_TYPE)
        self.ksp.setUp()
        self._b, self._x = self.A.createVecs()
        self._local = PETSc.Vec().createSeq(len(self._dofs), comm=PETSc.COMM_SELF)
        self._scatter = PETSc.Scatter().create(self._x, PETSc.IS().createGeneral(self._numbers, comm=PETSc.COMM_SELF),
                                               self._local, None)
        register(self)

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        values, mode = x.FV().NumPy()[self._dofs], self.PETSc.InsertMode
        self._b.set(0.0)
        if x.GetParallelStatus() == ngs.la.PARALLEL_STATUS.DISTRIBUTED:  # summands: every rank's added
            self._b.setValues(self._numbers, values, addv=mode.ADD_VALUES)
        else:
            self._b.setValues(self._numbers[self._master], values[self._master], addv=mode.INSERT_VALUES)
        self._b.assemble()
        self.ksp.solve(self._b, self._x)
        if self.ksp.getConvergedReason() < 0:
            raise SolverError(f"mumps: the solve failed (PETSc reason {self.ksp.getConvergedReason()})")
        self._scatter.scatter(self._x, self._local, addv=mode.INSERT_VALUES)
        out = y.FV().NumPy()
        out[:] = 0.0
        out[self._dofs] = self._local.getArray()
        y.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)

    def destroy(self) -> None:
        """Free the PETSc objects (at exit: `petsc_init.register`)."""
        for obj in (self.ksp, self.A, self._b, self._x, self._local, self._scatter):
            obj.destroy()
        unregister(self)

    def IsComplex(self) -> bool:
        return False

    def Height(self) -> int:
        return self.matrix.local_mat.height

    def Width(self) -> int:
        return self.matrix.local_mat.width

    def CreateColVector(self) -> ngs.BaseVector:
        return self.matrix.CreateColVector()

    def CreateRowVector(self) -> ngs.BaseVector:
        return self.matrix.CreateRowVector()
