"""Where an iterative step solve starts: the minimal-residual combination of the last raw solutions, measured against
the linear extrapolation 2xⁿ − xⁿ⁻¹.

x is a step's raw solution, (vⁿ, pⁿ) under backward Euler and (vⁿ, mⁿ) with the multiplier mⁿ under the θ-scheme
and BDF2 (`Scheme.latest`). The reference start of step n + 1 is x̃ = 2xⁿ − xⁿ⁻¹, whose error is O(Δt²) where xⁿ's
is O(Δt) (the paper's level 3, Δt = 1e-2, 20 steps, tolerance 1e-8: 3.5 iterations a step instead of 6.9 from xⁿ;
docs/solvers.md, "Warm start"), or xⁿ where the extrapolation does not apply (`extrapolates`). The auto tolerance
reduces the reference start's residual r̃ = b − A x̃ (`solvers.base.START_REDUCTION`): it measures the step's time
error. The solve itself starts from the x₀ in span{xⁿ, …, xⁿ⁻ᴷ⁺¹} (K = `HISTORY`) that minimises ‖b − A x₀‖, which
is at most ‖r̃‖ (x̃ is in that span) and where the solution is smooth in time far smaller: the 3D tube of
examples/pressure_wave.toml at maxh 0.1, 40 steps, 7.2 → 4.6 iterations a step (docs/solvers.md). This is PETSc's
``KSPGuess`` Fischer idea, kept here so that a checkpoint holds what it needs: the K − 1 solutions before xⁿ
(``previous_solution``, ``previous_solution_2``, …) and how many there are (``start_count``). Their products
A xᵢ are made once each, when a solution is recorded (`record`), and again on resuming (`restored`), so that a
resumed run starts every step where the uninterrupted one did and stays bit-identical. The least-squares problem is
posed in the basis xⁿ, xⁿ − xⁿ⁻¹, xⁿ⁻¹ − xⁿ⁻², … (its Gram matrix scaled to a unit diagonal, eigenvalues below
`CUTOFF` of the largest dropped): the solutions themselves are nearly parallel.

With lumped outlets the system is A + C Γ Cᵀ (`solvers.woodbury`): the products include the outlets' terms, so that
the start and its residual are the whole system's (against A alone the reference residual was the outlets' term, not
the step's time error: a channel with an RCR outlet, 40 BDF2 steps, moved by 1.1e-4 of the factorisation's state
against 3.0e-6 now, in 730 iterations against 541). The terms act on the free dofs, C_f Γ C_fᵀ x: Dirichlet values
g on an outlet's dofs (0 in every shipped case) would move the reference residual by the constant C_f Γ Cᵀg.

Direct solvers ignore the start; for them nothing is formed or multiplied (`takes_start`), and the solutions are
kept all the same, so that a checkpoint holds the same vectors whichever solver wrote it.
"""
from __future__ import annotations

from collections.abc import Callable

import ngsolve as ngs
import numpy as np

from ..runtime import parallel

#: The solutions the start combines (xⁿ and the K − 1 before it). The 3D tube above, iterations a step: 7.2 from the
#: extrapolation, 6.35, 4.63, 4.43, 4.18 with K = 2, 4, 6, 8; the start keeps 3K + 1 vectors of X_h (the solutions,
#: their products, their differences, the guess) and takes K(K + 3)/2 inner products a step (K = 6: 27). At least 2:
#: the reference start is made of xⁿ and xⁿ⁻¹.
HISTORY = 6
#: The least-squares problem's scaled Gram eigenvalues below this fraction of the largest are dropped.
CUTOFF = 1e-12


def extrapolates(time_scheme, n: int) -> bool:
    """Whether step n + 1's reference start is 2xⁿ − xⁿ⁻¹: xⁿ⁻¹ and xⁿ solve steps n − 1 and n (n ≥ 2: x⁰ is the
    initial data, whose pressure may be unknown) of the scheme that step n + 1 takes (`time_scheme.start`)."""
    return n >= 2 and time_scheme.start(n - 2) == time_scheme.start(n - 1) == time_scheme.start(n)


def takes_start(solver) -> bool:
    """Whether the step solver ``solver`` (a Woodbury solver passes its base's attributes on) starts from a guess:
    PETSc's Krylov methods do; a factorisation and PETSc's MUMPS (``preonly``, which PETSc starts from zero) do not."""
    ksp = getattr(solver, "ksp", None)
    return ksp is not None and bool(ksp.getInitialGuessNonzero())


def _cumulated(vector: ngs.BaseVector) -> ngs.BaseVector:
    if parallel.distributed() and hasattr(vector, "Cumulate"):
        vector.Cumulate()
    return vector


class MinimalResidualStart:
    """The start of step n + 1 (the module's docstring) from the last `HISTORY` raw solutions, newest first in
    ``solutions`` (``count`` of them recorded), and their products with the step matrix on the free dofs.
    ``newest``: x⁰ (a vector of X_h: its parallel layout); ``matrix``: the run's step matrix A; ``free``: the free
    dofs; ``terms(x, out)``: adds the lumped outlets' rank-one terms C_f Γ C_fᵀ x to the product (the system the
    solver solves is A + C Γ Cᵀ, `WoodburySolver.add_terms`); ``enabled``: whether the solver takes a start
    (`takes_start`; if not, no product is made); ``combines``: whether the start is the least-squares combination,
    else the reference start itself (a time scheme that does not damp its stiff components, `Theta.damps`: their
    alternating signs are in no combination of the last solutions, and Crank–Nicolson took 130 against 125
    iterations on the paper's level 3, 20 steps, the auto tolerance)."""

    def __init__(self, newest: ngs.BaseVector, matrix: ngs.BaseMatrix, free: ngs.BitArray, enabled: bool = True,
                 combines: bool = True, terms: Callable[[ngs.BaseVector, ngs.BaseVector], None] | None = None):
        self.enabled, self.combines, self._terms = enabled, combines, terms
        self.solutions = [newest.CreateVector() for _ in range(HISTORY)]
        self.count = np.zeros(1)   # an array: a checkpoint restores it in place
        self._project = ngs.Projector(free, True)
        self._operator = self._project @ matrix @ self._project
        self.products = [newest.CreateVector() for _ in range(HISTORY)] if enabled else []
        self._differences = [newest.CreateVector() for _ in range(HISTORY)] if enabled else []
        self._residual = newest.CreateVector()
        self.guess = newest.CreateVector()
        self.reset(newest)

    def reset(self, newest: ngs.BaseVector) -> None:
        """Forget the solutions: xⁿ := ``newest`` alone (the initial data)."""
        self.count[0] = 0
        self.record(newest)

    def record(self, newest: ngs.BaseVector) -> None:
        """Step n + 1's solution ``newest`` becomes xⁿ⁺¹, the oldest kept solution is dropped."""
        self.solutions.insert(0, self.solutions.pop())
        self.solutions[0].data = newest
        if self.enabled:
            self.products.insert(0, self.products.pop())
            self._multiply(0)
        self.count[0] = min(self.count[0] + 1, HISTORY)

    def _multiply(self, i: int) -> None:
        self.products[i].data = self._operator * self.solutions[i]
        if self._terms is not None:
            self._terms(self.solutions[i], self.products[i])
        _cumulated(self.products[i])

    def history(self) -> dict[str, ngs.BaseVector | np.ndarray]:
        """What a checkpoint stores of the start (xⁿ is the scheme's own): the solutions before xⁿ and their count."""
        names = ["previous_solution"] + [f"previous_solution_{i}" for i in range(2, HISTORY)]
        return {**dict(zip(names, self.solutions[1:])), "start_count": self.count}

    def restored(self, newest: ngs.BaseVector, missing: set[str]) -> None:
        """After a checkpoint's vectors were loaded into `history`'s: xⁿ := ``newest``, the products made again. From a
        format without the start's count (``missing``) the solutions it had: xⁿ⁻¹ if stored (format 4), else xⁿ
        alone (format 3: the next step starts from xⁿ, as that format's runs did)."""
        if "start_count" in missing:
            self.count[0] = 1 if "previous_solution" in missing else 2
        self.solutions[0].data = newest
        if self.enabled:
            for i in range(int(self.count[0])):
                self._multiply(i)

    def predicts(self, time_scheme, n: int) -> bool:
        """Whether step n + 1's reference start is the extrapolation (the solver takes a start and it
        `extrapolates`): what the auto tolerance reads (`solvers.base.START_REDUCTION`)."""
        return self.enabled and extrapolates(time_scheme, n)

    def reference(self, time_scheme, n: int) -> ngs.BaseVector:
        """Step n + 1's reference start x̃ in `guess`: 2xⁿ − xⁿ⁻¹ where it `predicts`, else xⁿ itself."""
        if not self.predicts(time_scheme, n):
            return self.solutions[0]
        self.guess.data = 2 * self.solutions[0] - self.solutions[1]
        return self.guess

    def start(self, time_scheme, n: int, rhs: ngs.BaseVector) -> tuple[ngs.BaseVector, float | None]:
        """Step n + 1's start x₀ for the right-hand side ``rhs`` (its free part b) and ‖b − A x̃‖ of the reference
        start x̃; (xⁿ, None) for a solver that takes no start."""
        if not self.enabled:
            return self.solutions[0], None
        count = int(self.count[0])
        products, differences, residual = self.products, self._differences, self._residual
        residual.data = self._project * rhs   # b, then b − A x₀
        _cumulated(residual)
        differences[0].data = residual - (2 * products[0] - products[1] if self.predicts(time_scheme, n)
                                          else products[0])
        reference = ngs.Norm(differences[0])
        if not self.combines:
            return self.reference(time_scheme, n), reference
        differences[0].data = products[0]
        for i in range(1, count):
            differences[i].data = products[i - 1] - products[i]
        gram = np.zeros((count, count))
        for i in range(count):
            for j in range(i, count):
                gram[i, j] = gram[j, i] = ngs.InnerProduct(differences[i], differences[j])
        right = np.array([ngs.InnerProduct(differences[i], residual) for i in range(count)])
        coefficients = _least_squares(gram, right).tolist()   # floats: a numpy scalar times a vector is an array
        for c, difference in zip(coefficients, differences):
            residual.data -= c * difference
        if not ngs.Norm(residual) < reference:   # rounding: the reference start itself
            return self.reference(time_scheme, n), reference
        weights = np.zeros(count)   # x₀ = c₀ xⁿ + Σ cᵢ (xⁿ⁻ⁱ⁺¹ − xⁿ⁻ⁱ) in the solutions
        weights[0] = coefficients[0]
        for i in range(1, count):
            weights[i - 1] += coefficients[i]
            weights[i] -= coefficients[i]
        self.guess.data = float(weights[0]) * self.solutions[0]
        for w, solution in zip(weights[1:].tolist(), self.solutions[1:count]):
            self.guess.data += w * solution
        return self.guess, reference


def _least_squares(gram: np.ndarray, right: np.ndarray) -> np.ndarray:
    """c minimising ‖b − Σ cᵢ dᵢ‖ from the Gram matrix (dᵢ, dⱼ) and (dᵢ, b): scaled to a unit diagonal, eigenvalues
    below `CUTOFF` of the largest dropped (0 for a zero dᵢ)."""
    scale = np.sqrt(np.diag(gram))
    scale[scale == 0] = np.inf
    values, vectors = np.linalg.eigh(gram / scale[:, None] / scale[None, :])
    kept = values > CUTOFF * values.max() if values.max() > 0 else np.zeros(len(values), bool)
    solution = vectors[:, kept] @ ((vectors[:, kept].T @ (right / scale)) / values[kept])
    return solution / scale
