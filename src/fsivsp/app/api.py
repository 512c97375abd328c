"""``fsivsp.run``: a production run from Python, the same entry as ``fsivsp run`` (`cli.run_command`).

    summary = fsivsp.run("examples/pressure_wave_2d.toml", out="wave2d", overrides={"time.T": 1e-3})
    summary = fsivsp.run({"geometry": {...}, "materials": {...}, "time": {...}})   # a case as a dict
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from ..config.production import load_run_case, refine_over_ranks
from ..geometry import shared_case
from ..runtime.logs import reporting, stage
from ..runtime.threads import using
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
        if threads is not None:
            loaded = replace(loaded, solver=replace(loaded.solver, threads=threads,
                                                    where={"threads": "fsivsp run: --threads"}))
        with using(loaded.solver.threads):
            return run_case(loaded, out, resume=resume, quiet=quiet)
