"""The weak forms of the fully discrete scheme (5.1), one function per form.

Each function returns an (un-assembled) NGSolve form; the scheme assembles them
once. Read them against METHOD.md: v, w velocity trial/test, p, q pressure,
σ, τ stress. Ω_F and Ω_S are the cell regions of the spaces' `Phases`; the constants ρ_F, ρ_S, ν, λ, μ are numbers, or
region-wise CoefficientFunctions where the regions' materials differ (`coefficients`). A tissue support on a solid
boundary (`model.data.Support`) adds its spring to K and its dashpot to K_F (`boundary_mass`).

With a solid pressure (`Spaces.solid_pressure`, P_h on Ω_S, docs/solvers.md "The solid pressure") the solid stress
is σ = σ*_h + 2μ ε(u) − P I with the discrete constitutive law P = −κ Π div u, κ = λ (`bulk_modulus`) and Π the
L² projection onto P_h (Herrmann's u–p form of elasticity), kept as the rate relation π = −κ Π div v of the third
unknown: the velocity block carries 2μΔt² ∫_S ε(v):ε(w) and no λ term, and step 1 reads (unknowns (vⁿ, pⁿ, ŝⁿ),
ŝ = ϑπ)

    A(v, w) − Δt ∫_F p div w − Δt²/ϑ ∫_S ŝ div w = ...,   −Δt ∫_F q div v = 0,
    −Δt²/ϑ ∫_S r div v − Δt²/(ϑ²κ) ∫_S ŝ r = 0,

symmetric; ϑ (``unit``) is the run's τ, so that ŝ is the pressure's increment over a backward-Euler step and the
solid rows are −Δt ∫_S r div v − (1/κ) ∫_S ŝ r, scaled as the fluid's. The displacement's companion ϑP is the third
component of the scheme's carried vector and evolves as u does (`timestepping.scheme`).
"""
from __future__ import annotations

from collections.abc import Mapping

import ngsolve as ngs
from ngsolve import InnerProduct, Trace, div

from ..geometry import FLUID, SOLID, Phases, pattern
from ..model.data import Support
from ..model.materials import FLUID_FIELDS, Materials
from .spaces import Spaces

#: Extra quadrature order for integrands with data (loads, projections of exact fields, the Gram
#: matrices they are measured with), which are not polynomials.
DATA_BONUS = 2


def region_integral(integrand, region: str | None = None, fluid_bonus: int = 0, extra: int = 0,
                    phases: Phases = Phases(), solid_bonus: int = 0):
    """∫_region integrand with ``extra`` quadrature orders everywhere, ``fluid_bonus`` more on the fluid cells and
    ``solid_bonus`` more on the solid cells: ``region`` `FLUID` (Ω_F of ``phases``), `SOLID` (Ω_S), None (Ω), or the
    pattern of some solid regions."""
    if region not in (None, FLUID, SOLID):
        return integrand * ngs.dx(region, bonus_intorder=solid_bonus + extra)
    fluid = integrand * ngs.dx(phases.pattern(FLUID), bonus_intorder=fluid_bonus + extra)
    if region == FLUID:
        return fluid
    solid = integrand * ngs.dx(phases.pattern(SOLID), bonus_intorder=solid_bonus + extra)
    return solid if region == SOLID else fluid + solid


def integral(integrand, spaces: Spaces, region: str | None = None, extra: int = 0):
    """∫_region integrand (Ω if None), with the extra quadrature order that cells with
    bubbles need (`Spaces.bonus_intorder`, `Spaces.solid_bonus_intorder`), plus ``extra`` everywhere (for data that
    are not polynomials)."""
    return region_integral(integrand, region, spaces.bonus_intorder, extra, spaces.phases,
                           spaces.solid_bonus_intorder)


def trial_test(spaces: Spaces):
    """((v, p), (w, q)): the velocity and fluid pressure trial and test functions of X_h (a solid pressure's left out,
    `solid_trial_test`)."""
    trial, test = spaces.mixed.TnT()
    return tuple(trial[:2]), tuple(test[:2])


def test_functions(spaces: Spaces):
    """(w, q): the velocity and fluid pressure test functions of X_h."""
    return tuple(spaces.mixed.TestFunction()[:2])


def solid_trial_test(spaces: Spaces):
    """(ŝ, r): the solid pressure's trial and test functions of X_h (`Spaces.solid_pressure`)."""
    trial, test = spaces.mixed.TnT()
    return trial[2], test[2]


def bulk_modulus(mat: Materials, dim: int):
    """κ = λ: the solid pressure's P = −κ Π div u with σ = 2μ ε(u) − P I (the module's docstring)."""
    return mat.lam


def deviator(e, dim: int):
    """ε_D = e − tr(e)/d I."""
    return e - (Trace(e) / dim) * ngs.Id(dim)


def coefficients(mat: Materials, spaces: Spaces) -> Materials:
    """The constants the forms multiply in: ``mat`` itself where every cell region of the spaces has the same
    values, else each constant that differs between regions as ``mesh.MaterialCF`` over the regions of its medium
    (`Materials.regions`, the defaults where a region has none). Two regions of equal materials thus assemble
    exactly as one."""
    values = {}
    for name, default in mat.constants().items():
        regions = spaces.phases.names(FLUID if name in FLUID_FIELDS else SOLID)
        table = {region: getattr(mat.of(region), name) for region in regions}
        values[name] = default if all(v == default for v in table.values()) else \
            spaces.mesh.MaterialCF({pattern([region]): value for region, value in table.items()}, default=0)
    return mat if all(values[k] is v for k, v in mat.constants().items()) else Materials(**values)


def eps(v):
    """ε(v) = (∇v + ∇vᵀ)/2."""
    return ngs.Sym(ngs.Grad(v))


def elastic_stress(v, mat: Materials, dim: int):
    """λ div(v) I + 2μ ε(v): the solid constitutive law applied to a velocity (step 2)."""
    return mat.lam * div(v) * ngs.Id(dim) + 2 * mat.mu * eps(v)


def solid_stress(u, pressure, mat: Materials, dim: int):
    """2μ ε(u) − P I: the stress of a displacement u and a solid pressure P (a solid pressure's scheme)."""
    return 2 * mat.mu * eps(u) - pressure * ngs.Id(dim)


def _carried_stress(spaces: Spaces, mat: Materials, unit: float):
    """(u, ϑP) ↦ ∫_S σ:ε(w) as an integrand of X_h's trial and test functions: Cε(u):ε(w), or with a solid pressure
    2μ ε(u):ε(w) − P div w (P = ŝ/ϑ, the module's docstring)."""
    d = spaces.mesh.dim
    (v, _), (w, _) = trial_test(spaces)
    if spaces.solid_pressure is None:
        return InnerProduct(elastic_stress(v, mat, d), eps(w))
    s, _ = solid_trial_test(spaces)
    return InnerProduct(2 * mat.mu * eps(v), eps(w)) - (1 / unit) * s * div(w)


def density(mat: Materials, spaces: Spaces) -> ngs.CoefficientFunction:
    """ρ = ρ_F in Ω_F, ρ_S in Ω_S."""
    phases = spaces.phases
    return spaces.mesh.MaterialCF({phases.pattern(FLUID): mat.rho_fluid, phases.pattern(SOLID): mat.rho_solid},
                                  default=0)


def boundary_mass(spaces: Spaces, supports: Mapping[str, Support] | None, weight):
    """Σ_Γ weight(support) ∫_Γ v·w ds over the supported boundaries Γ (None where every weight vanishes): the
    tissue support σn = −k u − c v adds k M_Γ to K and c M_Γ to K_F."""
    (v, _), (w, _) = trial_test(spaces)
    terms = [weight(support) * InnerProduct(v, w) * ngs.ds(name) for name, support in (supports or {}).items()
             if weight(support)]
    return sum(terms[1:], terms[0]) if terms else None


def _with_supports(form: ngs.BilinearForm, spaces: Spaces, supports: Mapping[str, Support] | None,
                   weight) -> ngs.BilinearForm:
    if (extra := boundary_mass(spaces, supports, weight)) is not None:
        form += extra
    return form


def step_matrix(spaces: Spaces, mat: Materials, dt: float, supports: Mapping[str, Support] | None = None,
                unit: float | None = None, **storage) -> ngs.BilinearForm:
    """Left-hand side of step 1 of (5.1), symmetric and indefinite:
    ∫ρ v·w + 2νΔt ∫_F ε(v):ε(w) + 2μΔt² ∫_S ε(v):ε(w) + λΔt² ∫_S div v div w
    − Δt ∫_F p div w − Δt ∫_F q div v, plus (cΔt + kΔt²) ∫_Γ v·w on each supported boundary Γ; with a solid
    pressure the solid's terms of the module's docstring, ``unit`` ϑ (None: Δt).
    ``storage``: BilinearForm flags (symmetric, symmetric_storage)."""
    (v, p), (w, q) = trial_test(spaces)
    a = ngs.BilinearForm(spaces.mixed, **storage)
    a += velocity_block(v, w, spaces, mat, dt)
    a += integral(-dt * p * div(w) - dt * q * div(v), spaces, FLUID)
    if spaces.solid_pressure is not None:
        unit = dt if unit is None else unit
        s, r = solid_trial_test(spaces)
        coupling = dt**2 / unit
        a += integral(-coupling * (s * div(w) + r * div(v))
                      - coupling / (unit * bulk_modulus(mat, spaces.mesh.dim)) * s * r, spaces, SOLID)
    return _with_supports(a, spaces, supports, lambda s: s.damping * dt + s.stiffness * dt**2)


def velocity_block(v, w, spaces: Spaces, mat: Materials, dt: float):
    """The velocity block A of `step_matrix`: ∫ρ v·w + 2νΔt ∫_F ε(v):ε(w) + 2μΔt² ∫_S ε(v):ε(w)
    + λΔt² ∫_S div v div w (an integrand for any velocity-like trial and test functions v, w); with a solid pressure
    2μΔt² ∫_S ε(v):ε(w) alone in the solid (λ is in the solid pressure's rows)."""
    if spaces.solid_pressure is not None:
        solid = 2 * mat.mu * dt**2 * InnerProduct(eps(v), eps(w))
    else:
        solid = 2 * mat.mu * dt**2 * InnerProduct(eps(v), eps(w)) + mat.lam * dt**2 * div(v) * div(w)
    return (integral(density(mat, spaces) * InnerProduct(v, w), spaces)
            + integral(2 * mat.nu * dt * InnerProduct(eps(v), eps(w)), spaces, FLUID)
            + integral(solid, spaces, SOLID))


def velocity_mass(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """∫_Ω ρ v·w on X_h (the ρ vⁿ⁻¹ term of the right-hand side)."""
    (v, _), (w, _) = trial_test(spaces)
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(density(mat, spaces) * InnerProduct(v, w), spaces)
    return a


def solid_stiffness(spaces: Spaces, mat: Materials, supports: Mapping[str, Support] | None = None,
                    unit: float = 1.0) -> ngs.BilinearForm:
    """K = ∫_S (λ div v I + 2μ ε(v)):ε(w) on X_h, plus k ∫_Γ v·w on each supported boundary Γ.

    By (18) the stress update is exact, σⁿ_h = σ*_h + M_σ⁻¹C uⁿ_h with the displacement uⁿ_h (5), and
    ∫_S σⁿ_h:ε(w) = ∫_S σ*_h:ε(w) + K uⁿ_h: the ∫_S σ:ε(w) terms of step 1 without stress-space
    operators (`scheme`). With a solid pressure K (u, ϑP) = ∫_S (2μ ε(u) − P I):ε(w) (not symmetric: its solid
    pressure rows are zero), ``unit`` ϑ."""
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(_carried_stress(spaces, mat, unit), spaces, SOLID)
    return _with_supports(a, spaces, supports, lambda s: s.stiffness)


def fluid_viscous(spaces: Spaces, mat: Materials, supports: Mapping[str, Support] | None = None) -> ngs.BilinearForm:
    """K_F = 2ν ∫_F ε(v):ε(w) on X_h, plus c ∫_Γ v·w on each supported boundary Γ (the θ-scheme's lagged
    viscous term and its energy)."""
    (v, _), (w, _) = trial_test(spaces)
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(2 * mat.nu * InnerProduct(eps(v), eps(w)), spaces, FLUID)
    return _with_supports(a, spaces, supports, lambda s: s.damping)


def lagged_operator(spaces: Spaces, mat: Materials, stiffness: float, viscous: float,
                    supports: Mapping[str, Support] | None = None, unit: float = 1.0) -> ngs.BilinearForm:
    """R = ∫_Ω ρ v·w − ``stiffness`` K − ``viscous`` K_F on X_h: the operator a time scheme applies to the
    velocity history (`timeschemes`; backward Euler: ρM − Δt² K), K and K_F with the supports' terms (``unit``: K's,
    `solid_stiffness`)."""
    (v, _), (w, _) = trial_test(spaces)
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(density(mat, spaces) * InnerProduct(v, w), spaces)
    a += integral(-stiffness * _carried_stress(spaces, mat, unit), spaces, SOLID)
    if viscous:
        a += integral(-viscous * 2 * mat.nu * InnerProduct(eps(v), eps(w)), spaces, FLUID)
    return _with_supports(a, spaces, supports, lambda s: -stiffness * s.stiffness - viscous * s.damping)


def divergence(spaces: Spaces) -> ngs.BilinearForm:
    """Bᵀ: ∫_F p div w on X_h (velocity tests, pressure trials; `step_matrix` holds −Δt Bᵀ and −Δt B)."""
    (_, p), (w, _) = trial_test(spaces)
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(p * div(w), spaces, FLUID)
    return a


def initial_projection(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """The Stokes projection (22) on Ω_F and the H¹ projection (23) on Ω_S, glued into one
    Galerkin problem on X_h: 2ν ∫_F ε(v):ε(w) + ∫_S ∇v:∇w − ∫_F p div w − ∫_F q div v (and ∫_S ŝ r on a solid
    pressure, which the projection leaves zero)."""
    (v, p), (w, q) = trial_test(spaces)
    a = ngs.BilinearForm(spaces.mixed)
    a += integral(2 * mat.nu * InnerProduct(eps(v), eps(w)) - p * div(w) - q * div(v), spaces, FLUID)
    a += integral(InnerProduct(ngs.Grad(v), ngs.Grad(w)), spaces, SOLID)
    if spaces.solid_pressure is not None:
        s, r = solid_trial_test(spaces)
        a += integral(s * r, spaces, SOLID)
    return a


def initial_projection_load(spaces: Spaces, mat: Materials, grad_v0, p0) -> ngs.LinearForm:
    """`initial_projection` applied to the exact (v⁰, p⁰), given ∇v⁰ and p⁰ as CoefficientFunctions; the
    constraint is ∫_F q div v⁰_h = 0 as in (22), so the result is discretely divergence-free even if v⁰ is not."""
    w, _ = test_functions(spaces)
    strain = 0.5 * (grad_v0 + grad_v0.trans)
    f = ngs.LinearForm(spaces.mixed)
    f += integral(2 * mat.nu * InnerProduct(strain, eps(w)) - p0 * div(w), spaces, FLUID, extra=DATA_BONUS)
    f += integral(InnerProduct(grad_v0, ngs.Grad(w)), spaces, SOLID, extra=DATA_BONUS)
    return f


def stress_rate(spaces: Spaces, mat: Materials) -> ngs.BilinearForm:
    """(v, τ) ↦ λ ∫_S div v tr τ + 2μ ∫_S ε(v):τ, from X_h to S_h (step 2 of (5.1))."""
    v = spaces.mixed.TrialFunction()[0]
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


def pressure_mass(p, q, spaces: Spaces, weight=1.0):
    """∫_F ``weight`` p q: with weight 1/(2ν) and 1/Δt, the inverse of the pressure Schur complement where the
    viscosity dominates (Cahouet–Chabard)."""
    return integral(weight * p * q, spaces, FLUID)
