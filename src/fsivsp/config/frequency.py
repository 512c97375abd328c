"""Frequency-domain case files (issue 35): ``fsivsp harmonic CASE`` (`load_harmonic_case`) and ``fsivsp modes CASE``
(`load_modes_case`), every field read and validated before any heavy work.

A harmonic case is a run case without ``[time]`` and with ``[harmonic] frequencies``: its body forces (``[data]``
force_fluid, force_solid) and boundary data (``[boundary.NAME]`` velocity or traction) are expressions of x, y, z
(no t), read as complex amplitudes, each boundary with an optional ``phase`` in degrees: the datum g(x) cos(2πft − φ)
(`frequency.harmonic.HarmonicData`). A modes case is any case but a study's: the modes are those of the unloaded
system (velocity boundaries at rest, traction boundaries free), ``[modes]`` count and near (the command line's
--count, --near override them). What a run case has that the command does not use ([time], [checkpoint], initial
data, ...) is named in one warning line and left unread.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CaseError, expected, is_number, is_whole
from ..geometry import geometry_phases
from ..model.expressions import T
from ..runtime.logs import warn
from .boundaries import BOUNDARY_KEYS, check_boundaries, read_boundaries
from .case import Discretisation, build_mesh, read_discretisation, read_geometry, read_materials
from .overrides import case_document
from .production import DATA_KEYS, OUTPUT_KEYS, RUN_SECTIONS, read_output, read_vector, refine_count, refined_mesh
from .readers import check_command, check_keys, section

#: ``[harmonic]``: the frequencies, a list or a range {start, stop, count, spacing}.
HARMONIC_KEYS = {"frequencies"}
RANGE_KEYS = {"start", "stop", "count", "spacing"}
SPACINGS = ("linear", "log")
#: At most this many frequencies in one case.
MAX_FREQUENCIES = 10_000
#: ``[modes]``: how many oscillating modes, nearest which frequency (default: the lowest).
MODES_KEYS = {"count", "near"}
DEFAULT_COUNT = 6
#: The ``[boundary.NAME]`` conditions of each frequency-domain command (`fsivsp run`'s flow-rate inflow is a
#: time-domain condition; the modes are those of the linear pencil, which an outlet's Z(s) would make rational).
FREQUENCY_KINDS = {"harmonic": ("velocity", "traction", "resistance", "windkessel", "support"),
                   "modes": ("velocity", "traction")}
#: ``[boundary.NAME] phase`` (harmonic only).
PHASE = "phase"
#: What each command reads of a run case's sections and keys; the others are named in a warning.
USED = {
    "harmonic": {"sections": {"geometry", "materials", "discretisation", "data", "boundary", "output", "harmonic"},
                 "data": {"force_fluid", "force_solid"}, "output": {"probes", "vtk", "subdivision", "continuous"},
                 "discretisation": {"family", "order", "curved", "threads", "solver"}},
    "modes": {"sections": {"geometry", "materials", "discretisation", "solver", "boundary", "output", "modes"},
              "data": set(), "output": {"vtk", "subdivision", "continuous"},
              "discretisation": {"family", "order", "curved", "threads"}},
}
#: ``fsivsp harmonic``'s ``[discretisation] solver``: a factorisation of complex matrices (the iterative solvers are
#: real; SuperLU's wrapper and sparsecholesky are not for this complex symmetric indefinite matrix).
HARMONIC_SOLVERS = ("auto", "direct", "pardiso", "umfpack")


@dataclass(kw_only=True)
class FrequencyCase:
    """A validated frequency-domain case: its mesh (built and refined at load), materials, `Discretisation` and
    `solvers.SolverSpec`, d, boundaries {name: (kind, d expressions)} and output."""

    name: str
    path: Path
    geometry: dict[str, Any]
    dim: int
    mesh: Any = field(repr=False)
    materials: Any
    discretisation: Discretisation
    solver: Any
    boundaries: dict[str, tuple[str, list]]
    output: dict[str, Any]
    overrides: dict[str, Any] = field(default_factory=dict)


@dataclass(kw_only=True)
class HarmonicCase(FrequencyCase):
    """`FrequencyCase` of ``fsivsp harmonic``: the ``frequencies`` (increasing), the body forces ``data`` {key: d
    expressions of x} and each boundary's ``phases`` in degrees."""

    frequencies: list[float]
    data: dict[str, list]
    phases: dict[str, float]


@dataclass(kw_only=True)
class ModesCase(FrequencyCase):
    """`FrequencyCase` of ``fsivsp modes``: ``count`` oscillating modes nearest the frequency ``near`` (None: the
    lowest); ``refine``: uniform refinements of ``mesh`` still to make (`load_modes_case`'s ``coarse``)."""

    count: int
    near: float | None
    refine: int = 0


def read_frequencies(value: Any) -> list[float]:
    """``frequencies``: a list of distinct positive numbers, or {start, stop, count, spacing = "linear" | "log"}
    (count numbers from start to stop, both included); increasing."""
    where = "harmonic.frequencies"
    if isinstance(value, dict):
        check_keys(value, RANGE_KEYS, where)
        for key in ("start", "stop", "count"):
            if key not in value:
                raise CaseError(f"{where}.{key}: missing; expected {{ start, stop, count[, spacing] }}")
        start, stop, count = value["start"], value["stop"], value["count"]
        if not is_number(start) or start <= 0:
            raise expected(f"{where}.start", "a positive frequency", start)
        if not is_number(stop) or stop < start:
            raise expected(f"{where}.stop", f"a frequency >= start = {start:g}", stop)
        if not is_whole(count, 1 if stop == start else 2, MAX_FREQUENCIES):
            raise expected(f"{where}.count", f"a whole number from 2 to {MAX_FREQUENCIES} (1 if stop = start)", count)
        spacing = value.get("spacing", "linear")
        if spacing not in SPACINGS:
            raise expected(f"{where}.spacing", " or ".join(f'"{s}"' for s in SPACINGS), spacing)
        values = (np.geomspace if spacing == "log" else np.linspace)(float(start), float(stop), count)
        return [float(f) for f in values]
    if not isinstance(value, list) or not value or len(value) > MAX_FREQUENCIES:
        raise expected(where, "a list of positive frequencies (cycles per unit time) or "
                       "{ start, stop, count, spacing }", value)
    for i, item in enumerate(value):
        if not is_number(item) or item <= 0:
            raise expected(f"{where}[{i}]", "a positive frequency", item)
    if len(set(value)) < len(value):
        raise expected(where, "distinct frequencies", value)
    return sorted(float(f) for f in value)


def read_phase(value: Any, where: str) -> float:
    """A boundary's ``phase``: a number of degrees."""
    if not is_number(value):
        raise expected(where, "a phase in degrees (a number)", value)
    return float(value)


def amplitude(value: Any, where: str, dim: int) -> list:
    """d expressions of x, y[, z] (a harmonic amplitude): t refused."""
    vector = read_vector(value, where, dim)
    if any(T in expr.free_symbols for expr in vector):
        raise expected(where, "expressions of x, y, z (a harmonic amplitude, the time factor is cos(2πft − phase): "
                       "no t)", value)
    return vector


def warn_unused(doc: dict, command: str, more: list[str]) -> None:
    """One warning line naming the sections and keys of ``doc`` that ``command`` does not read, and ``more``."""
    used = USED[command]
    names = [name for name in doc if name not in used["sections"]]
    for table in ("data", "output", "discretisation"):
        if table in used["sections"] and isinstance(doc.get(table), dict):
            names += [f"{table}.{key}" for key in doc[table] if key not in used[table]]
    if names + more:
        warn(f"not used by `fsivsp {command}`: {', '.join(names + more)}")


def _read(doc: dict, path: Path, command: str, overrides: dict | None) -> dict[str, Any]:
    """The `FrequencyCase` fields of ``doc`` for ``command`` but its mesh and boundaries."""
    check_command(doc, path, command)
    check_keys(doc, (RUN_SECTIONS - {"exact"}) | {"harmonic", "modes"}, "")
    geometry, dim = read_geometry(section(doc, "geometry"), path.parent)
    if geometry.get("regions"):
        raise CaseError(f"geometry.regions: `fsivsp {command}` takes one fluid and one solid material (cell regions of "
                        "their own materials: `fsivsp run`)")
    materials = read_materials(section(doc, "materials"), dim, young_allowed=True)
    disc, spec = read_discretisation(section(doc, "discretisation", required=False),
                                     section(doc, "solver", required=False))
    if command == "harmonic" and spec.method not in HARMONIC_SOLVERS:
        raise expected("discretisation.solver", f"one of {', '.join(HARMONIC_SOLVERS)} for `fsivsp harmonic` (a "
                       "factorisation of a complex matrix)", spec.method)
    output = section(doc, "output", required=False)
    check_keys(output, OUTPUT_KEYS, "output")
    output = read_output({key: value for key, value in output.items() if key in USED[command]["output"]}, dim)
    return {"name": path.stem, "path": path, "geometry": geometry, "dim": dim, "materials": materials,
            "discretisation": disc, "solver": spec, "output": output, "overrides": dict(overrides or {})}


def _boundaries(table: dict, dim: int, command: str) -> tuple[dict[str, tuple[str, list]], dict[str, float]]:
    """``[boundary.NAME]`` with each one's phase (``fsivsp harmonic``: its amplitudes checked for t; ``fsivsp modes``
    reads no phase, its caller names them unused)."""
    plain, phases = {}, {}
    for name, spec in table.items():
        if isinstance(spec, dict):
            check_keys(spec, BOUNDARY_KEYS | {PHASE}, f"boundary.{name}")
            if PHASE in spec:
                phases[name] = read_phase(spec[PHASE], f"boundary.{name}.{PHASE}")
            spec = {key: value for key, value in spec.items() if key != PHASE}
        plain[name] = spec
    boundaries = read_boundaries(plain, dim)
    for name, (kind, value) in boundaries.items():
        if kind not in FREQUENCY_KINDS[command]:
            *others, last = FREQUENCY_KINDS[command]
            raise CaseError(f"boundary.{name}.{kind}: `fsivsp {command}` takes {', '.join(others)} or {last} on a "
                            "boundary")
        if kind in ("velocity", "traction") and command == "harmonic":
            amplitude(plain[name][kind], f"boundary.{name}.{kind}", dim)
        if kind in ("resistance", "windkessel") and value.distal_pressure != 0:
            where = f"boundary.{name}." + ("windkessel." if kind == "windkessel" else "")
            raise expected(where + "distal_pressure", "0 in `fsivsp harmonic` (a constant pressure does not "
                           "oscillate: give an oscillating one as a traction)", value.distal_pressure)
    return boundaries, phases


def load_harmonic_case(source: str | Path | dict, overrides: dict | None = None) -> HarmonicCase:
    """Read and validate a harmonic case (a file or a dict; ``overrides`` as `production.load_run_case` takes
    them), its mesh built."""
    path, doc = case_document(source, overrides)
    fields = _read(doc, path, "harmonic", overrides)
    table = section(doc, "harmonic")
    check_keys(table, HARMONIC_KEYS, "harmonic")
    if "frequencies" not in table:
        raise CaseError("harmonic.frequencies: missing; expected a list of frequencies or { start, stop, count }")
    frequencies = read_frequencies(table["frequencies"])
    data_table = section(doc, "data", required=False)
    check_keys(data_table, DATA_KEYS, "data")
    data = {key: amplitude(value, f"data.{key}", fields["dim"]) for key, value in data_table.items()
            if key in USED["harmonic"]["data"]}
    boundaries, phases = _boundaries(section(doc, "boundary", required=False), fields["dim"], "harmonic")
    warn_unused(doc, "harmonic", [])
    mesh = refined_mesh(fields["geometry"], fields["dim"], fields["discretisation"].project_refinement)
    check_boundaries(boundaries, mesh, geometry_phases(fields["geometry"]["kind"], mesh))
    return HarmonicCase(**fields, mesh=mesh, boundaries=boundaries, frequencies=frequencies, data=data,
                        phases=phases)


def load_modes_case(source: str | Path | dict, overrides: dict | None = None, coarse: bool = False) -> ModesCase:
    """Read and validate a modes case (any case file but a study's; ``overrides`` as `production.load_run_case`
    takes them), its mesh built and refined, or with ``coarse`` its ``[geometry] refine`` left to the caller (under
    mpirun: refined where the cells live, `geometry.refined_part`)."""
    path, doc = case_document(source, overrides)
    fields = _read(doc, path, "modes", overrides)
    table = section(doc, "modes", required=False)
    check_keys(table, MODES_KEYS, "modes")
    count = table.get("count", DEFAULT_COUNT)
    if not is_whole(count):
        raise expected("modes.count", "a positive whole number", count)
    near = table.get("near")
    if near is not None and (not is_number(near) or near < 0):
        raise expected("modes.near", "a frequency >= 0", near)
    boundaries, phases = _boundaries(section(doc, "boundary", required=False), fields["dim"], "modes")
    loaded = [f"boundary.{name}.{kind} (its values: the modes take velocity boundaries at rest, traction ones free)"
              for name, (kind, values) in boundaries.items() if any(value != 0 for value in values)]
    loaded += [f"boundary.{name}.{PHASE}" for name in phases]
    warn_unused(doc, "modes", loaded)
    refine = refine_count(fields["geometry"]) if coarse else 0
    mesh = (build_mesh(fields["geometry"], fields["dim"], skip=("refine",)) if coarse
            else refined_mesh(fields["geometry"], fields["dim"], fields["discretisation"].project_refinement))
    check_boundaries(boundaries, mesh, geometry_phases(fields["geometry"]["kind"], mesh))
    return ModesCase(**fields, mesh=mesh, boundaries=boundaries, count=count,
                     near=None if near is None else float(near), refine=refine)
