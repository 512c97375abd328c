"""What happens on a surface: per named boundary the flow ∫ v·n, the mean fluid pressure, the area and the force
∫ σn every step (`Surfaces`, surfaces.csv and surfaces.png), and the interface's traction and wall shear stress as
fields on the boundary mesh (`Surfaces.interface_fields`, vtk/interface.pvd).

Which side. A volume field's gradient on a boundary integral is NGSolve's surface gradient (∂v/∂n is lost), and on
an interior facet such as Γ the trace of one of its two cells, not chosen by medium. So every quantity here is an
integral over the cells of one medium, ``dx(medium, element_boundary=True)`` — each cell's own trace and outward
normal — times the indicator χ of the boundary's facets: ∫_Γ f = Σ_{T ⊂ medium} ∫_{∂T} χ f. The medium is the
fluid on fluid boundaries and on Γ (n out of the fluid: the paper's n), the solid on solid boundaries; σ is σ_F =
−pI + 2νε(v) there, σ_h (`Scheme.stress`) on solid boundaries, and the force is the one the outside exerts on that
medium. Each quantity is linear in the state, so it is a vector assembled once and an inner product a step. On Γ the
traction t = σ_F n and the wall shear stress τ = t − (t·n)n are L²-projected facet by facet into the facet space of
the velocity's degree less one (exact for the trace). Under MPI each rank assembles on its cells and the inner
products add the ranks' parts.
"""
from __future__ import annotations

import csv
from pathlib import Path

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
from ngsolve import InnerProduct

from ..fem.forms import elastic_stress, eps, solid_stress, test_functions
from ..geometry import FLUID, INTERFACE, SOLID, adjacent_regions
from ..runtime import parallel
from . import atomic
from .checkpoint import CheckpointError

#: The quantities per boundary, as the CSV's column suffixes (forces by axis).
QUANTITIES = ("flow", "pressure", "area")


def indicator(mesh: ngs.Mesh, name: str) -> ngs.GridFunction:
    """χ: 1 on the facets of boundary ``name``, 0 elsewhere (order-0 facet space; on every rank that has the facet
    under MPI)."""
    space = ngs.FacetFESpace(mesh, order=0)
    chi = ngs.GridFunction(space)
    values = chi.vec.FV().NumPy()  # not chi.vec[dof] = …: on a parallel vector that waits for the other ranks
    values[:] = 0.0
    mask = mesh.Boundaries(name).Mask()
    for el in mesh.Elements(ngs.BND):
        if mask[el.index]:
            values[list(space.GetDofNrs(el))] = 1.0
    if mesh.comm.size > 1:
        chi.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
        chi.vec.Cumulate()
        values = chi.vec.FV().NumPy()
        values[:] = np.minimum(values, 1.0)
    return chi


class Surfaces:
    """Surface quantities of the ``names`` boundaries of a `Scheme` at its current step (the module's docstring):
    `values` → {"NAME.flow", "NAME.pressure", "NAME.area", "NAME.force_x", ...}; `interface_fields` → the traction and
    the wall shear stress on Γ."""

    def __init__(self, scheme, names):
        self.scheme, self.names = scheme, list(names)
        spaces = scheme.spaces
        self.mesh, self.phases, self.dim = spaces.mesh, spaces.phases, spaces.mesh.dim
        self.chi = {name: indicator(self.mesh, name) for name in self.names}
        self.band = {name: self._band(name) for name in self.names}
        self.medium = {name: FLUID if name == INTERFACE or adjacent_regions(self.mesh, name) & set(self.phases.fluid)
                       else SOLID for name in self.names}
        self.areas = {name: self._integral(ngs.CF(1.0), name) for name in self.names}
        self._rows = self._functionals()
        self._projection = None

    def columns(self) -> list[str]:
        """The CSV's columns after time: NAME.flow, NAME.pressure, NAME.area, NAME.force_x, … per boundary."""
        axes = "xyz"[: self.dim]
        return [f"{name}.{q}" for name in self.names for q in (*QUANTITIES, *(f"force_{a}" for a in axes))]

    def _band(self, name: str) -> ngs.BitArray:
        """The cells with a facet on boundary ``name``: the only ones χ reaches, so that the functionals are assembled
        on them alone (the 3D artery at 155 948 unknowns: 15 functionals over every cell took 9.3 s)."""
        cells = ngs.Integrate(self.chi[name] * ngs.dx(element_boundary=True), self.mesh, element_wise=True)
        return ngs.BitArray((cells.NumPy() > 0).tolist())

    def _measure(self, name: str):
        medium = self.medium[name]
        return ngs.dx(self.phases.pattern(medium), element_boundary=True, definedonelements=self.band[name],
                      bonus_intorder=self.scheme.spaces.bonus_intorder if medium == FLUID else 0)

    def _integral(self, cf, name: str) -> float:
        """∫ χ cf over the cells' boundaries, added cell by cell in their order, over the ranks under MPI (NGSolve's
        Integrate of a form does not add them)."""
        cells = ngs.Integrate(cf * self.chi[name] * self._measure(name), self.mesh, element_wise=True)
        local = float(np.sum(cells.NumPy()))
        return self.mesh.comm.Sum(local) if self.mesh.comm.size > 1 else local

    def _functionals(self) -> dict[str, tuple[ngs.BaseVector, str, float, float]]:
        """Every quantity but the area is linear in the state (v, p), or on a solid boundary the force in the
        displacement u_h (σ_h = σ*_h + Cε(u_h)): column → (l, "state" or "carried", scale, constant) with the
        quantity scale·lᵀx + constant, l = ∫ χ q(w) for the test functions w, assembled once."""
        scheme = self.scheme
        (w, test_pressure), n = test_functions(scheme.spaces), ngs.specialcf.normal(self.dim)

        def functional(name, integrand):
            form = ngs.LinearForm(scheme.spaces.mixed)
            form += self.chi[name] * integrand * self._measure(name)
            return form.Assemble().vec

        rows = {}
        for name in self.names:
            fluid = self.medium[name] == FLUID
            rows[f"{name}.flow"] = (functional(name, InnerProduct(w, n)), "state", 1.0, 0.0)
            if fluid:
                rows[f"{name}.pressure"] = (functional(name, test_pressure), "state", 1 / self.areas[name], 0.0)
                traction = -test_pressure * n + 2 * scheme.coefficients.nu * eps(w) * n
            elif scheme.spaces.solid_pressure is not None:   # σ_h = σ*_h + 2μ ε(u_h) − (ŝ/ϑ) I
                r = scheme.spaces.mixed.TestFunction()[2]
                traction = solid_stress(w, r / scheme.pressure_unit, scheme.coefficients, self.dim) * n
            else:
                traction = elastic_stress(w, scheme.coefficients, self.dim) * n
            for i, axis in enumerate("xyz"[: self.dim]):
                offset = 0.0 if fluid or scheme.stress_offset is None else \
                    self._integral((scheme.stress_offset * n)[i], name)
                rows[f"{name}.force_{axis}"] = (functional(name, traction[i]), "state" if fluid else "carried", 1.0,
                                                offset)
        return rows

    def fluid_stress(self) -> ngs.CoefficientFunction:
        """σ_F = −pI + 2ν ε(v) of the scheme's state."""
        s = self.scheme
        return -s.pressure * ngs.Id(self.dim) + 2 * s.coefficients.nu * eps(s.velocity)

    def values(self) -> dict[str, float]:
        """The quantities of every boundary at the scheme's step; the mean pressure NaN on a solid boundary."""
        vectors = {"state": self.scheme.state.vec, "carried": self.scheme.carried.vec}
        out = {}
        for name in self.names:
            out[f"{name}.pressure"], out[f"{name}.area"] = float("nan"), self.areas[name]
        for column, (functional, source, scale, constant) in self._rows.items():
            out[column] = scale * InnerProduct(functional, vectors[source]) + constant
        return {column: out[column] for column in self.columns()}

    def interface_fields(self) -> tuple[ngs.CoefficientFunction, ngs.CoefficientFunction]:
        """The traction t = σ_F n and the wall shear stress τ = t − (t·n)n on Γ (n out of the fluid), each
        component the facet-wise L² projection of its trace from the fluid cells."""
        if self._projection is None:
            self._projection = _FacetProjection(self.mesh, self.scheme.spaces.velocity_order - 1, self.chi[INTERFACE],
                                                self._measure(INTERFACE))
            self._fields = [[ngs.GridFunction(self._projection.space) for _ in range(self.dim)] for _ in range(2)]
        n = ngs.specialcf.normal(self.dim)
        t = self.fluid_stress() * n
        return tuple(self._projection(cf, fields) for cf, fields in zip((t, t - InnerProduct(t, n) * n), self._fields))


class _FacetProjection:
    """A vector CF ↦ its L² projection on the facets χ marks, component by component and facet by facet (the mass is
    block diagonal by facet: its blocks inverted once)."""

    def __init__(self, mesh: ngs.Mesh, order: int, chi: ngs.GridFunction, measure):
        self.space = ngs.FacetFESpace(mesh, order=max(order, 0))
        self.chi, self.measure = chi, measure
        u, q = self.space.TnT()
        mass = ngs.BilinearForm(self.space)
        mass += chi * u * q * measure
        mass.Assemble()
        matrix = mass.mat.local_mat if mesh.comm.size > 1 else mass.mat
        rows, cols, values = matrix.COO()
        local = sp.csr_matrix((np.asarray(values), (np.asarray(rows), np.asarray(cols))), shape=(matrix.height,) * 2)
        diagonal = local.diagonal()
        blocks = []
        for facet in mesh.facets:
            dofs = [d for d in self.space.GetDofNrs(facet) if d >= 0]
            if dofs and np.any(diagonal[dofs] > 0):
                blocks.append((dofs, np.linalg.inv(local[dofs][:, dofs].toarray())))
        entries = [(np.repeat(d, len(d)), np.tile(d, len(d)), b.ravel()) for d, b in blocks] or [([], [], [])]
        rows, cols, values = (np.concatenate(part) for part in zip(*entries))
        self.inverse = sp.csr_matrix((values, (rows, cols)), shape=(self.space.ndof,) * 2)
        self.distributed = mesh.comm.size > 1

    def __call__(self, cf: ngs.CoefficientFunction, fields: list[ngs.GridFunction]) -> ngs.CoefficientFunction:
        """The projection of ``cf`` into ``fields`` (GridFunctions of `space`, one per component), as a CF."""
        q = self.space.TestFunction()
        for i, field in enumerate(fields):
            rhs = ngs.LinearForm(self.space)
            rhs += self.chi * cf[i] * q * self.measure
            rhs.Assemble()
            field.vec.FV().NumPy()[:] = self.inverse @ rhs.vec.FV().NumPy()
            if self.distributed:  # each facet's value from the rank of its fluid cell, summed
                field.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
                field.vec.Cumulate()
        return ngs.CF(tuple(fields))


class SurfaceTable:
    """surfaces.csv: the time and `Surfaces.values` of every step (rows kept for a checkpoint, `state`/`restore`)."""

    def __init__(self, surfaces: Surfaces):
        self.surfaces, self.columns = surfaces, surfaces.columns()
        self.rows: list[list[float]] = []

    def record(self, time: float) -> None:
        values = self.surfaces.values()
        self.rows.append([time, *(values[c] for c in self.columns)])

    def state(self) -> dict:
        """The columns and the rows so far (a checkpoint's JSON)."""
        return {"columns": self.columns, "rows": self.rows}

    def restore(self, state: dict) -> None:
        """Continue the rows of a checkpoint's `state`; one of other surfaces is refused (`CheckpointError`)."""
        if state.get("columns") != self.columns:
            raise CheckpointError(f"checkpoint: its surface quantities are of {state.get('columns')}, this run's "
                                  f"[output] surfaces give {self.columns}; resume with the same surfaces")
        self.rows = [list(map(float, row)) for row in state["rows"]]

    def write_csv(self, out: Path) -> None:
        """surfaces.csv (rank 0)."""
        if not parallel.is_root():
            return
        with atomic.replacing(out / "surfaces.csv") as tmp, open(tmp, "w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(["time", *self.columns])
            writer.writerows([[repr(v) for v in row] for row in self.rows])
