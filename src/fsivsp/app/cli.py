"""The command line: `fsivsp paper`, `study`, `run`, `harmonic`, `modes` and `matrix`, a handler each (their argument
types in `arguments`)."""
from __future__ import annotations

import logging
import os
import signal
import sys
import time
from dataclasses import replace
from pathlib import Path

from .. import __version__
from ..config.case import CaseError
from ..geometry import GeometryError
from ..io.checkpoint import CheckpointError
from ..model.data import INITIAL_STRESS, INITIAL_VELOCITY
from ..runtime import logs, parallel
from ..runtime.threads import ThreadsError, using
from ..solvers import AUTO, START_REDUCTION, TOLERANCE, NotConverged
from .arguments import (
    DEFAULT_THREADS,
    Parser,
    UsageError,
    chosen_scheme,
    dt_list,
    level_arg,
    levels_arg,
    non_negative_float,
    petsc_argument,
    positive_float,
    positive_int,
    scheme_options,
    solver_spec,
    threads_option,
    tolerance_arg,
)

log = logging.getLogger(__name__)

def build_parser() -> Parser:
    parser = Parser(prog="fsivsp", description="Velocity–stress–pressure finite elements for linear FSI "
                    "(González & Selgas, Appl. Numer. Math. 123, 2018).")
    parser.add_argument("--version", action="version", version=f"fsivsp {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    commands.required = True

    paper = commands.add_parser("paper", help="reproduce the experiment of Section 5.3 (Tables 1–8)",
                                description="Run the paper's experiment (MINI element, backward Euler, T = 1) "
                                "on uniformly refined meshes and print errors and rates next to the paper's.")
    paper.add_argument("--dt", type=positive_float, default=1e-2, help="time step (default 1e-2)")
    paper.add_argument("--levels", type=levels_arg, default=range(0, 5),
                       help="refinement levels, 'A-B' or 'A' (default 0-4)")
    paper.add_argument("--all", action="store_true",
                       help="run dt = 1e-1, 1e-2, 1e-3, 1e-4 (Tables 1–8) and write a Markdown report with a plot")
    paper.add_argument("--initial-stress", choices=INITIAL_STRESS, default=INITIAL_STRESS[0],
                       help="σ⁰ from the interpolated displacement (the paper's, default) or the L² projection (26)")
    paper.add_argument("--initial-velocity", choices=INITIAL_VELOCITY, default=INITIAL_VELOCITY[0],
                       help="v⁰ by nodal interpolation (the paper's, default) or the projections (22)–(23)")
    paper.add_argument("--project", action="store_true",
                       help="move new interface nodes onto the circle when refining (default: they stay at the "
                       "chords' midpoints; projection raises e(p) by 12-19%%)")
    paper.add_argument("--solver", default="auto", metavar="NAME",
                       help="auto (default: direct below the measured crossover, iterative above), direct, iterative, "
                       "or a direct method (pardiso, umfpack, sparsecholesky, scipy)")
    paper.add_argument("--tolerance", type=tolerance_arg, default=AUTO,
                       help="the iterative solver's tolerance: a number relative to the right-hand side, or auto "
                       f"(default: {TOLERANCE:g} or the warm start's residual reduced by {START_REDUCTION:g})")
    scheme_options(paper)
    petsc_argument(paper)
    paper.add_argument("--json", type=Path, default=None, metavar="PATH", help="write one record per level to PATH")
    paper.add_argument("--out", type=Path, default=None, metavar="DIR",
                       help="with --all: folder for report.md, convergence.png, results.json (default paper-report)")
    paper.add_argument("--jobs", type=positive_int, default=len(os.sched_getaffinity(0)),
                       help="with --all: parallel processes (default: the cores this process may use)")
    paper.add_argument("--quiet", action="store_true", help="no progress bars")
    threads_option(paper, f"{DEFAULT_THREADS}; with --all, one per job, a given N shared among its --jobs")
    paper.set_defaults(handler=paper_command)

    study = commands.add_parser("study", help="convergence study of a manufactured solution from a case file",
                                description="Uniform refinement study of the case file's [exact] solution: errors in "
                                "the paper's norms and rates (76) generalised to d dimensions.")
    study.add_argument("case", type=Path, metavar="CASE.toml", help="case file with an [exact] section")
    study.add_argument("--levels", type=levels_arg, default=range(0, 3),
                       help="refinement levels, 'A-B' or 'A' (default 0-2)")
    study.add_argument("--dt", type=dt_list, default=None, metavar="LIST",
                       help="a study in time instead: comma-separated, decreasing time steps on refinement --level")
    study.add_argument("--level", type=level_arg, default=0, help="the refinement level of a study in time (default 0)")
    scheme_options(study)
    study.add_argument("--json", type=Path, default=None, metavar="PATH",
                       help="write one record per level (per time step with --dt) to PATH")
    petsc_argument(study)
    study.add_argument("--quiet", action="store_true", help="no progress bars")
    threads_option(study, f"the case's [discretisation] threads, else {DEFAULT_THREADS}")
    study.set_defaults(handler=study_command)

    run = commands.add_parser("run", help="run a case file: ParaView series, probes, plots, checkpoints",
                              description="Production run of a case file (no [exact] section): writes a PVD/VTU "
                              "series, probes.csv, lines.csv, energy.png, probes.png, summary.json and checkpoints.")
    run.add_argument("case", type=Path, metavar="CASE.toml", help="the case file")
    run.add_argument("--out", type=Path, default=None, metavar="DIR", help="output folder (default: the case's name)")
    run.add_argument("--resume", action="store_true", help="continue from the last checkpoint in DIR/checkpoints")
    run.add_argument("--quiet", action="store_true", help="no progress bar, no set-up or estimate lines")
    run.add_argument("--dry-run", action="store_true",
                     help="print the unknowns and the estimated memory, time per step and output size; run nothing")
    run.add_argument("--force", action="store_true",
                     help="run even when the estimated memory exceeds MemAvailable or the output the free space")
    run.add_argument("--set", action="append", default=[], dest="overrides",
                     metavar="SECTION.KEY=VALUE", help="override a case-file key with a TOML value, e.g. "
                     "--set time.dt=1e-4 (validated like the file, recorded in summary.json; repeatable)")
    threads_option(run, f"the case's [discretisation] threads, else {DEFAULT_THREADS}")
    run.set_defaults(handler=run_command)

    harmonic = commands.add_parser("harmonic", help="the harmonic response of a case at its frequencies",
                                   description="One complex solve per frequency of the case file's [harmonic] "
                                   "frequencies (amplitudes of x, a phase per boundary): harmonic.csv and "
                                   "harmonic.png at the probes, vtk/harmonic.pvd, summary.json (docs/frequency.md).")
    harmonic.add_argument("case", type=Path, metavar="CASE.toml", help="the case file, with a [harmonic] section")
    frequency_options(harmonic)
    harmonic.set_defaults(handler=harmonic_command)

    modes = commands.add_parser("modes", help="the coupled modes of the fluid–structure system (SLEPc)",
                                description="The N coupled oscillating modes nearest a frequency (default: the "
                                "lowest) by shift-and-invert: modes.csv, overdamped.csv, modes.png, vtk/modes.pvd, "
                                "summary.json (docs/frequency.md). Runs under mpirun.")
    modes.add_argument("case", type=Path, metavar="CASE.toml", help="the case file (any but a study's)")
    modes.add_argument("--count", type=positive_int, default=None, metavar="N",
                       help="how many oscillating modes (default: the case's [modes] count, else 6)")
    modes.add_argument("--near", type=non_negative_float, default=None, metavar="F",
                       help="the frequency they are nearest to, in cycles per unit time (default: the case's "
                       "[modes] near, else the lowest modes)")
    frequency_options(modes)
    modes.set_defaults(handler=modes_command)

    matrix = commands.add_parser("matrix", help="run the verification matrix and print it as a Markdown table",
                                 description="Every (element, dimension, configuration) entry of "
                                 "fsivsp.experiments.verification.TABLE on three levels, with least-squares "
                                 "rates (76).")
    matrix.add_argument("--slow", action="store_true", help="include the slow entries (TH3 2D, 3D balls, TH2 3D)")
    matrix.add_argument("--markdown", type=Path, default=None, metavar="PATH", help="also write the table to PATH")
    matrix.add_argument("--json", type=Path, default=None, metavar="PATH", help="write the rates and records to PATH")
    matrix.add_argument("--readme", type=Path, default=None, metavar="PATH",
                        help="replace the table between <!-- matrix:begin --> and <!-- matrix:end --> in PATH "
                             "(the committed table of docs/verification.md has every entry: with --slow only)")
    matrix.add_argument("--quiet", action="store_true", help="no progress bar")
    threads_option(matrix)
    matrix.set_defaults(handler=matrix_command)
    return parser


def frequency_options(parser) -> None:
    """The options ``fsivsp harmonic`` and ``fsivsp modes`` share with ``fsivsp run``: --out, --quiet, --set,
    --threads, -v."""
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="output folder (default: the case's name)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar, no set-up lines")
    parser.add_argument("--set", action="append", default=[], dest="overrides", metavar="SECTION.KEY=VALUE",
                        help="override a case-file key with a TOML value (validated like the file, recorded in "
                        "summary.json; repeatable)")
    threads_option(parser, f"the case's [discretisation] threads, else {DEFAULT_THREADS}")


def paper_options(args, spec) -> dict:
    """The `paper_case` options of ``fsivsp paper`` (``spec``: its `SolverSpec`, `solver_spec`)."""
    from ..timestepping.schemes import Theta

    return {"initial_stress": args.initial_stress, "initial_velocity": args.initial_velocity,
            "project_refinement": args.project, "solver": spec, "time_scheme": chosen_scheme(args, Theta())}


def distributed_check(command: str, solver: str | None, initial_velocity: str, serial_only: str | None = None) -> None:
    """Under mpirun: refuse (UsageError) options a distributed run does not take (docs/mpi.md)."""
    from ..solvers import unsupported

    if not parallel.distributed():
        return
    if serial_only:
        raise UsageError(f"fsivsp {command}: {serial_only} does not run under mpirun (docs/mpi.md); run without mpirun")
    if reason := unsupported(solver, initial_velocity):
        raise UsageError(f"fsivsp {command}: {reason}")


def paper_command(args) -> int:
    from ..experiments.paper import TIME_STEPS, paper_case, run_jobs
    from ..experiments.report import paper_report, paper_tables
    from ..experiments.study import study
    from ..io.atomic import write_json

    spec = solver_spec(args, "fsivsp paper")
    distributed_check("paper", spec.method, args.initial_velocity, "--all" if args.all else None)
    options = paper_options(args, spec)
    scheme = options["time_scheme"]
    out = args.out or Path("paper-report" if scheme.name == "backward_euler" else f"paper-report-{scheme.name}")
    if not args.all:
        case = paper_case(args.dt, **options)
        with using(spec.threads):
            records = study(case, args.levels, quiet=args.quiet)
        for r in records:
            r["dt"] = args.dt
        print(paper_tables(records, args.dt, scheme.name))
        if args.json:
            write_json(args.json, records)
        return 0

    threads = spec.threads or args.jobs
    per_job = max(1, threads // args.jobs)   # the processes share the cores with their threads
    options["solver"] = replace(spec, threads=per_job)
    jobs = [(dt, level, options) for dt in TIME_STEPS for level in args.levels]
    jobs.sort(key=lambda job: (4.0 ** job[1]) / job[0], reverse=True)  # longest first
    start = time.perf_counter()
    results = run_jobs(jobs, min(args.jobs, threads), args.quiet)
    print(paper_report(out, results, options, time.perf_counter() - start, args.jobs, args.json))
    print(f"\nwrote {out / 'report.md'}, {out / 'convergence.png'}")
    return 0


def study_command(args) -> int:
    from ..config.case import load_study_case

    case = load_study_case(args.case)
    distributed_check("study", case.solver.method, case.discretisation.initial_velocity)
    case = replace(case, time_scheme=chosen_scheme(args, case.time_scheme),
                   solver=solver_spec(args, "fsivsp study", case.solver))
    with using(case.solver.threads):
        return study_records(args, case)


def study_records(args, case) -> int:
    """`study_command` once the case is read: the study, its tables and JSON."""
    from ..experiments.report import error_table, rate_table, time_table
    from ..experiments.study import study, time_study
    from ..io.atomic import write_json

    disc = case.discretisation
    element = f"{disc.family}{'' if disc.family == 'mini' else disc.order}"
    if args.dt is not None:
        records = time_study(case, args.level, args.dt, quiet=args.quiet)
        print(f"{case.name}: {element}, {case.time_scheme.name}, level {args.level}, T = {case.T:g}\n"
              f"{time_table(records)}")
    else:
        records = study(case, args.levels, quiet=args.quiet)
        print(f"{case.name}: {element}, {case.time_scheme.name}, dt = {case.dt:g}, T = {case.T:g}\n"
              f"{error_table(records)}")
        if len(records) > 1:
            print(f"\nrates (76)\n{rate_table(records)}")
    if args.json:
        write_json(args.json, records)
    return 0


def run_command(args) -> int:
    """``fsivsp run``: exit 0, 2 (bad input, or a run the estimate says does not fit: `estimate.before_run`),
    3 (not converged), 4 (a file could not be written), 130/143 (SIGINT/SIGTERM: the current step finished and
    checkpointed; during set-up at once, nothing written)."""
    from ..config.overrides import parse_overrides
    from ..io.atomic import WriteError
    from ..io.checkpoint import latest_checkpoint
    from ..runtime.stopping import Terminated, catch, raise_terminated
    from .api import run
    from .loop import SolveDiverged

    previous = catch(raise_terminated)   # set-up: stop at once
    try:
        out = args.out or Path(args.case.stem)
        threads = solver_spec(args, "fsivsp run").threads   # checked before the case is read
        summary = run(args.case, out, overrides=parse_overrides(args.overrides), resume=args.resume,
                      quiet=args.quiet, threads=threads, dry_run=args.dry_run, force=args.force)
        if summary is None:  # --dry-run
            return 0
    except (SolveDiverged, NotConverged) as error:
        log.error("%s", error)
        return 3
    except WriteError as error:
        last = parallel.shared(latest_checkpoint, out / "checkpoints")
        log.error("%s; last good checkpoint: %s", error, last if last else "none")
        return 4
    except Terminated as stop:
        print(stop.message(), file=sys.stderr)   # the command's last line (other ranks: `parallel.start`)
        return stop.exit_code
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    threads = summary["threads"]
    print(f"{summary['status']}: {summary['step']} steps to t = {summary['time']:g} on {threads} "
          f"thread{'s' * (threads > 1)}; results in {out}")
    return 0


def frequency_command(args, command: str, call) -> int:
    """``fsivsp harmonic`` and ``fsivsp modes`` (``call(out, overrides, threads)``, the API's function): exit 0,
    2 (bad input), 3 (a solve failed), 4 (a file could not be written), 130/143 (SIGINT/SIGTERM: during set-up at
    once, nothing written; later after the current frequency or outer iteration, with what was done written)."""
    from ..config.overrides import parse_overrides
    from ..io.atomic import WriteError
    from ..runtime.stopping import Terminated, catch, raise_terminated
    from ..solvers import SolverError

    previous = catch(raise_terminated)   # set-up: stop at once
    try:
        out = args.out or Path(args.case.stem)
        threads = solver_spec(args, f"fsivsp {command}").threads   # checked before the case is read
        summary = call(out, parse_overrides(args.overrides), threads)
    except SolverError as error:
        log.error("%s", error)
        return 3
    except WriteError as error:
        log.error("%s", error)
        return 4
    except Terminated as stop:
        print(stop.message(), file=sys.stderr)   # the command's last line (other ranks: `parallel.start`)
        return stop.exit_code
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    print(summary_line(command, summary, out))
    return 0


def summary_line(command: str, summary: dict, out: Path) -> str:
    """The command's last line of output: what it computed and where it is."""
    if command == "harmonic":
        solves = summary["solves"]
        worst = max(solve["residual"] for solve in solves)
        return (f"{summary['status']}: {len(solves)} frequencies, {summary['dofs']['free']} unknowns, residuals "
                f"<= {worst:.1e}; results in {out}")
    rows = ["mode  frequency     decay rate    damping ratio  residual"]
    rows += [f"{m['index']:>4}  {m['frequency']:<12.6g}  {m['decay_rate']:<12.6g}  {m['damping_ratio']:<13.4g}  "
             f"{m['residual']:.1e}" for m in summary["modes"]]
    return "\n".join(rows + [f"{summary['status']}: {len(summary['modes'])} oscillating modes "
                              f"({len(summary['overdamped'])} overdamped in overdamped.csv, {summary['static']} static "
                              f"excluded); results in {out}"])


def harmonic_command(args) -> int:
    from .api import harmonic

    distributed_check("harmonic", None, "interpolation", "the harmonic response")
    return frequency_command(args, "harmonic", lambda out, overrides, threads: harmonic(
        args.case, out, overrides=overrides, quiet=args.quiet, threads=threads))


def modes_command(args) -> int:
    from ..solvers import SolverError
    from ..solvers.petsc_init import use
    from .api import modes

    try:
        use("complex")   # before anything imports petsc4py: one PETSc build per process
    except SolverError as error:
        raise UsageError(f"fsivsp modes: {error}") from None
    return frequency_command(args, "modes", lambda out, overrides, threads: modes(
        args.case, out, count=args.count, near=args.near, overrides=overrides, quiet=args.quiet, threads=threads))


def matrix_command(args) -> int:
    distributed_check("matrix", None, "interpolation", "the verification matrix")
    if (args.readme and not args.slow
            and args.readme.resolve() == (Path(__file__).parents[3] / "docs" / "verification.md").resolve()):
        raise UsageError("fsivsp matrix: --readme docs/verification.md: its table has every entry, the slow ones "
                         "too; add --slow (or write elsewhere with --markdown)")
    with using(solver_spec(args, "fsivsp matrix").threads):
        return matrix_table(args)


def matrix_table(args) -> int:
    """`matrix_command` under its threads: the matrix (`verification.run_matrix`), its table and files."""
    from ..experiments.verification import MARKERS, run_matrix, with_table
    from ..io.atomic import write_json, write_text

    table, records = run_matrix(args.slow, args.quiet)
    print(table)
    if args.markdown:
        write_text(args.markdown, table + "\n")
    if args.readme:
        text = with_table(args.readme.read_text(), table)
        if text is None:
            raise UsageError(f"fsivsp matrix: --readme: {args.readme} has no {' ... '.join(MARKERS)} markers")
        write_text(args.readme, text)
    if args.json:
        write_json(args.json, records)
    return 0 if all(r["passed"] for r in records) else 1


def main(argv: list[str] | None = None) -> int:
    """Run a command; its exit code (under mpirun the same on every rank, which leave together)."""
    parallel.start()
    return parallel.settle(_main(argv))


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        with logs.verbosity(args.verbose):
            return args.handler(args)
    except (UsageError, CaseError, GeometryError, CheckpointError, ThreadsError) as error:
        log.error("%s", error)
        return 2
    except NotConverged as error:
        log.error("%s", error)
        return 3
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as error:  # under mpirun possibly on some ranks only: end them all
        if parallel.distributed():
            parallel.abort(error)
        raise


