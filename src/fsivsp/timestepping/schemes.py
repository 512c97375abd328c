"""Time schemes for the semi-discrete problem (10): backward Euler (5.1), the θ-scheme and BDF2.

All three keep the structure of (5.1): one saddle-point matrix per run, `forms.step_matrix` at a
weight τ in place of Δt,

    A(τ) = [[ρM + 2ντ K_F + τ² K, −τBᵀ], [−τB, 0]],

and the stress update by the displacement (exact by (18)): uⁿ_h = ũⁿ + τ vⁿ, σⁿ_h = σ*_h + Cε(uⁿ_h),
where ũⁿ is the explicit part of the update. With K = ∫_S Cε(v):ε(w), K_F = 2ν∫_F ε(v):ε(w) and
b* = ∫_S σ*_h:ε(w), step n's right-hand side is

    R aⁿ − ω (b* + K eⁿ) + Σ_j w_j f(t_j),      R = ρM − s K − c K_F,

aⁿ, eⁿ and ũⁿ linear combinations of the history (uⁿ⁻¹, vⁿ⁻¹, uⁿ⁻², vⁿ⁻²); the pressure is the step's
multiplier mⁿ, of which the θ-scheme reports the value at tₙ (`Theta.pressure`).

- θ-scheme: σⁿ = σⁿ⁻¹ + Δt(θ Cε(vⁿ) + (1 − θ) Cε(vⁿ⁻¹)), the momentum equation at the same weights:
  τ = θΔt, ω = Δt, a = vⁿ⁻¹, e = uⁿ⁻¹ − τ vⁿ⁻¹, ũ = uⁿ⁻¹ + (1 − θ)Δt vⁿ⁻¹, s = θ(2 − θ)Δt²,
  c = (1 − θ)Δt, loads θΔt f(tₙ) + (1 − θ)Δt f(tₙ₋₁). θ = 1 is backward Euler.
- BDF2: (3vⁿ − 4vⁿ⁻¹ + vⁿ⁻²)/(2Δt) and σⁿ = (4σⁿ⁻¹ − σⁿ⁻²)/3 + (2Δt/3) Cε(vⁿ): τ = ω = 2Δt/3,
  a = (4vⁿ⁻¹ − vⁿ⁻²)/3, ũ = (4uⁿ⁻¹ − uⁿ⁻²)/3, e = ũ − τa, s = τ², c = 0, loads τ f(tₙ). Its first step
  is Crank–Nicolson (θ = 1/2, local error O(Δt³)), solved with the run's A(τ) by a preconditioned
  Richardson iteration (`scheme`), so the start keeps order 2 and the run keeps one matrix.
"""
from __future__ import annotations

from dataclasses import dataclass

#: The names `[time] scheme` accepts.
SCHEMES = ("backward_euler", "theta", "bdf2")

#: Coefficients over the history (uⁿ⁻¹, vⁿ⁻¹, uⁿ⁻², vⁿ⁻²).
Combination = tuple[float, float, float, float]


@dataclass(frozen=True)
class Theta:
    """The θ-scheme, θ ∈ [1/2, 1]; θ = 1 is backward Euler (5.1), θ = 1/2 Crank–Nicolson."""

    theta: float = 1.0

    def __post_init__(self):
        if not 0.5 <= self.theta <= 1.0:
            raise ValueError(f"theta: expected a number in [0.5, 1], got {self.theta!r}")

    @property
    def name(self) -> str:
        return "backward_euler" if self.theta == 1.0 else "theta"

    @property
    def label(self) -> str:
        return "backward Euler" if self.theta == 1.0 else f"the θ-scheme (θ = {self.theta:g})"

    #: history levels a step reads (vⁿ⁻¹, uⁿ⁻¹)
    levels = 1

    @property
    def damps(self) -> bool:
        """Whether its steps damp the stiff components (θ > 1/2; Crank–Nicolson's alternate in sign)."""
        return self.theta > 0.5

    def start(self, n: int) -> Theta:
        """The scheme of step n + 1 (every step is a θ-step)."""
        return self

    def tau(self, dt: float) -> float:
        return self.theta * dt

    def weight(self, dt: float) -> float:
        """ω, the weight of b* + K e."""
        return dt

    def lagged(self, dt: float) -> tuple[float, float]:
        """(s, c) of R = ρM − s K − c K_F."""
        return self.theta * (2 - self.theta) * dt**2, (1 - self.theta) * dt

    def velocity(self, dt: float) -> Combination:
        """aⁿ."""
        return 0.0, 1.0, 0.0, 0.0

    def stiffness(self, dt: float) -> Combination:
        """eⁿ."""
        return 1.0, -self.tau(dt), 0.0, 0.0

    def explicit(self, dt: float) -> Combination:
        """ũⁿ, the explicit part of uⁿ = ũⁿ + τ vⁿ."""
        return 1.0, (1 - self.theta) * dt, 0.0, 0.0

    def loads(self, n: int, dt: float) -> list[tuple[float, float]]:
        """(time, weight) of the data terms of step n (n ≥ 1)."""
        if self.theta == 1.0:
            return [(n * dt, dt)]
        return [(n * dt, self.theta * dt), ((n - 1) * dt, (1 - self.theta) * dt)]

    def pressure(self, first: bool) -> tuple[float, float]:
        """pⁿ = α mⁿ + β p̂ⁿ⁻¹ with p̂ = θ m the multiplier of the momentum equation, ≈ p(tₙ₋₁ + θΔt) to
        O(Δt²): linear extrapolation to tₙ, from p̂ⁿ⁻¹ or, on the first step, from p⁰ (``first``; then
        β multiplies p⁰)."""
        theta = self.theta
        if first:
            return 1.0, -(1 - theta) / theta
        return (2 - theta) * theta, -(1 - theta)

    def energy_levels(self) -> int:
        """1: the plain energy ½‖vⁿ‖²_ρ + ½‖σⁿ‖²_A is the scheme's stable norm."""
        return 1


@dataclass(frozen=True)
class BDF2:
    """The two-step backward differentiation formula, started by one Crank–Nicolson step."""

    name = "bdf2"
    label = "BDF2"
    theta = 1.0
    levels = 2
    damps = True   # L-stable (its Crank–Nicolson start is one step)

    def start(self, n: int) -> Theta | BDF2:
        return Theta(0.5) if n == 0 else self

    def tau(self, dt: float) -> float:
        return 2 * dt / 3

    def weight(self, dt: float) -> float:
        return self.tau(dt)

    def lagged(self, dt: float) -> tuple[float, float]:
        return self.tau(dt) ** 2, 0.0

    def velocity(self, dt: float) -> Combination:
        return 0.0, 4 / 3, 0.0, -1 / 3

    def stiffness(self, dt: float) -> Combination:
        tau = self.tau(dt)
        return 4 / 3, -4 * tau / 3, -1 / 3, tau / 3

    def explicit(self, dt: float) -> Combination:
        return 4 / 3, 0.0, -1 / 3, 0.0

    def loads(self, n: int, dt: float) -> list[tuple[float, float]]:
        return [(n * dt, self.tau(dt))]

    def pressure(self, first: bool) -> tuple[float, float]:
        return 1.0, 0.0

    def energy_levels(self) -> int:
        """2: Dahlquist's G-norm ¼(‖Uⁿ‖² + ‖2Uⁿ − Uⁿ⁻¹‖²) of U = (v, σ) is BDF2's stable norm."""
        return 2


def time_scheme(name: str = "backward_euler", theta: float | None = None) -> Theta | BDF2:
    """The scheme called ``name`` (`SCHEMES`); ``theta`` only with ``"theta"`` (default 1/2)."""
    if name not in SCHEMES:
        raise ValueError(f"scheme: expected one of {', '.join(SCHEMES)}, got {name!r}")
    if theta is not None and name != "theta":
        raise ValueError(f"theta: only with scheme = \"theta\", got scheme = {name!r}")
    if name == "bdf2":
        return BDF2()
    if name == "theta":
        return Theta(0.5 if theta is None else float(theta))
    return Theta(1.0)
