"""Scale: set-up time, time per step, iterations and peak memory against the number of unknowns, and the cost of
a step in products with the step matrix (``matvec_ratio``, as summary.json records it: `timestepping.cost`).

The 3D fluid ball of examples/fluid_in_solid_3d.toml (MINI, its manufactured data, no error norms: the
work of `fsivsp run`), uniformly refined, with the iterative solver and, up to ``--direct-max``, the direct
one. Each (solver, level) runs in a process of its own, so that its peak resident memory is its own.
Prints a table, writes JSON and a PNG plot.

    python benchmarks/scale.py --levels 1-4 --steps 3 --json benchmarks/scale.json --plot benchmarks/scale.png
    python benchmarks/scale.py --maxh 0.17 --levels 2-4 --steps 2 --direct-max 2 --tolerance 1e-8   # 2.2 million
"""
from __future__ import annotations

import argparse
import json
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

from fsivsp.app.arguments import tolerance_arg

EXAMPLE = Path(__file__).parent.parent / "examples" / "fluid_in_solid_3d.toml"


def measure(level: int, solver: str, steps: int, maxh: float | None, tolerance: float | str) -> dict:
    """One run on the threads `fsivsp run` takes (`threads.using`'s default, so that ``matvec_ratio``'s unit is the
    run's product, as in summary.json): mesh, spaces, scheme (assembly and solver set-up), ``steps`` steps; peak
    memory."""
    from fsivsp.runtime import threads
    with threads.using():
        return {**_measured(level, solver, steps, maxh, tolerance), "threads": threads.current()}


def _measured(level: int, solver: str, steps: int, maxh: float | None, tolerance: float | str) -> dict:
    import dataclasses

    from fsivsp.config.case import load_study_case
    from fsivsp.experiments.study import dirichlet_boundaries, manufactured_data
    from fsivsp.fem.spaces import build_spaces
    from fsivsp.geometry import refined
    from fsivsp.timestepping.cost import StepClock, step_cost
    from fsivsp.timestepping.scheme import Scheme
    case = load_study_case(EXAMPLE).with_solver(tolerance=tolerance)
    if maxh is not None:
        from fsivsp.geometry import build_geometry
        coarse = build_geometry("fluid_in_solid", 3, maxh, curvature_safety=1.0)
        case = dataclasses.replace(case, coarse_mesh=lambda: coarse)
    seconds = {}
    start = time.perf_counter()
    mesh = refined(case.coarse_mesh(), level, case.discretisation.project_refinement)
    seconds["mesh"] = time.perf_counter() - start
    start = time.perf_counter()
    dirichlet = dirichlet_boundaries(mesh)
    spaces = build_spaces(mesh, case.discretisation.family, case.discretisation.order, dirichlet)
    seconds["spaces"] = time.perf_counter() - start
    start = time.perf_counter()
    data = manufactured_data(case.exact, case.materials, dirichlet, case.discretisation.initial_stress,
                             case.discretisation.initial_velocity)
    scheme = Scheme(spaces, case.materials, data, case.dt, solver=case.with_solver(method=solver).solver)
    seconds["scheme"] = time.perf_counter() - start
    seconds["solver_setup"] = scheme.solver.factor_seconds
    setup_memory = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    start = time.perf_counter()
    scheme.march(steps)   # each solve beside the rest of the step before, from 10 000 unknowns on
    clock = StepClock()
    clock.seconds, clock.steps = time.perf_counter() - start, steps
    cost = step_cost(scheme, clock)
    seconds["matvec"], seconds["step"] = cost["product_seconds"], cost["step_seconds"]
    return {"level": level, "solver": scheme.solver.method, "dofs": spaces.free_dofs(), "vertices": mesh.nv,
            "cells": mesh.ne, "seconds": seconds, "steps": steps, "cost": cost,
            "statistics": scheme.solver.statistics(),
            "setup_peak_bytes": setup_memory,
            "peak_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}


def child(level: int, solver: str, steps: int, maxh: float | None, tolerance: float | str) -> dict | None:
    """`measure` in a fresh process (None if it failed, e.g. out of memory)."""
    done = subprocess.run([sys.executable, __file__, "--child", f"{level}:{solver}:{steps}:{maxh}:{tolerance}"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        print(f"level {level} {solver}: failed ({done.returncode}): {done.stderr.strip()[-300:]}", file=sys.stderr)
        return None
    return json.loads(done.stdout.strip().splitlines()[-1])


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    for solver, marker in (("iterative", "o"), ("petsc", "^"), ("direct", "s")):
        mine = [r for r in rows
                if r["solver"] == solver or (solver == "direct" and r["solver"] not in ("iterative", "petsc"))]
        if not mine:
            continue
        n = [r["dofs"] for r in mine]
        left.loglog(n, [r["seconds"]["step"] for r in mine], marker + "-", label=f"{solver}: time per step")
        left.loglog(n, [r["seconds"]["scheme"] for r in mine], marker + "--", label=f"{solver}: set-up")
        right.loglog(n, [r["peak_bytes"] / 2**30 for r in mine], marker + "-", label=solver)
    left.set_xlabel("free unknowns"), left.set_ylabel("seconds"), left.legend()
    left.grid(True, which="both", alpha=0.3)
    right.set_xlabel("free unknowns"), right.set_ylabel("peak memory (GiB)"), right.legend()
    right.grid(True, which="both", alpha=0.3)
    fig.suptitle("fsivsp: 3D fluid ball, MINI (benchmarks/scale.py)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def growth(rows: list[dict], method: str) -> None:
    """Print how the time per step of ``method`` grows between its two largest sizes."""
    import math
    mine = list({r["dofs"]: r for r in rows if r["solver"] == method}.values())   # one row per size
    if len(mine) < 2:
        return
    a, b = mine[-2], mine[-1]

    def exponent(key):
        return math.log(key(b) / key(a)) / math.log(b["dofs"] / a["dofs"])
    print(f"{method}, between the two largest sizes: "
          f"time per step grows like N^{exponent(lambda r: r['seconds']['step']):.2f}, "
          f"one product with the step matrix like N^{exponent(lambda r: r['seconds']['matvec']):.2f}, "
          f"time per step in products like N^{exponent(lambda r: r['seconds']['step'] / r['seconds']['matvec']):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", default="1-4", help="refinement levels A-B")
    parser.add_argument("--steps", type=int, default=3)
    parser.add_argument("--direct-max", type=int, default=3, help="the highest level the direct solver runs")
    parser.add_argument("--maxh", type=float, default=None, help="the coarse ball's mesh size (default: the example's)")
    parser.add_argument("--tolerance", type=tolerance_arg, default="auto",
                        help="the iterative solver's tolerance: auto (the default) or a number")
    parser.add_argument("--solvers", default="direct,iterative,petsc", help="comma-separated solver names")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--plot", type=Path, default=None)
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        level, solver, steps, maxh, tolerance = args.child.split(":")
        print(json.dumps(measure(int(level), solver, int(steps), None if maxh == "None" else float(maxh),
                                 tolerance_arg(tolerance))))
        return
    low, high = (int(x) for x in args.levels.split("-"))
    rows = []
    for level in range(low, high + 1):
        for solver in args.solvers.split(","):
            if solver == "direct" and level > args.direct_max:
                continue
            row = child(level, solver, args.steps, args.maxh, args.tolerance)
            if row is None:
                continue
            rows.append(row)
            s, st = row["seconds"], row["statistics"]
            its = st.get("iterations") or {}
            print(f"level {level} {row['solver']:>9} dofs {row['dofs']:>9}  threads {row['threads']}  "
                  f"set-up {s['scheme']:8.1f} s "
                  f"(solver {s['solver_setup']:7.1f} s)  step {s['step']:8.2f} s = {row['cost']['matvec_ratio']:7.1f} "
                  f"products  its {its.get('mean', 0):6.1f}  "
                  f"peak {row['peak_bytes'] / 2**30:6.2f} GiB = "
                  f"{row['peak_bytes'] / row['dofs'] / 1e3:6.1f} kB/unknown",
                  flush=True)
    print("the cost of a step in step-matrix products against N (summary.json's matvec_ratio):")
    for row in rows:
        cost = row["cost"]
        its = f"{cost['iterations_mean']:6.1f}" if cost["iterations_mean"] is not None else f"{'-':>6}"
        print(f"  N {row['dofs']:>9}  {row['solver']:>9}  iterations {its}  matvec_ratio {cost['matvec_ratio']:8.1f}")
    for method in ("iterative", "petsc"):
        growth(rows, method)
    if args.json:
        from fsivsp.experiments.report import write_json
        write_json(args.json, {"machine": platform.platform(), "processor": platform.processor(), "maxh": args.maxh,
                               "tolerance": args.tolerance, "rows": rows})
    if args.plot:
        plot(rows, args.plot)


if __name__ == "__main__":
    main()
