"""Sparse-matrix utilities of the solvers: NGSolve matrices as scipy CSR and back, the free dofs as a mask (and a
mask as a BitArray), a symmetry test."""
from __future__ import annotations

import ngsolve as ngs
import numpy as np

from .base import SolverError


def free_mask(freedofs: ngs.BitArray | None, n: int) -> np.ndarray:
    """The free dofs as a boolean numpy mask of length ``n`` (all True if None)."""
    if freedofs is None:
        return np.ones(n, dtype=bool)
    if len(freedofs) != n:
        raise ValueError(f"freedofs has {len(freedofs)} bits, the matrix {n} rows")
    return np.fromiter(freedofs, dtype=bool, count=n)


def _raw_csr(matrix):
    import scipy.sparse as sp

    vals, cols, rowptr = matrix.CSR()
    return sp.csr_matrix(
        (np.array(vals, dtype=complex if matrix.is_complex else float), np.array(cols), np.array(rowptr)),
        shape=(matrix.height, matrix.width),
    )


def to_ngsolve(matrix) -> ngs.BaseMatrix:
    """A scipy sparse matrix as an NGSolve sparse matrix (general storage)."""
    coo = matrix.tocoo()  # numpy arrays straight to C++: Python lists cost ~100 bytes an entry
    return ngs.la.SparseMatrixd.CreateFromCOO(coo.row, coo.col, coo.data, matrix.shape[0], matrix.shape[1])


def compact(matrix, symmetric: bool = False) -> ngs.BaseMatrix:
    """The same operator without stored zeros (NGSolve's ``DeleteZeroElements``, in place of memory). A
    form on a product space stores every pair of dofs of an element, so e.g. the velocity mass on
    V_h × Q_h keeps 2.4× its nonzeros (no coupling between components or with the pressure); a product
    costs its stored entries. A distributed matrix (``ParallelMatrix``, under MPI) is returned as it is.

    With ``symmetric`` the pattern is made symmetric again (`symmetric_pattern`): on periodic spaces an entry
    that vanishes analytically sums to an exact 0 on one side of the diagonal and to round-off (1e-19 of the
    largest entry) on the other, and NGSolve's PARDISO fails on the one-sided pattern ("illegal position")."""
    if isinstance(matrix, ngs.la.ParallelMatrix):
        return matrix
    compacted = matrix.DeleteZeroElements(0.0)
    return symmetric_pattern(compacted) if symmetric else compacted


def symmetric_pattern(matrix) -> ngs.BaseMatrix:
    """``matrix`` itself if its pattern is symmetric (or it is not square), else a copy that also stores the
    transposed positions of its one-sided entries (as zeros)."""
    import scipy.sparse as sp

    if matrix.height != matrix.width:
        return matrix
    _, cols, rowptr = matrix.CSR()
    cols, rowptr = np.asarray(cols, dtype=np.int64), np.asarray(rowptr, dtype=np.int64)
    pattern = sp.csr_matrix((np.ones(len(cols), dtype=np.int8), cols, rowptr), shape=(matrix.height,) * 2)
    missing = (pattern.T - pattern).tocoo()
    missing = (missing.row[missing.data > 0], missing.col[missing.data > 0])
    if not len(missing[0]):
        return matrix
    full = _raw_csr(matrix).tocoo()
    return ngs.la.SparseMatrixd.CreateFromCOO(np.concatenate([full.row, missing[0]]),
                                              np.concatenate([full.col, missing[1]]),
                                              np.concatenate([full.data, np.zeros(len(missing[0]))]),
                                              matrix.height, matrix.width)


def _stores_lower_triangle(matrix) -> bool:
    """True for NGSolve's symmetric storage (only the lower triangle is kept)."""
    if isinstance(matrix, getattr(ngs.la, "SparseMatrixSymmetricd", ())):
        return True
    return bool(getattr(matrix, "is_symmetric_storage", False))


def to_scipy_csr(matrix, *, verify: bool = True):
    """The full matrix of an assembled NGSolve sparse matrix as scipy CSR.

    With ``BilinearForm(..., symmetric=True, symmetric_storage=True)`` NGSolve keeps
    only the lower triangle (``SparseMatrixSymmetricd``); its ``CSR()`` is then
    symmetrised to ``L + L^T - diag(L)``. If ``verify``, the result is compared with
    NGSolve's own matrix-vector product on a random vector, and symmetrised anyway
    if a triangular pattern only matches that way (storage flags are not always
    exposed).
    """
    import scipy.sparse as sp

    raw = _raw_csr(matrix)
    candidates = []
    if _stores_lower_triangle(matrix):
        candidates.append(_symmetrise_lower(raw))
    candidates.append(raw)
    if not verify:
        return candidates[0]
    if sp.triu(raw, 1).nnz == 0 and sp.tril(raw, -1).nnz > 0 and len(candidates) == 1:
        candidates.append(_symmetrise_lower(raw))

    x = matrix.CreateRowVector()
    y = matrix.CreateColVector()
    xs = np.random.default_rng(12345).standard_normal(matrix.width)
    x.FV().NumPy()[:] = xs
    y.data = matrix * x
    ys = y.FV().NumPy()
    scale = max(np.linalg.norm(ys), 1e-300)
    for cand in candidates:
        if np.linalg.norm(cand @ xs - ys) <= 1e-12 * scale + 1e-300:
            return cand
    raise SolverError("scipy: CSR conversion does not reproduce the NGSolve matrix-vector product")


def is_symmetric(matrix, rtol: float = 1e-12) -> bool:
    """Whether ``matrix`` is symmetric: by its storage, else by the probabilistic test
    ``|y^T A x - x^T A y| <= rtol ||A x|| ||y||`` with seeded random x, y (two
    matrix-vector products; an asymmetry above roundoff fails it with probability 1)."""
    if _stores_lower_triangle(matrix):
        return True
    if matrix.height != matrix.width:
        return False
    rng = np.random.default_rng(4321)
    x, y = matrix.CreateRowVector(), matrix.CreateRowVector()
    x.FV().NumPy()[:] = rng.standard_normal(matrix.width)
    y.FV().NumPy()[:] = rng.standard_normal(matrix.width)
    ax, ay = matrix.CreateColVector(), matrix.CreateColVector()
    ax.data = matrix * x
    ay.data = matrix * y
    xs, ys = x.FV().NumPy(), y.FV().NumPy()
    axs, ays = ax.FV().NumPy(), ay.FV().NumPy()
    scale = max(np.linalg.norm(axs) * np.linalg.norm(ys), np.linalg.norm(ays) * np.linalg.norm(xs))
    return bool(abs(ys @ axs - xs @ ays) <= rtol * scale)


def full_storage_copy(matrix):
    """A full-storage ``SparseMatrixd`` copy of an NGSolve sparse matrix."""
    return to_ngsolve(to_scipy_csr(matrix))


def _symmetrise_lower(lower):
    import scipy.sparse as sp

    lower = sp.tril(lower).tocsr()
    full = lower + sp.tril(lower, -1).T
    return full.tocsr()


def bits(mask: np.ndarray) -> ngs.BitArray:
    """A boolean numpy mask as an NGSolve BitArray."""
    array = ngs.BitArray(len(mask))
    array.Clear()
    for i in np.flatnonzero(mask):
        array.Set(int(i))
    return array
