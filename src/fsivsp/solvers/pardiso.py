"""MKL PARDISO through its documented C interface (``pardiso``, ctypes), as an NGSolve inverse on the free dofs.

The step matrix is symmetric indefinite: PARDISO's type −2 (Bunch–Kaufman pivoting inside supernodes; 6 for a
complex symmetric matrix, 11/13 when not symmetric) on the upper triangle, with MKL's scaling and symmetric weighted
matching (iparm[10] = iparm[12] = 1, MKL's advice for saddle points) where pivots had to be perturbed
(``matching="auto"``: factorised without, and again with matching if iparm[13] reports perturbed pivots). Matching
pairs each zero-diagonal pressure dof with a velocity dof in a 2×2 pivot. The parameters are NGSolve's binding's
(`ngsolve.solvers.mkl_pardiso`, whose own analysis turns matching off for symmetric types), so the factors are the
ones it gives, bit for bit; MKL runs on the running code's thread count with NGSolve's TaskManager suspended.
"""
from __future__ import annotations

import ctypes
from contextlib import contextmanager
from typing import Any

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
from pyngcore import GetNumThreads, SuspendTaskManager

from ..runtime.threads import mkl_runtime
from .sparse import free_mask, to_scipy_csr

#: ``ordering``: iparm[1].
ORDERINGS = {"minimum_degree": 0, "metis": 2, "parallel_metis": 3}
#: PARDISO's matrix types by (complex, symmetric).
TYPES = {(False, True): -2, (False, False): 11, (True, True): 6, (True, False): 13}
PHASE_ANALYSE_FACTORISE, PHASE_SOLVE, PHASE_RELEASE = 12, 33, -1


def available() -> bool:
    """Whether MKL's runtime (the ``mkl`` package) with ``pardiso`` loads here."""
    runtime = mkl_runtime()
    return runtime is not None and hasattr(runtime, "pardiso")


@contextmanager
def _mkl_threads():
    """MKL on the running code's threads, NGSolve's TaskManager suspended meanwhile."""
    runtime = mkl_runtime()
    previous = runtime.MKL_Set_Num_Threads_Local(GetNumThreads())
    suspended = SuspendTaskManager()
    try:
        yield
    finally:
        del suspended
        runtime.MKL_Set_Num_Threads_Local(previous)


class Pardiso(ngs.BaseMatrix):
    """A_ff⁻¹ of ``matrix`` on ``freedofs`` (zero on the other dofs, as NGSolve's inverses), factorised once by
    PARDISO. ``symmetric``: the matrix is (the caller asserts it); ``ordering`` (`ORDERINGS`), ``refinement`` (MKL's
    iterative refinement steps, iparm[7]; 0: only where pivots were perturbed), ``matching`` (True, False or
    ``"auto"``, see the module's docstring), ``iparm``: raw ``{N: value}`` entries. After factorising:
    ``perturbed_pivots`` (iparm[13]) and ``matching`` (whether it was used)."""

    def __init__(self, matrix: ngs.BaseMatrix, freedofs: ngs.BitArray | None, symmetric: bool,
                 ordering: str = "minimum_degree", refinement: int = 0, matching: bool | str = "auto",
                 iparm: dict[int, int] | None = None):
        super().__init__()
        self.matrix, self._complex = matrix, matrix.is_complex
        self._free = np.flatnonzero(free_mask(freedofs, matrix.height))
        csr = to_scipy_csr(matrix)[self._free][:, self._free]
        if symmetric:
            csr = sp.triu(csr)
        csr = csr.tocsr()
        csr.sort_indices()
        dtype = np.complex128 if self._complex else np.float64
        self._data = np.ascontiguousarray(csr.data, dtype=dtype)
        self._ia = np.ascontiguousarray(csr.indptr, dtype=np.int32)
        self._ja = np.ascontiguousarray(csr.indices, dtype=np.int32)
        self._b, self._x = np.zeros(len(self._free), dtype=dtype), np.zeros(len(self._free), dtype=dtype)
        self._type = ctypes.c_int(TYPES[self._complex, bool(symmetric)])
        self._arrays = {name: array.ctypes.data_as(ctypes.c_void_p)
                        for name, array in (("a", self._data), ("ia", self._ia), ("ja", self._ja), ("b", self._b),
                                            ("x", self._x))}
        self._params = self._parameters(ordering, refinement, iparm or {})
        self._pt = (ctypes.c_int64 * 64)()
        auto = matching == "auto"
        self.matching = False if auto else bool(matching)
        self._factorise(symmetric)
        if auto and self.perturbed_pivots:
            self._release()
            self.matching = True
            self._factorise(symmetric)

    @staticmethod
    def _parameters(ordering: str, refinement: int, iparm: dict[int, int]):
        """iparm (0-based, C indexing): NGSolve's binding's values."""
        params = (ctypes.c_int * 64)()
        values = {0: 1, 1: ORDERINGS[ordering], 7: int(refinement), 9: 13, 10: 1, 12: 1, 17: -1, 20: 1, 26: 1, 34: 1}
        for key, value in {**values, **iparm}.items():
            params[key] = value
        return params

    def _factorise(self, symmetric: bool) -> None:
        """Analysis and factorisation: scaling on (iparm[10]), matching (iparm[12]) if `matching` or the type is
        not symmetric (as NGSolve's binding, whose symmetric analysis leaves matching off)."""
        self._params[12] = 1 if self.matching or not symmetric else 0
        self._call(PHASE_ANALYSE_FACTORISE)

    @property
    def perturbed_pivots(self) -> int:
        """MKL's count of perturbed pivots in the last factorisation (iparm[13])."""
        return int(self._params[13])

    def _call(self, phase: int, data: bool = True) -> None:
        """``pardiso(pt, maxfct, mnum, mtype, phase, n, a, ia, ja, perm, nrhs, iparm, msglvl, b, x, error)``; the
        matrix and vectors left out (null) where ``data`` is False (the release)."""
        one, error, n = ctypes.c_int(1), ctypes.c_int(0), ctypes.c_int(len(self._free))
        null, arrays = ctypes.c_void_p(0), self._arrays
        with _mkl_threads():
            mkl_runtime().pardiso(self._pt, ctypes.byref(one), ctypes.byref(one), ctypes.byref(self._type),
                                  ctypes.byref(ctypes.c_int(phase)), ctypes.byref(n), arrays["a"] if data else null,
                                  arrays["ia"], arrays["ja"], null, ctypes.byref(one), self._params,
                                  ctypes.byref(ctypes.c_int(0)), arrays["b"] if data else null,
                                  arrays["x"] if data else null, ctypes.byref(error))
        if error.value != 0:
            raise RuntimeError(f"MKL PARDISO error {error.value} in phase {phase}")

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        self._b[:] = x.FV().NumPy()[self._free]
        self._call(PHASE_SOLVE)
        values = y.FV().NumPy()
        values[:] = 0.0
        values[self._free] = self._x

    def _release(self) -> None:
        if any(self._pt):
            self._call(PHASE_RELEASE, data=False)

    def __del__(self) -> None:
        if hasattr(self, "_pt"):
            self._release()

    def IsComplex(self) -> bool:
        return self._complex

    def Height(self) -> int:
        return self.matrix.height

    def Width(self) -> int:
        return self.matrix.width

    def CreateRowVector(self) -> ngs.BaseVector:
        return self.matrix.CreateRowVector()

    def CreateColVector(self) -> ngs.BaseVector:
        return self.matrix.CreateColVector()


def pardiso(matrix: ngs.BaseMatrix, freedofs: ngs.BitArray | None, flags: dict[str, Any]) -> Pardiso:
    """`Pardiso` from flags as `direct.DirectSolver` takes them (``symmetric``, ``ordering``, ``refinement``,
    ``matching``, ``iparmN``)."""
    flags = dict(flags)
    iparm = {int(key[5:]): int(flags.pop(key)) for key in list(flags) if key.startswith("iparm")}
    return Pardiso(matrix, freedofs, iparm=iparm, **flags)
