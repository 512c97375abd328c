"""Production runs: ``fsivsp run CASE.toml`` from a case file to ParaView series, probes,
plots and a JSON summary, with atomic checkpoints and resume.

Case file sections (all validated before any heavy work, see `load_run_case`):
``[geometry]`` (with ``refine``: uniform refinements), ``[materials]`` (lam/mu or young/poisson), ``[time]``,
``[discretisation]`` (family, order, solver, tolerance, max_iterations, curved, initial_stress, initial_velocity),
``[data]`` (force_fluid, force_solid, velocity0, displacement0; default zero),
``[boundary.NAME]`` (``velocity = [...]`` Dirichlet or ``traction = [...]`` σn; default: zero
velocity on fluid_wall and solid_wall, zero traction elsewhere), ``[output]`` (every, probes,
lines, vtk, subdivision, continuous) and ``[checkpoint]`` (every).
"""
from __future__ import annotations

import math
import signal
import sys
import time as clock
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import parallel
from .case import CaseError, Case, build_mesh, check_command, check_keys, read_case, section
from .expressions import ExpressionError, parse_vector
from .fields import Field
from .inputs import is_number, is_whole
from .geometry import FLUID_WALL, INTERFACE, SOLID_WALL, refined
from .overrides import case_document
from .quadratic import curve
from .stages import stage

RUN_SECTIONS = {"geometry", "materials", "time", "discretisation", "solver", "data", "boundary", "output", "checkpoint"}
DATA_KEYS = {"force_fluid", "force_solid", "velocity0", "displacement0"}
OUTPUT_KEYS = {"every", "probes", "lines", "subdivision", "vtk", "continuous"}
CHECKPOINT_KEYS = {"every"}
#: ``[geometry] refine``: uniform refinements of the generated or read mesh (each multiplies the cells by 2^d)
MAX_REFINE = 6


class SolveDiverged(RuntimeError):
    """The discrete solution stopped being finite."""


@dataclass(kw_only=True)
class RunCase(Case):
    """A validated production case (``fsivsp run``): a `Case` without an exact solution, with d, its mesh (built
    and refined at load), data, boundaries, output and checkpoints."""

    dim: int
    data: dict[str, list]
    boundaries: dict[str, tuple[str, list]]
    output: dict[str, Any]
    checkpoint_every: int
    mesh: Any = field(default=None, repr=False)
    overrides: dict[str, Any] = field(default_factory=dict)   # ``--set``: dotted key → value


def _whole(table: dict, key: str, where: str, default: int) -> int:
    value = table.get(key, default)
    if not is_whole(value):
        raise CaseError(f"{where}.{key}: expected a positive whole number, got {value!r}")
    return value


def _vector(value, field_name: str, dim: int) -> list:
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
    return {"every": _whole(table, "every", "output", 10), "probes": _points(table.get("probes", []), "output.probes", dim),
            "lines": lines, "vtk": vtk, "subdivision": subdivision, "continuous": continuous}


def read_boundaries(table: dict, dim: int) -> dict[str, tuple[str, list]]:
    boundaries = {}
    for name, spec in table.items():
        where = f"boundary.{name}"
        if not isinstance(spec, dict):
            raise CaseError(f"{where}: expected a table [boundary.{name}] with velocity or traction, got {spec!r}")
        check_keys(spec, {"velocity", "traction"}, where)
        if len(spec) != 1:
            raise CaseError(f"{where}: expected exactly one of velocity = [...] or traction = [...]")
        kind, value = next(iter(spec.items()))
        boundaries[name] = (kind, _vector(value, f"{where}.{kind}", dim))
    return boundaries


def check_boundaries(boundaries: dict, mesh) -> None:
    present = set(mesh.GetBoundaries())
    for name in boundaries:
        if name == INTERFACE:
            raise CaseError("boundary.interface: the interface is not a boundary (its conditions are built in)")
        if name not in present:
            names = ", ".join(sorted(present - {INTERFACE}))
            raise CaseError(f"boundary.{name}: no boundary of that name in the mesh; expected one of {names}")


def load_run_case(source: str | Path | dict, overrides: dict | None = None) -> RunCase:
    """Read and validate every field of a production case (a file or a dict, with the ``--set`` ``overrides``
    {dotted key: value} applied first, `overrides`), including the mesh's boundary names."""
    path, doc = case_document(source, overrides)
    check_command(doc, path, "run")
    check_keys(doc, RUN_SECTIONS, "")
    fields, dim = read_case(doc, path, young_allowed=True)
    data_table = section(doc, "data", required=False)
    check_keys(data_table, DATA_KEYS, "data")
    data = {key: _vector(value, f"data.{key}", dim) for key, value in data_table.items()}
    boundaries = read_boundaries(section(doc, "boundary", required=False), dim)
    output = read_output(section(doc, "output", required=False), dim)
    checkpoint_table = section(doc, "checkpoint", required=False)
    check_keys(checkpoint_table, CHECKPOINT_KEYS, "checkpoint")
    every = _whole(checkpoint_table, "every", "checkpoint", 50)
    refine = fields["geometry"].get("refine", 0)
    if not is_whole(refine, 0, MAX_REFINE):
        raise CaseError(f"geometry.refine: expected a whole number from 0 to {MAX_REFINE}, got {refine!r}")
    mesh = build_mesh(fields["geometry"], dim, skip=("refine",))
    if refine:
        mesh = refined(mesh, refine, fields["discretisation"].project_refinement)
    check_boundaries(boundaries, mesh)
    return RunCase(coarse_mesh=None, exact=None, **fields, dim=dim, data=data, boundaries=boundaries, output=output,
                   checkpoint_every=every, mesh=mesh, overrides=dict(overrides or {}))


def boundary_conditions(case: RunCase) -> tuple[dict[str, Field], dict[str, Field]]:
    """Dirichlet and traction data per boundary; walls default to rest, other boundaries to σn = 0."""
    present = set(case.mesh.GetBoundaries())
    velocity, traction = {}, {}
    for name in (FLUID_WALL, SOLID_WALL):
        if name in present and name not in case.boundaries:
            velocity[name] = Field([0] * case.dim)
    for name, (kind, value) in case.boundaries.items():
        (velocity if kind == "velocity" else traction)[name] = Field(value)
    return velocity, traction


def build_scheme(case: RunCase):
    from .manufactured import elastic_stress
    from .data import Data
    from .scheme import Scheme
    from .spaces import base_order, build_spaces

    velocity, traction = boundary_conditions(case)
    disc = case.discretisation
    with stage("spaces"):
        if disc.curved:
            curve(case.mesh, base_order(disc.family, disc.order))
        spaces = build_spaces(case.mesh, case.discretisation.family, case.discretisation.order, "|".join(velocity))
    zero = [0] * case.dim
    displacement0 = case.data.get("displacement0", zero)
    data = Data(
        velocity0=Field(case.data.get("velocity0", zero)),
        initial_velocity=disc.initial_velocity,
        displacement0=Field(displacement0),
        stress0=(Field(elastic_stress(displacement0, case.materials, case.dim))
                 if disc.initial_stress == "projection" else None),
        force_fluid=Field(case.data["force_fluid"]) if "force_fluid" in case.data else None,
        force_solid=Field(case.data["force_solid"]) if "force_solid" in case.data else None,
        boundary_velocity=velocity,
        boundary_traction=traction,
    )
    return Scheme(spaces, case.materials, data, case.dt, solver=case.solver, time_scheme=case.time_scheme)


class Terminated(KeyboardInterrupt):
    """The run was stopped by ``signal`` (SIGINT: Ctrl-C, SIGTERM: a scheduler's time limit, ``timeout``):
    ``step`` and ``time`` where it stopped, ``checkpoint`` the file written there (None: during set-up)."""

    def __init__(self, signum: int, step: int | None = None, time: float | None = None, checkpoint=None):
        super().__init__(signal.Signals(signum).name)
        self.signum, self.step, self.time, self.checkpoint = signum, step, time, checkpoint

    @property
    def exit_code(self) -> int:
        return 128 + self.signum

    def message(self) -> str:
        if self.step is None:
            return f"{'interrupted' if self.signum == signal.SIGINT else 'terminated'} during set-up: nothing written"
        what = "interrupted" if self.signum == signal.SIGINT else "terminated"
        return f"{what} at step {self.step} (t = {self.time:g}): checkpoint {self.checkpoint}; continue with --resume"


def _skipped(path: Path, error: Exception) -> None:
    """Say, on resume, that an unreadable checkpoint was passed over."""
    print(f"skipped {path}: not a readable checkpoint ({type(error).__name__}: {error}); resuming from the one before",
          file=sys.stderr)


def raise_terminated(signum, _frame) -> None:
    """A signal handler for set-up: stop at once."""
    raise Terminated(signum)


#: The signals that stop a run: during set-up at once (`raise_terminated`), in the loop after the step (`_Interrupt`).
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _Interrupt:
    """SIGINT and SIGTERM set a flag; the time loop finishes the current step, checkpoints and stops."""

    def __init__(self):
        self.requested = 0

    def __enter__(self):
        self._previous = [signal.signal(signum, self._handle) for signum in STOP_SIGNALS]
        return self

    def _handle(self, signum, _frame):
        self.requested = signum

    def __exit__(self, *exc):
        for signum, previous in zip(STOP_SIGNALS, self._previous):
            signal.signal(signum, previous)


def l2_norms(scheme) -> dict[str, float]:
    """‖v‖_{L²(Ω)}, ‖p‖_{L²(Ω_F)}, ‖σ‖_{L²(Ω_S)}."""
    import ngsolve as ngs

    from .geometry import FLUID, SOLID
    from .threads import integrate
    mesh, sigma = scheme.spaces.mesh, scheme.stress
    return {"velocity": math.sqrt(integrate(ngs.InnerProduct(scheme.velocity, scheme.velocity), mesh)),
            "pressure": math.sqrt(integrate(scheme.pressure**2, mesh, definedon=mesh.Materials(FLUID))),
            "stress": math.sqrt(max(integrate(ngs.InnerProduct(sigma, sigma), mesh, definedon=mesh.Materials(SOLID)), 0.0))}


def check_distributed(case: RunCase) -> None:
    """Under mpirun: what a distributed run does not do yet (docs/mpi.md) raises a one-line CaseError."""
    from .solvers import unsupported

    if reason := unsupported(case.solver.method, case.discretisation.initial_velocity):
        raise CaseError(f"discretisation.{reason}")


def peak_memory() -> int:
    """The peak resident memory of this process so far, in bytes: Linux's VmHWM (``ru_maxrss`` of a forked
    child starts from its parent's peak: 1 510 MiB reported for a child that used 8.7 MB)."""
    from .estimate import proc_bytes

    if (peak := proc_bytes("/proc/self/status", "VmHWM")) is not None:
        return peak
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def run_case(case: RunCase, out: Path, resume: bool = False, quiet: bool = False) -> dict:
    """Run the case into ``out``; returns the summary. Raises SolveDiverged on a non-finite step."""
    import ngsolve as ngs

    from .checkpoint import checkpoint_path, latest_checkpoint, load_checkpoint, prune_checkpoints, save_checkpoint
    from .output import Probes, VTKSeries, energy_plot, line_plot, probe_plot, scheme_fields, write_summary
    from .progress import tqdm
    from .solvers import NotConverged
    from .spaces import global_count
    from .threads import current as current_threads

    if parallel.distributed():
        check_distributed(case)
    started = clock.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    checkpoints = out / "checkpoints"
    scheme = build_scheme(case)
    setup = clock.perf_counter() - started
    fields, stress = scheme_fields(scheme)
    series = VTKSeries(out / "vtk", case.mesh, fields, name="fields", subdivision=case.output["subdivision"],
                       refresh=stress, continuous=case.output["continuous"]) if case.output["vtk"] else None
    probes = Probes(case.mesh, points=case.output["probes"], lines=case.output["lines"])
    history = {"time": [], "energy": []}
    resumed_from = None
    if resume and (latest := parallel.shared(latest_checkpoint, checkpoints, _skipped)) is not None:
        extra = load_checkpoint(latest, scheme)
        history = extra["history"]
        probes.restore(extra["probes"])
        if series is not None:
            series.restore(extra["vtk"])
        resumed_from = scheme.n
    else:
        history["time"].append(0.0)
        history["energy"].append(scheme.energy())
        probes.record(scheme)
        if series is not None:
            series.write(0.0, 0)

    def extra() -> dict:
        return {"history": history, "probes": probes.state(), "vtk": series.entries if series else []}

    def finish(status: str) -> dict:
        if parallel.is_root():
            probes.write_csv(out)
            energy_plot(history["time"], history["energy"], out / "energy.png")
            if case.output["probes"]:
                probe_plot(probes, out / "probes.png")
            if case.output["lines"]:
                line_plot(probes, out / "lines.png")
        spaces, memory, vertices = scheme.spaces, parallel.gather(peak_memory()), ngs.H1(case.mesh, order=1)
        summary = {
            "case": str(case.path), "overrides": case.overrides, "status": status, "step": scheme.n, "time": scheme.time,
            "inputs": {"geometry": case.geometry, "materials": case.materials.as_dict(), "T": case.T, "dt": case.dt,
                       "scheme": case.time_scheme.name, "theta": case.time_scheme.theta,
                       "family": case.discretisation.family, "order": case.discretisation.order},
            "mesh": {"vertices": global_count(vertices, vertices.FreeDofs()),
                     "cells": round(case.mesh.comm.Sum(case.mesh.ne))},
            "dofs": {"free": spaces.free_dofs(), "velocity": spaces.velocity.ndofglobal,
                     "pressure": global_count(spaces.pressure, spaces.pressure.FreeDofs()),
                     "stress": spaces.stress.ndofglobal},
            "solver": {**scheme.solver.statistics(), "spec": case.solver.record()},
            "seconds": {"setup": setup, "solver_setup": scheme.solver.factor_seconds,
                        "total": clock.perf_counter() - started},
            "peak_memory_bytes": max(memory),
            "ranks": {"size": len(memory), "peak_memory_bytes": memory},
            "threads": current_threads(),
            "resumed_from": resumed_from,
            "energy": history,
            "l2_norms": l2_norms(scheme),
        }
        if parallel.is_root():
            write_summary(out / "summary.json", summary)
        return summary

    def advance() -> None:
        try:
            scheme.step()
        except NotConverged as error:
            last = latest_checkpoint(checkpoints)
            finish("not converged")
            raise NotConverged(f"step {scheme.n + 1} (t = {scheme.time + case.dt:g}): {error}; "
                               f"last good checkpoint: {last if last else 'none'}") from None

    every, keep = case.output["every"], case.checkpoint_every
    comm = case.mesh.comm  # decisions below are taken on every MPI rank alike
    with _Interrupt() as interrupt, tqdm(total=case.steps, initial=scheme.n, disable=quiet or not parallel.is_root(),
                                         unit="step", desc=case.path.stem) as bar:
        while scheme.n < case.steps:
            advance()
            if not comm.Min(float(np.all(np.isfinite(scheme.state.vec.FV().NumPy())))):
                last = latest_checkpoint(checkpoints)
                finish("diverged")
                raise SolveDiverged(f"the solution is not finite at step {scheme.n} (t = {scheme.time:g}); "
                                    f"last good checkpoint: {last if last else 'none'}")
            history["time"].append(scheme.time)
            history["energy"].append(scheme.energy())
            probes.record(scheme)
            if series is not None and (scheme.n % every == 0 or scheme.n == case.steps):
                series.write(scheme.time, scheme.n)
            interrupted = int(comm.Max(float(interrupt.requested)))
            if scheme.n % keep == 0 or interrupted:
                written = save_checkpoint(checkpoint_path(checkpoints, scheme.n), scheme, extra())
                parallel.shared(prune_checkpoints, checkpoints, 2)
            bar.update(1)
            bar.set_postfix_str(f"{scheme.solver.progress()}, {peak_memory() / 2**30:.2f} GiB", refresh=False)
            if interrupted:
                finish("interrupted" if interrupted == signal.SIGINT else "terminated")
                raise Terminated(interrupted, scheme.n, scheme.time, written)
    return finish("completed")
