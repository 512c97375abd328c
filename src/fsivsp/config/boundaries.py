"""A run's ``[boundary.NAME]`` tables: one condition each, in svFSI's vocabulary, read and validated before any heavy
work (`read_boundaries`, then `check_boundaries` against the mesh), and the `Data` fields they make
(`boundary_conditions`).

- ``velocity = [...]`` (Dirichlet) or ``traction = [...]`` (σn), d expressions of x, y, z, t;
- ``flow = "Q(t)"`` or ``flow = { table = "q.csv" }`` (time, Q), with ``profile`` (parabolic, plug, womersley),
  ``period`` and ``harmonics``: a flow-rate inflow (`model.data.FlowRate`);
- ``resistance = R`` with ``distal_pressure``, or ``windkessel = { proximal, capacitance, distal, distal_pressure }``:
  a lumped outlet (`model.data.Windkessel`);
- ``support = { stiffness, damping }``: tissue support on a solid boundary (`model.data.Support`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CaseError, is_number, is_whole
from ..geometry import FLUID, FLUID_WALL, INTERFACE, PERIODIC, SOLID, SOLID_WALL, Phases, adjacent_regions
from ..geometry.sections import detect_section
from ..model.data import HARMONICS, PROFILES, FlowRate, Support, Windkessel, resistance
from ..model.expressions import ExpressionError, T, parse, parse_vector
from ..model.fields import Field
from .case import resolve_path
from .readers import check_keys, number

#: The condition of a ``[boundary.NAME]`` table: exactly one of these keys.
KINDS = ("velocity", "traction", "flow", "resistance", "windkessel", "support")
#: Keys that go with one kind.
COMPANIONS = {"flow": ("profile", "period", "harmonics"), "resistance": ("distal_pressure",)}
BOUNDARY_KEYS = set(KINDS) | {key for keys in COMPANIONS.values() for key in keys}
WINDKESSEL_KEYS = ("proximal", "capacitance", "distal", "distal_pressure")
SUPPORT_KEYS = ("stiffness", "damping")
#: At most this many harmonics of a Womersley inflow.
MAX_HARMONICS = 100
#: The medium a condition acts on.
MEDIUM = {"flow": FLUID, "resistance": FLUID, "windkessel": FLUID, "support": SOLID}


def _time_expression(value: Any, where: str) -> Any:
    """A number, or an expression of t alone (parsed by `model.expressions`)."""
    if is_number(value):
        return float(value)
    if not isinstance(value, str):
        raise CaseError(f"{where}: expected a number or an expression of t, got {value!r}")
    try:
        expr = parse(value, where)
    except ExpressionError as error:
        raise CaseError(str(error)) from None
    if not expr.free_symbols <= {T}:
        raise CaseError(f"{where}: expected an expression of t only, got {value!r}")
    return expr


def _table(spec: Any, where: str, folder: Path) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``{ table = "file.csv" }``: two columns, time and Q (a header line allowed), times increasing."""
    if not isinstance(spec, dict) or set(spec) != {"table"} or not isinstance(spec["table"], str):
        raise CaseError(f"{where}: expected an expression of t or {{ table = \"file.csv\" }}, got {spec!r}")
    path = Path(resolve_path(spec["table"], folder, f"{where}.table"))
    try:
        rows = [line.split(",") for line in path.read_text().splitlines() if line.strip()]
    except (OSError, UnicodeDecodeError) as error:
        raise CaseError(f"{where}.table: cannot read {path} ({error.__class__.__name__})") from None
    try:
        values = np.array([[float(c) for c in row] for row in rows[1:]] if rows and not _numeric(rows[0])
                          else [[float(c) for c in row] for row in rows])
    except ValueError:
        values = np.zeros((0, 0))
    if values.ndim != 2 or values.shape[0] < 2 or values.shape[1] != 2 or not np.all(np.isfinite(values)) \
            or np.any(np.diff(values[:, 0]) <= 0):
        raise CaseError(f"{where}.table: expected rows 'time, Q' of numbers with increasing times in {path}")
    return tuple(values[:, 0].tolist()), tuple(values[:, 1].tolist())


def _numeric(row: list[str]) -> bool:
    try:
        [float(c) for c in row]
    except ValueError:
        return False
    return True


def _positive(value: Any, where: str, strict: bool = True) -> float:
    if not is_number(value) or value < 0 or (strict and value == 0):
        raise CaseError(f"{where}: expected a {'positive' if strict else 'non-negative'} number, got {value!r}")
    return float(value)


def _flow(spec: dict, where: str, folder: Path) -> FlowRate:
    value = spec["flow"]
    flow = (_table(value, f"{where}.flow", folder) if isinstance(value, dict)
            else _time_expression(value, f"{where}.flow"))
    profile = spec.get("profile", PROFILES[0])
    if profile not in PROFILES:
        raise CaseError(f"{where}.profile: expected one of {', '.join(PROFILES)}, got {profile!r}")
    period = _positive(spec["period"], f"{where}.period") if "period" in spec else None
    if profile == "womersley" and period is None:
        raise CaseError(f"{where}.period: missing; a womersley profile needs the period of the flow")
    harmonics = spec.get("harmonics", HARMONICS)
    if not is_whole(harmonics, 1, MAX_HARMONICS):
        raise CaseError(f"{where}.harmonics: expected a whole number from 1 to {MAX_HARMONICS}, got {harmonics!r}")
    return FlowRate(flow, profile, period, harmonics)


def _windkessel(spec: Any, where: str) -> Windkessel:
    if not isinstance(spec, dict):
        raise CaseError(f"{where}: expected {{ proximal = R_p, capacitance = C, distal = R_d }}, got {spec!r}")
    check_keys(spec, WINDKESSEL_KEYS, where)
    values = {key: number(spec, key, where, minimum=0, strict=False) for key in WINDKESSEL_KEYS[:3]}
    if values["capacitance"] > 0 and values["distal"] == 0:
        raise CaseError(f"{where}.distal: expected a positive number with a capacitance, got 0")
    pressure = _time_expression(spec.get("distal_pressure", 0.0), f"{where}.distal_pressure")
    return Windkessel(values["proximal"], values["capacitance"], values["distal"], pressure)


def _support(spec: Any, where: str) -> Support:
    if not isinstance(spec, dict):
        raise CaseError(f"{where}: expected {{ stiffness = k, damping = c }}, got {spec!r}")
    check_keys(spec, SUPPORT_KEYS, where)
    values = {key: number(spec, key, where, default=0.0, minimum=0, strict=False) for key in SUPPORT_KEYS}
    if not any(values.values()):
        raise CaseError(f"{where}: expected a positive stiffness or damping, got {spec!r}")
    return Support(**values)


def read_boundary(name: str, spec: Any, dim: int, folder: Path) -> tuple[str, Any]:
    """(kind, value) of one ``[boundary.NAME]`` table (the module's docstring)."""
    where = f"boundary.{name}"
    if not isinstance(spec, dict):
        raise CaseError(f"{where}: expected a table [boundary.{name}] with one of {', '.join(KINDS)}, got {spec!r}")
    check_keys(spec, BOUNDARY_KEYS, where)
    kinds = [key for key in spec if key in KINDS]
    if len(kinds) != 1:
        raise CaseError(f"{where}: expected exactly one of {', '.join(KINDS)}, got "
                        f"{', '.join(kinds) if kinds else 'none'}")
    kind = kinds[0]
    strays = sorted(set(spec) - {kind, *COMPANIONS.get(kind, ())})
    if strays:
        owner = next(k for k, keys in COMPANIONS.items() if strays[0] in keys)
        raise CaseError(f"{where}.{strays[0]}: goes with {owner}, not with {kind}")
    if kind in ("velocity", "traction"):
        try:
            return kind, parse_vector(spec[kind], f"{where}.{kind}", dim)
        except ExpressionError as error:
            raise CaseError(str(error)) from None
    if kind == "flow":
        return kind, _flow(spec, where, folder)
    if kind == "resistance":
        pressure = _time_expression(spec.get("distal_pressure", 0.0), f"{where}.distal_pressure")
        return kind, resistance(_positive(spec["resistance"], f"{where}.resistance", strict=False), pressure)
    if kind == "windkessel":
        return kind, _windkessel(spec["windkessel"], f"{where}.windkessel")
    return kind, _support(spec["support"], f"{where}.support")


def read_boundaries(table: dict, dim: int, folder: Path = Path(".")) -> dict[str, tuple[str, Any]]:
    """Every ``[boundary.NAME]`` table as (kind, value); ``folder``: where a flow table's path starts."""
    return {name: read_boundary(name, spec, dim, folder) for name, spec in table.items()}


def check_boundaries(boundaries: dict, mesh, phases: Phases) -> None:
    """Every named boundary is one of the mesh's, not Γ nor a periodic side, and borders the medium its condition
    needs; a flow-rate inflow's boundary is a straight segment (2D) or a flat disk (3D) (`geometry.sections`)."""
    present = set(mesh.GetBoundaries())
    for name, (kind, _) in boundaries.items():
        if name == INTERFACE:
            raise CaseError("boundary.interface: the interface is not a boundary (its conditions are built in)")
        if name == PERIODIC:
            raise CaseError("boundary.periodic: the sides of [geometry] periodic take no condition (they are glued)")
        if name not in present:
            names = ", ".join(sorted(present - {INTERFACE}))
            raise CaseError(f"boundary.{name}: no boundary of that name in the mesh; expected one of {names}")
        medium = MEDIUM.get(kind)
        if medium is not None:
            media = {phases.phase(region) for region in adjacent_regions(mesh, name)}
            if media != {medium}:
                raise CaseError(f"boundary.{name}.{kind}: expected a boundary of the {medium}, got one of the "
                                f"{' and '.join(sorted(media))}")
        if kind == "flow":
            detect_section(mesh, name)


def boundary_conditions(boundaries: dict, mesh, dim: int) -> dict[str, dict]:
    """The `Data` fields of the boundary tables: ``boundary_velocity``, ``boundary_traction`` (walls default to rest,
    other boundaries to σn = 0), ``boundary_flow``, ``outlets``, ``supports``."""
    present = set(mesh.GetBoundaries())
    fields: dict[str, dict] = {"boundary_velocity": {}, "boundary_traction": {}, "boundary_flow": {}, "outlets": {},
                               "supports": {}}
    for name in (FLUID_WALL, SOLID_WALL):
        if name in present and name not in boundaries:
            fields["boundary_velocity"][name] = Field([0] * dim)
    target = {"velocity": "boundary_velocity", "traction": "boundary_traction", "flow": "boundary_flow",
              "resistance": "outlets", "windkessel": "outlets", "support": "supports"}
    for name, (kind, value) in boundaries.items():
        fields[target[kind]][name] = Field(value) if kind in ("velocity", "traction") else value
    return fields


def dirichlet(conditions: dict[str, dict]) -> str:
    """The boundaries where the velocity is prescribed: velocity tables, the walls at rest, flow-rate inflows."""
    return "|".join([*conditions["boundary_velocity"], *conditions["boundary_flow"]])
