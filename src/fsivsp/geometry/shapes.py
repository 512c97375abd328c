"""The built-in shapes, meshed by netgen's OCC kernel (each mesh keeps its geometry): the paper's
channel, a disk/ball of one medium inside the other, a fluid over a solid, an elastic tube."""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import ngsolve as ngs
from netgen.meshing import IdentificationType
from netgen.occ import Box, Circle, Cylinder, Glue, MoveTo, OCCGeometry, Pnt, Rectangle, Sphere, X, Y, Z, gp_Trsf

from .params import dimension, fail, point_parameter, positive
from .regions import FLUID, FLUID_WALL, INFLOW, INTERFACE, OUTFLOW, PERIODIC, SOLID, SOLID_ENDS, SOLID_WALL

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


DEFAULT_MAXH = {
    "fluid_in_solid": {2: 0.1, 3: 0.2},
    "solid_in_fluid": {2: 0.1, 3: 0.2},
    "fluid_over_solid": {2: 0.1, 3: 0.2},
    "elastic_tube": {2: 0.1, 3: 0.3},
}


def _mesh_size(kind: str, dim: int, maxh: Any) -> float:
    return DEFAULT_MAXH[kind][dim] if maxh is None else positive("maxh", maxh)


def occ_mesh(shape, dim: int, maxh: float, curvature_safety: float = 2.0) -> ngs.Mesh:
    """netgen's mesh; ``curvature_safety`` (netgen's curvaturesafety) bounds the element size on
    curved surfaces by radius / curvature_safety: lower it for coarse meshes of a ball."""
    geometry = OCCGeometry(shape, dim=dim)
    return ngs.Mesh(geometry.GenerateMesh(maxh=maxh, curvaturesafety=positive("curvature_safety", curvature_safety)))


def _inclusion(kind: str, dim: int, maxh: float | None, size: float, radius: float,
               centre: Sequence[float] | None, inner: str, outer: str, outer_wall: str,
               curvature_safety: float = 2.0) -> ngs.Mesh:
    """A disk/ball (region ``inner``, boundary ``interface``) strictly inside the square/cube
    (0, size)^dim (region ``outer``, outer boundary ``outer_wall``)."""
    dim = dimension(kind, dim)
    h = _mesh_size(kind, dim, maxh)
    size, radius = positive("size", size), positive("radius", radius)
    c = (size / 2,) * dim if centre is None else point_parameter("centre", centre, dim)
    if not all(0 < ci < size for ci in c):
        raise fail("centre", f"a point inside (0, {size:g})^{dim}", centre)
    gap = min(min(ci, size - ci) for ci in c)
    if radius >= gap:
        shape = "disk" if dim == 2 else "ball"
        raise fail("radius", f"a {shape} strictly inside (0, {size:g})^{dim}, i.e. radius < {gap:g} "
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
    return occ_mesh(Glue([rest, inclusion]), dim, h, curvature_safety)


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


def periodic_axes(value: Any, allowed: str) -> str:
    """``[geometry] periodic``: the axes (a string of letters from ``allowed``, each once) along which the
    shape is periodic; "" (the default) for none."""
    if not isinstance(value, str) or len(set(value)) != len(value) or not set(value) <= set(allowed):
        choices = " or ".join(f'"{a}"' for a in _axis_sets(allowed))
        raise fail("periodic", f"{choices} (the axes along which the shape repeats), or \"\" for none", value)
    return "".join(sorted(value))


def _axis_sets(allowed: str) -> list[str]:
    return [allowed[i] for i in range(len(allowed))] + ([allowed] if len(allowed) > 1 else [])


def identify(parts, dim: int, axes: str, lengths: dict[str, float]) -> None:
    """Make each of ``parts`` (OCC shapes, before they are glued) periodic along ``axes``: its two boundaries
    at the lowest and highest coordinate along an axis are named `PERIODIC` and identified by the translation
    by ``lengths[axis]`` (netgen's periodic identification, kept by `refine.refined`)."""
    directions = {"x": (X, (1, 0, 0)), "y": (Y, (0, 1, 0))}
    for part in parts:
        boundaries = part.edges if dim == 2 else part.faces
        for axis in axes:
            direction, unit = directions[axis]
            low, high = boundaries.Min(direction), boundaries.Max(direction)
            low.name = high.name = PERIODIC
            shift = gp_Trsf.Translation(tuple(lengths[axis] * c for c in unit))
            low.Identify(high, f"{PERIODIC}_{axis}", IdentificationType.PERIODIC, shift)


def fluid_over_solid(dim: int = 2, maxh: float | None = None, *, width: float = 1.0,
                     solid_height: float = 0.5, fluid_height: float = 0.5, periodic: str = "") -> ngs.Mesh:
    """Ω_S = (0, width)^(dim-1) × (0, solid_height), Ω_F = (0, width)^(dim-1) × (solid_height,
    solid_height + fluid_height): a flat interface at the top of the solid (y = solid_height in
    2D, z = solid_height in 3D). The rest of ∂Ω_F is ``fluid_wall``, of ∂Ω_S ``solid_wall``; ``periodic``
    ("x", and in 3D "y" or "xy"): the sides across those axes are instead the boundary ``periodic``, identified
    (`identify`): layers of infinite extent. ``maxh`` defaults to 0.1 (2D) / 0.2 (3D)."""
    kind = "fluid_over_solid"
    dim = dimension(kind, dim)
    h = _mesh_size(kind, dim, maxh)
    width = positive("width", width)
    hs, hf = positive("solid_height", solid_height), positive("fluid_height", fluid_height)
    axes = periodic_axes(periodic, "x" if dim == 2 else "xy")
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
    identify((solid, fluid), dim, axes, {"x": width, "y": width})
    return occ_mesh(Glue([solid, fluid]), dim, h)


def elastic_tube(dim: int = 2, maxh: float | None = None, *, radius: float = 0.5, length: float = 5.0,
                 wall: float = 0.1, periodic: str = "") -> ngs.Mesh:
    """A straight elastic tube along the x axis. 3D: Ω_F the cylinder of ``radius`` and
    ``length``, Ω_S the tube wall of thickness ``wall`` around it. 2D (the axial section):
    Ω_F = (0, L) × (-R, R), Ω_S = (0, L) × (R, R + wall) ∪ (0, L) × (-R - wall, -R).

    Boundaries: ``inflow`` (fluid, x = 0), ``outflow`` (fluid, x = L), ``interface``,
    ``solid_ends`` (the solid at x = 0 and x = L), ``solid_wall`` (the outer surface); there is
    no ``fluid_wall``. ``periodic = "x"``: the ends x = 0 and x = L (fluid and wall) are instead the boundary
    ``periodic``, identified (`identify`): a tube of infinite length. ``maxh`` defaults to 0.1 (2D) / 0.3 (3D);
    the wall gets at least one element across whatever ``maxh``."""
    kind = "elastic_tube"
    dim = dimension(kind, dim)
    h = _mesh_size(kind, dim, maxh)
    r, length, wall = positive("radius", radius), positive("length", length), positive("wall", wall)
    axes = periodic_axes(periodic, "x")
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
        identify((fluid, *walls), 2, axes, {"x": length})
        return occ_mesh(Glue([fluid, *walls]), 2, h)
    fluid = Cylinder(Pnt(0, 0, 0), X, r=r, h=length, bottom=INFLOW, top=OUTFLOW, mantle=INTERFACE)
    outer = Cylinder(Pnt(0, 0, 0), X, r=r + wall, h=length, bottom=SOLID_ENDS, top=SOLID_ENDS,
                     mantle=SOLID_WALL)
    solid = outer - fluid  # the inner mantle inherits the name `interface`
    solid.mat(SOLID)
    fluid.mat(FLUID)
    identify((solid, fluid), 3, axes, {"x": length})
    return occ_mesh(Glue([solid, fluid]), 3, h)
