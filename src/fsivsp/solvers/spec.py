"""How step 1 (5.1) is solved: one `SolverSpec`, validated where it is built (a case file's ``[discretisation]``
and ``[solver]``, the command line, code) and passed unchanged to `Scheme` and the backends of `step_solver`."""
from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import InitVar, dataclass, field

from ..errors import CaseError, expected, is_number, is_whole, read_number
from ..runtime import parallel
from .base import AUTO, MAX_ITERATIONS, START_REDUCTION
from .direct import available_methods

#: A PETSc option name: letters, digits and underscores, capitals included (hypre's `pc_hypre_boomeramg_P_max`).
PETSC_OPTION = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


#: The velocity block's preconditioners (``[solver.petsc] velocity_preconditioner``; `petsc.velocity_options`).
VELOCITY_PRECONDITIONERS = ("boomeramg", "ssor", "p-multigrid", "condensed")

#: The pressure block's approximations (``[solver.petsc] schur_approximation``; `petsc_schur`, `petsc_joint`: the
#: joint ones with a solid pressure).
SCHUR_APPROXIMATIONS = ("lsc", "cahouet-chabard", "petsc", "joint-lsc", "joint-lsc-mass", "joint-cahouet-chabard")

#: The bases of a degree-2 pressure Laplacian's AMG (``[solver.petsc] schur_laplacian_basis``; `petsc_basis`).
LAPLACIAN_BASES = ("lagrange", "hierarchical")

#: The options whose value is one of a few names (the first the default), checked by `read_petsc_options`.
CHOICES = {"velocity_preconditioner": VELOCITY_PRECONDITIONERS, "schur_approximation": SCHUR_APPROXIMATIONS,
           "schur_laplacian_basis": LAPLACIAN_BASES}


def solver_names() -> list[str]:
    """The methods a `SolverSpec` takes here."""
    return ["auto", "direct", "iterative", "petsc", *available_methods()]


def read_petsc_options(table, where: str = "solver.petsc") -> dict[str, str]:
    """The ``[solver.petsc]`` table: PETSc option names (without the leading dash and the ``fsivsp_`` prefix,
    e.g. ``ksp_monitor = true``, ``fieldsplit_velocity_pc_type = "gamg"``) to strings, numbers or booleans
    (true: the option without a value; false: left out), as `solvers.petsc` passes them to PETSc."""
    if not isinstance(table, Mapping):
        raise CaseError(f"{where}: expected a table of PETSc options, got {table!r}")
    options = {}
    for key, value in table.items():
        name = key.lstrip("-")
        if not PETSC_OPTION.fullmatch(name):
            raise expected(f"{where}.{key}", "a PETSc option name (letters, digits, _)", key)
        if isinstance(value, bool):
            if value:
                options[name] = ""
        elif isinstance(value, (str, int, float)):
            options[name] = str(value)
        else:
            raise expected(f"{where}.{key}", "a string, a number or true/false", value)
    for name, choices in CHOICES.items():
        if options.get(name, choices[0]) not in choices:
            raise expected(f"{where}.{name}", f"one of {', '.join(choices)}", options[name])
    weight = read_number(options.get("schur_higher_weight", "1"))
    if not (is_number(weight) and weight > 0):
        raise expected(f"{where}.schur_higher_weight", "a positive number",
                       next(v for k, v in table.items() if k.lstrip("-") == "schur_higher_weight"))
    return options


@dataclass(frozen=True)
class SolverSpec:
    """The solver of a run: ``method`` (``"auto"``, ``"direct"``, ``"iterative"``, ``"petsc"`` or a direct
    method of `solvers.direct.METHODS`), the iterative solvers' ``tolerance`` (``"auto"`` or a number, `base`), the auto
    tolerance's ``reduction`` of the start's residual and ``max_iterations``, ``threads``
    (None: the default of `threads.using`), PETSc's options (``petsc``, `read_petsc_options`) and whether the run is
    ``distributed`` over MPI ranks (default: this run's, `parallel.distributed`).

    Every field is checked when the spec is made (also by `dataclasses.replace`): a bad one is a `CaseError`
    ``<where>: expected ..., got ...``, ``where`` the field's label in ``where`` (e.g. ``{"method":
    "discretisation.solver"}``), else ``solver.<field>``."""

    method: str = "auto"
    tolerance: float | str = AUTO
    max_iterations: int = MAX_ITERATIONS
    threads: int | None = None
    petsc: Mapping[str, str] = field(default_factory=dict)
    reduction: float = START_REDUCTION
    distributed: bool = field(default_factory=parallel.distributed)
    where: InitVar[Mapping[str, str] | None] = None

    def __post_init__(self, where: Mapping[str, str] | None) -> None:
        def label(name: str) -> str:
            return (where or {}).get(name, f"solver.{name}")

        if self.method not in solver_names():
            raise expected(label("method"), f"one of {', '.join(solver_names())}", self.method)
        if self.tolerance != AUTO and (not is_number(self.tolerance) or not 0 < self.tolerance < 1):
            raise expected(label("tolerance"), '"auto" or a number in (0, 1)', self.tolerance)
        if not is_number(self.reduction) or not 0 < self.reduction < 1:
            raise expected(label("reduction"), "a number in (0, 1)", self.reduction)
        if not is_whole(self.max_iterations):
            raise expected(label("max_iterations"), "a positive whole number", self.max_iterations)
        if self.threads is not None and not is_whole(self.threads):
            raise expected(label("threads"), "a positive whole number", self.threads)
        if self.tolerance != AUTO:
            object.__setattr__(self, "tolerance", float(self.tolerance))
        object.__setattr__(self, "petsc", read_petsc_options(self.petsc, label("petsc")))

    def record(self) -> dict:
        """The spec for a report (summary.json)."""
        return {"method": self.method, "tolerance": self.tolerance, "reduction": self.reduction,
                "max_iterations": self.max_iterations,
                "threads": self.threads, "options": dict(self.petsc)}
