"""The exact shear motions of a fluid layer on a solid layer, periodic in x: the coupled modes (roots of the
dispersion relation (D)) and the harmonic response to the top wall, against which `frequency` is verified
(tests/frequency, docs/frequency.md).

Solid 0 < y < h_S at rest at y = 0, fluid h_S < y < h_S + h_F at rest at the top (`fluid_over_solid` with
``periodic = "x"``), v = (v_x(y), 0), p = 0, every field ∝ e^{st}. With σ_F = −pI + 2ν ε(v) (ν the dynamic
viscosity, METHOD.md) σ_F,xy = ν v_x′ and the momentum equation is ρ_F s v = ν v″: v = a sinh(k_F (h_S + h_F − y)),
k_F² = ρ_F s/ν. In the solid u = v/s and ρ_S s² u = μ u″: v = b sinh(k_S y), k_S = s √(ρ_S/μ). Continuity of v and
of the shear traction at y = h_S (ν v_F′ = μ u_S′ = (μ/s) v_S′), divided one by the other, give

    ν k_F coth(k_F h_F) + √(ρ_S μ) coth(k_S h_S) = 0                                                 (D)

k coth(kh) is even in k, so the branch of √ does not matter. The roots are those of the entire function

    H(s) = ν cosh(k_F h_F) sinh(k_S h_S) + √(ρ_S μ) cosh(k_S h_S) sinh(k_F h_F)/k_F,

(D) times sinh(k_F h_F) sinh(k_S h_S)/k_F, without poles; its one extra root is s = 0 (v = 0). The solid's
compressional modes u = (0, sin(nπy/h_S)) with the fluid at rest (a constant pressure balances σ_yy at Γ) are
undamped: s = i nπ √((λ + 2μ)/ρ_S) / h_S.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import mpmath
import numpy as np

#: Digits of mpmath's arithmetic for the roots.
DIGITS = 30


@dataclass(frozen=True)
class ShearLayers:
    """The layers' data: densities, the (dynamic) viscosity ν, the shear modulus μ, the thicknesses."""

    rho_fluid: float
    rho_solid: float
    nu: float
    mu: float
    fluid_height: float
    solid_height: float

    def wave_numbers(self, s):
        """k_F = √(ρ_F s/ν), k_S = s √(ρ_S/μ) (mpmath numbers)."""
        s = mpmath.mpc(s)
        return mpmath.sqrt(self.rho_fluid * s / self.nu), s * mpmath.sqrt(self.rho_solid / self.mu)

    def dispersion(self, s) -> complex:
        """The left-hand side of (D) at ``s``."""
        with mpmath.workdps(DIGITS):
            kf, ks = self.wave_numbers(s)
            return complex(self.nu * kf * mpmath.coth(kf * self.fluid_height)
                           + mpmath.sqrt(self.rho_solid * self.mu) * mpmath.coth(ks * self.solid_height))

    def entire(self, s):
        """H(s) (mpmath number)."""
        kf, ks = self.wave_numbers(s)
        sinc = mpmath.sinh(kf * self.fluid_height) / kf if abs(kf) > 1e-20 else self.fluid_height
        return (self.nu * mpmath.cosh(kf * self.fluid_height) * mpmath.sinh(ks * self.solid_height)
                + mpmath.sqrt(self.rho_solid * self.mu) * mpmath.cosh(ks * self.solid_height) * sinc)

    def root(self, guess: complex) -> complex:
        """The root of H that Muller's iteration reaches from ``guess``."""
        with mpmath.workdps(DIGITS):
            return complex(mpmath.findroot(self.entire, mpmath.mpc(guess), solver="muller", tol=1e-25,
                                           maxsteps=200))

    def roots(self, box: tuple[float, float, float, float], starts: int = 12) -> list[complex]:
        """The roots of H but 0 in the box (Re min, Re max, Im min, Im max), from a ``starts`` × ``starts`` grid of
        starting points and 4 ``starts`` on the real axis (the overdamped modes), sorted by |s|."""
        low, high, bottom, top = box
        guesses = [complex(low + (high - low) * (i + 0.5) / starts, bottom + (top - bottom) * (j + 0.5) / starts)
                   for i in range(starts) for j in range(starts)]
        guesses += [complex(low + (high - low) * (i + 0.5) / (4 * starts), 0.0) for i in range(4 * starts)]
        found: list[complex] = []
        for guess in guesses:
            try:
                s = self.root(guess)
            except (ValueError, ZeroDivisionError):   # Muller's iteration did not converge from there
                continue
            inside = low <= s.real <= high and bottom <= s.imag <= top
            if inside and abs(s) > 1e-8 and all(abs(s - t) > 1e-8 * max(1.0, abs(s)) for t in found):
                found.append(s)
        return sorted(found, key=abs)

    def shape(self, s: complex, y: float) -> complex:
        """v_x(y) of the mode of ``s``, scaled to v_x(h_S) = 1."""
        with mpmath.workdps(DIGITS):
            kf, ks = self.wave_numbers(s)
            if y <= self.solid_height:
                return complex(mpmath.sinh(ks * y) / mpmath.sinh(ks * self.solid_height))
            top = self.solid_height + self.fluid_height
            return complex(mpmath.sinh(kf * (top - y)) / mpmath.sinh(kf * self.fluid_height))

    def driven(self, s: complex, y: float, wall_velocity: complex = 1.0) -> complex:
        """v_x(y) of the harmonic response at ``s`` = iω to the top wall moving with v = (U, 0) e^{st}:
        v_S = C sinh(k_S y), v_F = A sinh(k_F (y − h_S)) + C sinh(k_S h_S) cosh(k_F (y − h_S)), the shear traction
        ν A k_F = √(ρ_S μ) C cosh(k_S h_S) at Γ and v_F = U at the top: C = U ν / H(s)."""
        with mpmath.workdps(DIGITS):
            kf, ks = self.wave_numbers(s)
            c = wall_velocity * self.nu / self.entire(s)
            if y <= self.solid_height:
                return complex(c * mpmath.sinh(ks * y))
            a = mpmath.sqrt(self.rho_solid * self.mu) * c * mpmath.cosh(ks * self.solid_height) / (self.nu * kf)
            depth = y - self.solid_height
            return complex(a * mpmath.sinh(kf * depth)
                           + c * mpmath.sinh(ks * self.solid_height) * mpmath.cosh(kf * depth))

    def driven_coefficient(self, s: complex, wall_velocity: complex = 1.0):
        """`driven` as an NGSolve CoefficientFunction (v_x(y), 0) (complex; sinh and cosh by ``exp``), exact to
        round-off where it is evaluated."""
        import ngsolve as ngs

        kf, ks = (complex(k) for k in self.wave_numbers(s))
        with mpmath.workdps(DIGITS):
            c = complex(wall_velocity * self.nu / self.entire(s))
        a = math.sqrt(self.rho_solid * self.mu) * c * np.cosh(ks * self.solid_height) / (self.nu * kf)
        sinh = lambda z: (ngs.exp(z) - ngs.exp(-z)) / 2   # noqa: E731
        cosh = lambda z: (ngs.exp(z) + ngs.exp(-z)) / 2   # noqa: E731
        depth = ngs.y - self.solid_height
        fluid = a * sinh(kf * depth) + c * np.sinh(ks * self.solid_height) * cosh(kf * depth)
        return ngs.CF((ngs.IfPos(depth, fluid, c * sinh(ks * ngs.y)), 0))


def compressional(lam: float, mu: float, rho_solid: float, solid_height: float, n: int = 1) -> complex:
    """The undamped compressional mode n of the solid layer: s = i nπ √((λ + 2μ)/ρ_S) / h_S."""
    return 1j * n * math.pi * math.sqrt((lam + 2 * mu) / rho_solid) / solid_height
