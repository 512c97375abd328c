"""Womersley's fully developed oscillatory flow: the velocity profile of a flow rate Q(t) in a planar channel (2D) or
a circular pipe (3D) of radius R, from ρ ∂t u = −∂x p + ν Δu (ν the dynamic viscosity of σ_F = −pI + 2ν ε(v)).

For the harmonic e^{iωt}, κ = √(iωρ/ν) (the Womersley number α = R √(ωρ/ν), κR = i^{1/2} α), the profile of unit
flux (2D: ∫_{−R}^{R} W = 1; 3D: ∫_disk W = 1) is

    2D  W_ω(r) = [1 − cosh(κr)/cosh(κR)] / [2R − 2 tanh(κR)/κ]
    3D  W_ω(r) = [1 − I₀(κr)/I₀(κR)] / [πR² − 2πR I₁(κR)/(κ I₀(κR))]      (I₀(κr) = J₀(i^{3/2} α r/R))

and ω = 0 is the Poiseuille parabola. A periodic Q(t) ≈ Q_N(t) = Re Σ_{k=0}^{N} Q̂_k e^{iω_k t}, ω_k = 2πk/period
(`fourier`), has the velocity u(r, t) = Re Σ_k Q̂_k e^{iω_k t} W_{ω_k}(r) (`profile`).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import special

#: Samples of Q over a period for its Fourier coefficients (at least 8 per harmonic kept).
FOURIER_SAMPLES = 512


def womersley_shape(r: np.ndarray, radius: float, omega: float, rho: float, nu: float, dim: int) -> np.ndarray:
    """W_ω(r) of unit flux (complex; the module's docstring); ω = 0: the parabola."""
    r = np.asarray(r, dtype=float)
    if omega == 0:
        scale = 3 / (4 * radius) if dim == 2 else 2 / (np.pi * radius**2)
        return (scale * (1 - (r / radius) ** 2)).astype(complex)
    kappa = np.sqrt(1j * omega * rho / nu)
    big = kappa * radius
    if dim == 2:  # cosh(κr)/cosh(κR) without overflow
        ratio = np.exp(kappa * (r - radius)) * (1 + np.exp(-2 * kappa * r)) / (1 + np.exp(-2 * big))
        return (1 - ratio) / (2 * radius - 2 * np.tanh(big) / kappa)
    # I₀(κr)/I₀(κR) by the exponentially scaled ive(ν, z) = iv(ν, z) e^{−|Re z|}
    ratio = special.ive(0, kappa * r) / special.ive(0, big) * np.exp((kappa * r).real - big.real)
    return (1 - ratio) / (np.pi * radius**2 - 2 * np.pi * radius * special.ive(1, big) / (kappa * special.ive(0, big)))


def fourier(flow: Callable[[float], float], period: float, harmonics: int) -> np.ndarray:
    """Q̂_0 … Q̂_N with Q_N(t) = Re Σ Q̂_k e^{iω_k t}: Q̂_0 the mean, Q̂_k = (2/M) Σ_j Q(t_j) e^{−iω_k t_j} over M
    samples of a period."""
    m = max(FOURIER_SAMPLES, 8 * (harmonics + 1))
    samples = np.array([flow(t) for t in np.arange(m) * period / m])
    coefficients = np.fft.rfft(samples)[: harmonics + 1] / m
    coefficients[1:] *= 2
    return coefficients


def frequencies(period: float, harmonics: int) -> np.ndarray:
    """ω_k = 2πk/period, k = 0 … N."""
    return 2 * np.pi * np.arange(harmonics + 1) / period


def profile(r: np.ndarray, t: float, coefficients: np.ndarray, period: float, radius: float, rho: float, nu: float,
            dim: int) -> np.ndarray:
    """The axial velocity u(r, t) = Re Σ_k Q̂_k e^{iω_k t} W_{ω_k}(r) of the series ``coefficients`` (`fourier`)."""
    omegas = frequencies(period, len(coefficients) - 1)
    return sum((a * np.exp(1j * w * t) * womersley_shape(r, radius, w, rho, nu, dim)).real
               for a, w in zip(coefficients, omegas))
