"""The weak forms of the fully discrete scheme (5.1), one function per form.

Each function returns an (un-assembled) NGSolve form; the scheme assembles them
once. Read them against METHOD.md: v, w velocity trial/test, p, q pressure,
σ, τ stress.
"""
from __future__ import annotations

import ngsolve as ngs
from ngsolve import InnerProduct, Trace, div

from .geometry import FLUID, SOLID
from .materials import Materials
from .spaces import Spaces


def integral(integrand, spaces: Spaces, region: str | None = None):
    """∫_region integrand (Ω if None), with the extra quadrature order that fluid cells with
    bubbles need (`Spaces.bonus_intorder`)."""
    fluid = integrand * ngs.dx(FLUID, bonus_intorder=spaces.bonus_intorder)
    if region == FLUID:
        return fluid
    if region == SOLID:
        return integrand * ngs.dx(SOLID)
    return fluid + integrand * ngs.dx(SOLID)


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
    rho = density(mat, spaces.mesh)
    a = ngs.BilinearForm(spaces.mixed, **storage)
    a += integral(rho * InnerProduct(v, w), spaces)
    a += integral(2 * mat.nu * dt * InnerProduct(eps(v), eps(w)), spaces, FLUID)
    a += integral(2 * mat.mu * dt**2 * InnerProduct(eps(v), eps(w)) + mat.lam * dt**2 * div(v) * div(w), spaces, SOLID)
    a += integral(-dt * p * div(w) - dt * q * div(v), spaces, FLUID)
    return a


def velocity_mass(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """∫_Ω ρ v·w on X_h (the ρ vⁿ⁻¹ term of the right-hand side)."""
    (v, _), (w, _) = spaces.mixed.TnT()
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(density(mat, spaces.mesh) * InnerProduct(v, w), spaces)
    return a


def stress_divergence(spaces: Spaces) -> ngs.BilinearForm:
    """(σ, w) ↦ ∫_S σ:ε(w), from S_h to X_h (the −Δt ∫_S σⁿ⁻¹:ε(w) term)."""
    sigma = spaces.stress.TrialFunction()
    w, _ = spaces.mixed.TestFunction()
    a = ngs.BilinearForm(trialspace=spaces.stress, testspace=spaces.mixed)
    a += integral(InnerProduct(sigma, eps(w)), spaces, SOLID)
    return a


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
