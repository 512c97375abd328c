"""Cases: the one `Case` type (a study case has an exact solution; `runcase.RunCase` adds a run's fields) and case
files (TOML), every field read and validated before any heavy work.

Every problem with a case file is a `CaseError` whose message is one line naming the
field and what was expected, e.g. ``materials.mu: expected a positive number, got -1``.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import CaseError, is_whole
from ..fem.spaces import FAMILIES, SOLID_PRESSURES
from ..geometry import Phases, geometry_phases
from ..model.data import INITIAL_STRESS, INITIAL_VELOCITY
from ..model.materials import FLUID_FIELDS, SOLID_FIELDS, Materials, lame
from ..runtime.logs import warn
from ..solvers import AUTO, MAX_ITERATIONS, SolverSpec
from ..timestepping.schemes import BDF2, Theta, time_scheme
from .overrides import case_document
from .readers import check_command, check_keys, choice, number, section

if TYPE_CHECKING:
    import ngsolve as ngs

    from ..model.manufactured import ExactSolution

SECTIONS = {
    "geometry": None,  # free-form parameters, checked by the geometry builder
    "materials": {"rho_fluid", "rho_solid", "nu", "lam", "mu"},
    "time": {"T", "dt", "scheme", "theta"},
    "discretisation": {"family", "order", "initial_stress", "initial_velocity", "solver", "tolerance", "max_iterations",
                       "curved", "threads", "solid_pressure"},
    "exact": {"velocity", "pressure", "displacement"},
    "solver": {"petsc"},
}
ORDERS = {"mini": (1, 1), "taylor_hood": (1, 3)}
#: The case file's names of the `SolverSpec` fields (``[discretisation]`` and ``[solver]``).
SOLVER_FIELDS = {"method": "discretisation.solver", "tolerance": "discretisation.tolerance",
                 "max_iterations": "discretisation.max_iterations", "threads": "discretisation.threads",
                 "petsc": "solver.petsc"}


def read_materials(table: dict, dim: int, young_allowed: bool = False) -> Materials:
    """ρ_F, ρ_S, ν > 0 and the Lamé constants μ > 0, λ > −2μ/d; with ``young_allowed`` the
    solid may be given instead by Young's modulus E > 0 and Poisson's ratio −1 < ν_P < 1/2. Sub-tables (a cell
    region's own materials) are read once the mesh is known (`read_region_materials`)."""
    table = {key: value for key, value in table.items() if not isinstance(value, dict)}
    allowed = SECTIONS["materials"] | ({"young", "poisson"} if young_allowed else set())
    check_keys(table, allowed, "materials")
    fluid = {key: number(table, key, "materials", minimum=0) for key in ("rho_fluid", "rho_solid", "nu")}
    kinematic_note(fluid["nu"], fluid["rho_fluid"])
    return Materials(**fluid, **_lame(table, "materials", dim, young_allowed, required=True))


def _lame(table: dict, where: str, dim: int, young_allowed: bool, required: bool,
          mu_default: float | None = None) -> dict[str, float]:
    """λ and μ of a table: lam and mu, or young and poisson (``young_allowed``); all ``required``, or any of them
    (a region's: μ defaults to ``mu_default`` for λ's bound)."""
    if young_allowed and ("young" in table or "poisson" in table):
        for key in ("lam", "mu"):
            if key in table:
                raise CaseError(f"{where}.{key}: give either lam and mu or young and poisson, not both")
        young = number(table, "young", where, minimum=0)
        poisson = number(table, "poisson", where, minimum=-1)
        if poisson >= 0.5:
            raise CaseError(f"{where}.poisson: expected a number in (-1, 0.5), got {poisson!r}")
        return lame(young, poisson)
    values = {}
    if required or "mu" in table:
        values["mu"] = number(table, "mu", where, minimum=0)
    if required or "lam" in table:
        values["lam"] = number(table, "lam", where, minimum=-2 * values.get("mu", mu_default) / dim)
    return values


def read_region_materials(table: dict, materials: Materials, phases: Phases, dim: int, young_allowed: bool = False,
                          discretisation: Discretisation | None = None) -> Materials:
    """``materials`` with the regions' own (``[materials.NAME]``, the sub-tables of ``table``): a fluid region's
    rho_fluid and nu, a solid region's rho_solid and lam, mu (or young, poisson), each optional. The regions of
    ``phases``; with solid regions of their own materials σ⁰ comes from the displacement (``initial_stress``)."""
    for name, own in table.items():
        if not isinstance(own, dict):
            continue
        where = f"materials.{name}"
        if name not in phases.regions:
            raise CaseError(f"{where}: no cell region of that name in the mesh; expected one of "
                            f"{', '.join(phases.regions)}")
        fluid = name in phases.fluid
        keys = set(FLUID_FIELDS) if fluid else set(SOLID_FIELDS) | ({"young", "poisson"} if young_allowed else set())
        check_keys(own, keys, where)
        values = {key: number(own, key, where, minimum=0) for key in ("rho_fluid", "nu", "rho_solid") if key in own}
        if not fluid:
            values.update(_lame(own, where, dim, young_allowed, required=False, mu_default=materials.mu))
        materials = materials.with_region(name, **values)
    if discretisation is not None and discretisation.initial_stress == "projection" \
            and not materials.uniform(phases.solid):
        raise CaseError("discretisation.initial_stress: \"projection\" is not supported with solid regions of their "
                        "own materials; expected \"displacement\"")
    return materials


def kinematic_note(nu: float, rho_fluid: float) -> None:
    """One line on stderr when ν looks like water's kinematic viscosity in SI units (ν < 1e-4 with ρ_F ≈ 1000):
    fsivsp's ν is the dynamic viscosity (σ_F = −pI + 2ν ε(v))."""
    if nu < 1e-4 and 500 <= rho_fluid <= 2000:
        warn(f"materials.nu = {nu:g} is the dynamic viscosity (σ_F = −pI + 2ν ε(v), Pa·s in SI); with "
               f"rho_fluid = {rho_fluid:g} this looks like a kinematic one (m²/s): water's dynamic viscosity is about "
               "1e-3 Pa·s")


@dataclass
class Discretisation:
    """The element (``family``, ``order``), how σ⁰ and v⁰ are made, whether cells on curved boundaries are
    ``curved`` and refinement moves new boundary nodes onto them (``project_refinement``), and whether the solid
    keeps a pressure (``solid_pressure``: `fem.spaces.SOLID_PRESSURES`, ``"auto"`` resolved by the materials in
    `fem.spaces.resolve_solid_pressure`). A case file's ``[discretisation]`` (but its solver: `SolverSpec`) curves by
    default, and projects when it curves."""

    family: str = "mini"
    order: int = 1
    initial_stress: str = "displacement"
    initial_velocity: str = "interpolation"
    curved: bool = False
    project_refinement: bool = True
    solid_pressure: str = "auto"


def read_discretisation(table: dict, solver: dict | None = None) -> tuple[Discretisation, SolverSpec]:
    """``[discretisation]`` and ``[solver]`` (``solver``): the discretisation and the `SolverSpec` (`read_solver`)."""
    check_keys(table, SECTIONS["discretisation"], "discretisation")
    spec = read_solver(table, solver or {})
    family = choice(table, "family", "discretisation", FAMILIES, "mini")
    low, high = ORDERS[family]
    order = table.get("order", low)
    if not is_whole(order, low, high):
        raise CaseError(f"discretisation.order: expected a whole number from {low} to {high} for {family}, "
                        f"got {order!r}")
    initial = choice(table, "initial_stress", "discretisation", INITIAL_STRESS, INITIAL_STRESS[0])
    velocity = choice(table, "initial_velocity", "discretisation", INITIAL_VELOCITY, INITIAL_VELOCITY[0])
    curved = table.get("curved", True)
    if not isinstance(curved, bool):
        raise CaseError(f"discretisation.curved: expected true or false, got {curved!r}")
    solid = choice(table, "solid_pressure", "discretisation", SOLID_PRESSURES, "auto")
    return Discretisation(family, order, initial, velocity, curved, project_refinement=curved,
                          solid_pressure=solid), spec


def read_solver(table: dict, solver: dict) -> SolverSpec:
    """The `SolverSpec` of ``[discretisation]``'s solver, tolerance, max_iterations and threads (``table``) and
    ``[solver.petsc]`` (in ``solver``)."""
    check_keys(solver, SECTIONS["solver"], "solver")
    return SolverSpec(table.get("solver", "auto"), table.get("tolerance", AUTO),
                      table.get("max_iterations", MAX_ITERATIONS), table.get("threads"), solver.get("petsc", {}),
                      where=SOLVER_FIELDS)


def read_time(table: dict) -> tuple[float, float, Theta | BDF2]:
    """T, Δt and the time scheme (`timeschemes`: ``scheme``, default backward Euler; ``theta`` with "theta")."""
    check_keys(table, SECTIONS["time"], "time")
    T = number(table, "T", "time", minimum=0)
    dt = number(table, "dt", "time", minimum=0)
    if dt > T:
        raise CaseError(f"time.dt: expected a time step <= time.T = {T:g}, got {dt:g}")
    theta = number(table, "theta", "time") if "theta" in table else None
    try:
        return T, dt, time_scheme(table.get("scheme", "backward_euler"), theta)
    except ValueError as error:  # "scheme: ..." or "theta: ..."
        raise CaseError(f"time.{error}") from None


@dataclass
class Case:
    """A problem: its (coarse) mesh, materials, exact solution (a study case, ``fsivsp study``; None: a run case,
    `runcase.RunCase`, whose mesh is its ``mesh``), time, `Discretisation` and `SolverSpec`; from a case file also its
    ``path`` and validated ``[geometry]`` table."""

    name: str
    coarse_mesh: Callable[[], ngs.Mesh] | None
    materials: Materials
    exact: ExactSolution | None
    T: float
    dt: float
    time_scheme: Theta | BDF2 = Theta()
    discretisation: Discretisation = field(default_factory=Discretisation)
    solver: SolverSpec = field(default_factory=SolverSpec)
    path: Path | None = None
    geometry: dict[str, Any] = field(default_factory=dict)

    @property
    def steps(self) -> int:
        return max(1, round(self.T / self.dt))

    def with_discretisation(self, **changes) -> Case:
        """This case with the fields ``changes`` of its `Discretisation` (e.g. ``family="taylor_hood"``)."""
        return replace(self, discretisation=replace(self.discretisation, **changes))

    def with_solver(self, **changes) -> Case:
        """This case with the fields ``changes`` of its `SolverSpec` (e.g. ``method="iterative"``)."""
        return replace(self, solver=replace(self.solver, **changes))


def read_geometry(table: dict, folder: Path = Path(".")) -> tuple[dict, int]:
    """The geometry table, its ``path`` resolved from ``folder`` (the case file's, `resolve_path`), and d."""
    dim = table.get("dim", 2)
    if dim not in (2, 3) or isinstance(dim, bool):
        raise CaseError(f"geometry.dim: expected 2 or 3, got {dim!r}")
    if "kind" not in table:
        raise CaseError("geometry.kind: missing; expected the name of a geometry")
    table = dict(table)
    if "path" in table:
        table["path"] = resolve_path(table["path"], folder, "geometry.path")
    return table, dim


def resolve_path(value: Any, folder: Path, where: str) -> Any:
    """A relative file path of a case file is its folder's: ``folder / value``. Kept as it is: an absolute path,
    a value that is no path (the geometry builder reports it), and, with a one-line note on stderr, a path that
    exists only relative to the working directory (case files written before paths were the case file's)."""
    if not isinstance(value, str) or not value or Path(value).is_absolute():
        return value
    beside = folder / value
    if beside.exists() or not Path(value).exists():
        return str(beside)
    warn(f"{where}: {value} is not in the case file's folder {folder}; using {value} relative to the "
           "working directory (write it relative to the case file)")
    return value


def read_case(doc: dict, path: Path, young_allowed: bool = False) -> tuple[dict[str, Any], int]:
    """The `Case` fields of the sections every case file has ([geometry], [materials], [time], [discretisation],
    [solver]; ``young_allowed``: `read_materials`) and d."""
    geometry, dim = read_geometry(section(doc, "geometry"), path.parent)
    materials = read_materials(section(doc, "materials"), dim, young_allowed)
    T, dt, scheme = read_time(section(doc, "time"))
    disc, spec = read_discretisation(section(doc, "discretisation", required=False),
                                     section(doc, "solver", required=False))
    return {"name": path.stem, "materials": materials, "T": T, "dt": dt, "time_scheme": scheme,
            "discretisation": disc, "solver": spec, "path": path, "geometry": geometry}, dim


def build_mesh(geometry: dict, dim: int, skip: tuple[str, ...] = ()) -> ngs.Mesh:
    """The mesh of a validated ``[geometry]`` table (``skip``: keys that are not the geometry builder's)."""
    from ..geometry import build_geometry

    params = {k: v for k, v in geometry.items() if k not in ("kind", "dim", "maxh", *skip)}
    return build_geometry(geometry["kind"], dim, geometry.get("maxh"), **params)


def read_exact(table: dict, dim: int) -> ExactSolution:
    """``[exact]``: the manufactured solution's velocity, pressure and displacement."""
    from ..model.expressions import ExpressionError
    from ..model.manufactured import ExactSolution, ManufacturedError

    check_keys(table, SECTIONS["exact"], "exact")
    for key in SECTIONS["exact"]:
        if key not in table:
            raise CaseError(f"exact.{key}: missing; expected "
                            f"{'an expression' if key == 'pressure' else f'a list of {dim} expressions'}")
    try:
        return ExactSolution.parse(table["velocity"], table["pressure"], table["displacement"], dim)
    except (ExpressionError, ManufacturedError) as error:
        raise CaseError(str(error)) from None


def load_study_case(source: str | Path | dict, overrides: dict | None = None) -> Case:
    """Read and validate a case file with an [exact] section (``fsivsp study``; a dict and ``overrides`` as
    `runcase.load_run_case` takes them), its coarse mesh built (which validates the geometry before any solve)."""
    path, doc = case_document(source, overrides)
    check_command(doc, path, "study")
    check_keys(doc, SECTIONS, "")
    fields, dim = read_case(doc, path)
    exact = read_exact(section(doc, "exact"), dim)
    coarse = build_mesh(fields["geometry"], dim)
    phases = geometry_phases(fields["geometry"]["kind"], coarse, fields["geometry"].get("regions"))
    fields["materials"] = read_region_materials(section(doc, "materials"), fields["materials"], phases, dim,
                                                discretisation=fields["discretisation"])
    return Case(coarse_mesh=lambda: coarse, exact=exact, **fields)
