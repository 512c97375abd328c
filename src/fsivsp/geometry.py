"""Meshes conforming to the interface, with the region names the scheme expects.

Every mesh fsivsp works on has the volume regions ``fluid`` and ``solid`` and the
boundary regions ``interface`` (Γ), ``fluid_wall`` (Γ_F) and ``solid_wall`` (Γ_S);
Γ_F or Γ_S may be empty (Fig. 1 of the paper).

Builders (all return an ``ngsolve.Mesh`` that keeps its OCC geometry, so ``mesh.Curve(order)``
and ``refined(mesh, levels, project=True)`` follow the true curved boundaries):

- ``paper_channel``: the paper's 2D channel with a fluid disk (Section 5.3);
- ``fluid_in_solid``, ``solid_in_fluid``: a disk/ball of one medium inside a square/cube of the other;
- ``fluid_over_solid``: a fluid rectangle/box on top of a solid one (flat interface);
- ``elastic_tube``: a fluid cylinder inside a solid tube wall (2D: the axial section);
- ``load_mesh``: a gmsh ``.msh`` (version 2 ASCII, physical names) or netgen ``.vol`` file;
- ``build_geometry(kind, dim, maxh, **parameters)``: dispatch by name, with validation (``KINDS``).
"""
from __future__ import annotations

import contextlib
import io
import math
from numbers import Real
from pathlib import Path
from typing import Any, Callable, Sequence

import ngsolve as ngs
import netgen.meshing as nm
from netgen.occ import Box, Circle, Cylinder, Glue, MoveTo, OCCGeometry, Pnt, Rectangle, Sphere, X, Y, Z

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
    if old.dim == 3:
        return _without_geometry_3d(old)
    if old.dim != 2:
        raise GeometryError("geometry-free refinement is implemented for 2D and 3D meshes only")
    new = nm.Mesh(dim=2)
    points = [new.Add(nm.MeshPoint(nm.Pnt(*p.p))) for p in old.Points()]
    for index, name in enumerate(old.GetRegionNames(codim=0), start=1):
        new.SetMaterial(index, name)
    for index, name in enumerate(old.GetRegionNames(codim=1)):
        new.SetBCName(index, name)
    for el in old.Elements2D():
        new.Add(nm.Element2D(el.index, [points[v.nr - 1] for v in el.vertices]))
    for el in old.Elements1D():
        new.Add(nm.Element1D([points[v.nr - 1] for v in el.vertices], index=el.index))
    return ngs.Mesh(new)


def _without_geometry_3d(old: nm.Mesh) -> ngs.Mesh:
    """`without_geometry` for a tetrahedral mesh: points, face descriptors (with their
    boundary names and adjacent domains), surface and volume elements."""
    new = nm.Mesh(dim=3)
    points = [new.Add(nm.MeshPoint(nm.Pnt(*p.p))) for p in old.Points()]
    for index, name in enumerate(old.GetRegionNames(codim=0), start=1):
        new.SetMaterial(index, name)
    descriptors = list(old.FaceDescriptors())
    for fd in descriptors:
        new.Add(nm.FaceDescriptor(surfnr=fd.surfnr, domin=fd.domin, domout=fd.domout, bc=fd.bc))
    for fd in descriptors:
        new.SetBCName(fd.bc - 1, fd.bcname)
    for el in old.Elements2D():
        new.Add(nm.Element2D(el.index, [points[v.nr - 1] for v in el.vertices]))
    for el in old.Elements3D():
        new.Add(nm.Element3D(el.index, [points[v.nr - 1] for v in el.vertices]))
    return ngs.Mesh(new)


def refined(mesh: ngs.Mesh, levels: int, project: bool = True) -> ngs.Mesh:
    """``levels`` uniform red refinements (each triangle into four, each tetrahedron into eight, by
    the edge midpoints). With ``project`` the new boundary and interface nodes are moved onto the
    true (curved) geometry.

    netgen's red refinement, not NGSolve's ``Mesh.Refine`` (bisection of marked elements): on the
    same vertices, bisection leaves half of the triangles in a different pattern, so that the
    stress of the interpolated displacement is out of discrete equilibrium and the solid rings
    (velocity errors 2.6× the paper's at level 4 instead of 0.76×); in the 3D fluid ball of the examples
    it lowers the worst tetrahedron quality to 0.05 where red refinement keeps 0.09, and Taylor–Hood
    k = 1 converged at 1.6, not 2, in the pressure."""
    ngmesh = mesh.ngmesh.Copy() if project else without_geometry(mesh).ngmesh
    for _ in range(levels):
        ngmesh.Refine(adaptive=False)
    return ngs.Mesh(ngmesh)


def check_regions(mesh: ngs.Mesh) -> None:
    """Refuse a mesh that lacks a fluid, a solid or an interface."""
    materials, boundaries = set(mesh.GetMaterials()), set(mesh.GetBoundaries())
    for name in (FLUID, SOLID):
        if name not in materials:
            raise GeometryError(f"mesh: no volume region named '{name}' (found {sorted(materials)})")
    if INTERFACE not in boundaries:
        raise GeometryError(f"mesh: no boundary region named '{INTERFACE}' (found {sorted(boundaries)})")


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
    per mesh from the fluid cell adjacent to each interface facet.
    """
    normal = ngs.specialcf.normal(mesh.dim)
    coords = (ngs.x, ngs.y, ngs.z)[: mesh.dim]
    centre = (0.5,) if mesh.dim == 2 else (1 / 3, 1 / 3)
    signs = ngs.SurfaceL2(mesh, order=0, definedon=mesh.Boundaries(INTERFACE))
    sign = ngs.GridFunction(signs)
    for el in mesh.Elements(ngs.BND):
        if el.mat != INTERFACE:
            continue
        facet = el.edges[0] if mesh.dim == 2 else el.faces[0]
        fluid = [c for c in mesh[facet].elements if mesh[c].mat == FLUID]
        if len(fluid) != 1:
            raise GeometryError(f"mesh: interface facet {facet.nr} does not border exactly one fluid cell")
        trafo = mesh.GetTrafo(ngs.ElementId(el))  # must outlive the mesh point
        point = trafo(*centre)
        cell = [mesh[v].point for v in mesh[fluid[0]].vertices]
        into_solid = sum(n * (c(point) - sum(p[i] for p in cell) / len(cell))
                         for i, (n, c) in enumerate(zip(normal(point), coords)))
        sign.vec[signs.GetDofNrs(el)[0]] = 1.0 if into_solid > 0 else -1.0
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


def _gmsh_header(path: Path) -> None:
    """Refuse what `netgen.read_gmsh.ReadGmsh` cannot read (or would read without names):
    formats other than version 2 ASCII, files without ``$Elements`` or ``$PhysicalNames``."""
    try:
        with path.open("r", errors="replace") as f:
            lines = [line.strip() for line in f]
    except (OSError, UnicodeError) as error:
        raise GeometryError(f"mesh file {path}: cannot read ({error})") from None
    if "$MeshFormat" not in lines:
        raise GeometryError(f"mesh file {path}: not a gmsh mesh (no $MeshFormat section)")
    start = lines.index("$MeshFormat") + 1
    header = lines[start].split() if start < len(lines) else []
    if len(header) < 2 or not header[0].startswith("2") or header[1] != "0":
        version = " ".join(header[:2]) or "?"
        raise GeometryError(f"mesh file {path}: gmsh format '{version}' is not supported, "
                            "save it as version 2 ASCII (gmsh -format msh2)")
    if "$Elements" not in lines:
        raise GeometryError(f"mesh file {path}: no $Elements section")
    if "$PhysicalNames" not in lines:
        raise GeometryError(f"mesh file {path}: no $PhysicalNames section; name the physical groups "
                            f"'{FLUID}', '{SOLID}', '{INTERFACE}' (and '{FLUID_WALL}', '{SOLID_WALL}')")


def load_mesh(path: str | Path) -> ngs.Mesh:
    """A mesh from a file: gmsh ``.msh`` (version 2 ASCII; the physical names become the region
    names) or netgen ``.vol`` / ``.vol.gz``. The mesh must have the volume regions ``fluid`` and
    ``solid`` and the boundary region ``interface`` (`check_regions`); anything else is a
    `GeometryError` naming the file. A gmsh mesh has no geometry (refinement splits edges at their midpoints,
    ``Curve`` changes nothing); a ``.vol`` file saved from a mesh of an OCC geometry
    (``mesh.ngmesh.Save``) carries that geometry along."""
    path = Path(path)
    name = path.name.lower()
    suffix = next((s for s in MESH_SUFFIXES if name.endswith(s)), None)
    if suffix is None:
        raise GeometryError(f"mesh file {path}: unknown extension '{path.suffix}' "
                            f"(expected one of {', '.join(MESH_SUFFIXES)})")
    if not path.is_file():
        raise GeometryError(f"mesh file {path}: no such file")
    try:
        if suffix == ".msh":
            _gmsh_header(path)
            from netgen.read_gmsh import ReadGmsh

            with contextlib.redirect_stdout(io.StringIO()):  # ReadGmsh prints a warning about physical names
                mesh = ngs.Mesh(ReadGmsh(str(path)))
        else:
            mesh = ngs.Mesh(str(path))
    except GeometryError:
        raise
    except KeyError as error:
        raise GeometryError(f"mesh file {path}: physical group {error} has no entry in $PhysicalNames") from None
    except Exception as error:  # noqa: BLE001 - netgen raises bare Exceptions and IndexErrors
        detail = " ".join(str(error).split()) or type(error).__name__
        raise GeometryError(f"mesh file {path}: cannot read ({detail})") from None
    try:
        check_regions(mesh)
    except GeometryError as error:
        raise GeometryError(f"mesh file {path}: {str(error).removeprefix('mesh: ')}") from None
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
        "description": "a mesh file: gmsh .msh (version 2 ASCII, physical names fluid, solid, interface, "
                       "fluid_wall, solid_wall) or netgen .vol",
    },
}

_BUILDERS: dict[str, Callable[..., ngs.Mesh]] = {
    "fluid_in_solid": fluid_in_solid,
    "solid_in_fluid": solid_in_fluid,
    "fluid_over_solid": fluid_over_solid,
    "elastic_tube": elastic_tube,
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
        path = parameters.get("path")
        if not isinstance(path, (str, Path)) or not str(path):
            raise _fail("path", "the path of a .msh or .vol file", path)
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
