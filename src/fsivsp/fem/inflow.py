"""Flow-rate inflows: the velocity on a boundary Γ_in is Q(t) times a profile normal to Γ_in (`model.data.FlowRate`),
scaled so that the DISCRETE inflow −∫_Γin v_h·n = −cᵀv_h (n outward, c_i = ∫_Γin φ_i·n) is Q(t) to round-off.

The profiles are functions of the distance r from the section's axis (`geometry.sections`), each of unit flux:
``plug`` 1/|Γ_in|, ``parabolic`` the Poiseuille profile, ``womersley`` the oscillatory profile of each harmonic of Q
(`model.womersley`): v = Re Σ_k Q̂_k e^{iω_k t} W_{ω_k} + (Q(t) − Q_N(t)) W_0, where the remainder of the truncated
series rides on the parabola W_0, so that the flux is Q itself, not only Q_N.

Each shape W (real and imaginary parts) is interpolated into V_h on Γ_in, zero on the dofs another Dirichlet
boundary holds (a clamped wall at the rim: a plug gives up its rim value there), and divided by its discrete flux
Φ = −cᵀW_h (a complex division for the harmonics). Then −cᵀv_h(t) = Q(t) on any mesh. The values
g(t) = Σ_j T_j(t) G_j are time-separable: the G_j and their lifts A G_j are formed once (`Separated`).
"""
from __future__ import annotations

import logging
from collections.abc import Callable

import ngsolve as ngs
import numpy as np
from ngsolve import InnerProduct

from ..geometry.sections import Section, detect_section
from ..model.data import FlowRate
from ..model.womersley import fourier, frequencies, womersley_shape
from . import forms
from .spaces import Spaces

log = logging.getLogger(__name__)

#: Samples of a radial profile tabulated for NGSolve (piecewise linear in r: ~1e-8 of the peak at α = 10; the flux
#: is exact whatever the table, by the discrete scaling).
TABLE_POINTS = 4001
#: The truncated Fourier series may miss Q by this fraction of max |Q| before the run says so.
SERIES_NOTE = 0.01


class Separated:
    """Σ_j T_j(t) V_j for vectors V_j and time factors T_j (given together as ``terms(t)``); ``add_to`` as a
    `fields.TimeVector`."""

    def __init__(self, vectors: list[ngs.BaseVector], factors: Callable[[float], list[float]]):
        self.vectors, self.factors = vectors, factors

    def add_to(self, out: ngs.BaseVector, time: float, scale: float = 1.0) -> None:
        """out += scale · Σ_j T_j(time) V_j."""
        for factor, vector in zip(self.factors(time), self.vectors):
            out.data += (scale * factor) * vector


def flux_vector(spaces: Spaces, name: str, sign: float = 1.0) -> ngs.BaseVector:
    """c = ``sign`` ∫_Γ φ·n over boundary ``name`` on X_h (n the outward normal): cᵀx is the flow ``sign`` ∫_Γ v·n
    of x (summed over the ranks under MPI)."""
    w, _ = forms.test_functions(spaces)
    form = ngs.LinearForm(spaces.mixed)
    form += sign * InnerProduct(w, ngs.specialcf.normal(spaces.mesh.dim)) * ngs.ds(name)
    return form.Assemble().vec


class FlowInflow:
    """The Dirichlet values of a flow-rate inflow on boundary ``name`` (the module's docstring) and their lifts
    under ``matrix``: ``values`` and ``lift`` (`Separated`); ``inward`` is −c, so that ``inward``ᵀx is the inflow.
    ``rho``, ``nu``: the fluid's (Womersley)."""

    def __init__(self, spaces: Spaces, name: str, rate: FlowRate, matrix: ngs.BaseMatrix, rho: float, nu: float):
        self.spaces, self.name, self.rate = spaces, name, rate
        self.flow = rate.function()
        self.section: Section = detect_section(spaces.mesh, name)
        self.inward = flux_vector(spaces, name, -1.0)
        self._owned = self._owned_dofs()
        self.coefficients, self.omegas = np.ones(1, dtype=complex), np.zeros(1)
        if rate.profile == "womersley":
            self.coefficients = fourier(self.flow, rate.period, rate.harmonics)
            self.omegas = frequencies(rate.period, rate.harmonics)
            self._note_truncation()
        shapes = [self._discrete_shape(omega, rho, nu) for omega in self.omegas]
        # vectors: Re W_0, then Re W_k, Im W_k for k ≥ 1 (W_0 is real)
        self._vectors = [shapes[0][0]] + [part for shape in shapes[1:] for part in shape]
        self.values = Separated(self._vectors, self.factors)
        self.lift = Separated([self._image(matrix, v) for v in self._vectors], self.factors)

    def factors(self, time: float) -> list[float]:
        """The T_j(time) of g = Σ T_j G_j: Q(t) − Σ_{k≥1} Re a_k on W_0 (the series' mean and the remainder
        Q − Q_N), then Re a_k and −Im a_k on Re W_k and Im W_k, a_k = Q̂_k e^{iω_k t}."""
        phases = self.coefficients[1:] * np.exp(1j * self.omegas[1:] * time)
        out = [self.flow(time) - float(phases.real.sum())]
        for a in phases:
            out += [float(a.real), float(-a.imag)]
        return out

    # -- set-up ----------------------------------------------------------------------------------------
    def _owned_dofs(self) -> np.ndarray:
        """The inflow's velocity dofs that no other Dirichlet boundary of the spaces holds, as a mask of X_h's."""
        mesh, V = self.spaces.mesh, self.spaces.velocity
        others = {name for name in self.spaces.dirichlet.split("|") if name and name != self.name}
        mine, theirs = (np.zeros(self.spaces.mixed.ndof, dtype=bool) for _ in range(2))
        for el in mesh.Elements(ngs.BND):
            if el.mat == self.name or el.mat in others:
                (mine if el.mat == self.name else theirs)[[d for d in V.GetDofNrs(el) if d >= 0]] = True
        return mine & ~theirs

    def _note_truncation(self) -> None:
        times = np.linspace(0.0, self.rate.period, 257)
        series = [(self.coefficients * np.exp(1j * self.omegas * t)).real.sum() for t in times]
        missed = max(abs(s - self.flow(t)) for s, t in zip(series, times))
        peak = max(abs(self.flow(t)) for t in times) or 1.0
        if missed > SERIES_NOTE * peak:
            log.warning("boundary.%s: %d harmonics of the flow miss it by up to %.3g (%.1f %% of its peak); the "
                        "rest rides on the parabolic profile (the flux stays exact; more harmonics: the key "
                        "harmonics)", self.name, self.rate.harmonics, missed, 100 * missed / peak)

    def _interpolate(self, radii: np.ndarray, table: np.ndarray) -> ngs.BaseVector:
        """The velocity −n W(r) on the inflow's owned dofs, W a real table over ``radii``."""
        section = self.section
        spline = ngs.BSpline(2, [0.0, *radii, radii[-1]], list(table))
        r = section.radial()
        direction = ngs.CF(tuple(-float(c) for c in section.normal[: self.spaces.mesh.dim]))
        gf = ngs.GridFunction(self.spaces.mixed)
        gf.vec[:] = 0.0
        gf.components[0].Set(spline(ngs.IfPos(r - section.radius, section.radius, r)) * direction, ngs.BND,
                             definedon=self.spaces.mesh.Boundaries(self.name))
        gf.vec.FV().NumPy()[~self._owned] = 0.0
        vector = gf.vec.CreateVector()
        vector.data = gf.vec
        return vector

    def _discrete_shape(self, omega: float, rho: float, nu: float) -> tuple[ngs.BaseVector, ngs.BaseVector]:
        """The real and imaginary parts of harmonic ω's discrete shape, scaled to unit discrete flux."""
        radius, dim = self.section.radius, self.spaces.mesh.dim
        radii = np.linspace(0.0, radius, TABLE_POINTS)
        table = np.ones(TABLE_POINTS, dtype=complex) if self.rate.profile == "plug" else \
            womersley_shape(radii, radius, omega, rho, nu, dim)
        real, imaginary = self._interpolate(radii, table.real), self._interpolate(radii, table.imag)
        flux = complex(InnerProduct(self.inward, real), InnerProduct(self.inward, imaginary))
        if abs(flux) == 0:
            raise ValueError(f"boundary.{self.name}: the {self.rate.profile} profile has no discrete flux (every "
                             "dof of the inflow is held by another boundary)")
        # (G_r + i G_i) / Φ = [(G_r Φ_r + G_i Φ_i) + i (G_i Φ_r − G_r Φ_i)] / |Φ|²
        norm = abs(flux) ** 2
        re, im = real.CreateVector(), real.CreateVector()
        re.data = (flux.real / norm) * real + (flux.imag / norm) * imaginary
        im.data = (flux.real / norm) * imaginary - (flux.imag / norm) * real
        return re, im

    @staticmethod
    def _image(matrix: ngs.BaseMatrix, vector: ngs.BaseVector) -> ngs.BaseVector:
        image = matrix.CreateColVector()
        image.data = matrix * vector
        return image
