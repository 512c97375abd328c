"""The command line: ``fsivsp paper`` (Section 5.3, Tables 1–8)."""
from __future__ import annotations

import argparse
import multiprocessing
import os
import signal
import sys
import time
from dataclasses import replace
from pathlib import Path

from . import __version__, parallel
from .case import CaseError
from .checkpoint import CheckpointError
from .geometry import GeometryError
from .scheme import INITIAL_STRESS, INITIAL_VELOCITY
from .solvers import TOLERANCE, NotConverged
from .threads import using
from .timeschemes import SCHEMES

MAX_LEVEL = 6


class UsageError(Exception):
    """Bad command-line input: reported in one line, exit code 2."""


class Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2, no usage dump
        raise UsageError(f"{self.prog}: {message}")


def levels_arg(text: str) -> range:
    """'A-B' or 'A' → range(A, B + 1)."""
    parts = text.split("-")
    try:
        if len(parts) not in (1, 2):
            raise ValueError
        low, high = int(parts[0]), int(parts[-1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected A-B or A with whole numbers, got {text!r}") from None
    if not 0 <= low <= high <= MAX_LEVEL:
        raise argparse.ArgumentTypeError(
            f"expected 0 <= A <= B <= {MAX_LEVEL}, got {text!r}")
    return range(low, high + 1)


def level_arg(text: str) -> int:
    """One refinement level, 0 <= level <= MAX_LEVEL."""
    try:
        level = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 0 <= level <= MAX_LEVEL:
        raise argparse.ArgumentTypeError(f"expected 0 <= level <= {MAX_LEVEL}, got {text!r}")
    return level


def positive_float(text: str) -> float:
    """A finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def tolerance_arg(text: str) -> float:
    """A number in (0, 1)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), got {text!r}")
    return value


def positive_int(text: str) -> int:
    """A whole number ≥ 1."""
    if not text.strip().isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return int(text)


def dt_list(text: str) -> list[float]:
    """'0.1,0.05,0.025': positive, strictly decreasing time steps (`study.check_time_steps`)."""
    from .study import check_time_steps

    try:
        return check_time_steps([float(item) for item in text.split(",")])
    except ValueError as error:
        raise argparse.ArgumentTypeError(f"expected comma-separated, positive, strictly decreasing time steps, "
                                         f"got {text!r}") from error


def scheme_options(parser: argparse.ArgumentParser) -> None:
    """--scheme and --theta (`timeschemes`); without them the case's (paper: backward Euler)."""
    parser.add_argument("--scheme", choices=SCHEMES, default=None,
                        help="time scheme (default: the case's [time] scheme; backward_euler)")
    parser.add_argument("--theta", type=float, default=None, help="θ of --scheme theta, in [1/2, 1] (default 0.5)")


def threads_option(parser: argparse.ArgumentParser, default: str) -> None:
    """--threads N (`threads.using`; the command enters it when the run starts)."""
    parser.add_argument("--threads", type=positive_int, default=None, metavar="N",
                        help=f"threads for assembly, set-up and solves (default: {default})")


def chosen_scheme(args, default):
    """The time scheme of --scheme/--theta, or ``default``."""
    from .timeschemes import time_scheme

    if args.scheme is None:
        if args.theta is not None:
            raise UsageError("--theta: only with --scheme theta")
        return default
    try:
        return time_scheme(args.scheme, args.theta)
    except ValueError as error:  # "theta: ..."
        raise UsageError(f"--{error}") from None


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
    paper.add_argument("--tolerance", type=tolerance_arg, default=TOLERANCE,
                       help=f"the iterative solver's relative tolerance (default {TOLERANCE:g})")
    scheme_options(paper)
    petsc_argument(paper)
    paper.add_argument("--json", type=Path, default=None, metavar="PATH", help="write one record per level to PATH")
    paper.add_argument("--out", type=Path, default=None, metavar="DIR",
                       help="with --all: folder for report.md, convergence.png, results.json (default paper-report)")
    paper.add_argument("--jobs", type=positive_int, default=os.cpu_count() or 1,
                       help="with --all: parallel processes (default: all cores)")
    paper.add_argument("--quiet", action="store_true", help="no progress bars")
    threads_option(paper, "1; with --all, shared among its --jobs")
    paper.set_defaults(handler=paper_command)

    study = commands.add_parser("study", help="convergence study of a manufactured solution from a case file",
                                description="Uniform refinement study of the case file's [exact] solution: errors in "
                                "the paper's norms and rates (76) generalised to d dimensions.")
    study.add_argument("case", type=Path, metavar="CASE.toml", help="case file with an [exact] section")
    study.add_argument("--levels", type=levels_arg, default=range(0, 3), help="refinement levels, 'A-B' or 'A' (default 0-2)")
    study.add_argument("--dt", type=dt_list, default=None, metavar="LIST",
                       help="a study in time instead: comma-separated, decreasing time steps on refinement --level")
    study.add_argument("--level", type=level_arg, default=0, help="the refinement level of a study in time (default 0)")
    scheme_options(study)
    study.add_argument("--json", type=Path, default=None, metavar="PATH",
                       help="write one record per level (per time step with --dt) to PATH")
    petsc_argument(study)
    study.add_argument("--quiet", action="store_true", help="no progress bars")
    threads_option(study, "the case's [discretisation] threads, else 1")
    study.set_defaults(handler=study_command)

    run = commands.add_parser("run", help="run a case file: ParaView series, probes, plots, checkpoints",
                              description="Production run of a case file (no [exact] section): writes a PVD/VTU "
                              "series, probes.csv, lines.csv, energy.png, probes.png, summary.json and checkpoints.")
    run.add_argument("case", type=Path, metavar="CASE.toml", help="the case file")
    run.add_argument("--out", type=Path, default=None, metavar="DIR", help="output folder (default: the case's name)")
    run.add_argument("--resume", action="store_true", help="continue from the last checkpoint in DIR/checkpoints")
    run.add_argument("--quiet", action="store_true", help="no progress bar, no estimate line")
    run.add_argument("--dry-run", action="store_true",
                     help="print the unknowns and the estimated memory, time per step and output size; run nothing")
    run.add_argument("--force", action="store_true",
                     help="run even when the estimated memory exceeds MemAvailable or the output the free space")
    threads_option(run, "the case's [discretisation] threads, else 1")
    run.set_defaults(handler=run_command)

    matrix = commands.add_parser("matrix", help="run the verification matrix and print it as a Markdown table",
                                 description="Every (element, dimension, configuration) entry of "
                                 "fsivsp.verification.TABLE on three levels, with least-squares rates (76).")
    matrix.add_argument("--slow", action="store_true", help="include the slow entries (TH3 2D, 3D balls, TH2 3D)")
    matrix.add_argument("--markdown", type=Path, default=None, metavar="PATH", help="also write the table to PATH")
    matrix.add_argument("--json", type=Path, default=None, metavar="PATH", help="write the rates and records to PATH")
    matrix.add_argument("--readme", type=Path, default=None, metavar="PATH",
                        help="replace the table between <!-- matrix:begin --> and <!-- matrix:end --> in PATH")
    matrix.add_argument("--quiet", action="store_true", help="no progress bar")
    threads_option(matrix, "1")
    matrix.set_defaults(handler=matrix_command)
    return parser


def petsc_options_arg(text: str) -> dict[str, str]:
    """``--petsc-options "-ksp_monitor -fieldsplit_velocity_pc_type gamg"``: PETSc options (without the
    ``fsivsp_`` prefix) as the case file's ``[solver.petsc]`` table takes them."""
    from .case import CaseError, read_petsc_options

    def is_name(word: str) -> bool:
        return word.startswith("-") and not word[1:2].isdigit() and word[1:2] != "."

    options: dict = {}
    name = None
    for word in text.split():
        if is_name(word):
            name = word.lstrip("-")
            options[name] = True
        elif name is not None and options[name] is True:
            options[name] = word
        else:
            raise argparse.ArgumentTypeError(f"expected '-name [value] ...', got {word!r}")
    try:
        return read_petsc_options(options, "--petsc-options")
    except CaseError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def petsc_argument(parser) -> None:
    parser.add_argument("--petsc-options", type=petsc_options_arg, default={}, metavar="'-OPTION [VALUE] ...'",
                        help="PETSc options of --solver petsc, e.g. '-ksp_monitor -fieldsplit_velocity_pc_type gamg' "
                             "(docs/solvers.md; also the case file's [solver.petsc] and PETSC_OPTIONS with the "
                             "fsivsp_ prefix)")


def paper_options(args) -> dict:
    from .timeschemes import Theta

    return {"initial_stress": args.initial_stress, "initial_velocity": args.initial_velocity,
            "project_refinement": args.project, "solver": args.solver, "tolerance": args.tolerance,
            "petsc_options": args.petsc_options, "time_scheme": chosen_scheme(args, Theta())}


def paper_job(job: tuple[float, int, dict]) -> dict:
    """One (Δt, level) run of the paper's experiment (a worker of ``paper --all``)."""
    from .geometry import refined
    from .paper import paper_case
    from .study import run_level

    dt, level, options, threads = job
    with using(threads):
        case = paper_case(dt, **options)
        record = run_level(case, refined(case.coarse_mesh(), level, case.project_refinement), level)
    record["dt"] = dt
    return record


def distributed_check(command: str, solver: str | None, initial_velocity: str, serial_only: str | None = None) -> None:
    """Under mpirun: refuse (UsageError) options a distributed run does not take (docs/mpi.md)."""
    from .solvers import unsupported

    if not parallel.distributed():
        return
    if serial_only:
        raise UsageError(f"fsivsp {command}: {serial_only} does not run under mpirun (docs/mpi.md); run without mpirun")
    if reason := unsupported(solver, initial_velocity):
        raise UsageError(f"fsivsp {command}: {reason}")


def paper_command(args) -> int:
    from .paper import TIME_STEPS, paper_case, reference_table, stress_time_floor
    from .report import convergence_plot, error_table, rate_table, write_atomic, write_json
    from .solvers import solver_names
    from .study import rates, study

    if args.solver not in solver_names():
        raise UsageError(f"fsivsp paper: --solver: expected one of {', '.join(solver_names())}, got {args.solver!r}")
    distributed_check("paper", args.solver, args.initial_velocity, "--all" if args.all else None)
    options = paper_options(args)
    scheme = options["time_scheme"]
    out = args.out or Path("paper-report" if scheme.name == "backward_euler" else f"paper-report-{scheme.name}")
    if not args.all:
        case = paper_case(args.dt, **options)
        with using(args.threads):
            records = study(case, args.levels, quiet=args.quiet)
        for r in records:
            r["dt"] = args.dt
        reference = reference_table(args.dt)
        print(f"Δt = {args.dt:g}: errors, the paper's in parentheses (Tables 1–4)")
        print(error_table(records, reference))
        if len(records) > 1:
            print(f"\nΔt = {args.dt:g}: rates (76), the paper's in parentheses (Tables 5–8)")
            print(rate_table(records, reference))
        print(f"\nestimated backward-Euler floor of e(σ) for this Δt: {stress_time_floor(args.dt):.4f}"
              + ("" if scheme.name == "backward_euler" else f" (this run: {scheme.name})"))
        if args.json:
            write_json(args.json, records)
        return 0

    threads = args.threads or args.jobs
    per_job = max(1, threads // args.jobs)   # the processes share the cores with their threads
    jobs = [(dt, level, options, per_job) for dt in TIME_STEPS for level in args.levels]
    jobs.sort(key=lambda job: (4.0 ** job[1]) / job[0], reverse=True)  # longest first
    start = time.perf_counter()
    results = run_jobs(jobs, min(args.jobs, threads), args.quiet)
    wall = time.perf_counter() - start
    series, references = {}, {}
    lines = ["# fsivsp: the experiment of Section 5.3", "",
             f"MINI element, {scheme.label}, T = 1; initial stress from the {args.initial_stress}; "
             f"refinement {'with' if args.project else 'without'} projection onto the circle. "
             f"Wall time {wall:.0f} s on {args.jobs} process(es).", "",
             "Errors with the paper's in parentheses; dofs in the paper's convention.", ""]
    for dt in TIME_STEPS:
        records = sorted((r for r in results if r["dt"] == dt), key=lambda r: r["level"])
        rates(records, 2)
        reference = reference_table(dt)
        label = f"Δt = {dt:g}"
        series[label], references[label] = records, reference
        lines += [f"## {label}", "", error_table(records, reference, markdown=True), "",
                  rate_table(records, reference, markdown=True), "",
                  f"Estimated backward-Euler time-error floor of e(σ): {stress_time_floor(dt):.4f}.", ""]
    lines += ["![convergence](convergence.png)", ""]
    out.mkdir(parents=True, exist_ok=True)
    convergence_plot(series, references, out / "convergence.png")
    write_atomic(out / "report.md", "\n".join(lines))
    all_records = [r for label in series for r in series[label]]
    write_json(args.json or out / "results.json", all_records)
    print("\n".join(lines))
    print(f"\nwrote {out / 'report.md'}, {out / 'convergence.png'}")
    return 0


def study_command(args) -> int:
    from .case import load_study_case, to_study

    case_file = load_study_case(args.case)
    case = to_study(case_file)
    distributed_check("study", case.solver, case.initial_velocity)
    case = replace(case, time_scheme=chosen_scheme(args, case.time_scheme),
                   petsc_options={**case.petsc_options, **args.petsc_options})
    with using(args.threads or case_file.discretisation.threads):
        return study_records(args, case)


def study_records(args, case) -> int:
    """`study_command` once the case is read: the study, its tables and JSON."""
    from .report import error_table, rate_table, time_table, write_json
    from .study import study, time_study

    element = f"{case.family}{'' if case.family == 'mini' else case.order}"
    if args.dt is not None:
        records = time_study(case, args.level, args.dt, quiet=args.quiet)
        print(f"{case.name}: {element}, {case.time_scheme.name}, level {args.level}, T = {case.T:g}\n"
              f"{time_table(records)}")
    else:
        records = study(case, args.levels, quiet=args.quiet)
        print(f"{case.name}: {element}, {case.time_scheme.name}, dt = {case.dt:g}, T = {case.T:g}\n{error_table(records)}")
        if len(records) > 1:
            print(f"\nrates (76)\n{rate_table(records)}")
    if args.json:
        write_json(args.json, records)
    return 0


def check_output_folder(out: Path) -> None:
    """``--out``: a folder that is or can be made and written (UsageError naming it, before any work)."""
    if out.exists() and not out.is_dir():
        raise UsageError(f"fsivsp run: --out {out}: expected a folder, found a file")
    existing = next(p for p in (out, *out.absolute().parents) if p.exists())
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(f"fsivsp run: --out {out}: {existing} is not a writable folder")


def run_command(args) -> int:
    """``fsivsp run``: exit 0, 2 (bad input, or a run the estimate says does not fit: `estimate.before_run`),
    3 (not converged), 4 (a file could not be written), 130/143 (SIGINT/SIGTERM: the current step finished and
    checkpointed; during set-up at once, nothing written)."""
    from .atomic import WriteError
    from .checkpoint import latest_checkpoint
    from .estimate import before_run
    from .run import SolveDiverged, Terminated, load_run_case, raise_terminated, run_case

    previous = signal.signal(signal.SIGTERM, raise_terminated)  # set-up: stop at once
    try:
        case = parallel.shared_case(load_run_case, args.case)
        out = args.out or Path(args.case.stem)
        check_output_folder(out)
        if before_run(case, out, dry_run=args.dry_run, force=args.force, quiet=args.quiet):
            return 0
        with using(args.threads or case.discretisation.threads) as threads:
            summary = run_case(case, out, resume=args.resume, quiet=args.quiet)
    except (SolveDiverged, NotConverged) as error:
        print(f"error: {error}", file=sys.stderr)
        return 3
    except WriteError as error:
        last = parallel.shared(latest_checkpoint, out / "checkpoints")
        if parallel.is_root():
            print(f"error: {error}; last good checkpoint: {last if last else 'none'}", file=sys.stderr)
        return 4
    except Terminated as stop:
        if parallel.is_root():
            print(stop.message(), file=sys.stderr)
        return stop.exit_code
    finally:
        signal.signal(signal.SIGTERM, previous)
    print(f"{summary['status']}: {summary['step']} steps to t = {summary['time']:g} on {threads} "
          f"thread{'s' * (threads > 1)}; results in {out}")
    return 0


def matrix_command(args) -> int:
    distributed_check("matrix", None, "interpolation", "the verification matrix")
    with using(args.threads):
        return matrix_table(args)


def matrix_table(args) -> int:
    """`matrix_command` under its threads: the entries, the table and its files."""
    from tqdm.auto import tqdm

    from .report import write_atomic, write_json
    from .verification import TABLE, TIME_STEPS, TIME_TABLE, markdown, run, run_time, time_markdown, worst

    entries = [e for e in TABLE if args.slow or not e.slow]
    time_entries = [e for e in TIME_TABLE if args.slow or not e.slow]
    results, time_results, records = [], [], []
    with tqdm(total=len(entries) + len(time_entries), disable=args.quiet, unit="entry") as bar:
        for entry in entries:
            rates, levels = run(entry)
            results.append((entry, rates))
            records.append({"entry": entry.label, "levels": list(entry.levels), "expected": entry.expected,
                            "rates": rates, "passed": worst(rates) >= entry.expected, "records": levels})
            bar.update(1)
        for entry in time_entries:
            rates, steps = run_time(entry)
            time_results.append((entry, rates))
            records.append({"entry": entry.label, "dt": list(TIME_STEPS), "expected": entry.order, "rates": rates,
                            "passed": all(abs(r - entry.order) <= entry.tolerance for k, r in rates.items() if k != "total"),
                            "records": steps})
            bar.update(1)
    table = markdown(results) + "\n\nRates in Δt (last pair of time steps, level 0):\n\n" + time_markdown(time_results)
    print(table)
    if args.markdown:
        write_atomic(args.markdown, table + "\n")
    if args.readme:
        text = args.readme.read_text()
        begin, end = "<!-- matrix:begin -->", "<!-- matrix:end -->"
        if begin not in text or end not in text:
            raise UsageError(f"fsivsp matrix: --readme: {args.readme} has no {begin} ... {end} markers")
        head, rest = text.split(begin, 1)
        write_atomic(args.readme, head + begin + "\n" + table + "\n" + end + rest.split(end, 1)[1])
    if args.json:
        write_json(args.json, records)
    return 0 if all(r["passed"] for r in records) else 1


def run_jobs(jobs: list, processes: int, quiet: bool) -> list[dict]:
    """Run independent (Δt, level) jobs on ``processes`` cores, with a progress bar."""
    from tqdm.auto import tqdm

    if processes == 1:
        return [paper_job(job) for job in tqdm(jobs, disable=quiet, unit="run")]
    context = multiprocessing.get_context("spawn")
    with context.Pool(processes) as pool:
        return list(tqdm(pool.imap_unordered(paper_job, jobs), total=len(jobs), disable=quiet, unit="run"))


def main(argv: list[str] | None = None) -> int:
    """Run a command; its exit code (under mpirun the same on every rank, which leave together)."""
    parallel.start()
    return parallel.settle(_main(argv))


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return args.handler(args)
    except (UsageError, CaseError, GeometryError, CheckpointError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except NotConverged as error:
        print(f"error: {error}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as error:  # under mpirun possibly on some ranks only: end them all
        if parallel.distributed():
            parallel.abort(error)
        raise


if __name__ == "__main__":
    sys.exit(main())
