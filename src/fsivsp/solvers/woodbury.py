"""Step 1 with rank-one terms, one matrix per run: (A + C Γ Cᵀ) x = b by the Sherman–Morrison–Woodbury formula
around any `StepSolver` of A (a factorisation or PETSc's FGMRES, serial or over MPI ranks).

C = [c_1 … c_k] are vectors of X_h (a lumped outlet's flux vector c_i = ∫_Γi φ·n), Γ = diag(γ_i) their weights,
constant per run (complex for the harmonic response, `frequency.harmonic`). Once: Y = A_ff⁻¹ C_f (k solves, C_f: C
on the free dofs) and S = CᵀY (k × k). Every solve: with x⁰ = g + A_ff⁻¹ r the base solver's answer (g the
Dirichlet values, r the right-hand side lifted by A g),

    q = (I + S Γ)⁻¹ Cᵀx⁰,    x = x⁰ − Y Γ q,

and q = Cᵀx (an outlet's new flow). Dirichlet values on the vectors' dofs are included: Cᵀx⁰ sees them. A solve
costs the base solve, k inner products and k vector updates; the time loop (`timestepping.marching`) and the start
step of BDF2 call it as they call the base solver.
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
        project = ngs.Projector(free, True)
        zero = vectors[0].CreateVector()
        zero[:] = 0.0
        self.solutions = []
        for c in self.vectors:
            free_part, y = c.CreateVector(), c.CreateVector()
            free_part.data = project * c
            base.solve_step(free_part, zero, y, None)
            self.solutions.append(y)
        coupling = np.array([[_dot(c, y) for y in self.solutions] for c in self.vectors])
        self._inverse = np.linalg.inv(np.eye(len(self.vectors)) + coupling * self.weights[None, :])

    def flows(self, x: ngs.BaseVector) -> np.ndarray:
        """Cᵀx."""
        return np.array([_dot(c, x) for c in self.vectors])

    def solve_step(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, out: ngs.BaseVector,
                   guess: ngs.BaseVector | None = None, predicted: bool = False,
                   reference: float | None = None) -> None:
        """out = the solution of (A + C Γ Cᵀ) x = rhs on the free dofs with x = boundary on the others."""
        self.base.solve_step(rhs, boundary, out, guess, predicted, reference)
        for y, gamma, q in zip(self.solutions, self.weights, self._inverse @ self.flows(out)):
            out.data -= self._scalar(gamma * q) * y

    def __getattr__(self, name: str):
        if name == "base":
            raise AttributeError(name)
        return getattr(self.base, name)
