"""``fsivsp harmonic`` and ``fsivsp modes``: a frequency-domain case (`config.frequency`) through its spaces and
solves (`frequency`) to its files (`io.frequency`, a VTU series, summary.json), a progress line per frequency or
per converged eigenpair, SIGINT/SIGTERM as in ``fsivsp run`` (`runtime.stopping`): during set-up at once, else
after the current frequency (harmonic) or outer iteration (modes), with what was done written."""
from __future__ import annotations

import logging
import math
import signal
import time as clock
from pathlib import Path

import numpy as np

from ..config.boundaries import boundary_conditions
from ..config.frequency import FrequencyCase, HarmonicCase, ModesCase
from ..geometry.curved import curve
from ..model.fields import Field
from ..runtime import parallel
from ..runtime.logs import stage
from ..runtime.stopping import Interrupt, Terminated
from .loop import peak_memory

log = logging.getLogger(__name__)


class Stopped(Terminated):
    """A frequency-domain command stopped by ``signal`` after ``done`` of its ``total`` frequencies (harmonic) or
    with ``done`` of the modes asked for (modes), its results so far in ``out``."""

    def __init__(self, signum: int, done: int, total: int, what: str, out: Path):
        super().__init__(signum)
        self.done, self.total, self.what, self.out = done, total, what, out

    def message(self) -> str:
        how = "interrupted" if self.signum == signal.SIGINT else "terminated"
        return f"{how} after {self.done} of {self.total} {self.what}: the results so far are in {self.out}"


def case_spaces(case: FrequencyCase, complex: bool):
    """The spaces of a frequency-domain case (the cells curved if it says so), Dirichlet where a boundary has a
    velocity; and the boundary conditions as `Data` fields (`boundaries.boundary_conditions`)."""
    from ..fem.spaces import base_order, build_spaces

    conditions = boundary_conditions(case.boundaries, case.mesh, case.dim)
    velocity = conditions["boundary_velocity"]
    disc = case.discretisation
    with stage("spaces"):
        if disc.curved:
            curve(case.mesh, base_order(disc.family, disc.order))
        spaces = build_spaces(case.mesh, disc.family, disc.order, "|".join(velocity), complex=complex)
    return spaces, conditions


def summary_head(case: FrequencyCase, spaces, status: str) -> dict:
    """What both commands' summary.json start with: the case, its inputs, the mesh and the unknowns."""
    import ngsolve as ngs

    from ..fem.spaces import global_count

    vertices = ngs.H1(case.mesh, order=1)
    return {"case": str(case.path), "overrides": case.overrides, "status": status,
            "inputs": {"geometry": case.geometry, "materials": case.materials.as_dict(),
                       "family": case.discretisation.family, "order": case.discretisation.order},
            "mesh": {"vertices": global_count(vertices, vertices.FreeDofs()),
                     "cells": round(case.mesh.comm.Sum(case.mesh.ne))},
            "dofs": {"free": spaces.free_dofs(), "velocity": spaces.velocity.ndofglobal,
                     "pressure": global_count(spaces.pressure, spaces.pressure.FreeDofs())}}


def finished(summary: dict, started: float, seconds: dict[str, float]) -> dict:
    """``summary`` with the ``seconds`` of its stages and in total, the peak memory (every rank's) and the
    threads."""
    from ..runtime.threads import current

    memory = parallel.gather(peak_memory())
    return {**summary, "seconds": {**seconds, "total": clock.perf_counter() - started},
            "peak_memory_bytes": max(memory), "ranks": {"size": len(memory), "peak_memory_bytes": memory},
            "threads": current()}


class ComplexFields:
    """The VTU fields of complex solutions on ``spaces`` (complex), as `VTKSeries` writes them
    (`io.frequency.complex_fields`): a (v, p) shown by `show` with its s, û = v/s and σ̂ = Cε(û) formed from it."""

    def __init__(self, spaces, case: FrequencyCase, name: str, out: Path):
        import ngsolve as ngs

        from ..fem.forms import elastic_stress
        from ..io import VTKSeries
        from ..io.frequency import complex_fields

        self.state = ngs.GridFunction(spaces.mixed)
        self.per_s = (ngs.Parameter(1.0), ngs.Parameter(0.0))  # 1/s: real parameters (VTKOutput evaluates the
        per_s = self.per_s[0] + 1j * self.per_s[1]              # real part of a complex ParameterC in real mode)
        velocity, pressure = self.state.components
        fields = complex_fields(velocity, pressure, per_s * velocity,
                                per_s * elastic_stress(velocity, case.materials, case.dim), case.mesh)
        self.series = VTKSeries(out / "vtk", case.mesh, fields, name=name, subdivision=case.output["subdivision"],
                                continuous=case.output["continuous"])

    def write(self, values, s: complex, time: float, step: int) -> None:
        """Write the solution of X_h's (local) vector ``values`` (an NGSolve vector or numpy array) at ``s`` as
        ``step`` at ``time``."""
        self.state.vec.FV().NumPy()[:] = values if isinstance(values, np.ndarray) else values.FV().NumPy()
        self.per_s[0].Set((1 / s).real)
        self.per_s[1].Set((1 / s).imag)
        self.series.write(time, step)


def harmonic_data(case: HarmonicCase, conditions: dict[str, dict]):
    """The `frequency.harmonic.HarmonicData` of a harmonic case with its boundary ``conditions`` (`case_spaces`)."""
    from ..frequency.harmonic import HarmonicData

    return HarmonicData(case.dim, boundary_velocity=conditions["boundary_velocity"],
                        boundary_traction=conditions["boundary_traction"], phase=case.phases,
                        outlets=conditions["outlets"], supports=conditions["supports"],
                        **{key: Field(value) for key, value in case.data.items()})


def run_harmonic(case: HarmonicCase, out: Path, quiet: bool = False) -> dict:
    """The harmonic response at each of the case's frequencies (`frequency.harmonic.respond`) into ``out``:
    harmonic.csv and harmonic.png (with probes), vtk/harmonic.pvd (one VTU per frequency, its "time" the
    frequency), summary.json. Returns the summary."""
    from ..frequency.harmonic import Amplitudes, respond
    from ..io import Probes, write_summary
    from ..io.frequency import harmonic_plot, write_harmonic_csv
    from ..runtime.progress import tqdm
    from ..runtime.threads import fit

    started = clock.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    spaces, conditions = case_spaces(case, complex=True)
    fit(spaces.free_dofs())
    with stage("loads"):
        amplitudes = Amplitudes(spaces, harmonic_data(case, conditions))
    probes = Probes(case.mesh, points=case.output["probes"])
    output = ComplexFields(spaces, case, "harmonic", out) if case.output["vtk"] else None
    method = None if case.solver.method in ("auto", "direct") else case.solver.method
    setup = clock.perf_counter() - started
    solves, samples = [], []

    def finish(status: str) -> dict:
        done = [solve["frequency"] for solve in solves]
        if parallel.is_root() and len(probes.points):
            write_harmonic_csv(out / "harmonic.csv", probes, done, samples)
            harmonic_plot(out / "harmonic.png", probes, done, samples)
        summary = finished({**summary_head(case, spaces, status), "frequencies": case.frequencies,
                            "solves": solves}, started, {"setup": setup})
        if parallel.is_root():
            write_summary(out / "summary.json", summary)
        return summary

    with Interrupt() as interrupt, tqdm(total=len(case.frequencies), disable=quiet or not parallel.is_root(),
                                         unit="solve", desc=case.name) as bar:
        for frequency in case.frequencies:
            response = respond(spaces, case.materials, amplitudes, 2j * math.pi * frequency, method)
            solves.append({"frequency": frequency, "method": response.method, "residual": response.residual,
                           "seconds": response.seconds})
            samples.append(np.column_stack(probes.sample(response.velocity, response.pressure)))
            if output is not None:
                output.write(response.state.vec, response.s, frequency, len(solves) - 1)
            bar.update(1)
            bar.set_postfix_str(f"f = {frequency:g}, {response.method}, residual {response.residual:.1e}",
                                refresh=False)
            if interrupt.requested:
                finish("interrupted" if interrupt.requested == signal.SIGINT else "terminated")
                raise Stopped(interrupt.requested, len(solves), len(case.frequencies), "frequencies", out)
    return finish("completed")


def run_modes(case: ModesCase, out: Path, quiet: bool = False) -> dict:
    """The case's ``count`` oscillating modes nearest its frequency ``near`` (`frequency.modes.coupled_modes`) into
    ``out``: modes.csv, overdamped.csv, modes.png, vtk/modes.pvd (mode k at "time" k), summary.json. Returns the
    summary."""
    from ..fem.spaces import build_spaces
    from ..frequency.modes import coupled_modes
    from ..io import write_summary
    from ..io.frequency import modes_plot, write_modes_csv
    from ..runtime.progress import tqdm
    from ..runtime.threads import fit

    started = clock.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    spaces, _ = case_spaces(case, complex=False)
    fit(2 * spaces.free_dofs())
    with Interrupt() as interrupt, tqdm(total=case.count + 4, disable=quiet or not parallel.is_root(),
                                         unit="pair", desc=case.name) as bar:
        def monitor(converged: int, pairs: int) -> None:
            bar.total = max(pairs, converged)   # SLEPc may converge more pairs than asked for
            bar.update(converged - bar.n)

        found = coupled_modes(spaces, case.materials, case.count, case.near, dict(case.solver.petsc), monitor,
                              stop=lambda: bool(interrupt.requested))
    eigenpairs = clock.perf_counter() - started   # spaces, pencil, factorisation, iterations
    if parallel.is_root():
        write_modes_csv(out / "modes.csv", found.oscillating)
        write_modes_csv(out / "overdamped.csv", found.overdamped)
        modes_plot(out / "modes.png", found.oscillating, found.overdamped, found.target)
    if case.output["vtk"]:
        complex_spaces = build_spaces(case.mesh, spaces.family, spaces.order, spaces.dirichlet, complex=True)
        output = ComplexFields(complex_spaces, case, "modes", out)
        for index, mode in enumerate(found.oscillating, start=1):
            output.write(mode.state, mode.s, index, index)
    if found.static:
        log.info("modes: %d static eigenpair%s (s = 0: rigid motions of a free solid, a closed fluid's pressure) "
                 "excluded", found.static, "s" * (found.static > 1))
    signum = (interrupt.requested or signal.SIGINT) if found.stopped else None
    status = {None: "completed", signal.SIGINT: "interrupted"}.get(signum, "terminated")
    summary = finished({**summary_head(case, spaces, status), "count": case.count, "near": case.near,
                        "target": [found.target.real, found.target.imag],
                        "modes": [{"index": i, **m.record()} for i, m in enumerate(found.oscillating, start=1)],
                        "overdamped": [{"index": i, **m.record()} for i, m in enumerate(found.overdamped, start=1)],
                        "static": found.static, "eigensolver": found.solver}, started,
                       {"eigenpairs": eigenpairs})
    if parallel.is_root():
        write_summary(out / "summary.json", summary)
    if signum is not None:
        raise Stopped(signum, len(found.oscillating), case.count, "modes", out)
    return summary
