"""Direct solvers for the scheme's saddle-point matrix: factorise once, solve many times.

Every time step of the scheme solves one linear system with the same symmetric
*indefinite* matrix (velocity block plus the fluid pressure constraint), so the
matrix is factorised once per run and the factorisation is applied at each step.
:class:`DirectSolver` wraps the available sparse direct solvers behind one small
interface (`fsivsp.solvers.StepSolver`, shared with the iterative solver):

>>> solver = DirectSolver(a.mat, X.FreeDofs())          # factorises and checks
>>> x.data = solver.inverse * r                         # composes like NGSolve inverses
>>> solver.solve(r, x)                                  # the same, as a method

With ``refinement = k`` every solve is followed by k steps of iterative refinement
against the matrix (`RefinedInverse`); `factorise` retries PARDISO so before it
takes another method.

Methods (see ``benchmarks/solver_comparison.md`` for the measurements):

``"pardiso"``
    Intel MKL PARDISO through its documented C interface (`pardiso`; needs the ``mkl`` pip
    package: about 690 MB installed plus ~300 MB of Intel runtime libraries), with MKL's
    scaling and symmetric weighted matching for saddle points where pivots had to be
    perturbed. The fastest factorisation and solve here.
``"umfpack"``
    SuiteSparse UMFPACK, built into the NGSolve wheels: LU with partial pivoting,
    safe on indefinite matrices. The default when MKL is not installed. (NGSolve's
    UMFPACK wrapper mishandles symmetric *storage*; a full copy is factorised then.)
``"sparsecholesky"``
    NGSolve's own LDL^T factorisation *without pivoting*. On an indefinite matrix it
    may break down or lose accuracy, which the residual check detects.
``"scipy"``
    ``scipy.sparse.linalg.splu`` (SuperLU) on the free-dof block, wrapped as an
    NGSolve :class:`~ngsolve.BaseMatrix`. Slower, but independent of NGSolve's
    solvers (a cross-check).
``"mumps"`` (`DISTRIBUTED_METHOD`)
    MUMPS's LU through PETSc over the MPI ranks (`mumps`), the one method of a distributed matrix.
"""
from __future__ import annotations

import functools
import logging
import time
from collections.abc import Mapping
from typing import Any

import ngsolve as ngs
import numpy as np
from pyngcore import Flags

from .base import SolverError
from .mumps import MumpsInverse
from .pardiso import pardiso
from .sparse import _stores_lower_triangle, free_mask, full_storage_copy, is_symmetric, to_scipy_csr

log = logging.getLogger(__name__)

__all__ = ["METHODS", "DirectSolver", "available_methods", "default_method", "factorise"]

#: All methods :class:`DirectSolver` knows (:func:`default_method` picks the first
#: available of pardiso, umfpack, scipy, sparsecholesky).
METHODS: tuple[str, ...] = ("pardiso", "umfpack", "sparsecholesky", "scipy")

#: What `factorise` takes for a distributed matrix (mpirun), and nothing else does.
DISTRIBUTED_METHOD = "mumps"

#: Methods whose factorisation pivots, i.e. is safe on symmetric indefinite matrices.
PIVOTING_METHODS: frozenset[str] = frozenset({"pardiso", "umfpack", "scipy"})

#: SuperLU options for the "scipy" method, chosen by measurement (level 4, 72k free
#: dofs): COLAMD factorises in 1.6 s; MMD_AT_PLUS_A needs 14 s with SymmetricMode and
#: 197 s without; MMD_ATA is as fast as COLAMD.
SCIPY_SPLU_OPTIONS: dict[str, Any] = {"permc_spec": "COLAMD"}

#: Flags for NGSolve's MKL PARDISO binding (`ngsolve.solvers.mkl_pardiso`, which passes ``ordering``,
#: ``refinement``, ``symmetric`` and ``iparmN`` on to MKL's iparm), chosen by measurement on the peer case's
#: step matrix, Taylor–Hood k = 2 (benchmarks/peer_hdg.md, "PARDISO's fallback"). The symmetric indefinite type
#: (-2, Bunch–Kaufman pivoting inside supernodes; ``symmetric`` is set when the matrix is) with ``matching``
#: (`pardiso.Pardiso`) where pivots were perturbed: there (a fluid with a Dirichlet wall, whose pressure dofs
#: meet zero pivots: 10 to 258 on levels 0–5) the residual grows 10× per level to 3.1e-9 without it, and stays at
#: round-off with it (1.9e-13 to 1.1e-12; UMFPACK 1.4e-13 to 6.2e-13), no pivot perturbed, a solve 1.3–2.5×
#: faster (MKL's two automatic refinement steps after perturbed pivots are gone) for a 1.3–2.5× slower
#: factorisation. Where no pivot is perturbed (the paper's channel) matching only adds fill: 10% more factor
#: entries and solve time on level 4. ``refinement = 0``: MKL refines only if pivots were perturbed. Minimum
#: degree solves as fast as METIS here and factorises 1.2–1.4× faster.
PARDISO_FLAGS: dict[str, Any] = {"ordering": "minimum_degree", "refinement": 0, "matching": "auto"}

#: Steps of iterative refinement `factorise` retries PARDISO with when its residual check fails, before any
#: other method (the same flags; each step one product with the matrix and one solve). Measured on the step
#: matrix whose pivots were perturbed (no matching): one step brings 3.5e-10 to 3.3e-13 on level 4, 3.1e-9 to
#: 6.1e-13 on level 5 (MKL's own refinement stops after two steps, at 3.5e-10 with up to 16 allowed); two, for
#: the retry runs only on factors worse than any measured.
RETRY_REFINEMENT_STEPS = 2


class _SquareOperator(ngs.BaseMatrix):
    """An NGSolve BaseMatrix of the shape and vectors of ``template`` (a vector of the matrix)."""

    def __init__(self, template):
        super().__init__()
        self._template = template

    def IsComplex(self):
        return False

    def Height(self):
        return len(self._template)

    def Width(self):
        return len(self._template)

    def CreateRowVector(self):
        return self._template.CreateVector()

    def CreateColVector(self):
        return self._template.CreateVector()


class RefinedInverse(_SquareOperator):
    """``inverse`` followed by ``steps`` of iterative refinement against ``matrix``, x ← x + A⁻¹(b − A x):
    each step one product with A and one solve. A factorisation of A + E (perturbed pivots) then has its
    error multiplied by ‖A⁻¹E‖ per step. ``inverse`` must, like NGSolve's, read and write free dofs only."""

    def __init__(self, matrix, inverse, steps: int):
        super().__init__(matrix.CreateColVector())
        self.matrix, self.base, self.steps = matrix, inverse, steps
        self._residual = matrix.CreateColVector()

    def Mult(self, x, y):
        y.data = self.base * x
        for _ in range(self.steps):
            self._residual.data = x - self.matrix * y
            y.data += self.base * self._residual


# ---------------------------------------------------------------------------
# scipy SuperLU wrapped as an NGSolve BaseMatrix


class ScipyLUInverse(_SquareOperator):
    """``A_ff^{-1}`` from ``scipy.sparse.linalg.splu`` as an NGSolve BaseMatrix.

    ``Mult(x, y)`` sets ``y[free] = A_ff^{-1} x[free]`` and ``y[non-free] = 0``,
    like the inverses NGSolve returns from ``mat.Inverse(freedofs)``.
    """

    def __init__(self, matrix, freedofs, options: Mapping[str, Any] | None = None):
        super().__init__(matrix.CreateColVector())
        from scipy.sparse.linalg import splu

        self._free = np.flatnonzero(free_mask(freedofs, matrix.height))
        full = to_scipy_csr(matrix)
        aff = full[self._free][:, self._free].tocsc()
        opts = dict(SCIPY_SPLU_OPTIONS)
        if options:
            opts.update(options)
        self.lu = splu(aff, **opts)

    def Mult(self, x, y):
        xs = x.FV().NumPy()
        ys = y.FV().NumPy()
        sol = self.lu.solve(np.ascontiguousarray(xs[self._free]))
        ys[:] = 0.0
        ys[self._free] = sol

    def MultTrans(self, x, y):  # the matrix is symmetric, but be correct anyway
        xs = x.FV().NumPy()
        ys = y.FV().NumPy()
        sol = self.lu.solve(np.ascontiguousarray(xs[self._free]), trans="T")
        ys[:] = 0.0
        ys[self._free] = sol


# ---------------------------------------------------------------------------
# availability


def _probe_matrix():
    """A small symmetric indefinite (saddle-point) test matrix, all dofs free."""
    rows = [0, 1, 2, 0, 2, 1, 2]
    cols = [0, 1, 2, 2, 0, 2, 1]
    vals = [2.0, 3.0, -1.0, 1.0, 1.0, 1.0, 1.0]
    return ngs.la.SparseMatrixd.CreateFromCOO(rows, cols, vals, 3, 3)


def _works(method: str) -> bool:
    try:
        DirectSolver(_probe_matrix(), None, method=method, check=True, rtol=1e-10)
    except Exception:
        return False
    return True


@functools.cache
def available_methods() -> list[str]:
    """The methods of :data:`METHODS` that factorise a small test matrix here."""
    return [m for m in METHODS if _works(m)]


def default_method() -> str:
    """The fastest safe method available: MKL PARDISO if the ``mkl`` package is
    installed, else UMFPACK (built into NGSolve), else SuperLU via scipy, and
    NGSolve's sparsecholesky only as the last resort (it does not pivot)."""
    avail = available_methods()
    for m in ("pardiso", "umfpack", "scipy", "sparsecholesky"):
        if m in avail:
            return m
    return "sparsecholesky"


# ---------------------------------------------------------------------------
# the solver


def _free_residual(matrix, inverse, mask: np.ndarray, seed: int) -> float:
    b = matrix.CreateColVector()
    bs = b.FV().NumPy()
    bs[:] = np.random.default_rng(seed).standard_normal(len(bs))
    bs[~mask] = 0.0
    x = matrix.CreateRowVector()
    x.data = inverse * b
    r = b.CreateVector()
    r.data = b - matrix * x
    rs = r.FV().NumPy()[mask]
    nb = np.linalg.norm(bs[mask])
    if nb == 0.0:
        return 0.0
    res = float(np.linalg.norm(rs) / nb)
    return res if np.isfinite(res) else float("inf")


class DirectSolver:
    """Factorise once, solve many times; an inverse of ``matrix`` on the free dofs.

    Parameters
    ----------
    matrix
        An assembled NGSolve sparse matrix (``BilinearForm.mat``), with full or
        symmetric (lower-triangle) storage.
    freedofs
        The free dofs (``fes.FreeDofs()``); ``None`` means all.
    method
        One of :data:`METHODS`; ``None`` chooses :func:`default_method`.
    check
        Solve once with a seeded random right-hand side on the free dofs and raise
        :class:`SolverError` unless ``||b - A x|| / ||b|| < rtol`` (on the free dofs).
        sparsecholesky is LDL^T without pivoting; on an indefinite matrix this check
        is what makes it safe to use.
    rtol
        Tolerance of the residual check.
    options
        Method-specific options: for "scipy" keyword arguments of ``splu``
        (overriding :data:`SCIPY_SPLU_OPTIONS`), for the NGSolve methods flags of
        the inverse (e.g. ``{"symmetric": True}`` or ``{"matching": False}`` for pardiso).
    refinement
        Steps of iterative refinement after every solve (`RefinedInverse`); 0: none.

    Attributes
    ----------
    method, residual (NaN without check; after the refinement), residual_unrefined (of
    the factors alone, checked with ``refinement`` only), perturbed_pivots and matching
    (pardiso: the last factorisation's; else None), factor_seconds, factors (the inverse the method built), inverse (an
    NGSolve BaseMatrix, so ``x.data = solver.inverse * r`` works), freedofs.
    """

    #: The scheme may run a solve concurrently with other work of its own (`Scheme.march`).
    overlap = True

    def __init__(self, matrix, freedofs: ngs.BitArray | None = None, method: str | None = None, check: bool = True,
                 rtol: float = 1e-8, options: Mapping[str, Any] | None = None, refinement: int = 0):
        method = default_method() if method is None else method
        if method not in (*METHODS, DISTRIBUTED_METHOD):
            raise ValueError(f"unknown solver method {method!r}; known: {', '.join(METHODS)}")
        self.method, self.matrix, self.freedofs, self.rtol, self.refinement = method, matrix, freedofs, rtol, refinement
        self.residual = self.residual_unrefined = float("nan")
        self.fallback: dict | None = None   # set by `factorise` when a preferred method failed first

        start = time.perf_counter()
        try:
            self.factors = self._factorise(options)
        except SolverError:
            raise
        except Exception as exc:  # noqa: BLE001 - any backend failure
            raise SolverError(f"{method}: factorisation failed: {exc}") from exc
        self.factor_seconds = time.perf_counter() - start
        self.perturbed_pivots = getattr(self.factors, "perturbed_pivots", None)
        self.matching = getattr(self.factors, "matching", None)
        self.inverse = RefinedInverse(matrix, self.factors, refinement) if refinement else self.factors
        if check:
            self.check()

    def _factorise(self, options: Mapping[str, Any] | None):
        """The method's inverse of the matrix on the free dofs."""
        matrix, method = self.matrix, self.method
        if method == "scipy":
            return ScipyLUInverse(matrix, self.freedofs, options)
        if method == DISTRIBUTED_METHOD:
            return MumpsInverse(matrix, self.freedofs)
        opts: dict[str, Any] = {}
        if method == "pardiso":
            opts.update(PARDISO_FLAGS)
            opts["symmetric"] = is_symmetric(matrix)
        opts.update(options or {})
        if method == "pardiso":
            return pardiso(matrix, self.freedofs, opts)
        if method == "umfpack" and _stores_lower_triangle(matrix):
            # NGSolve 6.2.2608's UMFPACK takes the stored lower triangle for the
            # whole matrix: it fails (saddle point) or silently solves a wrong
            # system (SPD: residual ~1). Factorise a full-storage copy instead.
            matrix = full_storage_copy(matrix)
        return matrix.Inverse(self.freedofs, inverse=method, flags=Flags(opts) if opts else None)

    def refine(self, steps: int) -> None:
        """Apply ``steps`` of iterative refinement after every solve from now on (the same factors), and check
        again (`check`)."""
        self.refinement = steps
        self.inverse = RefinedInverse(self.matrix, self.factors, steps)
        self.check()

    def check(self) -> None:
        """The residual check (the ``check`` parameter); with refinement the factors' own residual is kept too."""
        mask = free_mask(self.freedofs, self.matrix.height)
        self.residual = _free_residual(self.matrix, self.inverse, mask, seed=20180101)
        if not self.residual < self.rtol:
            raise SolverError(
                f"{self.method}: residual check failed, ||b - A x|| / ||b|| = "
                f"{self.residual:.3e} >= rtol = {self.rtol:.1e}"
                + ("" if self.method in PIVOTING_METHODS else " (no pivoting: the matrix is indefinite?)"),
                self.residual,
            )
        if self.refinement:
            self.residual_unrefined = _free_residual(self.matrix, self.factors, mask, seed=20180101)

    def solve(self, rhs, out) -> None:
        """``out[free] = A_ff^{-1} rhs[free]``, ``out[non-free] = 0``."""
        out.data = self.inverse * rhs

    def solve_step(self, rhs, boundary, out, guess=None, target=None) -> None:
        """``out = boundary + A_ff^{-1} rhs``: the scheme's step (`fsivsp.solvers.StepSolver`; a direct
        solver needs no ``guess`` and no ``target``)."""
        out.data = boundary
        self.inverse.MultAdd(1.0, rhs, out)

    def progress(self) -> str:
        """The solver in a progress line."""
        return self.method

    def statistics(self) -> dict:
        """What a run records of its solver."""
        stats = {"method": self.method, "residual": self.residual, "setup_seconds": self.factor_seconds}
        if self.perturbed_pivots is not None:
            stats["perturbed_pivots"], stats["matching"] = self.perturbed_pivots, self.matching
        if self.refinement:
            stats["refinement"] = {"steps": self.refinement, "residual_before": self.residual_unrefined}
        if self.fallback is not None:
            stats["fallback"] = self.fallback
        return stats

    def __mul__(self, rhs):
        """``solver * r`` is the lazy expression ``solver.inverse * r``."""
        return self.inverse * rhs

    def __repr__(self) -> str:
        return (
            f"DirectSolver(method={self.method!r}, n={self.matrix.height}, "
            f"residual={self.residual:.2e}, factor_seconds={self.factor_seconds:.3g})"
        )


def factorise(matrix, freedofs: ngs.BitArray | None = None, method: str | None = None) -> DirectSolver:
    """A checked `DirectSolver`: the given ``method``, or else the available methods in order of
    preference (pivoting ones first), taking the first whose residual check passes; PARDISO's factors are
    refined with `RETRY_REFINEMENT_STEPS` before another method is tried (not factorised again). A method other than the
    first is never taken silently: one line on stderr names both methods and the first one's residual, and
    ``solver.fallback`` (in `statistics`) records it. A singular matrix fails them all: the `SolverError` then lists
    every failure. A distributed matrix takes `DISTRIBUTED_METHOD`, whose solves check PETSc's outcome instead."""
    if isinstance(matrix, ngs.la.ParallelMatrix):
        return DirectSolver(matrix, freedofs, method=DISTRIBUTED_METHOD, check=False)
    if method is not None:
        return DirectSolver(matrix, freedofs, method=method)
    failures: list[SolverError] = []
    candidates = [m for m in METHODS if m in PIVOTING_METHODS and m in available_methods()]
    for candidate in candidates:
        try:
            solver = DirectSolver(matrix, freedofs, method=candidate, check=False)
            try:
                solver.check()
            except SolverError as error:
                if candidate != "pardiso":
                    raise
                failures.append(error)
                solver.refine(RETRY_REFINEMENT_STEPS)  # PARDISO's own factors, refined
        except SolverError as error:
            failures.append(error)
            continue
        if failures:
            first = failures[0]
            how = candidate + (f" with {solver.refinement} refinement steps" if solver.refinement else "")
            solver.fallback = {"from": candidates[0], "to": how, "residual": first.residual, "reason": str(first)}
            log.warning("direct solver: %s failed (residual %.2e), using %s (residual %.2e)", candidates[0],
                        first.residual, how, solver.residual)
        return solver
    raise SolverError("no direct solver passed the residual check (is the matrix singular?): "
                      + "; ".join(map(str, failures)))
