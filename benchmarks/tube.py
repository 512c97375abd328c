"""The 3D fluid-filled elastic tube (examples/pressure_wave.toml) at several mesh sizes, solvers and rank counts.

Each (maxh, solver, ranks) is one ``fsivsp run`` of ``--steps`` steps in a process (or ``mpirun -np RANKS``) of its
own. Reads the run's summary.json: free unknowns, the peak memory of each rank,
iterations per step, set-up and time per step (the run's total minus its set-up, over the steps; and the steps
alone, summary.json's ``step_seconds``), one
matrix–vector product of the step matrix (the PETSc solver's ``matvec_seconds``) and the step's cost in products;
and the run's own record of that cost, ``matvec_ratio`` (summary.json: the steps alone over the median of 5 products
with NGSolve's step matrix, `timestepping.cost`). Prints a table and writes JSON.

    python benchmarks/tube.py --maxh 0.1 0.07 0.05 --solvers petsc iterative --steps 3 --json benchmarks/tube.json
    python benchmarks/tube.py --maxh 0.05 --solvers petsc --ranks 1 2 --steps 3 --json benchmarks/tube_mpi.json
    python benchmarks/tube.py --maxh 0.065 0.06 --steps 10 --velocity default ssor --json benchmarks/tube_velocity.json

``--velocity`` forces PETSc's velocity preconditioner (`solvers.spec.VELOCITY_PRECONDITIONERS`; ``default``: the
package's choice), one run per name beside the others.
"""
from __future__ import annotations

import argparse
import itertools
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).parent.parent
EXAMPLE = ROOT / "examples" / "pressure_wave.toml"


def case_text(maxh: float, solver: str, steps: int, velocity: str = "default") -> str:
    """The example with mesh size ``maxh``, ``solver`` and ``steps`` steps, no field output, and PETSc's velocity
    preconditioner ``velocity`` unless it is ``default``."""
    text = EXAMPLE.read_text()
    text = re.sub(r"^maxh = .*$", f"maxh = {maxh}", text, flags=re.M)
    text = re.sub(r"^T = .*$", f"T = {steps * 1.25e-5!r}", text, flags=re.M)
    text = text.replace('family = "mini"', f'family = "mini"\nsolver = "{solver}"')
    text = re.sub(r"^every = 160 .*$", "vtk = false", text, flags=re.M)
    return text if velocity == "default" else text + f'\n[solver.petsc]\nvelocity_preconditioner = "{velocity}"\n'


def measure(maxh: float, solver: str, ranks: int, steps: int, folder: Path, velocity: str = "default") -> dict:
    case = folder / f"tube_{maxh}_{solver}_{ranks}_{velocity}.toml"
    case.write_text(case_text(maxh, solver, steps, velocity))
    out = folder / case.stem
    command = [sys.executable, "-m", "fsivsp", "run", str(case), "--out", str(out), "--quiet"]
    if ranks > 1:
        command = ["/usr/bin/mpirun", "--allow-run-as-root", "-np", str(ranks), *command]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        return {"maxh": maxh, "solver": solver, "ranks": ranks, "failed": done.stderr.strip().splitlines()[-3:]}
    summary = json.loads((out / "summary.json").read_text())
    seconds, statistics = summary["seconds"], summary["solver"]
    step = (seconds["total"] - seconds["setup"]) / steps
    matvec = statistics.get("matvec_seconds")
    peak = max(summary["ranks"]["peak_memory_bytes"]) if "ranks" in summary else summary["peak_memory_bytes"]
    return {"maxh": maxh, "solver": statistics["method"], "ranks": ranks, "dofs": summary["dofs"]["free"],
            "velocity": statistics.get("preconditioner", {}).get("velocity"),
            "iterations": statistics.get("iterations"), "setup_seconds": seconds["setup"],
            "solver_setup_seconds": statistics.get("setup_seconds"), "step_seconds": step,
            "matvec_seconds": matvec, "step_matvecs": step / matvec if matvec else None,
            "matvec_ratio": statistics.get("matvec_ratio"), "iterations_mean": statistics.get("iterations_mean"),
            "steps_alone_seconds": statistics.get("step_seconds"),
            "peak_bytes_per_rank": peak, "peak_bytes_of_ranks": summary.get("ranks", {}).get(
                "peak_memory_bytes", [summary["peak_memory_bytes"]]), "l2_norms": summary["l2_norms"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maxh", type=float, nargs="+", default=[0.1, 0.07])
    parser.add_argument("--solvers", nargs="+", default=["petsc"])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1])
    parser.add_argument("--steps", type=int, default=3)
    parser.add_argument("--velocity", nargs="+", default=["default"], help="PETSc's velocity preconditioners")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    records = []
    print(f"{'maxh':>6} {'solver':>10} {'velocity':>10} {'ranks':>5} {'unknowns':>10} {'its':>6} {'set-up s':>9} "
          f"{'s/step':>8} {'steps s':>8} {'matvecs':>8} {'ratio':>8} {'GiB/rank':>8}")
    with tempfile.TemporaryDirectory() as folder:
        for maxh in args.maxh:
            for solver in args.solvers:
                for ranks, velocity in itertools.product(args.ranks, args.velocity):
                    r = measure(maxh, solver, ranks, args.steps, Path(folder), velocity)
                    records.append(r)
                    if "failed" in r:
                        print(f"{maxh:6.3f} {solver:>10} {velocity:>10} {ranks:5d} failed: {r['failed']}", flush=True)
                        continue
                    its = r["iterations"]["mean"] if r["iterations"] else float("nan")
                    matvecs = f"{r['step_matvecs']:8.0f}" if r["step_matvecs"] else f"{'–':>8}"
                    ratio = f"{r['matvec_ratio']:8.0f}" if r["matvec_ratio"] else f"{'–':>8}"
                    alone = r["steps_alone_seconds"] or float("nan")
                    print(f"{maxh:6.3f} {r['solver']:>10} {r['velocity'] or '–':>10} {ranks:5d} {r['dofs']:10d} "
                          f"{its:6.1f} {r['setup_seconds']:9.1f} {r['step_seconds']:8.2f} {alone:8.3f} {matvecs} "
                          f"{ratio} {r['peak_bytes_per_rank'] / 2**30:8.2f}", flush=True)
                    if args.json:
                        args.json.write_text(json.dumps(records, indent=1) + "\n")


if __name__ == "__main__":
    main()
