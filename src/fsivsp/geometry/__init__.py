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

The modules: `regions` (the names, the media of the cell regions (`Phases`), their checks and counts, the
interface normal), `refine`
(geometry-free meshes, red refinement), `params` (checks of the ``[geometry]`` values), `shapes`
(the built-in shapes), `mesh_files` (gmsh and netgen files), `cad_files` (STEP, BREP, IGES) and
`registry` (``KINDS``, ``build_geometry``), `curved` (curved cells: onto the geometry, a mesh file's
second-order cells), `export` (a mesh as a gmsh file) and `distribute` (a mesh over MPI ranks, refined where its
cells live).
"""
from .cad_files import cad
from .distribute import distribute, refined_part, refined_parts, shared_case
from .mesh_files import GMSH_CELLS, MID_EDGES, load_mesh
from .params import CAD_SUFFIXES, MESH_SUFFIXES
from .refine import netgen_mesh, refined, without_geometry
from .regions import (
    FLUID,
    FLUID_WALL,
    INFLOW,
    INTERFACE,
    OUTFLOW,
    PERIODIC,
    SOLID,
    SOLID_ENDS,
    SOLID_WALL,
    GeometryError,
    Phases,
    adjacent_regions,
    check_distributable,
    check_regions,
    extent,
    interface_normal,
    is_periodic,
    locked_fluid_cells,
    mesh_phases,
    pattern,
    region_counts,
    vertex_count,
)
from .registry import KINDS, build_geometry, geometry_phases
from .shapes import (
    CHANNEL_HEIGHT,
    CHANNEL_WIDTH,
    DEFAULT_MAXH,
    DISK_CENTRE,
    DISK_RADIUS,
    elastic_tube,
    fluid_in_solid,
    fluid_over_solid,
    paper_channel,
    solid_in_fluid,
)

__all__ = [
    "extent", "FLUID", "SOLID", "INTERFACE", "FLUID_WALL", "SOLID_WALL", "INFLOW", "OUTFLOW", "SOLID_ENDS", "PERIODIC",
    "GeometryError", "Phases", "adjacent_regions", "mesh_phases", "pattern", "geometry_phases",
    "check_regions", "is_periodic", "check_distributable", "region_counts", "vertex_count", "interface_normal",
    "locked_fluid_cells",
    "netgen_mesh", "without_geometry", "refined",
    "CHANNEL_WIDTH", "CHANNEL_HEIGHT", "DISK_CENTRE", "DISK_RADIUS", "DEFAULT_MAXH",
    "paper_channel", "fluid_in_solid", "solid_in_fluid", "fluid_over_solid", "elastic_tube",
    "MESH_SUFFIXES", "CAD_SUFFIXES", "GMSH_CELLS", "MID_EDGES", "load_mesh", "cad",
    "KINDS", "build_geometry", "distribute", "refined_part", "refined_parts", "shared_case",
]
