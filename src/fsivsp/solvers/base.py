"""What every solver of step 1 shares: the interface the scheme calls (`StepSolver`), the iterative tolerance and
iteration limit by default, and the errors the solvers raise (`SolverError`, `NotConverged`)."""
from __future__ import annotations

from typing import Protocol

import ngsolve as ngs

#: The iterative solvers' relative tolerance by default: their error norms then equal the direct solver's
#: (docs/solvers.md, "Tolerance"), and their iteration limit.
TOLERANCE = 1e-12
MAX_ITERATIONS = 2000


class SolverError(RuntimeError):
    """A factorisation that failed or whose residual check did not pass (``residual``: NaN if none)."""

    def __init__(self, message: str, residual: float = float("nan")):
        super().__init__(message)
        self.residual = residual


class NotConverged(SolverError):
    """An iterative solve that reached its iteration limit above its tolerance."""


class StepSolver(Protocol):
    """What the scheme needs of a solver: ``out = boundary + A_ff⁻¹ rhs`` (``guess``: where an iterative method
    starts) and a record for reports; ``overlap``: whether a solve may run concurrently with other work of the
    scheme (not when it communicates between MPI ranks)."""

    method: str
    factor_seconds: float
    overlap: bool

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
                   guess: ngs.BaseVector | None = None) -> None: ...

    def progress(self) -> str: ...

    def statistics(self) -> dict: ...
