"""The weak forms of the fully discrete scheme (5.1), one function per form.

Each function returns an (un-assembled) NGSolve form; the scheme assembles them
once. Read them against METHOD.md: v, w velocity trial/test, p, q pressure,
σ, τ stress.
"""
from __future__ import annotations

import ngsolve as ngs
from ngsolve import InnerProduct, Trace, div

from ..geometry import FLUID, SOLID
from ..model.materials import Materials
from .spaces import Spaces

#: Extra quadrature order for integrands with data (loads, projections of exact fields, the Gram
#: matrices they are measured with), which are not polynomials.
DATA_BONUS = 2


def region_integral(integrand, region: str | None = None, fluid_bonus: int = 0, extra: int = 0):
    """∫_region integrand (Ω if None) with ``extra`` quadrature orders everywhere and ``fluid_bonus``
    more on the fluid cells."""
    fluid = integrand * ngs.dx(FLUID, bonus_intorder=fluid_bonus + extra)
    if region == FLUID:
        return fluid
    solid = integrand * ngs.dx(SOLID, bonus_intorder=extra)
    return solid if region == SOLID else fluid + solid


def integral(integrand, spaces: Spaces, region: str | None = None, extra: int = 0):
    """∫_region integrand (Ω if None), with the extra quadrature order that fluid cells with
    bubbles need (`Spaces.bonus_intorder`), plus ``extra`` everywhere (for data that are not
    polynomials)."""
    return region_integral(integrand, region, spaces.bonus_intorder, extra)


def eps(v):
    """ε(v) = (∇v + ∇vᵀ)/2."""
    return ngs.Sym(ngs.Grad(v))


def elastic_stress(v, mat: Materials, dim: int):
    """λ div(v) I + 2μ ε(v): the solid constitutive law applied to a velocity (step 2)."""
    return mat.lam * div(v) * ngs.Id(dim) + 2 * mat.mu * eps(v)


def density(mat: Materials, mesh: ngs.Mesh) -> ngs.CoefficientFunction:
    """ρ = ρ_F in Ω_F, ρ_S in Ω_S."""
    return mesh.MaterialCF({FLUID: mat.rho_fluid, SOLID: mat.rho_solid}, default=0)


def step_matrix(spaces: Spaces, mat: Materials, dt: float, **storage) -> ngs.BilinearForm:
    """Left-hand side of step 1 of (5.1), symmetric and indefinite:
    ∫ρ v·w + 2νΔt ∫_F ε(v):ε(w) + 2μΔt² ∫_S ε(v):ε(w) + λΔt² ∫_S div v div w
    − Δt ∫_F p div w − Δt ∫_F q div v. ``storage``: BilinearForm flags (symmetric, symmetric_storage)."""
    (v, p), (w, q) = spaces.mixed.TnT()
    a = ngs.BilinearForm(spaces.mixed, **storage)
    a += velocity_block(v, w, spaces, mat, dt)
    a += integral(-dt * p * div(w) - dt * q * div(v), spaces, FLUID)
    return a


def velocity_block(v, w, spaces: Spaces, mat: Materials, dt: float):
    """The velocity block A of `step_matrix`: ∫ρ v·w + 2νΔt ∫_F ε(v):ε(w) + 2μΔt² ∫_S ε(v):ε(w)
    + λΔt² ∫_S div v div w (an integrand for any velocity-like trial and test functions v, w)."""
    return (integral(density(mat, spaces.mesh) * InnerProduct(v, w), spaces)
            + integral(2 * mat.nu * dt * InnerProduct(eps(v), eps(w)), spaces, FLUID)
            + integral(2 * mat.mu * dt**2 * InnerProduct(eps(v), eps(w)) + mat.lam * dt**2 * div(v) * div(w),
                       spaces, SOLID))


def velocity_mass(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """∫_Ω ρ v·w on X_h (the ρ vⁿ⁻¹ term of the right-hand side)."""
    (v, _), (w, _) = spaces.mixed.TnT()
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(density(mat, spaces.mesh) * InnerProduct(v, w), spaces)
    return a


def solid_stiffness(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """K = ∫_S (λ div v I + 2μ ε(v)):ε(w) on X_h.

    By (18) the stress update is exact, σⁿ_h = σ*_h + M_σ⁻¹C uⁿ_h with the displacement uⁿ_h (5), and
    ∫_S σⁿ_h:ε(w) = ∫_S σ*_h:ε(w) + K uⁿ_h: the ∫_S σ:ε(w) terms of step 1 without stress-space
    operators (`scheme`)."""
    (v, _), (w, _) = spaces.mixed.TnT()
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(InnerProduct(elastic_stress(v, mat, spaces.mesh.dim), eps(w)), spaces, SOLID)
    return a


def fluid_viscous(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """K_F = 2ν ∫_F ε(v):ε(w) on X_h (the θ-scheme's lagged viscous term and its energy)."""
    (v, _), (w, _) = spaces.mixed.TnT()
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(2 * mat.nu * InnerProduct(eps(v), eps(w)), spaces, FLUID)
    return a


def lagged_operator(spaces: Spaces, mat: Materials, stiffness: float, viscous: float) -> ngs.BilinearForm:
    """R = ∫_Ω ρ v·w − ``stiffness`` K − ``viscous`` K_F on X_h: the operator a time scheme applies to the
    velocity history (`timeschemes`; backward Euler: ρM − Δt² K)."""
    (v, _), (w, _) = spaces.mixed.TnT()
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(density(mat, spaces.mesh) * InnerProduct(v, w), spaces)
    a += integral(-stiffness * InnerProduct(elastic_stress(v, mat, spaces.mesh.dim), eps(w)), spaces, SOLID)
    if viscous:
        a += integral(-viscous * 2 * mat.nu * InnerProduct(eps(v), eps(w)), spaces, FLUID)
    return a


def divergence(spaces: Spaces) -> ngs.BilinearForm:
    """Bᵀ: ∫_F p div w on X_h (velocity tests, pressure trials; `step_matrix` holds −Δt Bᵀ and −Δt B)."""
    (_, p), (w, _) = spaces.mixed.TnT()
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(p * div(w), spaces, FLUID)
    return a


def initial_projection(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """The Stokes projection (22) on Ω_F and the H¹ projection (23) on Ω_S, glued into one
    Galerkin problem on X_h: 2ν ∫_F ε(v):ε(w) + ∫_S ∇v:∇w − ∫_F p div w − ∫_F q div v."""
    (v, p), (w, q) = spaces.mixed.TnT()
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(2 * mat.nu * InnerProduct(eps(v), eps(w)) - p * div(w) - q * div(v), spaces, FLUID)
    a += integral(InnerProduct(ngs.Grad(v), ngs.Grad(w)), spaces, SOLID)
    return a


def initial_projection_load(spaces: Spaces, mat: Materials, grad_v0, p0) -> ngs.LinearForm:
    """`initial_projection` applied to the exact (v⁰, p⁰), given ∇v⁰ and p⁰ as CoefficientFunctions; the
    constraint is ∫_F q div v⁰_h = 0 as in (22), so the result is discretely divergence-free even if v⁰ is not."""
    w, _ = spaces.mixed.TestFunction()
    strain = 0.5 * (grad_v0 + grad_v0.trans)
    f = ngs.LinearForm(spaces.mixed)
    f += integral(2 * mat.nu * InnerProduct(strain, eps(w)) - p0 * div(w), spaces, FLUID, extra=DATA_BONUS)
    f += integral(InnerProduct(grad_v0, ngs.Grad(w)), spaces, SOLID, extra=DATA_BONUS)
    return f


def stress_rate(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """(v, τ) ↦ λ ∫_S div v tr τ + 2μ ∫_S ε(v):τ, from X_h to S_h (step 2 of (5.1))."""
    v, _ = spaces.mixed.TrialFunction()
    tau = spaces.stress.TestFunction()
    a = ngs.BilinearForm(trialspace=spaces.mixed, testspace=spaces.stress)
    a += integral(mat.lam * div(v) * Trace(tau) + 2 * mat.mu * InnerProduct(eps(v), tau), spaces, SOLID)
    return a


def stress_mass(spaces: Spaces) -> ngs.BilinearForm:
    """∫_S σ:τ on S_h (block diagonal: S_h is discontinuous)."""
    sigma, tau = spaces.stress.TnT()
    a = ngs.BilinearForm(spaces.stress)
    a += integral(InnerProduct(sigma, tau), spaces, SOLID)
    return a


# -- the norm of the step (the iterative solver's block preconditioner, `solvers.iterative`) -------------

def velocity_component_block(u, w, j: int, mat: Materials, dt: float, mesh: ngs.Mesh):
    """The j-th diagonal block of the velocity part of `step_matrix`, for scalar u, w (the velocity
    u e_j, tested with w e_j): ε(u e_j):ε(w e_j) = ½(∇u·∇w + ∂_j u ∂_j w), div(u e_j) = ∂_j u, so
    ∫ρ u w + νΔt ∫_F (∇u·∇w + ∂_j u ∂_j w) + Δt² ∫_S μ(∇u·∇w + ∂_j u ∂_j w) + λ ∂_j u ∂_j w."""
    gu, gw = ngs.grad(u), ngs.grad(w)
    strain = gu * gw + gu[j] * gw[j]
    return (density(mat, mesh) * u * w * ngs.dx
            + mat.nu * dt * strain * ngs.dx(FLUID)
            + dt**2 * (mat.mu * strain + mat.lam * gu[j] * gw[j]) * ngs.dx(SOLID))


def pressure_laplacian(p, q):
    """∫_F ∇p·∇q: with ρ_F/Δt², the inverse of the pressure Schur complement where the mass dominates
    (Cahouet–Chabard)."""
    return ngs.grad(p) * ngs.grad(q) * ngs.dx(FLUID)


def pressure_mass(p, q):
    """∫_F p q: with 2ν/Δt, the inverse of the pressure Schur complement where the viscosity dominates."""
    return p * q * ngs.dx(FLUID)
