"""The geometry kinds of a case file's ``[geometry]`` table (`KINDS`) and `build_geometry`, which
validates a table and dispatches to the builder of its kind."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import ngsolve as ngs

from .cad_files import cad, kept_names
from .mesh_files import load_mesh
from .params import MESH_SUFFIXES, dimension, fail, path_parameter, positive
from .regions import GeometryError, Phases, mesh_phases
from .shapes import DEFAULT_MAXH, elastic_tube, fluid_in_solid, fluid_over_solid, paper_channel, solid_in_fluid

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
        "parameters": {"width": 1.0, "solid_height": 0.5, "fluid_height": 0.5, "periodic": ""},
        "description": "a fluid rectangle/box on top of a solid one, flat interface at height solid_height",
    },
    "elastic_tube": {
        "dims": (2, 3),
        "maxh": DEFAULT_MAXH["elastic_tube"],
        "parameters": {"radius": 0.5, "length": 5.0, "wall": 0.1, "periodic": ""},
        "description": "a fluid cylinder along x inside a solid tube wall (2D: the axial section); "
                       "boundaries inflow, outflow, interface, solid_ends, solid_wall",
    },
    "mesh": {
        "dims": (2, 3),
        "maxh": {},
        "parameters": {"path": None, "regions": None},
        "description": "a mesh file: gmsh .msh (format 2.2 or 4.x, ASCII or binary; physical names fluid, solid, "
                       "interface, fluid_wall, solid_wall or other wall names; other cell regions mapped to fluid or "
                       "solid by the regions table) or netgen .vol",
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
        raise fail("kind", f"one of {', '.join(KINDS)}", kind)
    spec = KINDS[kind]
    dim = dimension(kind, dim, spec["dims"])
    for name in parameters:
        if name not in spec["parameters"]:
            allowed = ", ".join(spec["parameters"]) or "none"
            raise GeometryError(f"geometry.{name}: unknown parameter for kind '{kind}' (expected one of {allowed})")
    if kind == "mesh":
        if maxh is not None:
            raise GeometryError(f"geometry.maxh: not used for kind 'mesh' (the file fixes the mesh), got {maxh!r}")
        path = path_parameter(parameters.get("path"), MESH_SUFFIXES)
        regions = parameters.get("regions")
        if regions is not None and not isinstance(regions, dict):
            raise fail("regions", "a table mapping cell region names to 'fluid' or 'solid'", regions)
        mesh = load_mesh(path, regions)
        if mesh.dim != dim:
            raise GeometryError(f"geometry.dim: expected {dim}, but mesh file {path} is {mesh.dim}D")
        return mesh
    if kind == "paper_channel":
        h = spec["maxh"][2] if maxh is None else positive("maxh", maxh)
        grading = positive("grading", parameters.get("grading", spec["parameters"]["grading"]))
        if grading > 1:
            raise fail("grading", "a number in (0, 1]", grading)
        return paper_channel(maxh=h, grading=grading)
    return _BUILDERS[kind](dim, maxh, **parameters)


def geometry_phases(kind: str, mesh: ngs.Mesh, regions: dict | None = None) -> Phases:
    """The `Phases` of a mesh that `build_geometry` made of ``kind`` with the ``regions`` table: a mesh file's cell
    regions by the table (`mesh_phases`); a CAD file's parts were named by their media, but those the table maps by a
    name of their own (`cad_files.kept_names`)."""
    return mesh_phases(mesh, kept_names(regions) if kind == "cad" else regions)
