"""The command line's vocabulary: argument types (levels, positive numbers, tolerances, time steps, PETSc
options) and the options several commands share, each bad value one line (`UsageError`, exit code 2)."""
from __future__ import annotations

import argparse

from ..errors import is_number, read_number
from ..timestepping.schemes import SCHEMES

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
    value = read_number(text)
    if not (is_number(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def non_negative_float(text: str) -> float:
    """A finite number ≥ 0."""
    value = read_number(text)
    if not (is_number(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return value


def tolerance_arg(text: str) -> float | str:
    """``auto`` or a number (its range is the field's: `SolverSpec` checks a tolerance)."""
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected auto or a number, got {text!r}") from None


def whole_arg(text: str) -> int:
    """A whole number (its range is the field's: `SolverSpec` checks a thread count)."""
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None


def positive_int(text: str) -> int:
    """A whole number ≥ 1."""
    if not text.strip().isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return int(text)


def dt_list(text: str) -> list[float]:
    """'0.1,0.05,0.025': positive, strictly decreasing time steps (`study.check_time_steps`)."""
    from ..experiments.study import check_time_steps

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


#: The threads of a run that gives none (`threads.default_threads`), as the help texts say it.
DEFAULT_THREADS = "FSIVSP_THREADS, else the cores this process may use"


def threads_option(parser: argparse.ArgumentParser, default: str = DEFAULT_THREADS) -> None:
    """--threads N (the `SolverSpec`'s threads, `solver_spec`; the command enters `threads.using` when the run
    starts), and -v (every command has both)."""
    parser.add_argument("--threads", type=whole_arg, default=None, metavar="N",
                        help=f"threads for assembly, set-up and solves (default: {default})")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more messages: -v the set-up stages of every run, -vv debugging records")


def chosen_scheme(args, default):
    """The time scheme of --scheme/--theta, or ``default``."""
    from ..timestepping.schemes import time_scheme

    if args.scheme is None:
        if args.theta is not None:
            raise UsageError("--theta: only with --scheme theta")
        return default
    try:
        return time_scheme(args.scheme, args.theta)
    except ValueError as error:  # "theta: ..."
        raise UsageError(f"--{error}") from None


def petsc_options_arg(text: str) -> dict[str, str]:
    """``--petsc-options "-ksp_monitor -fieldsplit_velocity_pc_type gamg"``: PETSc options (without the
    ``fsivsp_`` prefix) as the case file's ``[solver.petsc]`` table takes them."""
    from ..config.case import CaseError
    from ..solvers import read_petsc_options

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


def solver_labels(prog: str) -> dict[str, str]:
    """The command line's names of the `SolverSpec` fields, e.g. ``fsivsp paper: --solver``."""
    return {"method": f"{prog}: --solver", "tolerance": f"{prog}: --tolerance", "threads": f"{prog}: --threads",
            "petsc": f"{prog}: --petsc-options"}


def solver_spec(args, prog: str, base=None):
    """``base`` (None: the default `SolverSpec`) with the command's --solver, --tolerance, --threads and
    --petsc-options where given (the PETSc options added to the base's), checked as `SolverSpec` does."""
    from dataclasses import replace

    from ..solvers import SolverSpec

    base = SolverSpec() if base is None else base
    given = {field: getattr(args, option, None) for field, option in
             (("method", "solver"), ("tolerance", "tolerance"), ("threads", "threads"))}
    changes = {field: value for field, value in given.items() if value is not None}
    if getattr(args, "petsc_options", None):
        changes["petsc"] = {**base.petsc, **args.petsc_options}
    return replace(base, **changes, where=solver_labels(prog))
