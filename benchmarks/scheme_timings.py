"""Timings of the scheme on the paper's experiment, per refinement level.

Per level: assembly and factorisation (once per run), one time step done sequentially and
split into its right-hand side, solve, stress update and error norms (medians over the run),
the step as `fsivsp paper` takes it (`Scheme.march`: the stress update and the norms
run while the next solve does, wall time per step over the run), and a baseline that
re-assembles and re-factorises every step as a straightforward code would. Prints the
ratios and writes JSON.

    python benchmarks/scheme_timings.py --levels 0-4 --dt 1e-2 --json benchmarks/scheme_timings.json
"""
from __future__ import annotations

import argparse
import platform
import statistics
import time

import ngsolve as ngs

from fsivsp.app.arguments import levels_arg
from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.report import write_json
from fsivsp.experiments.study import Errors, dirichlet_boundaries, manufactured_data
from fsivsp.fem import forms
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import refined
from fsivsp.solvers import DirectSolver, SolverSpec
from fsivsp.timestepping.scheme import Scheme


def timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def baseline_step(scheme: Scheme) -> float:
    """One step of a code that assembles and factorises everything at every step."""
    spaces, mat, dt = scheme.spaces, scheme.materials, scheme.dt

    def step():
        matrix = forms.step_matrix(spaces, mat, dt).Assemble().mat
        for form in (forms.velocity_mass(spaces, mat), forms.solid_stiffness(spaces, mat)):
            form.Assemble()
        DirectSolver(matrix, spaces.mixed.FreeDofs(), method=scheme.solver.method, check=False)
        scheme.step()

    return timed(step)


def measure(level: int, dt: float, steps: int, solver: str | None) -> dict:
    case = paper_case(dt, solver=SolverSpec(solver or "auto"))
    mesh = refined(case.coarse_mesh(), level, case.discretisation.project_refinement)
    dirichlet = dirichlet_boundaries(mesh)
    start = time.perf_counter()
    spaces = build_spaces(mesh, "mini", 1, dirichlet)
    data = manufactured_data(case.exact, case.materials, dirichlet, case.discretisation.initial_stress)
    scheme = Scheme(spaces, case.materials, data, dt, solver=case.solver)
    setup = time.perf_counter() - start
    errors = Errors(scheme, case.exact)
    parts = {"rhs": [], "solve": [], "stress": [], "norms": [], "step": []}
    for _ in range(steps):
        n, current = scheme.n + 1, scheme.time_scheme
        a = timed(lambda current=current, n=n: scheme.right_hand_side(current, n, scheme._rhs, scheme._boundary))
        b = timed(lambda: (scheme.solve(scheme._rhs, scheme._boundary, scheme._raw, scheme.n),
                           scheme.warm.record(scheme._raw)))
        c = timed(lambda n=n, current=current: scheme.accept(scheme._raw, n, current, None))
        d = timed(lambda: errors(scheme))
        for key, value in zip(("rhs", "solve", "stress", "norms", "step"), (a, b, c, d, a + b + c + d)):
            parts[key].append(value)
    median = {key: statistics.median(values) for key, values in parts.items()}
    scheme.initialise()
    run = timed(lambda: scheme.march(steps, errors))
    median["marched"] = run / steps
    baseline = statistics.median(baseline_step(scheme) for _ in range(3))
    return {
        "level": level, "vertices": mesh.nv, "dofs": spaces.free_dofs(), "solver": scheme.solver.method,
        "assembly": setup - scheme.solver.factor_seconds, "factorisation": scheme.solver.factor_seconds,
        "step": median, "run": run, "steps": steps, "baseline_step": baseline,
        "sequential_overhead_over_solve": (median["step"] - median["solve"]) / median["solve"],
        "overhead_over_solve": (median["marched"] - median["solve"]) / median["solve"],
        "speedup_vs_baseline": baseline / median["marched"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=levels_arg, default=range(0, 5))
    parser.add_argument("--dt", type=float, default=1e-2)
    parser.add_argument("--solver", default=None)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    steps = round(1.0 / args.dt)
    rows = [measure(level, args.dt, steps, args.solver) for level in args.levels]
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}, ngsolve {ngs.__version__}; "
          f"dt = {args.dt:g}, {steps} steps")
    print(f"{'level':>5} {'dofs':>7} {'solver':>14} {'assembly':>9} {'factor':>8} {'rhs':>9} {'solve':>9} "
          f"{'stress':>9} {'norms':>9} {'seq. step':>9} {'step':>9} {'run':>8} {'seq. (step-solve)/solve':>24} "
          f"{'(step-solve)/solve':>19} {'baseline/step':>14}")
    for r in rows:
        s = r["step"]
        print(f"{r['level']:>5} {r['dofs']:>7} {r['solver']:>14} {r['assembly']:>9.4f} {r['factorisation']:>8.4f} "
              f"{s['rhs']:>9.2e} {s['solve']:>9.2e} {s['stress']:>9.2e} {s['norms']:>9.2e} {s['step']:>9.2e} "
              f"{s['marched']:>9.2e} {r['run']:>8.2f} {r['sequential_overhead_over_solve']:>24.3f} "
              f"{r['overhead_over_solve']:>19.3f} {r['speedup_vs_baseline']:>14.1f}")
    if args.json:
        write_json(args.json, {"dt": args.dt, "machine": platform.platform(), "levels": rows})


if __name__ == "__main__":
    main()
