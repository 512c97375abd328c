"""Lumped outlets in the time schemes: the resistance and the three-element Windkessel (`model.data.Windkessel`)
coupled implicitly, with one step matrix per run.

On the outlet σ_F n = −P n, so the momentum equation gains ∫_Γ P n·w = P cᵀw (c_i = ∫_Γ φ_i·n, Q = cᵀv). P acts
on the velocity as the viscous term does, and the time scheme applies it with the viscous term's weights: τPⁿ on
the left, (1 − θ)Δt Pⁿ⁻¹ on the right for the θ-scheme, τ = 2Δt/3 and nothing lagged for BDF2. The RCR ODE
C dP_c/dt = Q − (P_c − P_d)/R_d is discretised by the same scheme at its order:

    θ:    C (P_cⁿ − P_cⁿ⁻¹)/Δt = θ[Qⁿ − (P_cⁿ − P_dⁿ)/R_d] + (1 − θ)[Qⁿ⁻¹ − (P_cⁿ⁻¹ − P_dⁿ⁻¹)/R_d]
    BDF2: C (3P_cⁿ − 4P_cⁿ⁻¹ + P_cⁿ⁻²)/(2Δt) = Qⁿ − (P_cⁿ − P_dⁿ)/R_d    (its first step: Crank–Nicolson)

and its solution is affine in Qⁿ, P_cⁿ = τR_d/(R_dC + τ) Qⁿ + hⁿ, Pⁿ = R_eff(τ) Qⁿ + hⁿ with

    R_eff(τ) = R_p + τR_d/(R_dC + τ),
    θ:    hⁿ = [(R_dC − (1 − θ)Δt) P_cⁿ⁻¹ + (1 − θ)Δt R_d Qⁿ⁻¹ + Δt(θP_dⁿ + (1 − θ)P_dⁿ⁻¹)] / (R_dC + τ),
    BDF2: hⁿ = [R_dC (4P_cⁿ⁻¹ − P_cⁿ⁻²)/3 + τP_dⁿ] / (R_dC + τ).

So step n adds γ c cᵀ, γ = τ R_eff(τ), to the step matrix (constant per run: `solvers.woodbury`) and −(τhⁿ + c_lag
Pⁿ⁻¹) c to the right-hand side, c_lag = (1 − θ)Δt (0 for BDF2: the K_F weight of `schemes`); after the solve
P_cⁿ = (R_eff − R_p) Qⁿ + hⁿ. C = 0 is the algebraic P_c = P_d + R_d Q (R_eff = R_p + R_d, hⁿ = P_dⁿ): as an ODE
at θ = 1/2 it would keep a (−1)ⁿ mode of an inconsistent P_c⁰.
"""
from __future__ import annotations

import numpy as np

from ..model.data import Windkessel

#: An outlet's state in `Outlet.state`: P_cⁿ, P_cⁿ⁻¹, Qⁿ.
STATE = ("pc", "pc_old", "flow")


class Outlet:
    """One lumped outlet of a run (the module's docstring). ``state`` (a view of 3 floats, `STATE`) is what a
    checkpoint keeps; the history part hⁿ of a step whose right-hand side is formed waits in ``_pending`` until the
    step is accepted."""

    def __init__(self, name: str, model: Windkessel, state: np.ndarray):
        self.name, self.model, self.state = name, model, state
        self.distal_pressure = model.pressure_function()
        self._pending: dict[int, tuple[float, float]] = {}

    def start(self, flow: float) -> None:
        """The state at t = 0 from Q⁰ = ``flow``: P_c⁰ = P_d(0) (+ R_d Q⁰ without capacitance)."""
        m = self.model
        pc = self.distal_pressure(0.0) + (m.distal * flow if m.capacitance == 0 else 0.0)
        self.state[:] = (pc, pc, flow)

    def effective_resistance(self, tau: float) -> float:
        """R_eff(τ) = R_p + τR_d/(R_dC + τ)."""
        m = self.model
        return m.proximal + (m.distal if m.capacitance == 0 else tau * m.distal / (m.distal * m.capacitance + tau))

    def weight(self, current, dt: float) -> float:
        """γ = τ R_eff(τ), the outlet's term γ c cᵀ in the step matrix of ``current``."""
        tau = current.tau(dt)
        return tau * self.effective_resistance(tau)

    @property
    def pressure(self) -> float:
        """Pⁿ = P_cⁿ + R_p Qⁿ at the last accepted step."""
        return float(self.state[0] + self.model.proximal * self.state[2])

    def load(self, current, n: int, dt: float, solved: float | None = None) -> float:
        """s with step n's right-hand side −= s c: τhⁿ + c_lag Pⁿ⁻¹, from the accepted state, or with ``solved`` the
        flow Qⁿ⁻¹ of step n − 1, solved but not accepted yet (the overlapping time loop)."""
        pc, older, flow = self.state if solved is None else self._accepted(n - 1, solved)
        m, tau, t, pd = self.model, current.tau(dt), n * dt, self.distal_pressure
        rc = m.distal * m.capacitance
        lag = current.lagged(dt)[1]
        if m.capacitance == 0:
            h = pd(t)
        elif current.name == "bdf2":
            h = (rc * (4 * pc - older) / 3 + tau * pd(t)) / (rc + tau)
        else:
            theta = current.theta
            h = ((rc - lag) * pc + lag * m.distal * flow + dt * (theta * pd(t) + (1 - theta) * pd(t - dt))) / (rc + tau)
        self._pending[n] = (h, self.effective_resistance(tau))
        return float(tau * h + lag * (pc + m.proximal * flow))  # a Python float: numpy's would scale an NGSolve vector
                                                                 # through the buffer protocol (a crash under MPI)

    def _accepted(self, n: int, flow: float) -> tuple[float, float, float]:
        """(P_cⁿ, P_cⁿ⁻¹, Qⁿ) once step n is solved with Qⁿ = ``flow``."""
        h, resistance = self._pending[n]
        return (resistance - self.model.proximal) * flow + h, float(self.state[0]), flow

    def accept(self, n: int, flow: float) -> None:
        """Step n solved with Qⁿ = ``flow``: P_cⁿ = (R_eff − R_p) Qⁿ + hⁿ, the history shifted."""
        self.state[:] = self._accepted(n, flow)
        del self._pending[n]
