"""Where an iterative step solve starts: the linear extrapolation 2xⁿ − xⁿ⁻¹ of the steps' raw solutions.

x is a step's raw solution, (vⁿ, pⁿ) under backward Euler and (vⁿ, mⁿ) with the multiplier mⁿ under the θ-scheme
and BDF2 (`Scheme.latest`). Step n + 1 starts from x̃ = 2xⁿ − xⁿ⁻¹, whose error is O(Δt²) where xⁿ's is O(Δt):
on the paper's level 3 (Δt = 1e-2, 20 steps, tolerance 1e-8) FGMRES takes 3.5 iterations a step instead of 6.9
from xⁿ (docs/solvers.md, "Warm start"). It needs one vector more than the scheme's history, xⁿ⁻¹, which a
checkpoint stores (``previous_solution``), so that a resumed run starts every step where the uninterrupted one
did and stays bit-identical. PETSc's minimal-residual guess over the last ten solutions (``KSPGuess`` Fischer,
model 1) took 3.0 iterations on the same case, but its ten vectors and their products live inside PETSc's KSP,
which a checkpoint does not reach: a resumed run would start differently. Direct solvers ignore the start, and
for them it is not formed (`takes_start`); xⁿ⁻¹ is kept all the same, so that a checkpoint holds the same vectors
whichever solver wrote it.

The extrapolation is used only where it extrapolates one smooth sequence (`extrapolates`): from step 3 on, and
between steps of the same time scheme (BDF2's Crank–Nicolson start step has another τ, and its multiplier another
scale). Elsewhere a step starts from xⁿ, as before.
"""
from __future__ import annotations

import ngsolve as ngs


def extrapolates(time_scheme, n: int) -> bool:
    """Whether step n + 1 starts from 2xⁿ − xⁿ⁻¹: xⁿ⁻¹ and xⁿ solve steps n − 1 and n (n ≥ 2: x⁰ is the initial data,
    whose pressure may be unknown) of the scheme that step n + 1 takes (`time_scheme.start`)."""
    return n >= 2 and time_scheme.start(n - 2) == time_scheme.start(n - 1) == time_scheme.start(n)


def takes_start(solver) -> bool:
    """Whether the step solver ``solver`` (a Woodbury solver passes its base's attributes on) starts from a guess:
    PETSc's Krylov methods do; a factorisation and PETSc's MUMPS (``preonly``, which PETSc starts from zero) do not."""
    ksp = getattr(solver, "ksp", None)
    return ksp is not None and bool(ksp.getInitialGuessNonzero())


class Extrapolation:
    """The start 2xⁿ − xⁿ⁻¹ of step n + 1: ``older`` holds xⁿ⁻¹ (`shift` before xⁿ⁺¹ replaces xⁿ), ``guess`` the
    start once formed. ``like``: a vector of X_h (its parallel layout); ``enabled``: whether the solver takes a
    start (`takes_start`; if not, `start` is xⁿ and nothing is formed)."""

    def __init__(self, like: ngs.BaseVector, enabled: bool = True):
        self.older = like.CreateVector()
        self.older.data = like
        self.guess = like.CreateVector()
        self.enabled = enabled

    def shift(self, newest: ngs.BaseVector) -> None:
        """xⁿ⁻¹ := ``newest`` (xⁿ), before the scheme accepts xⁿ⁺¹."""
        self.older.data = newest

    def predicts(self, time_scheme, n: int) -> bool:
        """Whether step n + 1 starts from the extrapolation (the solver takes a start and it `extrapolates`): what
        the auto tolerance reads (`solvers.base.START_REDUCTION`)."""
        return self.enabled and extrapolates(time_scheme, n)

    def start(self, time_scheme, n: int, newest: ngs.BaseVector, older: ngs.BaseVector | None = None,
              out: ngs.BaseVector | None = None) -> ngs.BaseVector:
        """The start of step n + 1 from ``newest`` = xⁿ and ``older`` = xⁿ⁻¹ (default: `older`): 2xⁿ − xⁿ⁻¹ in ``out``
        (default: `guess`) where it `predicts`, else ``newest`` itself."""
        if not self.predicts(time_scheme, n):
            return newest
        out = self.guess if out is None else out
        out.data = 2 * newest - (self.older if older is None else older)
        return out
