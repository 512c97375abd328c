"""The region names the scheme expects, the media of a mesh's cell regions (`Phases`), their checks and counts, the
interface normal, locked cells."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
from netgen.meshing import IdentificationType

from . import curved as quadratic

FLUID, SOLID = "fluid", "solid"
INTERFACE, FLUID_WALL, SOLID_WALL = "interface", "fluid_wall", "solid_wall"
INFLOW, OUTFLOW, SOLID_ENDS = "inflow", "outflow", "solid_ends"  # boundary parts of `elastic_tube`
#: The boundary of the sides that ``[geometry] periodic`` identifies (no condition: the periodic spaces glue them).
PERIODIC = "periodic"


def extent(mesh: ngs.Mesh) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest vertex coordinates of the mesh (global under MPI: rank 0 holds no vertices)."""
    from ..runtime import parallel

    points = np.array([v.point for v in mesh.vertices], dtype=float).reshape(-1, mesh.dim)
    low = np.min(parallel.gather(points.min(axis=0) if len(points) else np.full(mesh.dim, np.inf)), axis=0)
    high = np.max(parallel.gather(points.max(axis=0) if len(points) else np.full(mesh.dim, -np.inf)), axis=0)
    return low, high


def is_periodic(mesh: ngs.Mesh) -> bool:
    """Whether the mesh identifies boundary points periodically (``[geometry] periodic``; its spaces are then
    NGSolve's ``Periodic`` ones, `fem.spaces`)."""
    ngmesh = mesh.ngmesh
    return any(ngmesh.GetIdentificationType(nr) == IdentificationType.PERIODIC
               for nr in range(1, ngmesh.GetNrIdentifications() + 1)) and bool(ngmesh.GetIdentifications())


class GeometryError(ValueError):
    """A mesh without the regions the formulation needs."""


#: The characters of NGSolve's region patterns (ECMAScript regular expressions, matched whole) that a name escapes.
_SPECIAL = set("\\^$.|?*+()[]{}")


def pattern(names) -> str:
    """The region pattern matching exactly the region ``names``: NGSolve reads ``dx(name)``, ``definedon`` and
    ``MaterialCF`` keys as regular expressions matched whole ("solid" does not match "solid2")."""
    return "|".join("".join("\\" + c if c in _SPECIAL else c for c in name) for name in names)


@dataclass(frozen=True)
class Phases:
    """The media of the cell regions: Ω_F is the union of the ``fluid`` regions, Ω_S of the ``solid`` ones (names
    as in the mesh; a mesh of the built-in shapes has one of each, called `FLUID` and `SOLID`)."""

    fluid: tuple[str, ...] = (FLUID,)
    solid: tuple[str, ...] = (SOLID,)

    def names(self, phase: str) -> tuple[str, ...]:
        """The regions of ``phase`` (`FLUID` or `SOLID`)."""
        return self.fluid if phase == FLUID else self.solid

    def pattern(self, phase: str) -> str:
        """The region pattern of Ω_F (``phase`` `FLUID`) or Ω_S (`SOLID`), for ``dx``, ``definedon`` and
        ``mesh.Materials``."""
        return pattern(self.names(phase))

    def phase(self, region: str) -> str:
        """`FLUID` or `SOLID`: the medium of a cell region."""
        return FLUID if region in self.fluid else SOLID

    @property
    def regions(self) -> tuple[str, ...]:
        return self.fluid + self.solid


def mesh_phases(mesh: ngs.Mesh, regions: Mapping[str, str] | None = None) -> Phases:
    """The `Phases` of a mesh's cell regions: ``regions`` maps names to `FLUID` or `SOLID` (``[geometry] regions``);
    regions it does not name are called `FLUID` or `SOLID`. Refuses (one-line `GeometryError`) a key that names no
    cell region, a value that is no medium, a region without a medium, and a mesh without fluid or solid."""
    names = list(dict.fromkeys(mesh.GetMaterials()))
    regions = dict(regions or {})
    for key, value in regions.items():
        if key not in names:
            raise GeometryError(f"geometry.regions.{key}: no cell region of that name in the mesh (its regions: "
                                f"{', '.join(names)})")
        if value not in (FLUID, SOLID):
            raise GeometryError(f"geometry.regions.{key}: expected '{FLUID}' or '{SOLID}', got {value!r}")
    media = {name: regions.get(name, name) for name in names}
    for name, medium in media.items():
        if medium not in (FLUID, SOLID):
            raise GeometryError(f"mesh: volume region '{name}' is neither '{FLUID}' nor '{SOLID}' (map it with "
                                f"[geometry] regions, e.g. regions = {{ {name} = \"{SOLID}\" }})")
    phases = Phases(*(tuple(n for n in names if media[n] == medium) for medium in (FLUID, SOLID)))
    for medium in (FLUID, SOLID):
        if not phases.names(medium):
            raise GeometryError(f"mesh: no volume region named '{medium}' or mapped to it by [geometry] regions "
                                f"(found {sorted(names)})")
    return phases


def check_regions(mesh: ngs.Mesh, phases: Phases | None = None) -> Phases:
    """Refuse a mesh that lacks a fluid, a solid or an interface; its `Phases` (``phases``, or by the names of
    `mesh_phases`)."""
    phases = mesh_phases(mesh) if phases is None else phases
    materials, boundaries = set(mesh.GetMaterials()), set(mesh.GetBoundaries())
    for name in phases.regions:
        if name not in materials:
            raise GeometryError(f"mesh: no volume region named '{name}' (found {sorted(materials)})")
    if INTERFACE not in boundaries:
        raise GeometryError(f"mesh: no boundary region named '{INTERFACE}' (found {sorted(boundaries)})")
    return phases


def adjacent_regions(mesh: ngs.Mesh, boundary: str) -> set[str]:
    """The cell regions next to the facets of ``boundary`` (over every rank of a distributed mesh)."""
    from ..runtime import parallel

    found = set()
    for el in mesh.Elements(ngs.BND):
        if el.mat == boundary:
            facet = el.edges[0] if mesh.dim == 2 else el.faces[0]
            found.update(mesh[cell].mat for cell in mesh[facet].elements)
    return set().union(*parallel.gather(found)) if mesh.comm.size > 1 else found


def check_distributable(mesh: ngs.Mesh) -> None:
    """Refuse, under mpirun, a mesh file's quadratic cells (`quadratic`): they are kept on the whole mesh; and a
    periodic mesh (`is_periodic`): a run of its periodic spaces over 2 ranks never finished its first step (NGSolve
    6.2.2608, the 2D layers of ``[geometry] periodic``)."""
    if is_periodic(mesh):
        raise GeometryError("geometry.periodic: a periodic mesh does not run under mpirun; run without mpirun")
    cells = quadratic.quadratic_cells(mesh)
    if cells is not None:
        raise GeometryError(f"mesh file {cells.source}: second-order cells are not supported under mpirun "
                            "(run serially, or write the file with first-order cells)")


def region_counts(mesh: ngs.Mesh, phases: Phases = Phases()) -> dict[str, int]:
    """Vertices, cells and boundary vertices per region (for reports and the paper's dof count); on a distributed
    mesh (MPI) over all ranks, a vertex shared by ranks counted once."""
    def vertices(elements, *names):
        marked = np.zeros(mesh.nv, dtype=bool)
        marked[[v.nr for el in elements if el.mat in names for v in el.vertices]] = True
        return marked

    cells = list(mesh.Elements(ngs.VOL))
    boundary = list(mesh.Elements(ngs.BND))
    every = np.ones(mesh.nv, dtype=bool)
    return {
        "vertices": vertex_count(mesh, every),
        "cells": round(mesh.comm.Sum(mesh.ne)),
        "fluid_cells": round(mesh.comm.Sum(sum(1 for el in cells if el.mat in phases.fluid))),
        "fluid_vertices": vertex_count(mesh, vertices(cells, *phases.fluid)),
        "boundary_vertices": vertex_count(mesh, vertices(boundary, FLUID_WALL, SOLID_WALL)),
        "interface_vertices": vertex_count(mesh, vertices(boundary, INTERFACE)),
    }


def vertex_count(mesh: ngs.Mesh, marked: np.ndarray) -> int:
    """How many vertices ``marked`` (one flag per vertex of this rank's part) marks; on a distributed mesh those
    marked on some rank, each once."""
    if mesh.comm.size == 1:
        return int(np.count_nonzero(marked))
    space = ngs.H1(mesh, order=1)   # one dof per vertex, in the vertices' order
    field = ngs.GridFunction(space)
    values = field.vec.FV().NumPy()
    values[:] = marked
    field.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
    field.vec.Cumulate()
    return round(mesh.comm.Sum((ngs.BitArray(values > 0) & space.ParallelDofs().MasterDofs()).NumSet()))


def interface_normal(mesh: ngs.Mesh, phases: Phases = Phases()) -> ngs.CoefficientFunction:
    """The unit normal on Γ pointing from Ω_F into Ω_S (the paper's n).

    NGSolve orients boundary normals per boundary element; the sign is fixed here once
    per mesh from the fluid cell adjacent to each interface facet. On a distributed mesh (MPI) that cell
    may live on another rank than the facet's other copy: each rank signs the facets whose fluid cell it
    has, and the signs are summed over the ranks.
    """
    normal = ngs.specialcf.normal(mesh.dim)
    coords = (ngs.x, ngs.y, ngs.z)[: mesh.dim]
    centre = (0.5,) if mesh.dim == 2 else (1 / 3, 1 / 3)
    signs = ngs.SurfaceL2(mesh, order=0, definedon=mesh.Boundaries(INTERFACE))
    sign = ngs.GridFunction(signs)
    values, interface, bad = sign.vec.FV().NumPy(), [], None
    values[:] = 0.0
    for el in mesh.Elements(ngs.BND):
        if el.mat != INTERFACE:
            continue
        facet = el.edges[0] if mesh.dim == 2 else el.faces[0]
        fluid = [c for c in mesh[facet].elements if mesh[c].mat in phases.fluid]
        interface.append(signs.GetDofNrs(el)[0])
        if len(fluid) > 1 or not fluid and mesh.comm.size == 1:
            bad = facet.nr
        if len(fluid) != 1:
            continue
        trafo = mesh.GetTrafo(ngs.ElementId(el))  # must outlive the mesh point
        point = trafo(*centre)
        cell = [mesh[v].point for v in mesh[fluid[0]].vertices]
        into_solid = sum(n * (c(point) - sum(p[i] for p in cell) / len(cell))
                         for i, (n, c) in enumerate(zip(normal(point), coords)))
        values[interface[-1]] = 1.0 if into_solid > 0 else -1.0
    if mesh.comm.size > 1:
        sign.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
        sign.vec.Cumulate()
        if bad is None and np.any(np.abs(values[interface]) != 1.0):
            bad = -1
    if mesh.comm.Max(0 if bad is None else 1):  # the same decision on every rank
        facet = f"facet {bad}" if bad is not None and bad >= 0 else "a facet"
        raise GeometryError(f"mesh: interface {facet} does not border exactly one fluid cell")
    return sign * normal


def locked_fluid_cells(mesh: ngs.Mesh, dirichlet: str, phases: Phases = Phases()) -> list[int]:
    """Fluid cells with every vertex on a Dirichlet boundary (Γ_F or Γ_S).

    Typically a box corner meshed by a single tetrahedron: a continuous velocity without
    interior dofs vanishes on it, and with Taylor–Hood the pressure at such a corner is
    seen by no free velocity dof (the step-1 matrix is singular).
    """
    if not dirichlet:
        return []
    region = mesh.Boundaries(dirichlet).Mask()
    walled = {v.nr for el in mesh.Elements(ngs.BND) if region[el.index] for v in el.vertices}
    return [el.nr for el in mesh.Elements(ngs.VOL)
            if el.mat in phases.fluid and all(v.nr in walled for v in el.vertices)]
