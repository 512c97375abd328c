"""Material constants of the model (1)–(3)."""
from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Materials:
    """ρ_F, ρ_S, ν (multiplies ε(v) in σ_F = −pI + 2νε(v)), and the Lamé constants λ, μ."""

    rho_fluid: float = 1.0
    rho_solid: float = 1.0
    nu: float = 0.5
    lam: float = 1.0
    mu: float = 0.5

    def as_dict(self) -> dict[str, float]:
        return asdict(self)

    @classmethod
    def from_young(cls, young: float, poisson: float, **others: float) -> Materials:
        """λ, μ from Young's modulus E and Poisson's ratio ν_P (plane strain / 3D)."""
        mu = young / (2 * (1 + poisson))
        lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
        return cls(lam=lam, mu=mu, **others)
