"""Step 1 with rank-one terms, one matrix per run: (A + C Γ Cᵀ) x = b by the Sherman–Morrison–Woodbury formula
around any `StepSolver` of A (a factorisation or PETSc's FGMRES, serial or over MPI ranks).

C = [c_1 … c_k] are vectors of X_h (a lumped outlet's flux vector c_i = ∫_Γi φ·n), Γ = diag(γ_i) their weights,
constant per run (complex for the harmonic response, `frequency.harmonic`). Once: Y = A_ff⁻¹ C_f (k solves, C_f: C
on the free dofs) and S = CᵀY (k × k). Every solve: with x⁰ = g + A_ff⁻¹ r the base solver's answer (g the
Dirichlet values, r the right-hand side lifted by A g),

    q = (I + S Γ)⁻¹ Cᵀx⁰,    x = x⁰ − Y Γ q,

and q = Cᵀx (an outlet's new flow). Dirichlet values on the vectors' dofs are included: Cᵀx⁰ sees them. A solve
costs the base solve, k inner products and k vector updates; the time loop (`timestepping.marching`) and the start
step of BDF2 call it as they call the base solver. A start x₀ of the whole system (`timestepping.warmstart`, whose
products include C Γ Cᵀ) becomes the base solve's x₀ + Y Γ Cᵀx₀ (`base_start`), whose residual under A is x₀'s under
A + C Γ Cᵀ: the auto tolerance's target holds for the base solve, and the solution's residual is the base solve's.
"""
from __future__ import annotations

import ngsolve as ngs
import numpy as np

from .base import StepSolver


def _dot(c: ngs.BaseVector, x: ngs.BaseVector):
    """cᵀx, not conjugated (complex symmetric systems: the harmonic response), summed over the ranks under MPI."""
    return c.InnerProduct(x, conjugate=False)


class WoodburySolver:
    """A `StepSolver` of A + C Γ Cᵀ from the `StepSolver` ``base`` of A (the module's docstring): ``vectors`` the
    c_i, ``weights`` the γ_i, ``free`` the free dofs of X_h. Everything but the solve is the base solver's."""

    def __init__(self, base: StepSolver, vectors: list[ngs.BaseVector], weights: list[float] | list[complex],
                 free: ngs.BitArray):
        self.base, self.vectors, self.weights = base, list(vectors), np.asarray(weights)
        self._scalar = complex if np.iscomplexobj(self.weights) else float
        self._project = project = ngs.Projector(free, True)
        zero = vectors[0].CreateVector()
        zero[:] = 0.0
        self.solutions, self.free_vectors = [], []
        for c in self.vectors:
            free_part, y = c.CreateVector(), c.CreateVector()
            free_part.data = project * c
            base.solve_step(free_part, zero, y, None)
            self.solutions.append(y)
            self.free_vectors.append(free_part)
        self._start = zero.CreateVector()
        coupling = np.array([[_dot(c, y) for y in self.solutions] for c in self.vectors])
        self._inverse = np.linalg.inv(np.eye(len(self.vectors)) + coupling * self.weights[None, :])

    def base_start(self, guess: ngs.BaseVector, boundary: ngs.BaseVector) -> ngs.BaseVector:
        """The base solve's start for a start x₀ = g + P ``guess`` of the whole system (g = ``boundary``, P the free
        dofs): x⁰ = x₀ + Y Γ Cᵀx₀, the base answer if x₀ were the answer. Its residual under A, b − A_ff x⁰, is x₀'s
        under A + C Γ Cᵀ (A_ff Y = C_f). From x₀ itself the base solve would start a whole Y Γ Cᵀx off its answer."""
        start = self._start
        start.data = boundary + self._project * guess
        for y, gamma, q in zip(self.solutions, self.weights, self.flows(start)):
            start.data += self._scalar(gamma * q) * y
        return start

    def add_terms(self, x: ngs.BaseVector, out: ngs.BaseVector) -> None:
        """out += C_f Γ C_fᵀ x: the rank-one terms on the free dofs (the whole system's product, `warmstart`)."""
        for c, gamma in zip(self.free_vectors, self.weights):
            out.data += self._scalar(gamma * _dot(c, x)) * c

    def flows(self, x: ngs.BaseVector) -> np.ndarray:
        """Cᵀx."""
        return np.array([_dot(c, x) for c in self.vectors])

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
                   guess: ngs.BaseVector | None = None, target: float | None = None) -> None:
        """out = the solution of (A + C Γ Cᵀ) x = rhs on the free dofs with x = boundary on the others; the base solve
        starts from `base_start` of ``guess`` (its residual is ``guess``'s, so ``target`` applies unchanged)."""
        self.base.solve_step(rhs, boundary, out, None if guess is None else self.base_start(guess, boundary), target)
        for y, gamma, q in zip(self.solutions, self.weights, self._inverse @ self.flows(out)):
            out.data -= self._scalar(gamma * q) * y

    def __getattr__(self, name: str):
        if name == "base":
            raise AttributeError(name)
        return getattr(self.base, name)
