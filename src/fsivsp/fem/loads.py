"""The data's part of a step's right-hand side (5.1): the loads ∫_Ω f·w, the tractions, Γ's load and the
Dirichlet values of the velocity with their lifts, each a `TimeVector` built once per run."""
from __future__ import annotations

from collections.abc import Callable

import ngsolve as ngs
import numpy as np
from ngsolve import InnerProduct, ds, dx

from ..geometry import FLUID, INTERFACE, SOLID, extent, interface_normal
from ..model.data import Data
from ..model.fields import TimeVector
from . import forms
from .spaces import Spaces


class Loads:
    """Σ w_j f(t_j) and the Dirichlet values g(t) with their lifts A g(t) under the step matrix A
    (``matrix``; None: no lifts, `add_to` only with ``lift=False``); ``dirichlet`` are the g(t) (each dof owned by
    the first boundary naming it)."""

    def __init__(self, spaces: Spaces, data: Data, matrix: ngs.BaseMatrix | None):
        self.spaces, self.data, self._matrix = spaces, data, matrix
        self._loads = self._load_vectors()
        self.dirichlet, self._lifts = self._dirichlet_vectors()

    def add_to(self, rhs: ngs.BaseVector, boundary: ngs.BaseVector, loads: list[tuple[float, float]],
               time: float, lift: bool = True) -> None:
        """rhs += Σ w_j f(t_j) − A g(time) (the lift, if ``lift``); boundary = g(time), the Dirichlet values."""
        for when, weight in loads:
            for load in self._loads:
                load.add_to(rhs, when, weight)
        if lift:
            for values in self._lifts:
                values.add_to(rhs, time, -1.0)
        boundary[:] = 0.0
        for values in self.dirichlet:
            values.add_to(boundary, time)

    def _linear_form(self, integrand: Callable, measure) -> Callable:
        """image(cf) for `TimeVector`: the load ∫ integrand(cf, w) over ``measure``."""
        w, _ = self.spaces.mixed.TestFunction()

        def image(cf):
            form = ngs.LinearForm(self.spaces.mixed)
            form += integrand(cf, w) * measure
            return lambda: form.Assemble().vec

        return image

    def _load_vectors(self) -> list[TimeVector]:
        """∫_F f_F·w + ∫_S f_S·w + Σ ∫_{Γ_N} t·w + ∫_Γ (J n)·w, each a `TimeVector`."""
        d, mesh = self.data, self.spaces.mesh
        order = forms.DATA_BONUS
        dot = lambda cf, w: InnerProduct(cf, w)
        loads = []
        if d.force_fluid is not None:
            fluid = dx(FLUID, bonus_intorder=order + self.spaces.bonus_intorder)
            loads.append(TimeVector(d.force_fluid, self._linear_form(dot, fluid)))
        if d.force_solid is not None:
            loads.append(TimeVector(d.force_solid, self._linear_form(dot, dx(SOLID, bonus_intorder=order))))
        for name, traction in d.boundary_traction.items():
            loads.append(TimeVector(traction, self._linear_form(dot, ds(name, bonus_intorder=order))))
        if d.interface_load is not None and not d.interface_load.is_zero(tuple(zip(*extent(mesh)))):
            n = interface_normal(mesh)
            loads.append(TimeVector(d.interface_load,
                                    self._linear_form(lambda J, w: InnerProduct(J * n, w),
                                                      ds(INTERFACE, bonus_intorder=order))))
        return loads

    def _dirichlet_vectors(self) -> tuple[list[TimeVector], list[TimeVector]]:
        """Boundary values g(t) of the velocity (each dof owned by the first boundary naming it)
        and their images A g(t) under the step matrix, which lift them into the right-hand side."""
        mesh, V = self.spaces.mesh, self.spaces.velocity
        owned = ngs.BitArray(self.spaces.mixed.ndof)
        owned.Clear()
        vectors, lifts = [], []
        for names, values in self.data.boundary_velocity.items():
            region = mesh.Boundaries(names)
            mine = ngs.BitArray(self.spaces.mixed.ndof)
            mine.Clear()
            for el in mesh.Elements(ngs.BND):
                if region.Mask()[el.index]:
                    for dof in V.GetDofNrs(el):
                        if dof >= 0 and not owned[dof]:
                            mine.Set(dof)
            owned = owned | mine
            image = self._boundary_image(region, mine)
            vectors.append(TimeVector(values, image))
            if self._matrix is not None:
                lifts.append(TimeVector(values, lambda cf, image=image: self._lift(image(cf))))
        return vectors, lifts

    def _lift(self, boundary_values: Callable) -> Callable:
        lifted = self._matrix.CreateColVector()

        def compute():
            lifted.data = self._matrix * boundary_values()
            return lifted

        return compute

    def _boundary_image(self, region, mine: ngs.BitArray) -> Callable:
        def image(cf):
            gf = ngs.GridFunction(self.spaces.mixed)
            others = ~np.array([mine[i] for i in range(len(mine))], dtype=bool)

            def compute():
                gf.components[0].Set(cf, ngs.BND, definedon=region)
                gf.vec.FV().NumPy()[others] = 0.0
                return gf.vec

            return compute

        return image
