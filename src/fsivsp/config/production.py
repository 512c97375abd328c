"""Run case files (``fsivsp run CASE.toml``): every field read and validated before any heavy work
(`load_run_case`) into a `RunCase`, and its boundary conditions (`boundary_conditions`).

Case file sections: ``[geometry]`` (with ``refine``: uniform refinements; ``regions`` for mesh and CAD files),
``[materials]`` (lam/mu or young/poisson; ``[materials.NAME]`` a cell region's own), ``[time]``, ``[discretisation]``
(family, order, solver, tolerance, max_iterations, curved, initial_stress, initial_velocity), ``[data]``
(force_fluid, force_solid, velocity0, displacement0; default zero), ``[boundary.NAME]`` (`boundaries`; default: zero
velocity on fluid_wall and solid_wall, zero traction elsewhere), ``[output]`` (every, probes, lines, surfaces, vtk,
subdivision, continuous) and ``[checkpoint]`` (every).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..errors import CaseError, is_number, is_whole
from ..geometry import Phases, geometry_phases, refined, refined_part
from ..model.expressions import ExpressionError, parse_vector
from ..runtime import parallel
from .boundaries import check_boundaries, read_boundaries
from .case import Case, build_mesh, read_case, read_region_materials
from .overrides import case_document
from .readers import check_command, check_keys, section

RUN_SECTIONS = {"geometry", "materials", "time", "discretisation", "solver", "data", "boundary", "output", "checkpoint"}
DATA_KEYS = {"force_fluid", "force_solid", "velocity0", "displacement0"}
OUTPUT_KEYS = {"every", "probes", "lines", "surfaces", "subdivision", "vtk", "continuous"}
CHECKPOINT_KEYS = {"every"}
#: ``[geometry] refine``: uniform refinements of the generated or read mesh (each multiplies the cells by 2^d)
MAX_REFINE = 6


@dataclass(kw_only=True)
class RunCase(Case):
    """A validated production case (``fsivsp run``): a `Case` without an exact solution, with d, its mesh (built
    and refined at load, or ``refine`` refinements still to make: `refine_over_ranks`) and the media of its cell
    regions (``phases``), data, boundaries (`boundaries`: each (kind, value)), output and checkpoints."""

    dim: int
    data: dict[str, list]
    boundaries: dict[str, tuple[str, Any]]
    output: dict[str, Any]
    checkpoint_every: int
    mesh: Any = field(default=None, repr=False)
    overrides: dict[str, Any] = field(default_factory=dict)   # ``--set``: dotted key → value
    phases: Phases = field(default_factory=Phases)
    refine: int = 0   #: uniform refinements of ``mesh`` still to make


def _whole(table: dict, key: str, where: str, default: int) -> int:
    value = table.get(key, default)
    if not is_whole(value):
        raise CaseError(f"{where}.{key}: expected a positive whole number, got {value!r}")
    return value


def read_vector(value, field_name: str, dim: int) -> list:
    """d expressions (`model.expressions.parse_vector`), a bad one a `CaseError`."""
    try:
        return parse_vector(value, field_name, dim)
    except ExpressionError as error:
        raise CaseError(str(error)) from None


def _points(value, field_name: str, dim: int) -> list[tuple[float, ...]]:
    if not isinstance(value, list):
        raise CaseError(f"{field_name}: expected a list of points, got {value!r}")
    points = []
    for i, point in enumerate(value):
        if (not isinstance(point, list) or len(point) != dim
                or not all(is_number(c) for c in point)):
            raise CaseError(f"{field_name}[{i}]: expected a point of {dim} numbers, got {point!r}")
        points.append(tuple(float(c) for c in point))
    return points


def _flag(table: dict, key: str, default: bool) -> bool:
    value = table.get(key, default)
    if not isinstance(value, bool):
        raise CaseError(f"output.{key}: expected true or false, got {value!r}")
    return value


def read_output(table: dict, dim: int) -> dict[str, Any]:
    """``[output]``: every key checked, with its default where not given."""
    check_keys(table, OUTPUT_KEYS, "output")
    lines = []
    for i, line in enumerate(table.get("lines", [])):
        if not isinstance(line, dict) or set(line) - {"start", "end", "n"} or not {"start", "end"} <= set(line):
            raise CaseError(f"output.lines[{i}]: expected {{start = [...], end = [...], n = N}}, got {line!r}")
        start, end = _points([line["start"], line["end"]], f"output.lines[{i}]", dim)
        lines.append((start, end, _whole(line, "n", f"output.lines[{i}]", 20)))
    vtk, continuous = (_flag(table, key, default) for key, default in (("vtk", True), ("continuous", False)))
    subdivision = table.get("subdivision", 0)
    if not is_whole(subdivision, 0, 3):
        raise CaseError(f"output.subdivision: expected a whole number from 0 to 3, got {subdivision!r}")
    surfaces = table.get("surfaces", [])
    if not isinstance(surfaces, list) or not all(isinstance(name, str) for name in surfaces) \
            or len(set(surfaces)) != len(surfaces):
        raise CaseError(f"output.surfaces: expected a list of boundary names (\"interface\" too), got {surfaces!r}")
    return {"every": _whole(table, "every", "output", 10),
            "probes": _points(table.get("probes", []), "output.probes", dim),
            "lines": lines, "surfaces": surfaces, "vtk": vtk, "subdivision": subdivision, "continuous": continuous}


def check_surfaces(names: list[str], mesh) -> None:
    """``[output] surfaces`` name boundaries of the mesh."""
    present = set(mesh.GetBoundaries())
    for name in names:
        if name not in present:
            raise CaseError(f"output.surfaces: no boundary {name!r} in the mesh; expected some of "
                            f"{', '.join(sorted(present))}")


def refine_count(geometry: dict) -> int:
    """``[geometry] refine``, checked."""
    refine = geometry.get("refine", 0)
    if not is_whole(refine, 0, MAX_REFINE):
        raise CaseError(f"geometry.refine: expected a whole number from 0 to {MAX_REFINE}, got {refine!r}")
    return refine


def refined_mesh(geometry: dict, dim: int, project: bool):
    """The mesh of a validated ``[geometry]`` table, refined ``refine`` times (projected onto the geometry if
    ``project``)."""
    refine = refine_count(geometry)
    mesh = build_mesh(geometry, dim, skip=("refine",))
    return refined(mesh, refine, project) if refine else mesh


def load_run_case(source: str | Path | dict, overrides: dict | None = None, coarse: bool = False) -> RunCase:
    """Read and validate every field of a production case (a file or a dict, with the ``--set`` ``overrides``
    {dotted key: value} applied first, `overrides`), including the mesh's boundary names. ``coarse``: the mesh as
    generated or read, its ``[geometry] refine`` left to `refine_over_ranks` (``fsivsp run`` estimates first)."""
    path, doc = case_document(source, overrides)
    check_command(doc, path, "run")
    check_keys(doc, RUN_SECTIONS, "")
    fields, dim = read_case(doc, path, young_allowed=True)
    data_table = section(doc, "data", required=False)
    check_keys(data_table, DATA_KEYS, "data")
    data = {key: read_vector(value, f"data.{key}", dim) for key, value in data_table.items()}
    boundaries = read_boundaries(section(doc, "boundary", required=False), dim, path.parent)
    output = read_output(section(doc, "output", required=False), dim)
    checkpoint_table = section(doc, "checkpoint", required=False)
    check_keys(checkpoint_table, CHECKPOINT_KEYS, "checkpoint")
    every = _whole(checkpoint_table, "every", "checkpoint", 50)
    refine = refine_count(fields["geometry"])
    mesh = build_mesh(fields["geometry"], dim, skip=("refine",))
    phases = geometry_phases(fields["geometry"]["kind"], mesh, fields["geometry"].get("regions"))
    fields["materials"] = read_region_materials(section(doc, "materials"), fields["materials"], phases, dim,
                                                young_allowed=True, discretisation=fields["discretisation"])
    check_boundaries(boundaries, mesh, phases)
    check_surfaces(output["surfaces"], mesh)
    if refine and not coarse:
        mesh, refine = refined(mesh, refine, fields["discretisation"].project_refinement), 0
    return RunCase(coarse_mesh=None, exact=None, **fields, dim=dim, data=data, boundaries=boundaries, output=output,
                   checkpoint_every=every, mesh=mesh, overrides=dict(overrides or {}), phases=phases, refine=refine)


def refine_over_ranks(case: RunCase) -> RunCase:
    """``case`` with its ``refine`` refinements made; under mpirun rank 0's mesh handed out and every rank's part
    refined where it lives (`geometry.refined_part`; the case's mesh is then this rank's part)."""
    if not case.refine and not parallel.distributed():
        return case
    return replace(case, mesh=refined_part(case.mesh, case.refine, case.discretisation.project_refinement), refine=0)
