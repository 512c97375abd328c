"""1 against 2 threads (`fsivsp.threads.using`), one fresh process per configuration and thread count.

Per configuration: the scheme's set-up (spaces, assembly, solver set-up), the step matrix's assembly alone,
the solver's set-up (factorisation or preconditioner, its ``setup_seconds``) and the wall time per step of
`Scheme.march`, on 1 and on 2 threads, with the ratio 1-thread / 2-thread. Prints a table and writes JSON.

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

#: (name, case, level, solver): the paper's level 4 (direct) and the 3D fluid ball at level 3.
CONFIGURATIONS = [("paper", "paper", 4, "direct"),
                  ("ball", "examples/fluid_in_solid_3d.toml", 3, "direct"),
                  ("ball", "examples/fluid_in_solid_3d.toml", 3, "iterative"),
                  ("ball", "examples/fluid_in_solid_3d.toml", 3, "petsc")]
QUICK_LEVELS = {"paper": 1, "ball": 1}
TIMES = ("setup", "assembly", "solver_setup", "step")


def _timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def measure(where: str, level: int, solver: str, threads: int, steps: int) -> dict:
    """One configuration on ``threads`` threads, in this process."""
    from fsivsp import forms
    from fsivsp.case import load_study_case
    from fsivsp.geometry import refined
    from fsivsp.paper import paper_case
    from fsivsp.study import discretise
    from fsivsp.threads import using

    with using(threads):
        case = (paper_case(1e-2) if where == "paper" else load_study_case(where)).with_solver(method=solver)
        mesh = refined(case.coarse_mesh(), level, case.discretisation.project_refinement)
        made = {}
        setup = _timed(lambda: made.update(scheme=discretise(case, mesh)[0]))
        scheme = made["scheme"]
        assembly = _timed(lambda: forms.step_matrix(scheme.spaces, case.materials, scheme.tau).Assemble())
        step = _timed(lambda: scheme.march(steps)) / steps
    return {"threads": threads, "unknowns": scheme.spaces.free_dofs(), "setup": setup, "assembly": assembly,
            "solver_setup": scheme.solver.statistics().get("setup_seconds"), "step": step}


def in_process(where: str, level: int, solver: str, threads: int, steps: int) -> dict:
    """`measure` in a fresh process (its own NGSolve and MKL start-up)."""
    out = subprocess.run([sys.executable, __file__, "--child", where, str(level), solver, str(threads), str(steps)],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def compare(name: str, where: str, level: int, solver: str, steps: int) -> dict:
    """1 and 2 threads of one configuration, and the ratios."""
    one, two = (in_process(where, level, solver, n, steps) for n in (1, 2))
    ratio = {key: one[key] / two[key] for key in TIMES if one[key] and two[key]}
    return {"case": name, "level": level, "solver": solver, "unknowns": one["unknowns"], "steps": steps,
            "one": one, "two": two, "ratio": ratio}


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
    parser.add_argument("--quick", action="store_true", help="level 1 of each case and 2 steps")
    parser.add_argument("--steps", type=int, default=20, help="time steps timed per run (default 20)")
    parser.add_argument("--json", default=None, help="write the records to this file")
    parser.add_argument("--child", nargs=5, metavar=("CASE", "LEVEL", "SOLVER", "THREADS", "STEPS"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        where, level, solver, threads, steps = args.child
        print(json.dumps(measure(where, int(level), solver, int(threads), int(steps))))
        return 0
    steps = 2 if args.quick else args.steps
    records = [compare(name, where, QUICK_LEVELS[name] if args.quick else level, solver, steps)
               for name, where, level, solver in CONFIGURATIONS]
    print(table(records))
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"machine": platform.node(), "records": records}, file, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
