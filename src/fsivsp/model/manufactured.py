"""Manufactured solutions: from an exact (v, p, u) derive every datum of the model (1)–(3).

Given the global velocity v (continuous across Γ), the fluid pressure p and the solid
displacement u with ∂t u = v in Ω_S, the stresses are σ_F = −pI + 2νε(v),
σ_S = λ div(u) I + 2μ ε(u), the body forces f = ρ ∂t v − div σ in each region,
and the interface load g = (σ_F − σ_S) n = (σ_S − σ_F) n_S (n from Ω_F into Ω_S, n_S = −n the
solid's outer normal), which the scheme adds to the right-hand side as ∫_Γ g·w: integrating
ρ∂t v − div σ = f by parts in each region leaves exactly this term where σ_F n ≠ σ_S n.

With materials that differ between cell regions (`Materials.regions`) each region r has its own σ_r and f_r, and
the integration by parts leaves Σ_r ∫_{∂Ω_r ∩ internal} σ_r n_r·w (n_r out of r): the jump (σ_F − σ_S,r) n on Γ, and
on a facet between two solid (or two fluid) regions the traction jump (σ_1 − σ_2) n_1 (`region_data`).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy

from .expressions import SPACE, ExpressionError, T, parse, parse_vector
from .fields import expression_is_zero
from .materials import Materials


class ManufacturedError(ValueError):
    """An exact solution the model cannot have (e.g. ∂t u ≠ v)."""


def grad(vector: list[sympy.Expr], dim: int) -> sympy.Matrix:
    return sympy.Matrix(dim, dim, lambda i, j: sympy.diff(vector[i], SPACE[j]))


def sym_grad(vector: list[sympy.Expr], dim: int) -> sympy.Matrix:
    g = grad(vector, dim)
    return (g + g.T) / 2


def divergence(vector: list[sympy.Expr], dim: int) -> sympy.Expr:
    return sum(sympy.diff(vector[i], SPACE[i]) for i in range(dim))


def elastic_stress(u: list[sympy.Expr], mat: Materials, dim: int) -> sympy.Matrix:
    """σ_S = λ div(u) I + 2μ ε(u) of a displacement field."""
    return (mat.lam * divergence(u, dim) * sympy.eye(dim) + 2 * mat.mu * sym_grad(u, dim)).applyfunc(sympy.expand)


def div_rows(tensor: sympy.Matrix, dim: int) -> list[sympy.Expr]:
    """(div σ)_i = Σ_j ∂_j σ_ij."""
    return [sympy.expand(sum(sympy.diff(tensor[i, j], SPACE[j]) for j in range(dim))) for i in range(dim)]


@dataclass
class ExactSolution:
    """Exact global velocity v, fluid pressure p and solid displacement u."""

    velocity: list[sympy.Expr]
    pressure: sympy.Expr
    displacement: list[sympy.Expr]
    dim: int

    @classmethod
    def parse(cls, velocity: list[str], pressure: str, displacement: list[str], dim: int,
              field: str = "exact") -> ExactSolution:
        """Parse the three fields through the whitelist parser and check ∂t u = v."""
        solution = cls(
            parse_vector(velocity, f"{field}.velocity", dim),
            parse(str(pressure), f"{field}.pressure", dim),
            parse_vector(displacement, f"{field}.displacement", dim),
            dim,
        )
        solution.check(field)
        return solution

    def check(self, field: str = "exact") -> None:
        """Refuse a solution whose displacement is not a time integral of the velocity (`expression_is_zero`:
        ``simplify`` took 1.1 s of the peer case's 2.8 s study of levels 0–2)."""
        for i, (u_i, v_i) in enumerate(zip(self.displacement, self.velocity)):
            if not expression_is_zero(sympy.diff(u_i, T) - v_i):
                raise ManufacturedError(
                    f"{field}.displacement[{i}]: d/dt of the displacement must equal velocity[{i}] "
                    f"(got d/dt u = {sympy.diff(u_i, T)}, v = {v_i})")

    def fluid_stress(self, mat: Materials) -> sympy.Matrix:
        """σ_F = −pI + 2ν ε(v)."""
        return -self.pressure * sympy.eye(self.dim) + 2 * mat.nu * sym_grad(self.velocity, self.dim)

    def solid_stress(self, mat: Materials) -> sympy.Matrix:
        """σ_S = λ div(u) I + 2μ ε(u)."""
        return elastic_stress(self.displacement, mat, self.dim)

    def _force(self, rho: float, stress: sympy.Matrix) -> list[sympy.Expr]:
        dv = [sympy.diff(v_i, T) for v_i in self.velocity]
        return [sympy.expand(rho * a - b) for a, b in zip(dv, div_rows(stress, self.dim))]

    def fluid_force(self, mat: Materials) -> list[sympy.Expr]:
        """f_F = ρ_F ∂t v − div σ_F."""
        return self._force(mat.rho_fluid, self.fluid_stress(mat))

    def solid_force(self, mat: Materials) -> list[sympy.Expr]:
        """f_S = ρ_S ∂t v − div σ_S."""
        return self._force(mat.rho_solid, self.solid_stress(mat))

    def interface_load(self, mat: Materials) -> sympy.Matrix:
        """σ_F − σ_S; the interface load is g = (σ_F − σ_S) n, n from Ω_F into Ω_S."""
        return (self.fluid_stress(mat) - self.solid_stress(mat)).applyfunc(sympy.expand)

    def region_data(self, mat: Materials, media: dict[str, str]) -> tuple[dict[str, list], dict[str, sympy.Matrix]]:
        """Per cell region r (``media``: r → "fluid" or "solid"), its body force f_r and stress σ_r with its own
        materials ``mat.of(r)``: the loads ∫_{Ω_r} f_r·w and Σ_r ∫_{∂Ω_r ∩ internal} σ_r n_r·w of a manufactured
        solution with region-wise materials (the module's docstring)."""
        forces, stresses = {}, {}
        for region, medium in media.items():
            own = mat.of(region)
            fluid = medium == "fluid"
            forces[region] = self.fluid_force(own) if fluid else self.solid_force(own)
            stresses[region] = (self.fluid_stress(own) if fluid else self.solid_stress(own)).applyfunc(sympy.expand)
        return forces, stresses

    def at_time(self, time: float) -> ExactSolution:
        sub = lambda e: e.subs(T, time)
        return ExactSolution([sub(v) for v in self.velocity], sub(self.pressure),
                             [sub(u) for u in self.displacement], self.dim)


__all__ = ["ExactSolution", "ManufacturedError", "ExpressionError"]
