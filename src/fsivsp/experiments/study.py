"""Convergence studies: one case, a sequence of uniformly refined meshes, errors and rates (76)."""
from __future__ import annotations

import math
import time as clock
from dataclasses import replace

import ngsolve as ngs
import numpy as np
import sympy

from ..config.case import Case
from ..fem.forms import elastic_stress, solid_stress
from ..fem.spaces import Spaces, base_order, build_spaces, resolve_solid_pressure
from ..geometry import (
    FLUID,
    FLUID_WALL,
    SOLID,
    SOLID_WALL,
    Phases,
    check_regions,
    geometry_phases,
    pattern,
    refined_part,
    refined_parts,
    region_counts,
)
from ..geometry.curved import curve
from ..model import manufactured
from ..model.data import INITIAL_STRESS, Data
from ..model.fields import Field
from ..model.manufactured import ExactSolution
from ..model.materials import Materials
from ..runtime import parallel
from ..runtime.progress import tqdm
from ..timestepping.scheme import Scheme
from .norms import ErrorNorm, NormGroup, component, h1_component, l2, rigid_motions


def dirichlet_boundaries(mesh: ngs.Mesh) -> str:
    """Γ_F ∪ Γ_S as present in the mesh (either may be empty)."""
    present = set(mesh.GetBoundaries())
    return "|".join(name for name in (FLUID_WALL, SOLID_WALL) if name in present)


def manufactured_data(exact: ExactSolution, mat: Materials, dirichlet: str, initial_stress: str,
                      initial_velocity: str = "interpolation", phases: Phases = Phases()) -> Data:
    """All data of the model derived from the exact solution (see `manufactured`); with materials that differ
    between the cell regions of ``phases``, the regions' forces and the traction jumps between them
    (`ExactSolution.region_data`)."""
    if initial_stress not in INITIAL_STRESS:
        raise ValueError(f"initial_stress: expected one of {', '.join(INITIAL_STRESS)}, got {initial_stress!r}")
    if not mat.uniform(phases.regions):
        if initial_stress == "projection":
            raise ValueError("initial_stress: \"projection\" is not supported with region-wise materials; expected "
                             "\"displacement\"")
        forces, stresses = exact.region_data(mat, {region: phases.phase(region) for region in phases.regions})
        return Data(velocity0=Field(exact.at_time(0).velocity), pressure0=Field(exact.at_time(0).pressure),
                    initial_velocity=initial_velocity, displacement0=Field(exact.at_time(0).displacement),
                    boundary_velocity={dirichlet: Field(exact.velocity)} if dirichlet else {},
                    region_forces={r: Field(f) for r, f in forces.items()},
                    region_tractions={r: Field(sigma) for r, sigma in stresses.items()})
    return Data(
        velocity0=Field(exact.at_time(0).velocity),
        pressure0=Field(exact.at_time(0).pressure),
        initial_velocity=initial_velocity,
        displacement0=Field(exact.at_time(0).displacement) if initial_stress == "displacement" else None,
        stress0=Field(exact.at_time(0).solid_stress(mat)) if initial_stress == "projection" else None,
        force_fluid=Field(exact.fluid_force(mat)),
        force_solid=Field(exact.solid_force(mat)),
        boundary_velocity={dirichlet: Field(exact.velocity)} if dirichlet else {},
        interface_load=Field(exact.interface_load(mat)),
    )


class Errors:
    """The norms of Section 5.3 at one time: v_j in H¹(Ω), p in L²(Ω_F), σ in L²(Ω_S).
    The unknowns of X_h = V_h × Q_h share one Gram product per evaluation (`NormGroup`); σ_h = σ*_h + Cε(u_h)
    is measured on the scheme's displacement u_h (Gram matrix of Cε on the solid, `ErrorNorm` with an offset)."""

    def __init__(self, scheme: Scheme, exact: ExactSolution):
        spaces, mat = scheme.spaces, scheme.materials
        phases, d = spaces.phases, spaces.mesh.dim
        intorder, bonus = self.intorder(spaces), spaces.bonus_intorder
        mixed = {f"v{j + 1}": ErrorNorm(spaces.mixed, component(0), h1_component(j, d), exact.velocity[j], intorder,
                                        bonus, phases=phases)
                 for j in range(d)}
        mixed["p"] = self.pressure(spaces, exact)
        self.mixed = NormGroup(mixed)
        if spaces.solid_pressure is not None:
            self.stress = self.solid_pressure_stress(scheme, exact, intorder)
            return
        kernel = rigid_motions(spaces.mixed, component(0), phases.solid)
        if mat.uniform(phases.solid):
            strain = [(SOLID, lambda u: elastic_stress(u, mat, d), lambda e: e)]
            self.stress = ErrorNorm(spaces.mixed, component(0), strain, exact.solid_stress(mat), intorder, bonus,
                                    offset=scheme.stress_offset, kernel=kernel, phases=phases)
            return
        # σ_r = C_r ε(u) on each group of solid regions of equal materials, measured against the displacement
        groups: dict[tuple, list[str]] = {}
        for region in phases.solid:
            groups.setdefault(tuple(mat.of(region).constants().items()), []).append(region)
        strain = [(pattern(names), lambda u, m=mat.of(names[0]): elastic_stress(u, m, d),
                   lambda e, m=mat.of(names[0]): manufactured.elastic_stress(list(e), m, d))
                  for names in groups.values()]
        self.stress = ErrorNorm(spaces.mixed, component(0), strain, sympy.Matrix(exact.displacement), intorder,
                                bonus, kernel=kernel, phases=phases)

    @staticmethod
    def solid_pressure_stress(scheme: Scheme, exact: ExactSolution, intorder: int) -> ErrorNorm:
        """‖σ − σ_h‖_{L²(Ω_S)} of a solid pressure's scheme, σ_h = σ*_h + 2μ ε(u_h) − P_h I on the carried (u_h, ϑP_h)
        of each group of solid regions of equal materials, by quadrature (`ErrorNorm`)."""
        spaces, mat, d = scheme.spaces, scheme.materials, scheme.spaces.mesh.dim
        phases, unit = spaces.phases, scheme.pressure_unit
        pair = lambda f: (f.components[0], f.components[2]) if isinstance(f, ngs.GridFunction) else (f[0], f[2])
        groups: dict[tuple, list[str]] = {}
        for region in phases.solid:
            groups.setdefault(tuple(mat.of(region).constants().items()), []).append(region)
        parts = [(pattern(names), lambda up, m=mat.of(names[0]): solid_stress(up[0], up[1] / unit, m, d),
                  lambda e, m=mat.of(names[0]): manufactured.elastic_stress(list(e), m, d))
                 for names in groups.values()]
        return ErrorNorm(spaces.mixed, pair, parts, sympy.Matrix(exact.displacement), intorder, spaces.bonus_intorder,
                         offset=scheme.stress_offset, phases=phases, quadrature=True)

    @staticmethod
    def intorder(spaces: Spaces) -> int:
        """Quadrature order for the exact fields."""
        return 2 * spaces.velocity_order + 2

    @classmethod
    def pressure(cls, spaces: Spaces, exact: ExactSolution) -> ErrorNorm:
        """‖p − p_h‖_{L²(Ω_F)} alone, for X_h's coefficient vectors."""
        return ErrorNorm(spaces.mixed, component(1), l2(FLUID), exact.pressure, cls.intorder(spaces),
                         spaces.bonus_intorder, phases=spaces.phases)

    def __call__(self, scheme: Scheme) -> dict[str, float]:
        errors = self.mixed(scheme.state.vec, scheme.time)
        errors["sigma"] = self.stress(scheme.carried.vec, scheme.time)
        return errors


def paper_dofs(counts: dict[str, int]) -> int:
    """The paper's dof count: 2·(vertices not on ∂Ω) + 2·(fluid triangles) + (fluid vertices)."""
    return 2 * (counts["vertices"] - counts["boundary_vertices"]) + 2 * counts["fluid_cells"] + counts["fluid_vertices"]


def case_phases(case: Case, mesh: ngs.Mesh) -> Phases:
    """The media of ``mesh``'s cell regions by the case's ``[geometry]`` (its kind and ``regions``)."""
    return geometry_phases(case.geometry.get("kind", ""), mesh, case.geometry.get("regions"))


def discretise(case: Case, mesh: ngs.Mesh) -> tuple[Scheme, Errors]:
    """`case_scheme` and its error norms."""
    scheme = case_scheme(case, mesh)
    return scheme, Errors(scheme, case.exact)


def case_scheme(case: Case, mesh: ngs.Mesh) -> Scheme:
    """The scheme of ``case`` on ``mesh`` (its regions checked, curved if the case says so), without the error
    norms (whose set-up can cost more than the scheme's: 2.6 against 1.7 s for Taylor–Hood k = 1 on the paper's
    level 3)."""
    phases = check_regions(mesh, case_phases(case, mesh))
    disc = case.discretisation
    if disc.curved:
        curve(mesh, base_order(disc.family, disc.order))
    spaces = build_spaces(mesh, disc.family, disc.order, dirichlet_boundaries(mesh), phases,
                          solid_pressure=resolve_solid_pressure(disc.solid_pressure, case.materials, phases))
    data = manufactured_data(case.exact, case.materials, dirichlet_boundaries(mesh), disc.initial_stress,
                             disc.initial_velocity, phases)
    return Scheme(spaces, case.materials, data, case.dt, solver=case.solver, time_scheme=case.time_scheme)


def solver_statistics(case: Case, mesh: ngs.Mesh, steps: int) -> dict:
    """``steps`` steps of `case_scheme` with PETSc: its solver's `statistics()` (iterations, blocks) with the free
    dofs under ``"dofs"``, the solver's PETSc objects freed after (else they live to the end of the process: 4 level-3
    rows of benchmarks/robustness.py held 1.56 GiB, not 0.91)."""
    scheme = case_scheme(case, mesh)
    scheme.march(steps)
    statistics = {**scheme.solver.statistics(), "dofs": scheme.spaces.free_dofs()}
    scheme.solver.destroy()
    return statistics


def run_level(case: Case, mesh: ngs.Mesh, level: int, quiet: bool = True) -> dict:
    """Run the scheme on one mesh (under mpirun this rank's part, `geometry.refined_parts`); return the record of
    this level (errors, dofs, timings)."""
    start = clock.perf_counter()
    counts, h = region_counts(mesh, case_phases(case, mesh)), max_edge_length(mesh)
    scheme, errors_at = discretise(case, mesh)
    spaces = scheme.spaces
    setup = clock.perf_counter() - start
    squares: dict[str, float] = {}

    def accumulate(scheme: Scheme) -> None:
        for name, error in errors_at(scheme).items():
            squares[name] = squares.get(name, 0.0) + case.dt * error**2
        bar.update(1)

    start = clock.perf_counter()
    with tqdm(total=case.steps, desc=f"level {level}", leave=False, disable=quiet, unit="step") as bar:
        scheme.march(case.steps, accumulate)
    loop = clock.perf_counter() - start
    errors = {name: math.sqrt(value) for name, value in squares.items()}
    errors["total"] = math.sqrt(sum(squares.values()))
    solver = scheme.solver.statistics()
    return {
        "level": level,
        "vertices": counts["vertices"],
        "h": h,
        "dofs": spaces.free_dofs(),
        "paper_dofs": paper_dofs(counts) if spaces.mesh.dim == 2 else None,
        "counts": counts,
        "errors": errors,
        "solver": scheme.solver.method,
        "residual": scheme.solver.residual,
        "iterations": solver.get("iterations"),
        "preconditioner": solver.get("preconditioner"),
        "fallback": solver.get("fallback"),
        "seconds": {
            "assembly": setup - scheme.solver.factor_seconds,
            "factorisation": scheme.solver.factor_seconds,
            "time_loop": loop,
        },
    }


def max_edge_length(mesh: ngs.Mesh) -> float:
    """h: the longest edge of an active cell (simplices; over all ranks of a distributed mesh). Not ``mesh.edges``:
    a netgen-refined mesh keeps its parents' edges there, so h would stay the coarse mesh's."""
    ngmesh = mesh.ngmesh
    cells = (ngmesh.Elements2D() if mesh.dim == 2 else ngmesh.Elements3D()).NumPy()["nodes"][:, :mesh.dim + 1] - 1
    if not len(cells):   # rank 0 of a distributed mesh
        return mesh.comm.Max(0.0)
    points = np.asarray(ngmesh.Coordinates())[:, :mesh.dim][cells]          # cells × corners × dim
    i, j = np.triu_indices(mesh.dim + 1, 1)
    return mesh.comm.Max(float(np.linalg.norm(points[:, i] - points[:, j], axis=-1).max()))


def rates(records: list[dict], dim: int) -> None:
    """Add the rate (76), r = −d log(e_fine/e_coarse) / log(N_fine/N_coarse), to each record (None on the first)."""
    previous = None
    for record in records:
        if previous is None or previous["level"] != record["level"] - 1:
            record["rates"] = dict.fromkeys(record["errors"])
        else:
            ratio = math.log(record["vertices"] / previous["vertices"])
            record["rates"] = {
                name: (-dim * math.log(e / previous["errors"][name]) / ratio
                       if e > 0 and previous["errors"][name] > 0 else None)
                for name, e in record["errors"].items()
            }
        previous = record


def study(case: Case, levels: range, quiet: bool = True) -> list[dict]:
    """The convergence study: uniform refinements ``levels`` of the case's coarse mesh (under mpirun made on rank 0
    and distributed once, then refined where the cells live: `geometry.refined_parts`)."""
    coarse = parallel.on_root(case.coarse_mesh)
    meshes = refined_parts(coarse, levels, case.discretisation.project_refinement)
    records = []
    for level, mesh in zip(tqdm(levels, desc=case.name, disable=quiet, unit="level"), meshes):
        records.append(run_level(case, mesh, level, quiet))
    rates(records, parallel.shared(lambda: coarse.dim))
    return records


def time_rates(records: list[dict]) -> None:
    """Add the rate in Δt, r = log(e_coarse/e_fine) / log(Δt_coarse/Δt_fine), to each record (None on the first)."""
    previous = None
    for record in records:
        if previous is None:
            record["rates"] = dict.fromkeys(record["errors"])
        else:
            ratio = math.log(previous["dt"] / record["dt"])
            record["rates"] = {
                name: (math.log(previous["errors"][name] / e) / ratio
                       if e > 0 and previous["errors"][name] > 0 else None)
                for name, e in record["errors"].items()
            }
        previous = record


def check_time_steps(steps: list[float]) -> list[float]:
    """``steps`` if they are finite, positive and strictly decreasing, else ValueError."""
    if (not steps or not all(math.isfinite(dt) and dt > 0 for dt in steps)
            or any(b >= a for a, b in zip(steps, steps[1:]))):
        raise ValueError(f"dt: expected positive, strictly decreasing time steps, got {steps}")
    return steps


def time_study(case: Case, level: int, steps: list[float], quiet: bool = True) -> list[dict]:
    """The convergence study in time: the case on refinement ``level`` with each Δt of ``steps`` (decreasing), on
    one mesh (under mpirun each rank's part, `geometry.refined_part`)."""
    check_time_steps(steps)
    mesh = refined_part(parallel.on_root(case.coarse_mesh), level, case.discretisation.project_refinement)
    records = []
    for dt in tqdm(steps, desc=case.name, disable=quiet, unit="dt"):
        record = run_level(replace(case, dt=dt), mesh, level, quiet)
        record["dt"] = dt
        records.append(record)
    time_rates(records)
    return records
