"""Robustness of an iterative solver: mean and largest iterations per step against the level, Δt and the
materials (issue 12's table; issue 22's for PETSc, with λ/μ = 10⁴ and Taylor–Hood k = 2 in 3D; issue 33's
"solid pressure" table, λ/μ = 10², 10⁴ with ``solid_pressure`` "none" and "continuous" in 2D and 3D; its "Taylor–Hood
in 2D" table, the paper's case with Taylor–Hood k = 1, 2, and its "Taylor–Hood k = 1 at large dt in 3D" table, the 3D
examples at Δt ≥ 10⁻² with Taylor–Hood k = 1 in place of MINI).

Each row: the case's manufactured data on its coarse mesh refined ``level`` times, ``--steps`` steps of the
scheme with ``--solver`` at ``--tolerance`` (default 1e-12 of the right-hand side, the tables' basis since issue 12;
``auto`` measures the auto tolerance), no error norms, with the case's ``solid_pressure`` (default "auto": a solid
pressure where λ ≥ 10 μ). ``--tables`` runs only the named tables (comma-separated), ``--dt`` only these time steps
of the "levels and time steps" table, ``--cases`` only the rows of these labels (one argument each: "paper",
"fluid_in_solid_3d", "paper, nu = 1", ...) and ``--levels`` only these levels (with ``--max-level-3d`` above 3:
the 3D fluid ball's and fluid_over_solid_3d's level 4). Each record names the velocity block's preconditioner
(BoomerAMG, SSOR where the mass dominates, the p-multigrid, MINI's condensed bubbles) and the stiffness ratio that
chose it.

    python benchmarks/robustness.py --solver petsc --json benchmarks/robustness_petsc.json
    python benchmarks/robustness.py --solver iterative --json benchmarks/robustness.json
    python benchmarks/robustness.py --tables "solid pressure,Taylor–Hood k = 2 in 3D,materials" \
        --json benchmarks/robustness_solid_pressure.json
    python benchmarks/robustness.py --tables "levels and time steps" --cases fluid_in_solid_3d fluid_over_solid_3d \
        --max-level-3d 4 --levels 4 --dt 0.1,0.01 --json benchmarks/robustness_large_dt_level4.json
    python benchmarks/robustness.py --tables "Taylor–Hood k = 1 at large dt in 3D" \
        --json benchmarks/robustness_large_dt_taylor_hood.json
    python benchmarks/robustness.py --tables "Taylor–Hood in 2D" --json benchmarks/robustness_taylor_hood_2d.json
    python benchmarks/robustness.py --tables "Taylor–Hood in 2D" \
        --json benchmarks/robustness_taylor_hood_2d_higher_weight.json
    python benchmarks/robustness.py --tables "Taylor–Hood in 2D,Taylor–Hood k = 2 in 3D" \
        --json benchmarks/robustness_taylor_hood_lagrange.json
    python benchmarks/robustness.py --tables "Taylor–Hood in 2D,Taylor–Hood k = 2 in 3D" \
        --petsc '{"schur_laplacian_basis": "hierarchical"}' --json benchmarks/robustness_taylor_hood_hierarchical.json
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

from fsivsp.app.arguments import levels_arg, tolerance_arg
from fsivsp.config.case import load_study_case
from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import solver_statistics
from fsivsp.fem.spaces import resolve_solid_pressure
from fsivsp.geometry import refined
from fsivsp.io.atomic import write_json

EXAMPLES = Path(__file__).parent.parent / "examples"
TIME_STEPS = (1e-1, 1e-2, 1e-3, 1e-4)
#: The time steps of the "Taylor–Hood k = 1 at large dt in 3D" table: where MINI's counts grow (docs/solvers.md).
LARGE_DT = 1e-2
#: Above the run's default: the table measures where the count breaks, not only whether it converges.
MAX_ITERATIONS = 20_000


def iterations(case, level: int, steps: int, solver: str, tolerance: float | str = 1e-12) -> dict:
    mesh = refined(case.coarse_mesh(), level, case.discretisation.project_refinement)
    start = time.perf_counter()
    statistics = solver_statistics(case.with_solver(method=solver, max_iterations=MAX_ITERATIONS, tolerance=tolerance),
                                   mesh, steps)
    return {"dofs": statistics["dofs"], "mean": statistics["iterations"]["mean"],
            "max": statistics["iterations"]["max"], "preconditioner": statistics["preconditioner"],
            "solid_pressure": resolve_solid_pressure(case.discretisation.solid_pressure, case.materials),
            "seconds": time.perf_counter() - start}


def with_lam(case, ratio: float):
    """``case`` with λ = ``ratio`` μ."""
    return dataclasses.replace(case, materials=dataclasses.replace(case.materials, lam=ratio * case.materials.mu))


def solid_pressure_rows(max_level_2d: int, max_level_3d: int):
    """Issue 33's table: λ/μ = 10², 10⁴ without and with a solid pressure, MINI in 2D (the paper's case, Δt = 10⁻²)
    and 3D (the solid ball, Δt = 0.02) on three levels, Taylor–Hood k = 2 in 3D with a solid pressure."""
    solid = load_study_case(EXAMPLES / "solid_in_fluid_3d.toml")
    for ratio in (1e2, 1e4):
        for choice in ("none", "continuous"):
            for label, case, top in (("paper", paper_case(1e-2), max_level_2d),
                                     ("solid_in_fluid_3d", solid, max_level_3d)):
                case = with_lam(case, ratio).with_discretisation(solid_pressure=choice)
                for level in range(min(top, 2) + 1):
                    yield "solid pressure", f"{label}, lam/mu = {ratio:g}, {choice}", case, level
    taylor_hood = with_lam(solid, 1e4).with_discretisation(family="taylor_hood", order=2, solid_pressure="continuous")
    for level in range(min(max_level_3d, 2) + 1):
        yield "solid pressure", "solid_in_fluid_3d, Taylor–Hood k = 2, lam/mu = 1e+04, continuous", taylor_hood, level


def rows(max_level_2d: int, max_level_3d: int, time_steps=TIME_STEPS):
    """(table, label, case, level) for every row (the "levels and time steps" table at ``time_steps``)."""
    for dt in time_steps:
        for level in range(max_level_2d + 1):
            yield "levels and time steps", "paper", paper_case(dt), level
    for example in ("fluid_in_solid_3d", "solid_in_fluid_3d", "fluid_over_solid_3d"):
        base = load_study_case(EXAMPLES / f"{example}.toml")
        for dt in time_steps:
            for level in range(max_level_3d + 1):
                yield "levels and time steps", example, dataclasses.replace(base, dt=dt), level
    for order in (1, 2):
        for dt in time_steps:
            for level in range(max_level_2d + 1):
                yield "Taylor–Hood in 2D", f"paper, Taylor–Hood k = {order}", \
                    paper_case(dt).with_discretisation(family="taylor_hood", order=order), level
    for example in ("fluid_in_solid_3d", "solid_in_fluid_3d", "fluid_over_solid_3d"):
        base = load_study_case(EXAMPLES / f"{example}.toml").with_discretisation(family="taylor_hood", order=1)
        for dt in (dt for dt in time_steps if dt >= LARGE_DT):
            for level in range(max_level_3d + 1):
                yield "Taylor–Hood k = 1 at large dt in 3D", f"{example}, Taylor–Hood k = 1", \
                    dataclasses.replace(base, dt=dt), level
    solid = load_study_case(EXAMPLES / "solid_in_fluid_3d.toml")
    fluid = load_study_case(EXAMPLES / "fluid_in_solid_3d.toml").with_discretisation(family="taylor_hood", order=2)
    incompressible = dataclasses.replace(solid.materials, lam=1e4 * solid.materials.mu)
    for level in range(max_level_3d):
        yield "Taylor–Hood k = 2 in 3D", "solid_in_fluid_3d", \
            solid.with_discretisation(family="taylor_hood", order=2), level
        yield "Taylor–Hood k = 2 in 3D", "fluid_in_solid_3d, dt = 0.1", dataclasses.replace(fluid, dt=0.1), level
        yield "materials", "solid_in_fluid_3d, lam/mu = 1e+04", \
            dataclasses.replace(solid, materials=incompressible), level
    paper = paper_case(1e-2)
    for name, values in (("lam/mu", (1.0, 1e2, 1e4)), ("rho_solid/rho_fluid", (0.1, 1.0, 10.0)),
                         ("nu", (1e-3, 1e-1, 1.0))):
        for value in values:
            m = paper.materials
            changed = {"lam/mu": dict(lam=value * m.mu), "rho_solid/rho_fluid": dict(rho_solid=value * m.rho_fluid),
                       "nu": dict(nu=value)}[name]
            for level in (1, 3):
                yield "materials", f"paper, {name} = {value:g}", \
                    dataclasses.replace(paper, materials=dataclasses.replace(m, **changed)), level
    yield from solid_pressure_rows(max_level_2d, max_level_3d)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--solver", default="petsc", help="petsc (the default) or iterative")
    parser.add_argument("--steps", type=int, default=3)
    parser.add_argument("--max-level-2d", type=int, default=4)
    parser.add_argument("--max-level-3d", type=int, default=3)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--tables", default=None, help="only these tables (comma-separated names)")
    parser.add_argument("--dt", default=None, help="only these time steps (comma-separated)")
    parser.add_argument("--cases", nargs="+", default=None,
                        help="only the rows of these labels (one argument each: the materials rows' have commas)")
    parser.add_argument("--levels", type=levels_arg, default=None, help="only these levels, 'A-B' or 'A'")
    parser.add_argument("--tolerance", type=tolerance_arg, default=1e-12,
                        help="1e-12 (the default), another number, or auto")
    parser.add_argument("--petsc", type=json.loads, default=None,
                        help="PETSc options over every row's, as JSON (old beside new), e.g. "
                             "'{\"schur_laplacian_basis\": \"hierarchical\"}'")
    args = parser.parse_args()
    time_steps = TIME_STEPS if args.dt is None else tuple(float(dt) for dt in args.dt.split(","))
    tables = None if args.tables is None else set(args.tables.split(","))
    records = []
    for table, label, case, level in rows(args.max_level_2d, args.max_level_3d, time_steps):
        if ((tables is not None and table not in tables) or (args.cases is not None and label not in args.cases)
                or (args.levels is not None and level not in args.levels)):
            continue
        if args.petsc:
            case = case.with_solver(petsc={**case.solver.petsc, **args.petsc})
        record = {"solver": args.solver, "table": table, "case": label, "dt": case.dt, "level": level,
                  **iterations(case, level, args.steps, args.solver, args.tolerance)}
        records.append(record)
        if args.json:
            write_json(args.json, records)   # as it goes: a long run keeps what it measured
        print(f"{table:22} {label:32} dt {case.dt:7.0e} level {level} dofs {record['dofs']:>7}  "
              f"its mean {record['mean']:6.1f} max {record['max']:4d}  {record['seconds']:6.1f} s  "
              f"{record['preconditioner']['velocity']} (q {record['preconditioner'].get('stiffness_ratio')})",
              flush=True)
    if args.json:
        write_json(args.json, records)


if __name__ == "__main__":
    main()
