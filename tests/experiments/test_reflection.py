"""A Windkessel tuned to the tube's characteristic impedance absorbs the pressure wave: the wave reflected back to the
inlet is less than a fifth of the traction-free outlet's.

A 2D channel of plane strain carries no Moens–Korteweg wave (examples/pressure_wave_2d.toml), so the wall here is a
compliant layer clamped on its outer surface: a local spring, which makes the channel the 1D wave guide of the
long-wave theory with the compliance per length C' = 2w/(λ + 2μ), the wave speed c = √(A/(ρ_F C')) =
√(R(λ + 2μ)/(ρ_F w)) and the characteristic impedance Z = ρ_F c/A (A = 2R). A Gaussian pressure pulse enters by
traction; at the inlet the backward wave is P₋ = (P − Z Q)/2 (Westerhof's wave separation, P the inflow's mean
pressure and Q its inflow, `io.surfaces`), measured when the reflection returns, t₀ + 2L/c.
"""
import numpy as np
import pytest
from support.channels import at_rest, channel_scheme, history

from fsivsp.io.surfaces import Surfaces
from fsivsp.model.data import Windkessel
from fsivsp.model.materials import Materials

RADIUS, WALL, RHO, NU, MODULUS, POISSON = 0.5, 0.1, 1.0, 0.01, 1000.0, 0.3
P0, WIDTH = 1000.0, 0.02   # the pulse P0 exp(−((t − t0)/s)²), s = WIDTH, t0 = 3s: shorter waves than the wall's
T0 = 3 * WIDTH             # resonance (2π√(R w ρ_S/ρ_F) ≈ 1.4) and the channel's width
SPEED = np.sqrt(RADIUS * MODULUS / (RHO * WALL))
IMPEDANCE = RHO * SPEED / (2 * RADIUS)


def reflection(outlets: dict, length: float, maxh: float, dt: float, trace: bool = False):
    """max |P₋| at the inlet within ±3s of t₀ + 2L/c, and the incident P₊ = (P + Z Q)/2's peak; with ``trace``
    also the times and P₋ at every step (benchmarks/artery_figures.py)."""
    young = MODULUS * (1 + POISSON) * (1 - 2 * POISSON) / (1 - POISSON)
    data = at_rest(velocity={"solid_wall": [0, 0]}, traction={"inflow": [f"{P0}*exp(-((t - {T0})/{WIDTH})**2)", 0]},
                   outlets=outlets)
    run = channel_scheme(data, Materials.from_young(young, POISSON, rho_fluid=RHO, rho_solid=1.0, nu=NU), dt, "bdf2",
                         maxh=maxh, length=length, dirichlet="solid_wall", radius=RADIUS, wall=WALL)
    surfaces = Surfaces(run, ["inflow"])
    record = history(run, round((T0 + 2 * length / SPEED + 4 * WIDTH) / dt),
                     pressure=lambda s: surfaces.values()["inflow.pressure"],
                     inflow=lambda s: -surfaces.values()["inflow.flow"])
    back = (record["pressure"] - IMPEDANCE * record["inflow"]) / 2
    gate = np.abs(record["time"] - (T0 + 2 * length / SPEED)) < 3 * WIDTH
    measured = float(np.abs(back[gate]).max()), float(((record["pressure"] + IMPEDANCE * record["inflow"]) / 2).max())
    return (*measured, (record["time"], back)) if trace else measured


def tuned() -> dict:
    """The RCR outlet with R_p = Z (C = 0.05, R_d = 10 Z: the slow part)."""
    return {"outflow": Windkessel(IMPEDANCE, 0.05, 10 * IMPEDANCE)}


def test_tuned_windkessel_cuts_the_reflection():
    """L = 5, maxh 0.1, Δt 0.002: the traction-free outlet reflects 0.74 of the incident wave (inverted), the tuned
    Windkessel less than a fifth of that (measured 0.017 of it)."""
    free, incident = reflection({}, 5.0, 0.1, 0.002)
    absorbed, _ = reflection(tuned(), 5.0, 0.1, 0.002)
    assert free > 0.5 * incident
    assert absorbed < free / 5, (absorbed, free)


@pytest.mark.slow
def test_tuned_windkessel_cuts_the_reflection_fine():
    """The prototype's L = 10, maxh 0.05, Δt 5e-4 (measured: the tuned RCR 0.013 of the traction-free outlet's, a
    resistance Z 0.011, R_p = Z/4 or 4Z 0.59–0.61)."""
    free, _ = reflection({}, 10.0, 0.05, 5e-4)
    absorbed, _ = reflection(tuned(), 10.0, 0.05, 5e-4)
    mistuned, _ = reflection({"outflow": Windkessel(IMPEDANCE / 4, 0.05, 10 * IMPEDANCE)}, 10.0, 0.05, 5e-4)
    assert absorbed < free / 5 < mistuned
