"""The data's part of a step's right-hand side (5.1): the loads ∫_Ω f·w, the tractions, Γ's load and the
Dirichlet values of the velocity (flow-rate inflows among them, `inflow`) with their lifts, each a `TimeVector` (or
like one) built once per run."""
from __future__ import annotations

from collections.abc import Callable

import ngsolve as ngs
import numpy as np
from ngsolve import InnerProduct, ds, dx

from ..geometry import FLUID, INTERFACE, SOLID, adjacent_regions, extent, interface_normal, pattern
from ..model.data import Data
from ..model.fields import TimeVector
from ..model.materials import FLUID_FIELDS, Materials
from . import forms
from .inflow import FlowInflow
from .spaces import Spaces


def fluid_next_to(spaces: Spaces, materials: Materials, boundary: str) -> Materials:
    """The materials of the fluid next to ``boundary``; a ValueError if it touches no fluid, or fluids that differ."""
    fluids = {tuple(getattr(materials.of(r), k) for k in FLUID_FIELDS): r
              for r in adjacent_regions(spaces.mesh, boundary) if r in spaces.phases.fluid}
    if len(fluids) != 1:
        raise ValueError(f"boundary.{boundary}: a flow-rate inflow must border one fluid, found "
                         f"{', '.join(sorted(fluids.values())) or 'none'}")
    return materials.of(next(iter(fluids.values())))


def region_facets(spaces: Spaces) -> dict[str, ngs.GridFunction]:
    """Per cell region r, the indicator χ_r (order-0 facet space) of the facets r shares with another cell region
    (Γ, and the facets between two regions of one medium). Under MPI the cells next to each facet are counted over
    the ranks."""
    mesh, phases = spaces.mesh, spaces.phases
    space = ngs.FacetFESpace(mesh, order=0)
    counts = {region: ngs.GridFunction(space) for region in phases.regions}
    total = ngs.GridFunction(space)
    values = {region: gf.vec.FV().NumPy() for region, gf in counts.items()}
    for array in (*values.values(), total.vec.FV().NumPy()):
        array[:] = 0.0
    for el in mesh.Elements(ngs.VOL):
        dofs = list(space.GetDofNrs(el))
        values[el.mat][dofs] += 1.0
        total.vec.FV().NumPy()[dofs] += 1.0
    for gf in (*counts.values(), total):
        if mesh.comm.size > 1:
            gf.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
            gf.vec.Cumulate()
    everywhere = total.vec.FV().NumPy()
    for gf in counts.values():
        mine = gf.vec.FV().NumPy()
        mine[:] = (mine > 0) & (everywhere - mine > 0)
    return counts


class Loads:
    """Σ w_j f(t_j) and the Dirichlet values g(t) with their lifts A g(t) under the step matrix A
    (``matrix``; None: no lifts, `add_to` only with ``lift=False``, and no flow-rate inflow); ``dirichlet`` are the
    g(t) (each dof owned by the first boundary naming it; a flow-rate inflow's (`inflows`, each a `FlowInflow`, its
    profile with the ``materials`` of the fluid next to it) by no other)."""

    def __init__(self, spaces: Spaces, data: Data, matrix: ngs.BaseMatrix | None, materials: Materials = Materials()):
        self.spaces, self.data, self._matrix = spaces, data, matrix
        self._loads = self._load_vectors()
        self.dirichlet, self._lifts = self._dirichlet_vectors()
        self.inflows = {}
        for name, rate in data.boundary_flow.items():
            fluid = fluid_next_to(spaces, materials, name)
            self.inflows[name] = FlowInflow(spaces, name, rate, matrix, fluid.rho_fluid, fluid.nu)
        for inflow in self.inflows.values():
            self.dirichlet.append(inflow.values)
            self._lifts.append(inflow.lift)

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
        w, _ = forms.test_functions(self.spaces)

        def image(cf):
            form = ngs.LinearForm(self.spaces.mixed)
            form += integrand(cf, w) * measure
            return lambda: form.Assemble().vec

        return image

    def _load_vectors(self) -> list[TimeVector]:
        """∫_F f_F·w + ∫_S f_S·w + Σ ∫_{Γ_N} t·w + ∫_Γ (J n)·w, the region-wise Σ_r ∫_{Ω_r} f_r·w +
        Σ_r ∫_{∂Ω_r ∩ internal} J_r n_r·w, each a `TimeVector`."""
        d, mesh = self.data, self.spaces.mesh
        order = forms.DATA_BONUS
        dot = lambda cf, w: InnerProduct(cf, w)
        loads = []
        phases = self.spaces.phases
        fluid_order = order + self.spaces.bonus_intorder
        if d.force_fluid is not None:
            fluid = dx(phases.pattern(FLUID), bonus_intorder=fluid_order)
            loads.append(TimeVector(d.force_fluid, self._linear_form(dot, fluid)))
        if d.force_solid is not None:
            solid = dx(phases.pattern(SOLID), bonus_intorder=order + self.spaces.solid_bonus_intorder)
            loads.append(TimeVector(d.force_solid, self._linear_form(dot, solid)))
        bonus = {region: fluid_order if region in phases.fluid else order + self.spaces.solid_bonus_intorder
                 for region in phases.regions}
        for region, force in d.region_forces.items():
            loads.append(TimeVector(force, self._linear_form(dot, dx(pattern([region]), bonus_intorder=bonus[region]))))
        facets = region_facets(self.spaces) if d.region_tractions else {}
        for region, tensor in d.region_tractions.items():
            n, chi = ngs.specialcf.normal(mesh.dim), facets[region]
            measure = dx(pattern([region]), element_boundary=True, bonus_intorder=bonus[region])
            loads.append(TimeVector(tensor, self._linear_form(lambda J, w, n=n, chi=chi: chi * InnerProduct(J * n, w),
                                                              measure)))
        for name, traction in d.boundary_traction.items():
            loads.append(TimeVector(traction, self._linear_form(dot, ds(name, bonus_intorder=order))))
        if d.interface_load is not None and not d.interface_load.is_zero(tuple(zip(*extent(mesh)))):
            n = interface_normal(mesh, phases)
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
