"""1 against 2 threads (`fsivsp.runtime.threads.using`), one fresh process per configuration and thread count.

Per configuration, on 1 and on 2 threads with the ratio 1-thread / 2-thread:
- ``assembly``: the step matrix's assembly alone (`forms.step_matrix`), timed once more after the scheme exists;
- ``solver_setup``: the solver's set-up inside `Scheme` (factorisation or preconditioner, ``setup_seconds``);
- ``setup``: the two together, the set-up the issue asks 1.7× of;
- ``scheme``: the whole `Scheme` construction (assembly, loads and lifts, the initial state, the solver);
- ``norms``: a study's error norms (`study.Errors`: Gram matrices, projections, quadrature), where measured;
- ``step``: the wall time per step of `Scheme.march`;
and each process's peak memory (VmHWM). Prints a table and writes JSON.

    python benchmarks/threads.py --json benchmarks/threads.json
    python benchmarks/threads.py --quick          # small meshes, 2 steps: checks that it runs
"""
from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time

BALL = "examples/fluid_in_solid_3d.toml"
#: (name, case, maxh of the coarse ball (None: the example's), level, solver, steps, norms): the paper's level 4
#: (direct), the 3D fluid ball at level 3 (direct, PETSc) and on the 267 522-unknown mesh of
#: benchmarks/scale_2m.json (maxh 0.17, level 3; PETSc, 5 steps).
CONFIGURATIONS = [("paper", "paper", None, 4, "direct", 100, True),
                  ("ball", BALL, None, 3, "direct", 40, True),
                  ("ball", BALL, None, 3, "petsc", 20, False),
                  ("ball 267k", BALL, 0.17, 3, "petsc", 5, False)]
QUICK_LEVELS = {"paper": 1, "ball": 1, "ball 267k": 0}
TIMES = ("setup", "assembly", "solver_setup", "scheme", "norms", "step")


def _timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def measure(where: str, maxh: float | None, level: int, solver: str, threads: int, steps: int, norms: bool) -> dict:
    """One configuration on ``threads`` threads, in this process."""
    import dataclasses

    from fsivsp.app.loop import peak_memory
    from fsivsp.config.case import load_study_case
    from fsivsp.experiments.paper import paper_case
    from fsivsp.experiments.study import Errors, dirichlet_boundaries, manufactured_data
    from fsivsp.fem import forms
    from fsivsp.fem.spaces import build_spaces
    from fsivsp.geometry import build_geometry, refined
    from fsivsp.runtime.threads import using
    from fsivsp.timestepping.scheme import Scheme

    with using(threads):
        case = (paper_case(1e-2) if where == "paper" else load_study_case(where)).with_solver(method=solver)
        if maxh is not None:
            coarse = build_geometry("fluid_in_solid", 3, maxh, curvature_safety=1.0)
            case = dataclasses.replace(case, coarse_mesh=lambda: coarse)
        disc = case.discretisation
        mesh = refined(case.coarse_mesh(), level, disc.project_refinement)
        dirichlet = dirichlet_boundaries(mesh)
        spaces = build_spaces(mesh, disc.family, disc.order, dirichlet)
        data = manufactured_data(case.exact, case.materials, dirichlet, disc.initial_stress, disc.initial_velocity)
        made = {}
        scheme_seconds = _timed(lambda: made.update(scheme=Scheme(spaces, case.materials, data, case.dt,
                                                                  solver=case.solver, time_scheme=case.time_scheme)))
        scheme = made["scheme"]
        norm_seconds = _timed(lambda: Errors(scheme, case.exact)) if norms else None
        assembly = _timed(lambda: forms.step_matrix(scheme.spaces, case.materials, scheme.tau).Assemble())
        step = _timed(lambda: scheme.march(steps)) / steps
    solver_setup = scheme.solver.statistics().get("setup_seconds")
    return {"threads": threads, "unknowns": spaces.free_dofs(), "method": scheme.solver.method,
            "setup": assembly + solver_setup, "assembly": assembly, "solver_setup": solver_setup,
            "scheme": scheme_seconds, "norms": norm_seconds, "step": step,
            "iterations": scheme.solver.statistics().get("iterations"), "peak_memory_bytes": peak_memory()}


def in_process(where: str, maxh: float | None, level: int, solver: str, threads: int, steps: int,
               norms: bool) -> dict:
    """`measure` in a fresh process (its own NGSolve and MKL start-up)."""
    out = subprocess.run([sys.executable, __file__, "--child", where, str(maxh), str(level), solver, str(threads),
                          str(steps), str(int(norms))], capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def compare(name: str, where: str, maxh: float | None, level: int, solver: str, steps: int, norms: bool) -> dict:
    """1 and 2 threads of one configuration, and the ratios."""
    one, two = (in_process(where, maxh, level, solver, n, steps, norms) for n in (1, 2))
    ratio = {key: one[key] / two[key] for key in TIMES if one[key] and two[key]}
    print(f"{name} level {level} {solver}: " + ", ".join(f"{k} {v:.2f}×" for k, v in ratio.items()), flush=True)
    return {"case": name, "maxh": maxh, "level": level, "solver": solver, "unknowns": one["unknowns"],
            "steps": steps, "one": one, "two": two, "ratio": ratio}


def table(records: list[dict]) -> str:
    lines = ["| case | level | solver | unknowns | " + " | ".join(f"{k} 1 / 2 threads (s, ×)" for k in TIMES) + " |",
             "|---" * (4 + len(TIMES)) + "|"]
    for r in records:
        cells = [f"{r['one'][k]:.3g} / {r['two'][k]:.3g} ({r['ratio'][k]:.2f}×)" if k in r["ratio"] else "–"
                 for k in TIMES]
        lines.append(f"| {r['case']} | {r['level']} | {r['solver']} | {r['unknowns']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="small levels of each case and 2 steps")
    parser.add_argument("--only", default=None, help="only the configurations whose case name starts with this")
    parser.add_argument("--json", default=None, help="write the records to this file")
    parser.add_argument("--child", nargs=7, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        where, maxh, level, solver, threads, steps, norms = args.child
        print(json.dumps(measure(where, None if maxh == "None" else float(maxh), int(level), solver, int(threads),
                                 int(steps), norms == "1")))
        return 0
    records = [compare(name, where, maxh, QUICK_LEVELS[name] if args.quick else level, solver,
                       2 if args.quick else steps, norms)
               for name, where, maxh, level, solver, steps, norms in CONFIGURATIONS
               if args.only is None or name.startswith(args.only)]
    print(table(records))
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"machine": platform.node(), "command": " ".join(sys.argv), "records": records}, file, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
