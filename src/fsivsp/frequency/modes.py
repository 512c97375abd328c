"""The coupled modes of the fluid–structure system: the eigenpairs of the pencil A x = s E x (`pencil`) nearest a
target s = 2πiF, by SLEPc's Krylov–Schur with shift-and-invert (ST sinvert; KSP preonly, PC lu, MUMPS) in complex
arithmetic (`solvers.petsc_init.slepc`), serially or over the MPI ranks of a distributed mesh.

A mode is ``oscillating`` (Im s ≠ 0; its conjugate is the same physical mode, so only Im s > 0 is reported),
``overdamped`` (a real s < 0: a viscous fluid has many) or ``static`` (s = 0: rigid motions of a free solid, a closed
fluid's constant pressure; excluded). Its frequency is Im s / 2π, its decay rate −Re s, its damping ratio −Re s / |s|;
its residual the backward error ‖Ax − sEx‖ / ((‖A‖₁ + |s| ‖E‖₁) ‖x‖), computed here, not by SLEPc.

Every EPS setting is a PETSc option under the prefix ``fsivsp_`` (`DEFAULTS`), e.g. ``-fsivsp_eps_view`` in
PETSC_OPTIONS or ``eps_tol = 1e-12`` in the case file's ``[solver.petsc]``.
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..fem.spaces import Spaces
from ..geometry import extent
from ..model.materials import Materials
from ..runtime import parallel
from ..solvers.petsc_init import entered_options, register, slepc, unregister
from .pencil import Pencil

log = logging.getLogger(__name__)

PREFIX = "fsivsp_"
#: The EPS's settings (keys without the prefix), overridden by the case's [solver.petsc] options.
DEFAULTS: dict[str, str] = {
    "eps_type": "krylovschur",
    "eps_tol": "1e-10",
    "eps_max_it": "500",
    "st_type": "sinvert",
    "st_ksp_type": "preonly",
    "st_pc_type": "lu",
    "st_pc_factor_mat_solver_type": "mumps",
    "st_mat_mumps_icntl_14": "100",
}
STATIC, OVERDAMPED, OSCILLATING = "static", "overdamped", "oscillating"
#: |s| ≤ this × `rate_scale`: static (computed static eigenvalues are round-off, 1e-15 of the scale).
STATIC_TOLERANCE = 1e-8
#: |Im s| ≤ this × |s|: overdamped (computed real eigenvalues come out with 1e-11 to 1e-25).
REAL_TOLERANCE = 1e-8
#: The target of "the lowest modes": i × this × `rate_scale` (σ = 0 is singular where a fluid is closed).
LOWEST = 0.1
#: The eigenpairs asked for at most, as a multiple of the modes wanted (and at least 40).
MAX_PAIRS = 8


@dataclass
class Mode:
    """An eigenpair: ``s``, its ``kind``, its backward error ``residual`` and ``state``, (v, p) on X_h's local
    dofs (complex), scaled to max |v| = 1 over the vertices with that value real."""

    s: complex
    kind: str
    residual: float
    state: np.ndarray

    @property
    def frequency(self) -> float:
        return self.s.imag / (2 * math.pi)

    @property
    def decay_rate(self) -> float:
        return -self.s.real

    @property
    def damping_ratio(self) -> float:
        return -self.s.real / abs(self.s)

    def record(self) -> dict:
        return {"kind": self.kind, "s": [self.s.real, self.s.imag], "frequency": self.frequency,
                "decay_rate": self.decay_rate, "damping_ratio": self.damping_ratio, "residual": self.residual}


def rate_scale(spaces: Spaces, materials: Materials) -> float:
    """A rate of the problem, 1/s: the solid's wave speed √((λ + 2μ)/ρ_S) over the size L of the domain, plus the
    viscous rate ν/(ρ_F L²)."""
    low, high = extent(spaces.mesh)
    size = float(np.linalg.norm(high - low))
    wave = math.sqrt((materials.lam + 2 * materials.mu) / materials.rho_solid)
    return wave / size + materials.nu / (materials.rho_fluid * size**2)


def target(near: float | None, scale: float) -> complex:
    """σ = 2πi ``near`` (a frequency), or for the lowest modes (None or 0) i `LOWEST` ``scale``."""
    return 2j * math.pi * near if near else 1j * LOWEST * scale


def kind(s: complex, scale: float) -> str:
    """`STATIC`, `OVERDAMPED` or `OSCILLATING` (the module's docstring)."""
    if abs(s) <= STATIC_TOLERANCE * scale:
        return STATIC
    return OVERDAMPED if abs(s.imag) <= REAL_TOLERANCE * abs(s) else OSCILLATING


@dataclass
class Modes:
    """What `coupled_modes` found: the ``oscillating`` modes nearest the ``target`` (Im s > 0, by increasing
    frequency), the ``overdamped`` ones among the converged pairs (by increasing decay rate), how many ``static``
    ones, whether it was ``stopped`` (a stop request), and SLEPc's figures (``solver``)."""

    target: complex
    oscillating: list[Mode]
    overdamped: list[Mode]
    static: int
    stopped: bool
    solver: dict


class ModeSolver:
    """SLEPc's EPS on a `Pencil`, generalised non-Hermitian, the pairs nearest ``target`` (shift-and-invert at it:
    A − σE factorised once, here). ``options``: PETSc options over `DEFAULTS`."""

    def __init__(self, spaces: Spaces, materials: Materials, target: complex, options: dict | None = None):
        self.PETSc, SLEPc = slepc("complex")
        self.SLEPc, self.target = SLEPc, target
        self.pencil = Pencil(self.PETSc, spaces, materials)
        comm = self.pencil.A.getComm()
        self.eps = SLEPc.EPS().create(comm=comm)
        self.eps.setOperators(self.pencil.A, self.pencil.E)
        self.eps.setProblemType(SLEPc.EPS.ProblemType.GNHEP)
        self.eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        self.eps.setTarget(target)
        self.eps.setOptionsPrefix(PREFIX)
        start = time.perf_counter()
        with entered_options(self.PETSc, PREFIX, DEFAULTS, options or {}) as self.options:
            self.eps.setFromOptions()
            self.eps.setUp()   # the factorisation of A − σE, whose MUMPS options are read now
        self.factor_seconds = time.perf_counter() - start
        self.norms = tuple(m.norm(self.PETSc.NormType.NORM_1) for m in (self.pencil.A, self.pencil.E))
        self._x, self._r = self.pencil.A.createVecs()
        self._e = self._r.duplicate()
        self.iterations = 0
        register(self)

    def solve(self, pairs: int, monitor: Callable[[int, int], None] | None = None,
              stop: Callable[[], bool] | None = None) -> list[tuple[complex, float, object]]:
        """The converged pairs (s, backward error, x) of a solve for ``pairs`` eigenpairs (a basis of 2 ``pairs`` + 10
        vectors, at least 30, or the options' ``eps_ncv``); ``monitor(converged, pairs)`` after every outer
        iteration, ``stop()`` true (on any rank) ends it early."""
        eps, reason = self.eps, self.SLEPc.EPS.ConvergedReason
        ncv = int(self.options["eps_ncv"]) if "eps_ncv" in self.options else max(2 * pairs + 10, 30)
        eps.setDimensions(nev=pairs, ncv=max(ncv, pairs + 1))
        if monitor is not None:
            eps.cancelMonitor()
            eps.setMonitor(lambda _eps, its, nconv, *_: monitor(int(nconv), pairs))
        if stop is not None:
            def stopping(_eps, its, max_it, nconv, nev):
                if parallel.total(np.array([float(stop())]))[0] > 0:
                    return reason.CONVERGED_USER
                if nconv >= nev:
                    return reason.CONVERGED_TOL
                return reason.DIVERGED_ITS if its >= max_it else reason.ITERATING
            eps.setStoppingTest(stopping)
        eps.solve()
        self.iterations += eps.getIterationNumber()
        pairs_found = []
        for i in range(eps.getConverged()):
            x = self._x.duplicate()
            s = complex(eps.getEigenpair(i, x))
            pairs_found.append((s, self.backward_error(s, x), x))
        return pairs_found

    def backward_error(self, s: complex, x) -> float:
        """‖Ax − sEx‖ / ((‖A‖₁ + |s| ‖E‖₁) ‖x‖)."""
        self.pencil.A.mult(x, self._r)
        self.pencil.E.mult(x, self._e)
        self._r.axpy(-s, self._e)
        return float(self._r.norm() / ((self.norms[0] + abs(s) * self.norms[1]) * x.norm()))

    def local_state(self, x) -> np.ndarray:
        """x's (v, p) on X_h's local dofs, scaled to max |v| = 1 over the vertices (the vertex dofs, first in each
        component, are point values) with that value real (collective under MPI)."""
        PETSc, n = self.PETSc, self.pencil.numbering
        local = PETSc.Vec().createSeq(len(n.numbers), comm=PETSc.COMM_SELF)
        scatter = PETSc.Scatter().create(x, PETSc.IS().createGeneral(n.numbers.astype(PETSc.IntType),
                                                                     comm=PETSc.COMM_SELF), local, None)
        scatter.scatter(x, local, addv=PETSc.InsertMode.INSERT_VALUES)
        values = local.getArray().copy()
        for obj in (scatter, local):
            obj.destroy()
        nv, spaces = len(n.velocity), self.pencil.spaces
        velocity = values[:nv]
        nodal = n.velocity % (spaces.velocity.ndof // spaces.mesh.dim) < spaces.mesh.nv   # a vertex's value
        largest = velocity[nodal][np.argmax(np.abs(velocity[nodal]))] if nodal.any() else 0.0
        scale = max(parallel.gather(complex(largest)), key=abs)
        state = np.zeros(self.pencil.spaces.mixed.ndof, dtype=complex)
        state[n.velocity] = velocity / scale
        state[n.pressure] = values[nv + int(n.solid.sum()):] / scale
        return state

    def destroy(self) -> None:
        for obj in (self.eps, self._x, self._r, self._e):
            obj.destroy()
        self.pencil.destroy()
        unregister(self)

    def statistics(self) -> dict:
        eps = self.eps
        return {"type": eps.getType(), "tolerance": eps.getTolerances()[0], "iterations": self.iterations,
                "pairs": eps.getDimensions()[0], "ncv": eps.getDimensions()[1], "unknowns": self.pencil.numbering.size,
                "factor_seconds": self.factor_seconds, "options": self.options}


def coupled_modes(spaces: Spaces, materials: Materials, count: int, near: float | None = None,
                  options: dict | None = None, monitor: Callable[[int, int], None] | None = None,
                  stop: Callable[[], bool] | None = None) -> Modes:
    """The ``count`` oscillating modes nearest s = 2πi ``near`` (None: the lowest, `target`), with the overdamped
    and static ones met on the way: SLEPc asked for ``count`` + 4 pairs first (2 ``count`` + 4 for the lowest: a
    target near 0 meets both conjugates), then twice as many while fewer than ``count`` oscillating ones converged,
    up to `MAX_PAIRS` × ``count`` (then fewer are returned, with a warning). Asking for no more pairs than needed
    matters: every overdamped mode with |s| ≪ |σ| lies about |σ| from the target, a cluster SLEPc converges
    slowly (a 3D tube at 50 Hz: 12 of 16 pairs in 2 minutes, the 4 others not in 25)."""
    scale = rate_scale(spaces, materials)
    sigma = target(near, scale)
    solver = ModeSolver(spaces, materials, sigma, options)
    try:
        pairs = (count if near else 2 * count) + 4
        limit = min(max(MAX_PAIRS * count, 40), solver.pencil.numbering.size - 2)
        while True:
            found = solver.solve(min(pairs, limit), monitor, stop)
            kinds = [kind(s, scale) for s, *_ in found]
            oscillating = [i for i, k in enumerate(kinds) if k == OSCILLATING and found[i][0].imag > 0]
            stopped = solver.eps.getConvergedReason() == solver.SLEPc.EPS.ConvergedReason.CONVERGED_USER
            if len(oscillating) >= count or pairs >= limit or stopped:
                break
            pairs *= 2
        oscillating.sort(key=lambda i: abs(found[i][0] - sigma))
        if len(oscillating) < count and not stopped:
            log.warning("modes: %d oscillating modes among the %d pairs nearest the target, fewer than the %d asked "
                        "for", len(oscillating), len(found), count)

        def mode(i: int) -> Mode:
            s, residual, x = found[i]
            return Mode(s, kinds[i], residual, solver.local_state(x))

        chosen = sorted(oscillating[:count], key=lambda i: found[i][0].imag)
        overdamped = sorted((i for i, k in enumerate(kinds) if k == OVERDAMPED), key=lambda i: -found[i][0].real)
        return Modes(sigma, [mode(i) for i in chosen], [mode(i) for i in overdamped], kinds.count(STATIC), stopped,
                     solver.statistics())
    finally:
        solver.destroy()
