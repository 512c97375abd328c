"""The harmonic response of (10): every field ∝ e^{st} at s = iω, ω = 2πf.

With s σ_S = Cε(v) in Ω_S the stress is eliminated, ∫_S σ_S:ε(w) = K_S v / s, and (10) becomes one complex
symmetric (not Hermitian) saddle-point system per frequency,

    [ sM + K_F + K_S/s   −Bᵀ ] [v̂]   [f̂]
    [ −B                  0  ] [p̂] = [0 ],      v̂ = ĝ on the Dirichlet boundaries,

M = ∫ρ v·w, K_F = 2ν ∫_F ε(v):ε(w), K_S = ∫_S Cε(v):ε(w), Bᵀp = ∫_F p div w, f̂ = ∫ f̂·w + Σ ∫_{Γ_N} t̂·w. It is
s times the step matrix of (5.1) at the complex weight τ = 1/s (`forms.step_matrix`): A(1/s) (v̂, p̂) = f̂/s, so p̂
is the pressure's amplitude itself. Tissue support σn = −k u − c v adds (c + k/s) ∫_Γ v·w to the momentum equation,
the step matrix's support term at τ = 1/s; a lumped outlet σn = −P n with P̂ = Z(s) Q̂ (`model.data.Windkessel.
impedance`, the RCR's constant distal pressure does not oscillate) adds Z(s) c cᵀ, c = ∫_Γ φ·n, solved by Woodbury's
formula around the factorisation (`solvers.woodbury`, weight Z(s)/s). Displacement and stress follow from (5) and
(18): û = v̂/s, σ̂_S = Cε(û).

The data are complex amplitudes: a datum g(x) cos(ωt − φ) = Re(ĝ e^{iωt}) has ĝ = g e^{−iφ} (`HarmonicData`), so
the response to it is Re(v̂ e^{iωt}) = |v̂| cos(ωt − φ_v) with the lag φ_v = −arg v̂.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np

from ..fem import forms
from ..fem.inflow import flux_vector
from ..fem.loads import Loads
from ..fem.spaces import Spaces
from ..model.data import Data, Support, Windkessel
from ..model.fields import Field
from ..model.materials import Materials
from ..solvers import factorise, free_mask
from ..solvers.woodbury import WoodburySolver


@dataclass
class HarmonicData:
    """The amplitudes of a harmonic case as fields of x (no t): body forces, Dirichlet velocities and tractions σn
    per boundary name, and each boundary's ``phase`` φ in degrees (the datum is g(x) cos(ωt − φ); default 0, as
    for the body forces); the lumped ``outlets`` and tissue ``supports`` by boundary name."""

    dim: int
    force_fluid: Field | None = None
    force_solid: Field | None = None
    boundary_velocity: dict[str, Field] = field(default_factory=dict)
    boundary_traction: dict[str, Field] = field(default_factory=dict)
    phase: dict[str, float] = field(default_factory=dict)
    outlets: dict[str, Windkessel] = field(default_factory=dict)
    supports: dict[str, Support] = field(default_factory=dict)

    def groups(self) -> dict[float, Data]:
        """The data of each phase (in degrees) as the `Data` of a time-domain run, whose fields do not depend on t."""
        groups: dict[float, Data] = {}

        def group(phase: float) -> Data:
            return groups.setdefault(phase, Data(velocity0=Field([0] * self.dim)))

        if self.force_fluid is not None:
            group(0.0).force_fluid = self.force_fluid
        if self.force_solid is not None:
            group(0.0).force_solid = self.force_solid
        for name, values in self.boundary_velocity.items():
            group(self.phase.get(name, 0.0)).boundary_velocity[name] = values
        for name, values in self.boundary_traction.items():
            group(self.phase.get(name, 0.0)).boundary_traction[name] = values
        return groups


class Amplitudes:
    """f̂ (``load``) and ĝ (``boundary``, the Dirichlet values) on X_h (complex spaces): Σ_φ e^{−iφ} times the load
    vectors and Dirichlet values of the data of phase φ (`fem.loads.Loads`, once: they do not depend on the
    frequency); the data's ``outlets`` with their flux vectors ``fluxes`` and ``supports``."""

    def __init__(self, spaces: Spaces, data: HarmonicData):
        self.outlets, self.supports = data.outlets, data.supports
        self.fluxes = [flux_vector(spaces, name) for name in data.outlets]
        self.load = ngs.GridFunction(spaces.mixed).vec
        self.boundary = self.load.CreateVector()
        part, values = self.load.CreateVector(), self.load.CreateVector()
        self.load[:] = 0.0
        self.boundary[:] = 0.0
        for phase, group in data.groups().items():
            factor = complex(np.exp(-1j * np.radians(phase)))
            part[:] = 0.0
            Loads(spaces, group, None).add_to(part, values, [(0.0, 1.0)], 0.0, lift=False)
            self.load.data += factor * part
            self.boundary.data += factor * values


@dataclass
class Response:
    """The harmonic solution at ``s``: ``state`` = (v̂, p̂) on X_h, the direct solver's ``method``, the ``residual``
    ‖f̂/s − A x‖ / ‖f̂/s − A ĝ‖ on the free dofs and the ``seconds`` of assembly, factorisation and solve."""

    s: complex
    state: ngs.GridFunction
    materials: Materials
    method: str
    residual: float
    seconds: float

    @property
    def frequency(self) -> float:
        return self.s.imag / (2 * np.pi)

    @property
    def velocity(self) -> ngs.CoefficientFunction:
        return self.state.components[0]

    @property
    def pressure(self) -> ngs.CoefficientFunction:
        return self.state.components[1]

    @property
    def displacement(self) -> ngs.CoefficientFunction:
        """û = v̂/s (5)."""
        return (1 / self.s) * self.velocity

    @property
    def stress(self) -> ngs.CoefficientFunction:
        """σ̂_S = Cε(û) (18), meaningful in Ω_S."""
        return (1 / self.s) * forms.elastic_stress(self.velocity, self.materials, self.state.space.mesh.dim)


def harmonic_matrix(spaces: Spaces, materials: Materials, s: complex,
                    supports: dict[str, Support] | None = None) -> ngs.BaseMatrix:
    """A(1/s) = [[sM + K_F + K_S/s, −Bᵀ], [−B, 0]] / s on X_h (complex spaces), with the ``supports``' terms:
    `forms.step_matrix` at τ = 1/s."""
    return forms.step_matrix(spaces, materials, 1 / s, supports).Assemble().mat


def respond(spaces: Spaces, materials: Materials, amplitudes: Amplitudes, s: complex,
            method: str | None = None) -> Response:
    """(v̂, p̂) at ``s`` (s = 2πif for the frequency f): x = ĝ + A_ff⁻¹(f̂/s − A ĝ) with A = `harmonic_matrix`,
    factorised by `solvers.factorise` (``method``: a direct method, None: the fastest that passes its residual
    check), and the outlets' terms Σ (Z_i(s)/s) c_i c_iᵀ by Woodbury's formula around it."""
    start = time.perf_counter()
    matrix = harmonic_matrix(spaces, materials, s, amplitudes.supports)
    free = spaces.mixed.FreeDofs()
    factors = factorise(matrix, free, method)
    weights = [outlet.impedance(s) / s for outlet in amplitudes.outlets.values()]
    solver = WoodburySolver(factors, amplitudes.fluxes, weights, free) if weights else factors
    state = ngs.GridFunction(spaces.mixed)
    rhs = amplitudes.load.CreateVector()
    rhs.data = (1 / s) * amplitudes.load - matrix * amplitudes.boundary
    lifted = rhs.FV().NumPy().copy()
    solver.solve_step(rhs, amplitudes.boundary, state.vec)
    rhs.data = (1 / s) * amplitudes.load - matrix * state.vec
    for c, weight in zip(amplitudes.fluxes, weights):
        rhs.data -= complex(weight * c.InnerProduct(state.vec, conjugate=False)) * c
    mask = free_mask(free, len(rhs))
    scale = np.linalg.norm(lifted[mask])
    residual = float(np.linalg.norm(rhs.FV().NumPy()[mask]) / scale) if scale else 0.0
    return Response(complex(s), state, materials, factors.method, residual, time.perf_counter() - start)
