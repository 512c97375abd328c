"""Material constants of the model (1)–(3), by default and per cell region."""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

#: The constants of the fluid (on fluid regions) and of the solid (on solid regions).
FLUID_FIELDS, SOLID_FIELDS = ("rho_fluid", "nu"), ("rho_solid", "lam", "mu")


@dataclass(frozen=True)
class Materials:
    """ρ_F, ρ_S, ν (multiplies ε(v) in σ_F = −pI + 2νε(v)), and the Lamé constants λ, μ; ``regions``: the
    materials of cell regions that have their own (``[materials.NAME]``), each a `Materials` without regions; every
    other region takes these."""

    rho_fluid: float = 1.0
    rho_solid: float = 1.0
    nu: float = 0.5
    lam: float = 1.0
    mu: float = 0.5
    regions: dict[str, Materials] = field(default_factory=dict)

    def constants(self) -> dict[str, float]:
        """ρ_F, ρ_S, ν, λ, μ by name."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "regions"}

    def of(self, region: str) -> Materials:
        """The materials of cell region ``region``."""
        return self.regions.get(region, self)

    def uniform(self, regions) -> bool:
        """Whether the cell ``regions`` all have these constants."""
        return all(self.of(region).constants() == self.constants() for region in regions)

    def with_region(self, region: str, **values: float) -> Materials:
        """These materials with region ``region``'s constants ``values`` (the others these defaults)."""
        own = replace(self, regions={}, **values)
        return replace(self, regions={**self.regions, region: own})

    def as_dict(self) -> dict:
        """The constants, and ``regions`` (by name, their constants) where there are any."""
        out: dict = self.constants()
        if self.regions:
            out["regions"] = {name: mat.constants() for name, mat in self.regions.items()}
        return out

    @classmethod
    def from_young(cls, young: float, poisson: float, **others: float) -> Materials:
        """λ, μ from Young's modulus E and Poisson's ratio ν_P (plane strain / 3D)."""
        return cls(**lame(young, poisson), **others)


def lame(young: float, poisson: float) -> dict[str, float]:
    """λ and μ of Young's modulus E and Poisson's ratio ν_P."""
    mu = young / (2 * (1 + poisson))
    return {"lam": young * poisson / ((1 + poisson) * (1 - 2 * poisson)), "mu": mu}
