"""Meshes conforming to the interface, with the region names the scheme expects.

Every mesh fsivsp works on has the volume regions ``fluid`` and ``solid`` and the
boundary regions ``interface`` (Γ), ``fluid_wall`` (Γ_F) and ``solid_wall`` (Γ_S);
Γ_F or Γ_S may be empty (Fig. 1 of the paper).

Builders (all but ``load_mesh`` and ``netgen_mesh`` return an ``ngsolve.Mesh`` that keeps its OCC
geometry, so ``mesh.Curve(order)`` and ``refined(mesh, levels, project=True)`` follow the true
curved boundaries; docs/meshes.md describes the file formats):

- ``paper_channel``: the paper's 2D channel with a fluid disk (Section 5.3);
- ``fluid_in_solid``, ``solid_in_fluid``: a disk/ball of one medium inside a square/cube of the other;
- ``fluid_over_solid``: a fluid rectangle/box on top of a solid one (flat interface);
- ``elastic_tube``: a fluid cylinder inside a solid tube wall (2D: the axial section);
- ``cad``: the solids (2D: the plane faces) of a STEP, BREP or IGES file, named ``fluid`` /
  ``solid`` in the file or by a ``regions`` table, glued and meshed;
- ``load_mesh``: a gmsh ``.msh`` (format 2.2 or 4.x, ASCII or binary, read by meshio; physical
  names as region names; second-order cells curve it, `quadratic`) or netgen ``.vol`` file, without
  geometry (unless a ``.vol`` carries it);
- ``netgen_mesh``: a geometry-free netgen mesh from points, cells and named facets (used by
  ``load_mesh`` and ``without_geometry``);
- ``build_geometry(kind, dim, maxh, **parameters)``: dispatch by name, with validation (``KINDS``).
"""
from __future__ import annotations

import contextlib
import io
import math
import os
import sys
import tempfile
from numbers import Real
from pathlib import Path
from typing import Any, Callable, Sequence

import ngsolve as ngs
import netgen.meshing as nm
import numpy as np
from netgen.occ import Box, Circle, Cylinder, Glue, MoveTo, OCCGeometry, Pnt, Rectangle, Sphere, X, Y, Z

from .. import quadratic

FLUID, SOLID = "fluid", "solid"
INTERFACE, FLUID_WALL, SOLID_WALL = "interface", "fluid_wall", "solid_wall"
INFLOW, OUTFLOW, SOLID_ENDS = "inflow", "outflow", "solid_ends"  # boundary parts of `elastic_tube`


class GeometryError(ValueError):
    """A mesh without the regions the formulation needs."""


#: The paper's domain (Section 5.3): channel width and height, disk centre (c, c) and radius.
CHANNEL_WIDTH, CHANNEL_HEIGHT, DISK_CENTRE, DISK_RADIUS = 2.5, 0.41, 0.2, 0.05


def paper_channel(maxh: float = 0.15, grading: float = 0.3) -> ngs.Mesh:
    """The domain of Section 5.3: Ω_F the disk of centre (0.2, 0.2), radius 0.05,
    Ω_S = (0, 2.5) × (0, 0.41) minus the disk (Γ_F = ∅). The defaults give the
    coarse mesh of about 128 vertices (136, 12 of them on Γ)."""
    channel = Rectangle(CHANNEL_WIDTH, CHANNEL_HEIGHT).Face()
    disk = Circle((DISK_CENTRE, DISK_CENTRE), DISK_RADIUS).Face()
    solid = channel - disk
    solid.faces.name, disk.faces.name = SOLID, FLUID
    solid.edges.name, disk.edges.name = SOLID_WALL, INTERFACE
    geometry = OCCGeometry(Glue([solid, disk]), dim=2)
    return ngs.Mesh(geometry.GenerateMesh(maxh=maxh, grading=grading))


def without_geometry(mesh: ngs.Mesh) -> ngs.Mesh:
    """A copy of a 2D or 3D mesh that has forgotten its geometry, so that refinement puts the new
    nodes at the edge midpoints instead of projecting them onto curved boundaries."""
    old = mesh.ngmesh
    if old.dim not in (2, 3):
        raise GeometryError("geometry-free refinement is implemented for 2D and 3D meshes only")
    points = np.array([p.p for p in old.Points()], dtype=float)
    if old.dim == 2:
        cells, facets = old.Elements2D(), old.Elements1D()
        boundaries = [(name, 0, 0) for name in old.GetRegionNames(codim=1)]
    else:
        cells, facets = old.Elements3D(), old.Elements2D()
        boundaries = [(fd.bcname, fd.domin, fd.domout) for fd in old.FaceDescriptors()]
    return netgen_mesh(old.dim, points, old.GetRegionNames(codim=0),
                       [(el.index, [v.nr - 1 for v in el.vertices]) for el in cells], boundaries,
                       [(el.index, [v.nr - 1 for v in el.vertices]) for el in facets])


def netgen_mesh(dim: int, points: np.ndarray, materials: Sequence[str], cells: Sequence[tuple[int, Sequence[int]]],
                boundaries: Sequence[tuple[str, int, int]], facets: Sequence[tuple[int, Sequence[int]]]) -> ngs.Mesh:
    """A geometry-free netgen mesh of triangles (``dim`` 2) or tetrahedra (3).

    ``points``: an (n, 3) array; ``materials``: the volume region names, numbered from 1;
    ``cells``: (material number, vertex numbers from 0); ``boundaries``: (name, domin, domout) of
    each boundary part, numbered from 1 (domin/domout: the material numbers on either side, 0 for
    none; only 3D uses them); ``facets``: (boundary number, vertex numbers from 0), each oriented
    with its normal out of domin (3D: (p1 - p0) × (p2 - p0); 2D: the cell on the left of p0 → p1)."""
    mesh = nm.Mesh(dim=dim)
    vertices = [mesh.Add(nm.MeshPoint(nm.Pnt(*p))) for p in points]
    for number, name in enumerate(materials, start=1):
        mesh.SetMaterial(number, name)
    for number, (name, domin, domout) in enumerate(boundaries, start=1):
        if dim == 3:
            mesh.Add(nm.FaceDescriptor(surfnr=number, domin=domin, domout=domout, bc=number))
        mesh.SetBCName(number - 1, name)
    cell_type = nm.Element2D if dim == 2 else nm.Element3D
    for number, corners in cells:
        mesh.Add(cell_type(number, [vertices[v] for v in corners]))
    for number, corners in facets:
        if dim == 2:
            mesh.Add(nm.Element1D([vertices[v] for v in corners], index=number))
        else:
            mesh.Add(nm.Element2D(number, [vertices[v] for v in corners]))
    return ngs.Mesh(mesh)


def refined(mesh: ngs.Mesh, levels: int, project: bool = True) -> ngs.Mesh:
    """``levels`` uniform red refinements (each triangle into four, each tetrahedron into eight, by
    the edge midpoints). With ``project`` the new boundary and interface nodes are moved onto the
    true (curved) geometry. A mesh file's quadratic cells (`quadratic`) go with the refined mesh.

    netgen's red refinement, not NGSolve's ``Mesh.Refine`` (bisection of marked elements): on the
    same vertices, bisection leaves half of the triangles in a different pattern, so that the
    stress of the interpolated displacement is out of discrete equilibrium and the solid rings
    (velocity errors 2.6× the paper's at level 4 instead of 0.76×); in the 3D fluid ball of the examples
    it lowers the worst tetrahedron quality to 0.05 where red refinement keeps 0.09, and Taylor–Hood
    k = 1 converged at 1.6, not 2, in the pressure."""
    ngmesh = mesh.ngmesh.Copy() if project else without_geometry(mesh).ngmesh
    for _ in range(levels):
        ngmesh.Refine(adaptive=False)
    return quadratic.carry(mesh, ngs.Mesh(ngmesh))


def check_regions(mesh: ngs.Mesh) -> None:
    """Refuse a mesh that lacks a fluid, a solid or an interface."""
    materials, boundaries = set(mesh.GetMaterials()), set(mesh.GetBoundaries())
    for name in (FLUID, SOLID):
        if name not in materials:
            raise GeometryError(f"mesh: no volume region named '{name}' (found {sorted(materials)})")
    if INTERFACE not in boundaries:
        raise GeometryError(f"mesh: no boundary region named '{INTERFACE}' (found {sorted(boundaries)})")


def check_distributable(mesh: ngs.Mesh) -> None:
    """Refuse, under mpirun, a mesh file's quadratic cells (`quadratic`): they are kept on the whole mesh."""
    cells = quadratic.quadratic_cells(mesh)
    if cells is not None:
        raise GeometryError(f"mesh file {cells.source}: second-order cells are not supported under mpirun "
                            "(run serially, or write the file with first-order cells)")


def region_counts(mesh: ngs.Mesh) -> dict[str, int]:
    """Vertices, cells and boundary vertices per region (for reports and the paper's dof count)."""
    def vertices(elements, name):
        return {v.nr for el in elements if el.mat == name for v in el.vertices}

    cells = list(mesh.Elements(ngs.VOL))
    boundary = list(mesh.Elements(ngs.BND))
    outer = vertices(boundary, FLUID_WALL) | vertices(boundary, SOLID_WALL)
    return {
        "vertices": mesh.nv,
        "cells": mesh.ne,
        "fluid_cells": sum(1 for el in cells if el.mat == FLUID),
        "fluid_vertices": len(vertices(cells, FLUID)),
        "boundary_vertices": len(outer),
        "interface_vertices": len(vertices(boundary, INTERFACE)),
    }


def interface_normal(mesh: ngs.Mesh) -> ngs.CoefficientFunction:
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
        fluid = [c for c in mesh[facet].elements if mesh[c].mat == FLUID]
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


# ---------------------------------------------------------------------------------------------
# Geometry builders
# ---------------------------------------------------------------------------------------------

DEFAULT_MAXH = {
    "fluid_in_solid": {2: 0.1, 3: 0.2},
    "solid_in_fluid": {2: 0.1, 3: 0.2},
    "fluid_over_solid": {2: 0.1, 3: 0.2},
    "elastic_tube": {2: 0.1, 3: 0.3},
}


def _fail(field: str, expected: str, got: Any) -> GeometryError:
    return GeometryError(f"geometry.{field}: expected {expected}, got {got!r}")


def _dimension(kind: str, dim: Any, dims: Sequence[int] = (2, 3)) -> int:
    if isinstance(dim, bool) or not isinstance(dim, int) or dim not in dims:
        raise _fail("dim", " or ".join(map(str, dims)) + f" for kind '{kind}'", dim)
    return dim


def _positive(field: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value) or value <= 0:
        raise _fail(field, "a positive number", value)
    return float(value)


def _mesh_size(kind: str, dim: int, maxh: Any) -> float:
    return DEFAULT_MAXH[kind][dim] if maxh is None else _positive("maxh", maxh)


def _point(field: str, value: Any, dim: int) -> tuple[float, ...]:
    try:
        point = tuple(value)
    except TypeError:
        raise _fail(field, f"a sequence of {dim} numbers", value) from None
    if len(point) != dim or not all(isinstance(c, Real) and not isinstance(c, bool) and math.isfinite(c)
                                    for c in point):
        raise _fail(field, f"a sequence of {dim} numbers", value)
    return tuple(float(c) for c in point)


def _mesh(shape, dim: int, maxh: float, curvature_safety: float = 2.0) -> ngs.Mesh:
    """netgen's mesh; ``curvature_safety`` (netgen's curvaturesafety) bounds the element size on
    curved surfaces by radius / curvature_safety: lower it for coarse meshes of a ball."""
    geometry = OCCGeometry(shape, dim=dim)
    return ngs.Mesh(geometry.GenerateMesh(maxh=maxh, curvaturesafety=_positive("curvature_safety", curvature_safety)))


def _inclusion(kind: str, dim: int, maxh: float | None, size: float, radius: float,
               centre: Sequence[float] | None, inner: str, outer: str, outer_wall: str,
               curvature_safety: float = 2.0) -> ngs.Mesh:
    """A disk/ball (region ``inner``, boundary ``interface``) strictly inside the square/cube
    (0, size)^dim (region ``outer``, outer boundary ``outer_wall``)."""
    dim = _dimension(kind, dim)
    h = _mesh_size(kind, dim, maxh)
    size, radius = _positive("size", size), _positive("radius", radius)
    c = (size / 2,) * dim if centre is None else _point("centre", centre, dim)
    if not all(0 < ci < size for ci in c):
        raise _fail("centre", f"a point inside (0, {size:g})^{dim}", centre)
    gap = min(min(ci, size - ci) for ci in c)
    if radius >= gap:
        shape = "disk" if dim == 2 else "ball"
        raise _fail("radius", f"a {shape} strictly inside (0, {size:g})^{dim}, i.e. radius < {gap:g} "
                    f"for centre {tuple(round(ci, 12) for ci in c)}", radius)
    if dim == 2:
        box = Rectangle(size, size).Face()
        inclusion = Circle(c, radius).Face()
        box.edges.name, inclusion.edges.name = outer_wall, INTERFACE
        rest = box - inclusion  # the hole's edge inherits the name `interface`
        rest.faces.name, inclusion.faces.name = outer, inner
    else:
        box = Box(Pnt(0, 0, 0), Pnt(size, size, size))
        inclusion = Sphere(Pnt(*c), radius)
        box.faces.name, inclusion.faces.name = outer_wall, INTERFACE
        rest = box - inclusion
        rest.mat(outer)
        inclusion.mat(inner)
    return _mesh(Glue([rest, inclusion]), dim, h, curvature_safety)


def fluid_in_solid(dim: int = 2, maxh: float | None = None, *, size: float = 1.0, radius: float = 0.25,
                   centre: Sequence[float] | None = None, curvature_safety: float = 2.0) -> ngs.Mesh:
    """Ω_F a disk (2D) / ball (3D) of ``radius`` around ``centre`` (default: the middle) inside
    the solid square/cube (0, size)^dim. Γ_F = ∅; the outer boundary is ``solid_wall``.
    ``maxh`` defaults to 0.1 (2D) / 0.2 (3D)."""
    return _inclusion("fluid_in_solid", dim, maxh, size, radius, centre, FLUID, SOLID, SOLID_WALL,
                      curvature_safety)


def solid_in_fluid(dim: int = 2, maxh: float | None = None, *, size: float = 1.0, radius: float = 0.25,
                   centre: Sequence[float] | None = None, curvature_safety: float = 2.0) -> ngs.Mesh:
    """Ω_S a disk (2D) / ball (3D) of ``radius`` around ``centre`` (default: the middle) inside
    the fluid square/cube (0, size)^dim. Γ_S = ∅; the outer boundary is ``fluid_wall``.
    ``maxh`` defaults to 0.1 (2D) / 0.2 (3D)."""
    return _inclusion("solid_in_fluid", dim, maxh, size, radius, centre, SOLID, FLUID, FLUID_WALL,
                      curvature_safety)


def fluid_over_solid(dim: int = 2, maxh: float | None = None, *, width: float = 1.0,
                     solid_height: float = 0.5, fluid_height: float = 0.5) -> ngs.Mesh:
    """Ω_S = (0, width)^(dim-1) × (0, solid_height), Ω_F = (0, width)^(dim-1) × (solid_height,
    solid_height + fluid_height): a flat interface at the top of the solid (y = solid_height in
    2D, z = solid_height in 3D). The rest of ∂Ω_F is ``fluid_wall``, of ∂Ω_S ``solid_wall``.
    ``maxh`` defaults to 0.1 (2D) / 0.2 (3D)."""
    kind = "fluid_over_solid"
    dim = _dimension(kind, dim)
    h = _mesh_size(kind, dim, maxh)
    width = _positive("width", width)
    hs, hf = _positive("solid_height", solid_height), _positive("fluid_height", fluid_height)
    if dim == 2:
        solid = Rectangle(width, hs).Face()
        fluid = MoveTo(0, hs).Rectangle(width, hf).Face()
        solid.edges.name, fluid.edges.name = SOLID_WALL, FLUID_WALL
        solid.edges.Max(Y).name = fluid.edges.Min(Y).name = INTERFACE
        solid.faces.name, fluid.faces.name = SOLID, FLUID
    else:
        solid = Box(Pnt(0, 0, 0), Pnt(width, width, hs))
        fluid = Box(Pnt(0, 0, hs), Pnt(width, width, hs + hf))
        solid.faces.name, fluid.faces.name = SOLID_WALL, FLUID_WALL
        solid.faces.Max(Z).name = fluid.faces.Min(Z).name = INTERFACE
        solid.mat(SOLID)
        fluid.mat(FLUID)
    return _mesh(Glue([solid, fluid]), dim, h)


def elastic_tube(dim: int = 2, maxh: float | None = None, *, radius: float = 0.5, length: float = 5.0,
                 wall: float = 0.1) -> ngs.Mesh:
    """A straight elastic tube along the x axis. 3D: Ω_F the cylinder of ``radius`` and
    ``length``, Ω_S the tube wall of thickness ``wall`` around it. 2D (the axial section):
    Ω_F = (0, L) × (-R, R), Ω_S = (0, L) × (R, R + wall) ∪ (0, L) × (-R - wall, -R).

    Boundaries: ``inflow`` (fluid, x = 0), ``outflow`` (fluid, x = L), ``interface``,
    ``solid_ends`` (the solid at x = 0 and x = L), ``solid_wall`` (the outer surface); there is
    no ``fluid_wall``. ``maxh`` defaults to 0.1 (2D) / 0.3 (3D); the wall gets at least one
    element across whatever ``maxh``."""
    kind = "elastic_tube"
    dim = _dimension(kind, dim)
    h = _mesh_size(kind, dim, maxh)
    r, length, wall = _positive("radius", radius), _positive("length", length), _positive("wall", wall)
    if dim == 2:
        fluid = MoveTo(0, -r).Rectangle(length, 2 * r).Face()
        fluid.edges.name = INTERFACE
        fluid.edges.Min(X).name, fluid.edges.Max(X).name = INFLOW, OUTFLOW
        fluid.faces.name = FLUID
        walls = []
        for bottom, above in ((r, True), (-r - wall, False)):
            solid = MoveTo(0, bottom).Rectangle(length, wall).Face()
            solid.edges.name = SOLID_WALL
            solid.edges.Min(X).name = solid.edges.Max(X).name = SOLID_ENDS
            (solid.edges.Min(Y) if above else solid.edges.Max(Y)).name = INTERFACE
            solid.faces.name = SOLID
            walls.append(solid)
        return _mesh(Glue([fluid, *walls]), 2, h)
    fluid = Cylinder(Pnt(0, 0, 0), X, r=r, h=length, bottom=INFLOW, top=OUTFLOW, mantle=INTERFACE)
    outer = Cylinder(Pnt(0, 0, 0), X, r=r + wall, h=length, bottom=SOLID_ENDS, top=SOLID_ENDS,
                     mantle=SOLID_WALL)
    solid = outer - fluid  # the inner mantle inherits the name `interface`
    solid.mat(SOLID)
    fluid.mat(FLUID)
    return _mesh(Glue([solid, fluid]), 3, h)


# ---------------------------------------------------------------------------------------------
# Mesh files
# ---------------------------------------------------------------------------------------------

MESH_SUFFIXES = (".msh", ".vol", ".vol.gz")
CAD_SUFFIXES = (".step", ".stp", ".brep", ".iges", ".igs")

#: meshio cell type → (dimension, corner count); the nodes after the corners are mid-edge nodes.
GMSH_CELLS = {"line": (1, 2), "line3": (1, 2), "triangle": (2, 3), "triangle6": (2, 3),
              "tetra": (3, 4), "tetra10": (3, 4)}
#: the edge (pair of corners) of each mid-edge node, in meshio's order (which it converts from gmsh's)
MID_EDGES = {"line3": [(0, 1)], "triangle6": [(0, 1), (1, 2), (0, 2)],
             "tetra10": [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]}
IGNORED_CELLS = {"vertex"}  # physical points
NAMES_HINT = f"name the physical groups '{FLUID}', '{SOLID}', '{INTERFACE}' (and '{FLUID_WALL}', '{SOLID_WALL}')"


def _existing_file(path: str | Path, suffixes: Sequence[str], label: str) -> tuple[Path, str]:
    """The path and its (lower-case) suffix, if it has one of ``suffixes`` and is a file."""
    path = Path(path)
    suffix = next((s for s in suffixes if path.name.lower().endswith(s)), None)
    if suffix is None:
        raise GeometryError(f"{label} {path}: unknown extension '{path.suffix}' (expected one of {', '.join(suffixes)})")
    if not path.is_file():
        raise GeometryError(f"{label} {path}: no such file")
    return path, suffix


def _path_parameter(path: Any, suffixes: Sequence[str]) -> str | Path:
    if not isinstance(path, (str, Path)) or not str(path):
        raise _fail("path", f"the path of a {', '.join(suffixes)} file", path)
    return path


def _one_line(error: BaseException) -> str:
    """A reader's exception as one line: its type and message."""
    return " ".join(f"{type(error).__name__}: {error}".split()).removesuffix(":")


def _read_gmsh(path: Path):
    """The file as a ``meshio.Mesh`` (gmsh 2.2, 4.0 or 4.1, ASCII or binary)."""
    import warnings

    import meshio

    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            return meshio.gmsh.read(str(path))  # not meshio.read: that exits on a ReadError
    except Exception as error:  # noqa: BLE001 - meshio raises ReadError, KeyError, struct.error, ...
        raise GeometryError(f"mesh file {path}: cannot read as a gmsh mesh ({_one_line(error)})") from None


def _gmsh_blocks(msh, path: Path) -> tuple[int, list[tuple[int, np.ndarray, list[str]]], list[np.ndarray]]:
    """The mesh dimension; per cell block of dimension dim or dim - 1, (dimension, corner numbers,
    physical name of each cell); and the mid-edge nodes of the second-order blocks as rows
    (corner, corner, node)."""
    unknown = sorted({block.type for block in msh.cells} - set(GMSH_CELLS) - IGNORED_CELLS)
    if unknown:
        raise GeometryError(f"mesh file {path}: cells of type {', '.join(unknown)} are not supported "
                            "(expected triangles and lines in 2D, tetrahedra and triangles in 3D)")
    tags = msh.cell_data.get("gmsh:physical")
    if not msh.field_data or tags is None:
        raise GeometryError(f"mesh file {path}: no physical names; {NAMES_HINT}")
    names = {(int(dim), int(tag)): name for name, (tag, dim) in msh.field_data.items()}
    blocks = [(b.type, b.data, t) for b, t in zip(msh.cells, tags) if b.type in GMSH_CELLS]
    dim = max((GMSH_CELLS[kind][0] for kind, _, _ in blocks), default=0)
    if dim not in (2, 3):
        raise GeometryError(f"mesh file {path}: no triangles or tetrahedra")
    result, middles = [], []
    for kind, data, block_tags in blocks:
        d, corners = GMSH_CELLS[kind]
        if d < dim - 1:
            continue
        missing = sorted({int(t) for t in block_tags if (d, int(t)) not in names})
        if missing:
            raise GeometryError(f"mesh file {path}: physical group {missing[0]} of dimension {d} has no name; {NAMES_HINT}")
        result.append((d, data[:, :corners], [names[d, int(t)] for t in block_tags]))
        middles += [data[:, [i, j, corners + k]] for k, (i, j) in enumerate(MID_EDGES.get(kind, []))]
    return dim, result, middles


def _coincident_vertices(points: np.ndarray, path: Path) -> None:
    """Refuse distinct vertices at one place: a fluid and a solid meshed separately."""
    from scipy.spatial import cKDTree

    size = float(np.ptp(points, axis=0).max()) or 1.0
    pairs = cKDTree(points).query_pairs(1e-10 * size, output_type="ndarray")
    if len(pairs):
        where = tuple(round(float(c), 6) for c in points[pairs[0, 0]])
        raise GeometryError(f"mesh file {path}: {len(pairs)} pairs of coincident vertices, e.g. at {where}; the "
                            "interface is not conforming (mesh the fluid and solid together so they share its nodes)")


def _facet_neighbours(cells: list[list[int]]) -> dict[tuple[int, ...], list[tuple[int, int]]]:
    """Each facet (sorted vertex numbers) → its cells as (cell number, the cell's vertex opposite the facet)."""
    neighbours: dict[tuple[int, ...], list[tuple[int, int]]] = {}
    for number, cell in enumerate(cells):
        for k, opposite in enumerate(cell):
            neighbours.setdefault(tuple(sorted(cell[:k] + cell[k + 1:])), []).append((number, opposite))
    return neighbours


def _outward(points: np.ndarray, facet: list[int], opposite: int) -> list[int]:
    """The facet's vertices ordered so that its normal points away from ``opposite`` (see `netgen_mesh`)."""
    edges = [points[v, : len(facet)] - points[facet[0], : len(facet)] for v in (*facet[1:], opposite)]
    inward = np.linalg.det(np.array(edges))
    return facet if (inward > 0) == (len(facet) == 2) else facet[::-1]


def _gmsh_boundaries(path: Path, points: np.ndarray, cells: list[list[int]], materials: list[str],
                     regions: list[int], facets: list[tuple[str, list[int]]]):
    """Boundary parts (name, domin, domout) and the facets oriented out of domin, for `netgen_mesh`;
    refuses a facet bordering no cell and an interface facet not between a fluid and a solid cell."""
    neighbours = _facet_neighbours(cells)
    parts: dict[tuple[str, int, int], int] = {}
    oriented = []
    for name, facet in facets:
        sides = sorted(neighbours.get(tuple(sorted(facet)), []), key=lambda side: regions[side[0]])
        media = [materials[regions[c] - 1] for c, _ in sides]
        if not sides or (name == INTERFACE and media != [FLUID, SOLID] and media != [SOLID, FLUID]):
            where = tuple(round(float(c), 6) for c in points[facet].mean(axis=0))
            found = " and ".join(f"a {medium} cell" for medium in media) or "no cell"
            raise GeometryError(f"mesh file {path}: a facet of '{name}' at {where} borders {found}"
                                + (" (non-conforming interface)" if name == INTERFACE else ""))
        domains = [regions[c] for c, _ in sides] + [0]
        number = parts.setdefault((name, domains[0], domains[1]), len(parts) + 1)
        oriented.append((number, _outward(points, facet, sides[0][1])))
    _unnamed_facets(path, neighbours, {tuple(sorted(facet)) for _, facet in facets}, regions)
    return list(parts), oriented


def _unnamed_facets(path: Path, neighbours: dict, named: set, regions: list[int]) -> None:
    """Refuse outer facets and fluid–solid facets that are in no physical group."""
    unnamed = [sides for key, sides in neighbours.items()
               if key not in named and (len(sides) == 1 or regions[sides[0][0]] != regions[sides[1][0]])]
    inner = sum(len(sides) == 2 for sides in unnamed)
    if inner:
        raise GeometryError(f"mesh file {path}: {inner} facets between fluid and solid cells are not in the "
                            f"physical group '{INTERFACE}'")
    if unnamed:
        raise GeometryError(f"mesh file {path}: {len(unnamed)} outer facets are in no physical group "
                            f"(e.g. '{FLUID_WALL}' or '{SOLID_WALL}')")


def _load_gmsh(path: Path) -> ngs.Mesh:
    """A gmsh mesh read by meshio, as a geometry-free netgen mesh (see `load_mesh`)."""
    msh = _read_gmsh(path)
    dim, blocks, middles = _gmsh_blocks(msh, path)
    cells = [(name, c) for d, data, names in blocks if d == dim for name, c in zip(names, data)]
    facets = [(name, c) for d, data, names in blocks if d < dim for name, c in zip(names, data)]
    materials = list(dict.fromkeys(name for name, _ in cells))
    strange = [name for name in materials if name not in (FLUID, SOLID)]
    if strange:
        raise GeometryError(f"mesh file {path}: volume region '{strange[0]}' is neither '{FLUID}' nor '{SOLID}'")
    used = np.unique(np.concatenate([c for _, c in cells]))
    number = np.full(len(msh.points), -1)
    number[used] = np.arange(len(used))  # the corners; mid-edge nodes are not vertices
    points = np.zeros((len(used), 3))
    points[:, : msh.points.shape[1]] = msh.points[used]
    if dim == 2 and np.abs(points[:, 2]).max() > 0:
        raise GeometryError(f"mesh file {path}: a 2D mesh must lie in the plane z = 0")
    _coincident_vertices(points, path)
    corners = [number[c].tolist() for _, c in cells]
    regions = [materials.index(name) + 1 for name, _ in cells]
    boundaries, oriented = _gmsh_boundaries(path, points, corners, materials, regions,
                                            [(name, number[c].tolist()) for name, c in facets])
    mesh = netgen_mesh(dim, points, materials, list(zip(regions, corners)), boundaries, oriented)
    if middles:
        _mid_edge_nodes(path, mesh, points, msh.points, number, np.vstack(middles))
    return mesh


def _mid_edge_nodes(path: Path, mesh: ngs.Mesh, points: np.ndarray, nodes: np.ndarray, number: np.ndarray,
                    middles: np.ndarray) -> None:
    """Curve ``mesh`` by the mid-edge nodes of its second-order cells (rows: corner, corner, node of the
    file), unless every one is its edge's midpoint; refuse an edge whose cells disagree on its node."""
    edges = np.sort(number[middles[:, :2]], axis=1)
    where = np.zeros((len(middles), 3))
    where[:, : nodes.shape[1]] = nodes[middles[:, 2]]
    size = float(np.ptp(points, axis=0).max()) or 1.0
    if np.abs(where - (points[edges[:, 0]] + points[edges[:, 1]]) / 2).max() <= 1e-12 * size:
        return
    unique, first, inverse = np.unique(edges, axis=0, return_index=True, return_inverse=True)
    apart = np.linalg.norm(where - where[first][inverse.ravel()], axis=1)
    if apart.max() > 1e-10 * size:
        at = tuple(round(float(c), 6) for c in points[edges[apart.argmax()]].mean(axis=0))
        raise GeometryError(f"mesh file {path}: the cells along the edge at {at} have different mid-edge nodes")
    quadratic.attach(mesh, {(int(a), int(b)): where[k] for (a, b), k in zip(unique, first)}, str(path))


def load_mesh(path: str | Path) -> ngs.Mesh:
    """A mesh from a file: gmsh ``.msh`` (format 2.2, 4.0 or 4.1, ASCII or binary, read by meshio;
    the physical names become the region names) or netgen ``.vol`` / ``.vol.gz``.

    The mesh must have the volume regions ``fluid`` and ``solid`` and the boundary region
    ``interface`` (`check_regions`); anything else is a one-line `GeometryError` naming the file.
    A gmsh mesh is 2D (triangles; boundary lines) or 3D (tetrahedra; boundary triangles), every
    cell in the physical group ``fluid`` or ``solid``, every outer facet in a named group (walls:
    ``fluid_wall``, ``solid_wall`` or other names), every fluid–solid facet in ``interface``, and the
    fluid and solid share their interface nodes (no coincident vertices). Second-order cells
    (triangle6, tetra10) are the straight mesh on their corners with their quadratic map attached
    (`quadratic`: `quadratic.curve` applies it, refinement keeps it); mid-edge nodes that all sit at
    their edges' midpoints leave it straight. A gmsh mesh has no other geometry (refinement splits
    edges at their midpoints); a ``.vol`` file saved from a mesh of an OCC geometry
    (``mesh.ngmesh.Save``) carries that geometry along."""
    path, suffix = _existing_file(path, MESH_SUFFIXES, "mesh file")
    if suffix == ".msh":
        mesh = _load_gmsh(path)
    else:
        try:
            mesh = ngs.Mesh(str(path))
        except Exception as error:  # noqa: BLE001 - netgen raises bare Exceptions
            raise GeometryError(f"mesh file {path}: cannot read ({_one_line(error)})") from None
    try:
        check_regions(mesh)
    except GeometryError as error:
        raise GeometryError(f"mesh file {path}: {str(error).removeprefix('mesh: ')}") from None
    return mesh


# ---------------------------------------------------------------------------------------------
# CAD files
# ---------------------------------------------------------------------------------------------

@contextlib.contextmanager
def _silenced():
    """Send what C++ code prints to stdout and stderr (OCC's parser messages) to /dev/null."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
    finally:
        for fd, copy in zip((1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)


def _read_cad(path: str | Path, dim: int) -> tuple[Path, list]:
    """The parts of a STEP, BREP or IGES file (netgen's OCC kernel): its solids (3D) or its faces
    in the plane z = 0 (2D)."""
    path, suffix = _existing_file(path, CAD_SUFFIXES, "CAD file")
    try:
        with _silenced(), tempfile.TemporaryDirectory() as folder:
            readable = path
            if suffix == ".igs":  # netgen's OCCGeometry knows the long suffix only
                readable = Path(folder) / "part.iges"
                readable.symlink_to(path.resolve())
            shape = OCCGeometry(str(readable)).shape
    except Exception as error:  # noqa: BLE001 - OCC raises bare Exceptions
        raise GeometryError(f"CAD file {path}: cannot read ({_one_line(error)})") from None
    solids, faces = list(shape.solids), list(shape.faces)
    low, high = shape.bounding_box
    plane = max(abs(low[2]), abs(high[2])) <= 1e-6 * max(high[i] - low[i] for i in range(2))
    if dim == 3 and not solids:
        raise GeometryError(f"CAD file {path}: no solids" + (
            "" if not faces else " (plane faces: use dim = 2)" if plane else
            f", only {len(faces)} faces (IGES in face mode?): export the solids (STEP, BREP, or IGES in BRep mode)"))
    if dim == 2 and (solids or not faces):
        raise GeometryError(f"CAD file {path}: " + ("has solids: use dim = 3" if solids else "no faces"))
    if dim == 2 and not plane:
        raise GeometryError(f"CAD file {path}: a 2D geometry must lie in the plane z = 0")
    return path, solids if dim == 3 else faces


def _solid_regions(path: Path, parts: list, regions: Any, word: str) -> list[str]:
    """``fluid`` or ``solid`` for each part (a solid, or a face in 2D, as ``word`` says):
    ``regions[number]`` (from 1, as a string or an integer), else ``regions[its name]``, else its
    own name in the file."""
    if regions is None:
        regions = {}
    if not isinstance(regions, dict):
        raise _fail("regions", f"a table mapping {word} names or numbers to 'fluid' or 'solid'", regions)
    names = [part.name for part in parts]
    listing = f"{word}s: " + ", ".join(f"{i} '{name}'" if name else f"{i} (unnamed)"
                                       for i, name in enumerate(names, start=1))
    regions = {str(key): value for key, value in regions.items()}
    for key, value in regions.items():
        if key not in names and key not in map(str, range(1, len(parts) + 1)):
            raise GeometryError(f"geometry.regions.{key}: no {word} of that name or number in {path} ({listing})")
        if value not in (FLUID, SOLID):
            raise _fail(f"regions.{key}", f"'{FLUID}' or '{SOLID}'", value)
    media = [regions.get(str(i), regions.get(name, name)) for i, name in enumerate(names, start=1)]
    for i, medium in enumerate(media, start=1):
        if medium not in (FLUID, SOLID):
            raise GeometryError(f"geometry.regions: {word} {i} of {path} is neither '{FLUID}' nor '{SOLID}' "
                                f"({listing}); map it, e.g. regions = {{ \"{i}\" = \"{FLUID}\" }}")
    for medium in (FLUID, SOLID):
        if medium not in media:
            raise GeometryError(f"geometry.regions: no {word} of {path} is '{medium}' ({listing})")
    return media


def _boundary_parts(ngmesh: nm.Mesh) -> list[tuple[int, str, int, int]]:
    """(boundary number, name, domin, domout) of each face (3D) or edge (2D) descriptor."""
    if ngmesh.dim == 3:
        return [(fd.bc, fd.bcname, fd.domin, fd.domout) for fd in ngmesh.FaceDescriptors()]
    return [(ed.edgenr, ed.name, ed.domin, ed.domout) for ed in ngmesh.EdgeDescriptors()]


def _name_boundaries(ngmesh: nm.Mesh, path: Path) -> None:
    """``interface`` on the faces (2D: edges) between fluid and solid; ``fluid_wall`` /
    ``solid_wall`` on the outer ones the CAD file leaves unnamed (netgen calls them ``default``).
    A boundary the file names ``interface`` elsewhere is refused."""
    materials = ngmesh.GetRegionNames(codim=0)
    for number, name, domin, domout in _boundary_parts(ngmesh):
        media = {materials[d - 1] for d in (domin, domout) if d > 0}
        if media == {FLUID, SOLID}:
            ngmesh.SetBCName(number - 1, INTERFACE)
        elif name == INTERFACE:
            raise GeometryError(f"CAD file {path}: a boundary named '{INTERFACE}' is not shared by the fluid and "
                                f"the solid (it borders {' and '.join(sorted(media))} only)")
        elif name == "default" and 0 in (domin, domout):
            ngmesh.SetBCName(number - 1, FLUID_WALL if media == {FLUID} else SOLID_WALL)


def cad(dim: int = 3, maxh: float | None = None, *, path: str | Path | None = None, regions: Any = None) -> ngs.Mesh:
    """The solids (3D) or the faces in the plane z = 0 (2D) of a STEP (.step, .stp), BREP or IGES
    file, glued so that what they share is meshed conformingly, and meshed with ``maxh`` (default: a
    tenth of the bounding box's longest side). The mesh keeps its OCC geometry (``Curve``,
    projected refinement).

    Each solid (2D: face) is ``fluid`` or ``solid`` by `regions` (keys: numbers from 1 in file
    order, or names; values ``fluid`` / ``solid``) or else by its own name. The faces (2D: edges)
    shared by the fluid and the solid become ``interface`` (whatever the file calls them); other
    outer ones keep the file's name, else become ``fluid_wall`` / ``solid_wall``; those between two
    parts of the same medium are inner boundaries (named ``default``, traction-free)."""
    dim = _dimension("cad", dim)
    h = None if maxh is None else _positive("maxh", maxh)
    path, parts = _read_cad(_path_parameter(path, CAD_SUFFIXES), dim)
    for part, medium in zip(parts, _solid_regions(path, parts, regions, "solid" if dim == 3 else "face")):
        part.name = medium  # netgen's region name of a solid (3D) or a face (2D)
    shape = Glue(parts)
    if h is None:
        low, high = shape.bounding_box
        h = max(high[i] - low[i] for i in range(3)) / 10
    mesh = _mesh(shape, dim, h)
    _name_boundaries(mesh.ngmesh, path)
    if INTERFACE not in mesh.GetBoundaries():
        raise GeometryError(f"CAD file {path}: no {'face' if dim == 3 else 'edge'} is shared by the fluid and the "
                            f"solid, so there is no '{INTERFACE}' (do they touch?)")
    check_regions(mesh)
    return mesh


# ---------------------------------------------------------------------------------------------
# Dispatch by name
# ---------------------------------------------------------------------------------------------

KINDS: dict[str, dict[str, Any]] = {
    "paper_channel": {
        "dims": (2,),
        "maxh": {2: 0.15},
        "parameters": {"grading": 0.3},
        "description": "the paper's channel (0, 2.5) × (0, 0.41), solid, with a fluid disk of centre "
                       "(0.2, 0.2) and radius 0.05 (Section 5.3); Γ_F = ∅",
    },
    **{kind: {
        "dims": (2, 3),
        "maxh": DEFAULT_MAXH[kind],
        "parameters": {"size": 1.0, "radius": 0.25, "centre": None, "curvature_safety": 2.0},
        "description": f"a {inner} disk/ball (default centre: the middle) inside the {outer} square/cube "
                       f"(0, size)^dim; {empty} = ∅",
    } for kind, inner, outer, empty in (("fluid_in_solid", "fluid", "solid", "Γ_F"),
                                        ("solid_in_fluid", "solid", "fluid", "Γ_S"))},
    "fluid_over_solid": {
        "dims": (2, 3),
        "maxh": DEFAULT_MAXH["fluid_over_solid"],
        "parameters": {"width": 1.0, "solid_height": 0.5, "fluid_height": 0.5},
        "description": "a fluid rectangle/box on top of a solid one, flat interface at height solid_height",
    },
    "elastic_tube": {
        "dims": (2, 3),
        "maxh": DEFAULT_MAXH["elastic_tube"],
        "parameters": {"radius": 0.5, "length": 5.0, "wall": 0.1},
        "description": "a fluid cylinder along x inside a solid tube wall (2D: the axial section); "
                       "boundaries inflow, outflow, interface, solid_ends, solid_wall",
    },
    "mesh": {
        "dims": (2, 3),
        "maxh": {},
        "parameters": {"path": None},
        "description": "a mesh file: gmsh .msh (format 2.2 or 4.x, ASCII or binary; physical names fluid, solid, "
                       "interface, fluid_wall, solid_wall or other wall names) or netgen .vol",
    },
    "cad": {
        "dims": (2, 3),
        "maxh": {},
        "parameters": {"path": None, "regions": None},
        "description": "the solids (2D: the faces in the plane z = 0) of a STEP, BREP or IGES file, each fluid "
                       "or solid by its name or the regions table; maxh defaults to a tenth of the bounding box",
    },
}

_BUILDERS: dict[str, Callable[..., ngs.Mesh]] = {
    "fluid_in_solid": fluid_in_solid,
    "solid_in_fluid": solid_in_fluid,
    "fluid_over_solid": fluid_over_solid,
    "elastic_tube": elastic_tube,
    "cad": cad,
}


def build_geometry(kind: str, dim: int = 2, maxh: float | None = None, **parameters: Any) -> ngs.Mesh:
    """The mesh of geometry ``kind`` (a key of `KINDS`) in dimension ``dim`` with mesh size
    ``maxh`` (None: the kind's default) and the kind's ``parameters`` (missing ones take their
    defaults). Bad input is a one-line `GeometryError` naming the field, e.g.
    ``geometry.radius: expected a positive number, got -1``."""
    if not isinstance(kind, str) or kind not in KINDS:
        raise _fail("kind", f"one of {', '.join(KINDS)}", kind)
    spec = KINDS[kind]
    dim = _dimension(kind, dim, spec["dims"])
    for name in parameters:
        if name not in spec["parameters"]:
            allowed = ", ".join(spec["parameters"]) or "none"
            raise GeometryError(f"geometry.{name}: unknown parameter for kind '{kind}' (expected one of {allowed})")
    if kind == "mesh":
        if maxh is not None:
            raise GeometryError(f"geometry.maxh: not used for kind 'mesh' (the file fixes the mesh), got {maxh!r}")
        path = _path_parameter(parameters.get("path"), MESH_SUFFIXES)
        mesh = load_mesh(path)
        if mesh.dim != dim:
            raise GeometryError(f"geometry.dim: expected {dim}, but mesh file {path} is {mesh.dim}D")
        return mesh
    if kind == "paper_channel":
        h = spec["maxh"][2] if maxh is None else _positive("maxh", maxh)
        grading = _positive("grading", parameters.get("grading", spec["parameters"]["grading"]))
        if grading > 1:
            raise _fail("grading", "a number in (0, 1]", grading)
        return paper_channel(maxh=h, grading=grading)
    return _BUILDERS[kind](dim, maxh, **parameters)



def locked_fluid_cells(mesh: ngs.Mesh, dirichlet: str) -> list[int]:
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
            if el.mat == FLUID and all(v.nr in walled for v in el.vertices)]
