"""``fsivsp.run``, ``fsivsp.harmonic`` and ``fsivsp.modes``: the commands from Python, the same entries as
``fsivsp run``, ``fsivsp harmonic`` and ``fsivsp modes`` (`cli`).

    summary = fsivsp.run("examples/pressure_wave_2d.toml", out="wave2d", overrides={"time.T": 1e-3})
    summary = fsivsp.run({"geometry": {...}, "materials": {...}, "time": {...}})   # a case as a dict
    summary = fsivsp.modes("examples/modes_2d.toml", out="modes", count=4)
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from ..config.frequency import load_harmonic_case, load_modes_case
from ..config.production import load_run_case, refine_over_ranks
from ..geometry import refined_part, shared_case
from ..runtime import parallel
from ..runtime.logs import reporting, stage
from ..runtime.threads import using
from .arguments import UsageError
from .frequency import run_harmonic, run_modes
from .loop import run_case  # at import, so that the name fsivsp.run stays this function


def run(case: str | Path | dict, out: str | Path | None = None, *, overrides: dict[str, Any] | None = None,
        resume: bool = False, quiet: bool = False, threads: int | None = None, dry_run: bool = False,
        force: bool = False) -> dict | None:
    """Run a case file (or a case as the dict its TOML parses to) into ``out`` (default: the case file's name,
    ``case`` for a dict) and return the summary (as in summary.json). ``overrides``: {"time.dt": 1e-4, ...} as
    ``--set``; ``threads``: default the case's [discretisation] threads, else `threads.default_threads`. Bad input
    raises `CaseError` (or `GeometryError`) with the one-line message of the command. Unless ``quiet``: the set-up
    stages on stderr (`stages`) and a progress bar. Before the mesh is refined (and under mpirun handed out) the
    estimate (`estimate.before_run`): ``dry_run`` prints it and returns None; a run it says does not fit raises
    `estimate.Refused` unless ``force``."""
    from .estimate import before_run, check_output_folder

    with reporting(not quiet):
        with stage("mesh"):
            loaded = shared_case(load_run_case, case, overrides=overrides, coarse=True)
        out = Path(out) if out is not None else Path(loaded.path.stem)
        check_output_folder(out)
        if before_run(loaded, out, dry_run=dry_run, force=force, quiet=quiet):
            return None
        with stage("refinement"):
            loaded = refine_over_ranks(loaded)
        loaded = _with_threads(loaded, threads, "run")
        with using(loaded.solver.threads):
            return run_case(loaded, out, resume=resume, quiet=quiet)


def _with_threads(case, threads: int | None, command: str):
    """``case`` with the thread count ``threads`` (None: the case's)."""
    if threads is None:
        return case
    where = {"threads": f"fsivsp {command}: --threads"}
    return replace(case, solver=replace(case.solver, threads=threads, where=where))


def harmonic(case: str | Path | dict, out: str | Path | None = None, *, overrides: dict[str, Any] | None = None,
             quiet: bool = False, threads: int | None = None) -> dict:
    """The harmonic response of a harmonic case file (or its dict; ``[harmonic] frequencies``, amplitudes of x)
    into ``out`` (default: the case file's name) as ``fsivsp harmonic``; returns the summary (summary.json). Bad
    input raises `CaseError` with the command's one-line message; serial only (under mpirun a `UsageError`)."""
    from .estimate import check_output_folder

    if parallel.distributed():
        raise UsageError("fsivsp harmonic: the harmonic response does not run under mpirun (a serial complex "
                         "factorisation per frequency); run without mpirun")
    with reporting(not quiet):
        with stage("mesh"):
            loaded = load_harmonic_case(case, overrides=overrides)
        out = Path(out) if out is not None else Path(loaded.path.stem)
        check_output_folder(out, "harmonic")
        loaded = _with_threads(loaded, threads, "harmonic")
        with using(loaded.solver.threads):
            return run_harmonic(loaded, out, quiet=quiet)


def modes(case: str | Path | dict, out: str | Path | None = None, *, count: int | None = None,
          near: float | None = None, overrides: dict[str, Any] | None = None, quiet: bool = False,
          threads: int | None = None) -> dict:
    """The ``count`` coupled oscillating modes nearest the frequency ``near`` (default: the case's ``[modes]``, else
    6 and the lowest) of a case file (or its dict) into ``out`` (default: the case file's name) as ``fsivsp modes``,
    serially or over the ranks of mpirun; returns the summary (summary.json). Bad input raises `CaseError` with the
    command's one-line message. Uses PETSc and SLEPc with complex scalars: a process that has imported the real
    petsc4py cannot (`solvers.petsc_init.use`)."""
    from ..solvers.petsc_init import use
    from .estimate import check_output_folder

    use("complex")
    given = {key: value for key, value in (("modes.count", count), ("modes.near", near)) if value is not None}
    with reporting(not quiet):
        with stage("mesh"):
            loaded = shared_case(load_modes_case, case, overrides={**(overrides or {}), **given},
                                 coarse=parallel.distributed())
        if parallel.distributed():   # rank 0 refines to a fair share, hands the mesh out, every rank refines its part
            with stage("refinement"):
                loaded = replace(loaded, mesh=refined_part(loaded.mesh, loaded.refine,
                                                           loaded.discretisation.project_refinement), refine=0)
        out = Path(out) if out is not None else Path(loaded.path.stem)
        check_output_folder(out, "modes")
        loaded = _with_threads(loaded, threads, "modes")
        with using(loaded.solver.threads):
            return run_modes(loaded, out, quiet=quiet)
