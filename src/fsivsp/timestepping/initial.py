"""The initial state of a `Scheme`: v⁰_h by interpolation (the paper's experiment) or the projections (22)–(23),
u⁰_h = I_h u⁰, σ⁰_h = C ε(u⁰_h) or the L² projection (26) of σ⁰, and the multiplier m⁰ the θ-scheme and BDF2
start from."""
from __future__ import annotations

import ngsolve as ngs
from ngsolve import InnerProduct

from ..fem import forms
from ..fem.spaces import Spaces
from ..geometry import SOLID
from ..model.data import Data
from ..model.fields import Field, TimeVector
from ..model.manufactured import grad
from ..model.materials import Materials
from ..runtime.threads import integrate, sequential
from ..solvers import factorise


def interpolate(spaces: Spaces, values: ngs.CoefficientFunction) -> ngs.GridFunction:
    """I_h v: nodal P1 interpolation for MINI (bubbles zero, as in the paper's experiment),
    NGSolve's projection-based interpolation for Taylor–Hood."""
    gf = ngs.GridFunction(spaces.velocity)
    if spaces.family == "mini":
        mesh = spaces.mesh
        with sequential():   # the same element colouring in every process (`Set` adds in its order)
            linear = ngs.GridFunction(ngs.VectorH1(mesh, order=1))
        linear.Set(values)
        # The hierarchical H1 basis numbers the vertex dofs first in each component.
        for mine, theirs in zip(gf.components, linear.components):
            mine.vec[: mesh.nv] = theirs.vec
    else:
        gf.Set(values)
    return gf


def initial_state(spaces: Spaces, materials: Materials, data: Data, dirichlet: list[TimeVector],
                  state: ngs.GridFunction, carried: ngs.GridFunction) -> None:
    """(v⁰_h, p⁰_h) into ``state``: I_h v⁰ (p⁰_h = 0) or the projections (22)–(23) (`projected_state`);
    (u⁰_h, 0) into ``carried``: u⁰_h = I_h u⁰, 0 if no u⁰ is given."""
    state.vec[:] = 0.0
    if data.initial_velocity == "projection":
        state.vec.data = projected_state(spaces, materials, data, dirichlet, state.vec)
    else:
        state.components[0].vec.data = interpolate(spaces, data.velocity0.coefficient(0.0)).vec
    carried.vec[:] = 0.0
    if data.displacement0 is not None:
        carried.components[0].vec.data = interpolate(spaces, data.displacement0.coefficient(0.0)).vec


def projected_state(spaces: Spaces, materials: Materials, data: Data, dirichlet: list[TimeVector],
                    like: ngs.BaseVector) -> ngs.BaseVector:
    """(v⁰_h, p⁰_h) from `forms.initial_projection` (Stokes (22) on Ω_F, H¹ (23) on Ω_S), with v⁰ as Dirichlet
    values on ∂Ω (``dirichlet``, `loads.Loads`); p⁰ = 0 if not given. A vector like ``like``."""
    gradient = grad(data.velocity0.components(), spaces.mesh.dim)
    pressure = data.pressure0.coefficient(0.0) if data.pressure0 is not None else ngs.CoefficientFunction(0.0)
    matrix = forms.initial_projection(spaces, materials).Assemble().mat
    load = forms.initial_projection_load(spaces, materials, Field(gradient).coefficient(0.0), pressure)
    rhs = load.Assemble().vec
    state = like.CreateVector()
    state[:] = 0.0
    for values in dirichlet:
        values.add_to(state, 0.0)
    rhs.data -= matrix * state
    state.data += factorise(matrix, spaces.mixed.FreeDofs()).inverse * rhs
    return state


def initial_solid_pressure(spaces: Spaces, materials: Materials, unit: float, data: Data,
                           state: ngs.GridFunction, carried: ngs.GridFunction) -> None:
    """The solid pressure's initial values (`forms`), ϑP⁰ into ``carried``'s third component and ϑπ⁰ into ``state``'s,
    from the exact data as a u–p method takes them: (P, r)_{1/κ} = (g, r) on P_h (κ = `forms.bulk_modulus`) with
    g = −tr(σ⁰ − 2μ ε(u⁰_h))/(dκ) where σ⁰ is given, else −div u⁰ (0 without u⁰), and g = −div v⁰ for π⁰:
    P⁰ = Π(−κ div u⁰) for one material. Not from I_h u⁰: its divergence error, times κ, would enter P⁰ (an error
    O(λ h^k) the step corrects only in part)."""
    space, d = spaces.solid_pressure, spaces.mesh.dim
    s, r = space.TnT()
    kappa = forms.bulk_modulus(materials, d)
    mass = ngs.BilinearForm(space, symmetric=True)
    mass += forms.integral(s * r / kappa, spaces, SOLID)
    inverse = factorise(mass.Assemble().mat, space.FreeDofs()).inverse

    def divergence(field):
        return ngs.Trace(Field(grad(field.components(), d)).coefficient(0.0))

    if data.stress0 is not None:
        elastic = forms.solid_stress(carried.components[0], 0.0, materials, d)   # its part in u⁰_h
        sources = [-ngs.Trace(data.stress0.coefficient(0.0) - elastic) / (d * kappa)]
    else:
        sources = [-divergence(data.displacement0) if data.displacement0 is not None else None]
    sources.append(-divergence(data.velocity0))
    for gf, source in zip((carried, state), sources):
        gf.components[2].vec[:] = 0.0
        if source is not None:
            load = ngs.LinearForm(space)
            load += forms.integral(unit * source * r, spaces, SOLID, extra=forms.DATA_BONUS)
            gf.components[2].vec.data = inverse * load.Assemble().vec


def project_offset(spaces: Spaces, materials: Materials, stress0: Field, stress: ngs.CoefficientFunction,
                   offset: ngs.GridFunction, load: ngs.BaseVector) -> float:
    """σ*_h = Π (σ⁰ − σ_h(u⁰_h)) into ``offset`` (Π the L² projection (26) onto S_h, cell by cell; σ_h(u⁰_h) =
    ``stress``, C ε(u⁰_h), on which Π is exact by (18)) and b* = ∫_S σ*_h:ε(w) into ``load``; returns
    ∫_S Aσ*_h:σ*_h. With a solid pressure σ*_h is the deviator's projection: the spherical part is −P⁰_h I
    (`initial_solid_pressure`), and its projection error, O(λ) on curved cells, would be a spurious load that only μ
    resists (the velocity's error grew like λ: 26 against 0.43 without a solid pressure, λ/μ = 10⁴, curved level 0
    of examples/fluid_in_solid_2d.toml)."""
    mesh = spaces.mesh
    solid = mesh.Materials(spaces.phases.pattern(SOLID))
    difference = stress0.coefficient(0.0) - stress
    if spaces.solid_pressure is not None:
        difference = forms.deviator(difference, mesh.dim)
    offset.Set(difference, definedon=solid, bonus_intorder=4)
    w, _ = forms.test_functions(spaces)
    form = ngs.LinearForm(spaces.mixed)
    form += forms.integral(InnerProduct(offset, forms.eps(w)), spaces, SOLID)
    load.data = form.Assemble().vec
    return integrate(compliance(offset, offset, materials, mesh.dim), mesh, definedon=solid)


def compliance(sigma: ngs.CoefficientFunction, tau: ngs.CoefficientFunction, materials: Materials,
               dim: int) -> ngs.CoefficientFunction:
    """A σ:τ with the compliance A σ = (σ − λ/(dλ + 2μ) tr(σ) I) / (2μ) (elastic energy)."""
    lam, mu = materials.lam, materials.mu
    return (InnerProduct(sigma, tau) - lam / (dim * lam + 2 * mu) * ngs.Trace(sigma) * ngs.Trace(tau)) / (2 * mu)


def initial_multiplier(data: Data, state: ngs.BaseVector, solution: ngs.GridFunction, theta: float) -> None:
    """(v⁰, m⁰) into ``solution`` with θ m⁰ = p⁰_h, the pressure the first step's extrapolation (`Theta.pressure`)
    starts from: the projection's (22) or the interpolant of p⁰; without p⁰ the first step reports p̂¹."""
    solution.vec.data = state
    pressure = solution.components[1]
    if data.pressure0 is not None and data.initial_velocity != "projection":
        pressure.Set(data.pressure0.coefficient(0.0))
    pressure.vec.data *= 1.0 / theta
