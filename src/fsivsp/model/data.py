"""The data of the model (1)–(3) a `Scheme` runs on, and how its initial state (22)–(26) is built from them; the
boundary conditions users bring besides velocity and traction: lumped outlets (`Windkessel`), flow-rate inflows
(`FlowRate`) and tissue support (`Support`)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import sympy

from .expressions import to_function
from .fields import Field

#: How σ⁰_h and v⁰_h are built (see `Data`): the paper's experiment first, then the analysis' projections.
INITIAL_STRESS = ("displacement", "projection")
INITIAL_VELOCITY = ("interpolation", "projection")

#: The velocity profiles of a flow-rate inflow (`FlowRate`).
PROFILES = ("parabolic", "plug", "womersley")
#: Harmonics of Q(t) a Womersley profile keeps by default (the rest of Q rides on the parabola, so the flux is Q
#: whatever their number).
HARMONICS = 10


def time_function(value: sympy.Expr | float) -> Callable[[float], float]:
    """A number or an expression of t as a function of t."""
    compiled = to_function(value if isinstance(value, sympy.Basic) else sympy.Float(value))
    return compiled if callable(compiled) else (lambda t: compiled)


@dataclass(frozen=True)
class Support:
    """Tissue support on a solid boundary: σn = −k u − c v, a spring ``stiffness`` k and a dashpot ``damping`` c per
    unit area, u the displacement (5), v the velocity."""

    stiffness: float = 0.0
    damping: float = 0.0


@dataclass(frozen=True)
class Windkessel:
    """A lumped outlet: σ_F n = −P n with the three-element Windkessel (RCR) C dP_c/dt = Q − (P_c − P_d)/R_d,
    P = P_c + R_p Q, Q = ∫ v·n over the outlet (n the fluid's outer normal). ``proximal`` R_p, ``capacitance`` C,
    ``distal`` R_d, ``distal_pressure`` P_d (a number or an expression of t); C = 0 is the resistance
    P = P_d + (R_p + R_d) Q (`resistance`)."""

    proximal: float
    capacitance: float = 0.0
    distal: float = 0.0
    distal_pressure: sympy.Expr | float = 0.0

    def __post_init__(self):
        if min(self.proximal, self.capacitance, self.distal) < 0:
            raise ValueError("windkessel: expected non-negative proximal, capacitance and distal")
        if self.capacitance > 0 and self.distal <= 0:
            raise ValueError("windkessel: a capacitance needs a positive distal resistance")

    def pressure_function(self) -> Callable[[float], float]:
        """P_d(t)."""
        return time_function(self.distal_pressure)

    def impedance(self, s: complex) -> complex:
        """Z(s) = P̂/Q̂ of the outlet for fields ∝ e^{st} (P_d constant): R_p + R_d/(1 + s R_d C)."""
        return self.proximal + self.distal / (1 + s * self.distal * self.capacitance)

    def record(self) -> dict:
        """The parameters as JSON (a checkpoint's fingerprint)."""
        return {"proximal": float(self.proximal), "capacitance": float(self.capacitance),
                "distal": float(self.distal), "distal_pressure": str(self.distal_pressure)}


def resistance(value: float, distal_pressure: sympy.Expr | float = 0.0) -> Windkessel:
    """σ_F n = −(P_d + R Q) n: the Windkessel with R_p = R and C = R_d = 0."""
    return Windkessel(value, 0.0, 0.0, distal_pressure)


@dataclass(frozen=True)
class FlowRate:
    """A flow-rate inflow: the velocity normal to the boundary with the flux Q(t) into the domain and a ``profile``
    of `PROFILES` (`fem.inflow`). ``flow``: Q as an expression of t, or a table (times, values) interpolated
    linearly (beyond its ends: its end values), periodic with ``period`` if given; ``period`` and ``harmonics``:
    the Fourier series of Q a Womersley profile is built from."""

    flow: sympy.Expr | tuple[tuple[float, ...], tuple[float, ...]]
    profile: str = "parabolic"
    period: float | None = None
    harmonics: int = HARMONICS

    def __post_init__(self):
        if self.profile not in PROFILES:
            raise ValueError(f"profile: expected one of {', '.join(PROFILES)}, got {self.profile!r}")
        if self.profile == "womersley" and not self.period:
            raise ValueError("period: a womersley profile needs the period of the flow")

    def function(self) -> Callable[[float], float]:
        """Q(t)."""
        if not isinstance(self.flow, tuple):
            return time_function(self.flow)
        times, values = (np.asarray(column, dtype=float) for column in self.flow)
        if self.period:
            return lambda t: float(np.interp(t, times, values, period=self.period))
        return lambda t: float(np.interp(t, times, values))

    def record(self) -> dict:
        """The parameters as JSON (a checkpoint's fingerprint)."""
        flow = [list(column) for column in self.flow] if isinstance(self.flow, tuple) else str(self.flow)
        return {"flow": flow, "profile": self.profile, "period": self.period, "harmonics": self.harmonics}

@dataclass
class Data:
    """Data of the model (1)–(3) as fields of x, y, z, t.

    ``boundary_velocity`` maps boundary names (``"a|b"`` allowed) to Dirichlet data,
    ``boundary_traction`` to prescribed σn, ``boundary_flow`` to flow-rate inflows (Dirichlet data too),
    ``outlets`` to lumped outlets, ``supports`` to tissue supports; ``interface_load`` is a tensor J whose
    traction J n (n from Ω_F into Ω_S) loads Γ as ∫_Γ J n·w (for a manufactured
    solution J = σ_F − σ_S, see `manufactured`). With region-wise materials a manufactured solution gives instead
    ``region_forces`` (each cell region's body force, in place of ``force_fluid`` and ``force_solid``) and
    ``region_tractions``: per cell region r a tensor J_r that loads the facets r shares with another region as
    ∫ J_r n_r·w, n_r out of r. The initial stress is built from
    ``displacement0`` (σ⁰ = λ div(I_h u⁰) I + 2μ ε(I_h u⁰), the paper's experiment) or,
    if given, is the L² projection (26) of ``stress0``. The initial velocity is the nodal
    interpolant of ``velocity0`` (``initial_velocity = "interpolation"``, the paper's experiment)
    or its projection (22)–(23) together with ``pressure0`` (``"projection"``, the analysis' choice).
    """

    velocity0: Field
    pressure0: Field | None = None
    initial_velocity: str = "interpolation"
    displacement0: Field | None = None
    stress0: Field | None = None
    force_fluid: Field | None = None
    force_solid: Field | None = None
    boundary_velocity: dict[str, Field] = field(default_factory=dict)
    boundary_traction: dict[str, Field] = field(default_factory=dict)
    interface_load: Field | None = None
    boundary_flow: dict[str, FlowRate] = field(default_factory=dict)
    outlets: dict[str, Windkessel] = field(default_factory=dict)
    supports: dict[str, Support] = field(default_factory=dict)
    region_forces: dict[str, Field] = field(default_factory=dict)
    region_tractions: dict[str, Field] = field(default_factory=dict)

    def __post_init__(self):
        if self.initial_velocity not in INITIAL_VELOCITY:
            raise ValueError(f"initial_velocity: expected one of {', '.join(INITIAL_VELOCITY)}, "
                             f"got {self.initial_velocity!r}")
