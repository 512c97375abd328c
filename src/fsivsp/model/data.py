"""The data of the model (1)–(3) a `Scheme` runs on, and how its initial state (22)–(26) is built from them."""
from __future__ import annotations

from dataclasses import dataclass, field

from .fields import Field

#: How σ⁰_h and v⁰_h are built (see `Data`): the paper's experiment first, then the analysis' projections.
INITIAL_STRESS = ("displacement", "projection")
INITIAL_VELOCITY = ("interpolation", "projection")


@dataclass
class Data:
    """Data of the model (1)–(3) as fields of x, y, z, t.

    ``boundary_velocity`` maps boundary names (``"a|b"`` allowed) to Dirichlet data,
    ``boundary_traction`` to prescribed σn, ``interface_load`` is a tensor J whose
    traction J n (n from Ω_F into Ω_S) loads Γ as ∫_Γ J n·w (for a manufactured
    solution J = σ_F − σ_S, see `manufactured`). The initial stress is built from
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

    def __post_init__(self):
        if self.initial_velocity not in INITIAL_VELOCITY:
            raise ValueError(f"initial_velocity: expected one of {', '.join(INITIAL_VELOCITY)}, "
                             f"got {self.initial_velocity!r}")
