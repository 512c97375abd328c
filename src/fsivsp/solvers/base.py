"""What every solver of step 1 shares: the interface the scheme calls (`StepSolver`), the iterative tolerance and
iteration limit by default, and the errors the solvers raise (`SolverError`, `NotConverged`)."""
from __future__ import annotations

from typing import Protocol

import ngsolve as ngs

#: The iterative solvers' tolerance relative to the right-hand side: a number stops a solve at ‖b − Ax‖ ≤ tol ‖b‖
#: (1e-12: the error norms equal the direct solver's, docs/solvers.md, "Tolerance"); ``"auto"``, the default, stops it
#: there or where the residual of the step's start has fallen by `START_REDUCTION`, whichever comes first.
TOLERANCE = 1e-12
AUTO = "auto"
#: The auto tolerance's reduction of the start's residual ‖b − Ax₀‖. The start x₀ = 2xⁿ − xⁿ⁻¹ (`warmstart`) misses
#: x^{n+1} by Δt² ẍ: twice backward Euler's local error, so the step's algebraic error stays 10⁻⁴ of it (the paper's
#: experiment, Δt = 1e-2, levels 1–4: the pressure's error norm moves by 9.4e-7, 1.2e-4, 5.6e-6, 3.3e-4 of itself, the
#: others by at most 6.2e-7; docs/solvers.md, "Tolerance"). A solve from zero (no start: a Woodbury column, a
#: correction) takes the fixed tolerance. From a start that is not the extrapolation (xⁿ: the first two steps, a change
#: of time scheme) ‖b − Ax₀‖ is the step's increment, O(Δt), not O(Δt²): the reduction squared (1e-8) stands in for
#: the missing factor Δt·ω (the paper's Δt·ω ≈ 1e-2, the 3D tube's 6e-3).
START_REDUCTION = 1e-4
#: The same for a time scheme that does not damp its stiff components (Crank–Nicolson, θ = 1/2: they alternate in
#: sign from step to step, and a start misses them by twice their size): at 1e-4 the paper's e(p) moved by 1.5 % of
#: itself on level 3, at 1e-5 by at most 4.8e-5 on levels 1–3 (`timestepping.scheme` takes it for θ = 1/2).
UNDAMPED_REDUCTION = 1e-5
MAX_ITERATIONS = 2000


class SolverError(RuntimeError):
    """A factorisation that failed or whose residual check did not pass (``residual``: NaN if none)."""

    def __init__(self, message: str, residual: float = float("nan")):
        super().__init__(message)
        self.residual = residual


class NotConverged(SolverError):
    """An iterative solve that reached its iteration limit above its tolerance."""


def auto_target(reduction: float | None, reference: float | None, extrapolated: bool) -> float | None:
    """The residual ‖b − Ax‖ at which the auto tolerance stops a solve from a start, if it comes before ``TOLERANCE``
    ‖b‖: ρ‖b − Ax̃‖ (``reduction`` ρ, ``reference`` ‖b − Ax̃‖, x̃ the reference start of `timestepping.warmstart`)
    where x̃ is the extrapolation 2xⁿ − xⁿ⁻¹ (``extrapolated``), ρ² ‖b − Ax̃‖ where it is xⁿ (`START_REDUCTION`).
    None (the tolerance alone) for a fixed tolerance (no ``reduction``) or a solve without a start (no
    ``reference``)."""
    if reduction is None or reference is None:
        return None
    return (reduction if extrapolated else reduction**2) * reference


class StepSolver(Protocol):
    """What the scheme needs of a solver: ``out = boundary + A_ff⁻¹ rhs`` (``guess``: where an iterative method
    starts; ``target``: the residual norm at which an iterative method may stop before its tolerance, `auto_target`;
    a direct solver ignores both) and a record for reports; ``overlap``: whether a solve may run concurrently with
    other work of the scheme (not when it communicates between MPI ranks)."""

    method: str
    factor_seconds: float
    overlap: bool

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
                   guess: ngs.BaseVector | None = None, target: float | None = None) -> None: ...

    def progress(self) -> str: ...

    def statistics(self) -> dict: ...
