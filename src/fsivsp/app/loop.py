"""Production runs: a `RunCase` (`runcase`) from its `Scheme` (`build_scheme`) through the time loop
(`run_case`: progress bar, checkpoints and resume, a stop by signal, divergence) to ParaView series, probes,
surface quantities, plots and a JSON summary."""
from __future__ import annotations

import logging
import math
import signal
import time as clock
from pathlib import Path

import numpy as np

from ..config.boundaries import boundary_conditions, dirichlet
from ..config.case import CaseError
from ..config.production import RunCase
from ..geometry.curved import curve
from ..model.fields import Field
from ..runtime import parallel
from ..runtime.logs import stage
from ..runtime.stopping import Interrupt, Terminated

log = logging.getLogger(__name__)


class SolveDiverged(RuntimeError):
    """The discrete solution stopped being finite."""


def build_scheme(case: RunCase):
    """The `Scheme` of a run case: its spaces (the cells curved if the case says so), data and solver."""
    from ..fem.spaces import base_order, build_spaces, resolve_solid_pressure
    from ..model.data import Data
    from ..model.manufactured import elastic_stress
    from ..timestepping.scheme import Scheme

    conditions = boundary_conditions(case.boundaries, case.mesh, case.dim)
    disc = case.discretisation
    with stage("spaces"):
        if disc.curved:
            curve(case.mesh, base_order(disc.family, disc.order))
        spaces = build_spaces(case.mesh, disc.family, disc.order, dirichlet(conditions), case.phases,
                              solid_pressure=resolve_solid_pressure(disc.solid_pressure, case.materials, case.phases))
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
        **conditions,
    )
    return Scheme(spaces, case.materials, data, case.dt, solver=case.solver, time_scheme=case.time_scheme)


def _skipped(path: Path, error: Exception) -> None:
    """Say, on resume, that an unreadable checkpoint was passed over."""
    log.warning("skipped %s: not a readable checkpoint (%s: %s); resuming from the one before", path,
                type(error).__name__, error)


def l2_norms(scheme) -> dict[str, float]:
    """‖v‖_{L²(Ω)}, ‖p‖_{L²(Ω_F)}, ‖σ‖_{L²(Ω_S)}."""
    import ngsolve as ngs

    from ..geometry import FLUID, SOLID
    from ..runtime.threads import integrate
    mesh, sigma, phases = scheme.spaces.mesh, scheme.stress, scheme.spaces.phases
    fluid, solid = (mesh.Materials(phases.pattern(medium)) for medium in (FLUID, SOLID))
    return {"velocity": math.sqrt(integrate(ngs.InnerProduct(scheme.velocity, scheme.velocity), mesh)),
            "pressure": math.sqrt(integrate(scheme.pressure**2, mesh, definedon=fluid)),
            "stress": math.sqrt(max(integrate(ngs.InnerProduct(sigma, sigma), mesh, definedon=solid), 0.0))}


def check_distributed(case: RunCase) -> None:
    """Under mpirun: what a distributed run does not do yet (docs/mpi.md) raises a one-line CaseError."""
    from ..solvers import unsupported

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
    """Run the case (its mesh refined: under mpirun this rank's part) into ``out``; returns the summary. Raises
    SolveDiverged on a non-finite step."""
    import ngsolve as ngs

    from ..fem.spaces import global_count
    from ..geometry import INTERFACE
    from ..io import (
        Probes,
        Surfaces,
        SurfaceTable,
        VTKSeries,
        energy_plot,
        line_plot,
        probe_plot,
        scheme_fields,
        surface_plot,
        write_summary,
    )
    from ..io.checkpoint import checkpoint_path, latest_checkpoint, load_checkpoint, prune_checkpoints, save_checkpoint
    from ..runtime.progress import tqdm
    from ..runtime.threads import current as current_threads
    from ..solvers import NotConverged
    from ..timestepping.cost import StepClock, step_cost

    if parallel.distributed():
        check_distributed(case)
    mesh_peak = peak_memory()   # the mesh ready, before spaces and assembly
    started = clock.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    checkpoints = out / "checkpoints"
    scheme = build_scheme(case)
    setup = clock.perf_counter() - started
    steps_clock = StepClock()   # the steps' wall time, for their cost in step-matrix products
    fields, stress = scheme_fields(scheme)
    series = VTKSeries(out / "vtk", case.mesh, fields, name="fields", subdivision=case.output["subdivision"],
                       refresh=stress, continuous=case.output["continuous"]) if case.output["vtk"] else None
    probes = Probes(case.mesh, points=case.output["probes"], lines=case.output["lines"], phases=case.phases)
    surfaces = SurfaceTable(Surfaces(scheme, case.output["surfaces"])) if case.output["surfaces"] else None
    walls = None
    if surfaces is not None and INTERFACE in case.output["surfaces"] and case.output["vtk"]:
        traction, wss = surfaces.surfaces.interface_fields()
        walls = VTKSeries(out / "vtk", case.mesh, {"traction": traction, "wss": wss,
                                                   "wss_magnitude": ngs.sqrt(ngs.InnerProduct(wss, wss))},
                          name="interface", subdivision=case.output["subdivision"],
                          refresh=surfaces.surfaces.interface_fields, boundary=INTERFACE)
    series_all = [s for s in (series, walls) if s is not None]
    history = {"time": [], "energy": []}
    resumed_from = None
    if resume and (latest := parallel.shared(latest_checkpoint, checkpoints, _skipped)) is not None:
        extra = load_checkpoint(latest, scheme)
        history = extra["history"]
        probes.restore(extra["probes"])
        for written, entries in zip(series_all, (extra["vtk"], extra.get("interface", []))):
            written.restore(entries)
        if surfaces is not None:
            surfaces.restore(extra["surfaces"])
        resumed_from = scheme.n
    else:
        history["time"].append(0.0)
        history["energy"].append(scheme.energy())
        probes.record(scheme)
        if surfaces is not None:
            surfaces.record(0.0)
        for written in series_all:
            written.write(0.0, 0)

    def extra() -> dict:
        return {"history": history, "probes": probes.state(), "vtk": series.entries if series else [],
                **({"interface": walls.entries} if walls else {}),
                **({"surfaces": surfaces.state()} if surfaces else {})}

    def finish(status: str) -> dict:
        if parallel.is_root():
            probes.write_csv(out)
            energy_plot(history["time"], history["energy"], out / "energy.png")
            if case.output["probes"]:
                probe_plot(probes, out / "probes.png")
            if case.output["lines"]:
                line_plot(probes, out / "lines.png")
            if surfaces is not None:
                surfaces.write_csv(out)
                surface_plot(surfaces.columns, surfaces.rows, out / "surfaces.png")
        spaces, memory, vertices = scheme.spaces, parallel.gather(peak_memory()), ngs.H1(case.mesh, order=1)
        ranks = {"size": len(memory), "peak_memory_bytes": memory, "mesh_peak_memory_bytes": parallel.gather(mesh_peak),
                 "cells": parallel.gather(case.mesh.ne),
                 "unknowns": parallel.gather(spaces.mixed.FreeDofs().NumSet()),   # shared ones on each rank
                 "setup_seconds": parallel.gather(setup)}
        summary = {
            "case": str(case.path), "overrides": case.overrides, "status": status, "step": scheme.n,
            "time": scheme.time,
            "inputs": {"geometry": case.geometry, "materials": case.materials.as_dict(), "T": case.T, "dt": case.dt,
                       "scheme": case.time_scheme.name, "theta": case.time_scheme.theta,
                       "family": case.discretisation.family, "order": case.discretisation.order},
            "mesh": {"vertices": global_count(vertices, vertices.FreeDofs()),
                     "cells": round(case.mesh.comm.Sum(case.mesh.ne))},
            "dofs": {"free": spaces.free_dofs(), "velocity": spaces.velocity.ndofglobal,
                     "pressure": global_count(spaces.pressure, spaces.pressure.FreeDofs()),
                     "stress": spaces.stress.ndofglobal},
            "solver": {**scheme.solver.statistics(), **step_cost(scheme, steps_clock, case.mesh.comm),
                       "spec": case.solver.record()},
            "seconds": {"setup": setup, "solver_setup": scheme.solver.factor_seconds,
                        "total": clock.perf_counter() - started},
            "peak_memory_bytes": max(memory),
            "ranks": ranks,
            "threads": current_threads(),
            "resumed_from": resumed_from,
            "energy": history,
            "l2_norms": l2_norms(scheme),
            **({"outlets": {o.name: {"pressure": o.pressure, "flow": float(o.state[2])} for o in scheme.outlets}}
               if scheme.outlets else {}),
        }
        if parallel.is_root():
            write_summary(out / "summary.json", summary)
        return summary

    def advance() -> None:
        try:
            with steps_clock:
                scheme.step()
        except NotConverged as error:
            last = latest_checkpoint(checkpoints)
            finish("not converged")
            raise NotConverged(f"step {scheme.n + 1} (t = {scheme.time + case.dt:g}): {error}; "
                               f"last good checkpoint: {last if last else 'none'}") from None

    every, keep = case.output["every"], case.checkpoint_every
    comm = case.mesh.comm  # decisions below are taken on every MPI rank alike
    with Interrupt() as interrupt, tqdm(total=case.steps, initial=scheme.n, disable=quiet or not parallel.is_root(),
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
            if surfaces is not None:
                surfaces.record(scheme.time)
            if scheme.n % every == 0 or scheme.n == case.steps:
                for written in series_all:
                    written.write(scheme.time, scheme.n)
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
