"""Distributed runs against the serial one (docs/mpi.md): ``fsivsp run`` of a case, serially and under
``mpirun -np N``, timed per step, with the iterative solver's iterations and every rank's peak memory.

    python benchmarks/mpi_scaling.py --case examples/large_ball_3d.toml --refine 2 --steps 3 --ranks 2,3 \\
        --json benchmarks/mpi_scaling.json

The case is copied with ``[geometry] refine``, ``[time] T = steps·dt``, no VTK and no probes (not written under
mpirun yet); the serial run takes the case's solver, the distributed ones their own (BDDC, `solvers.distributed`).
NGSolve keeps rank 0 free of cells, so N ranks assemble and solve on N − 1 parts.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def case_text(path: Path, refine: int | None, steps: int, maxh: float | None = None) -> str:
    """The case file with the overrides of the module's docstring (and ``maxh`` if given), as TOML text."""
    doc = tomllib.loads(path.read_text())
    if refine is not None:
        doc["geometry"]["refine"] = refine
    if maxh is not None:
        doc["geometry"]["maxh"] = maxh
    doc["time"]["T"] = steps * doc["time"]["dt"]
    doc.setdefault("output", {}).update(vtk=False)
    for key in ("probes", "lines"):
        doc["output"].pop(key, None)
    doc.pop("checkpoint", None)
    return "\n".join(toml(doc)) + "\n"


def toml(table: dict, name: str = "") -> list[str]:
    """Lines of TOML for a table of numbers, strings, booleans, lists of them and tables."""
    lines = [f"[{name}]"] if name else []
    lines += [f"{key} = {json.dumps(value)}" for key, value in table.items() if not isinstance(value, dict)]
    for key, value in table.items():
        if isinstance(value, dict):
            lines += toml(value, f"{name}.{key}" if name else key)
    return lines


def run(case: Path, out: Path, ranks: int) -> dict:
    """One ``fsivsp run`` (ranks = 1: without mpirun) and the record of its summary."""
    command = [sys.executable, "-m", "fsivsp", "run", str(case), "--out", str(out), "--quiet"]
    if ranks > 1:
        mpirun = shutil.which("mpirun", path=str(Path(sys.executable).parent)) or "mpirun"
        command = [mpirun, "-np", str(ranks), *command]
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PRTE_MCA_rmaps_default_mapping_policy=":oversubscribe")
    subprocess.run(command, check=True, env=env)
    summary = json.loads((out / "summary.json").read_text())
    seconds, steps = summary["seconds"], summary["step"]
    return {"ranks": ranks, "free_dofs": summary["dofs"]["free"], "solver": summary["solver"]["method"],
            "iterations_mean": summary["solver"].get("iterations", {}).get("mean"),
            "setup_seconds": seconds["setup"], "solver_setup_seconds": seconds["solver_setup"],
            "seconds_per_step": (seconds["total"] - seconds["setup"]) / steps,
            "peak_memory_gib": [m / 2**30 for m in summary.get("ranks", {}).get("peak_memory_bytes",
                                                                              [summary["peak_memory_bytes"]])],
            "l2_norms": summary["l2_norms"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", type=Path, default=ROOT / "examples" / "large_ball_3d.toml")
    parser.add_argument("--refine", type=int, default=2)
    parser.add_argument("--maxh", type=float, default=None, help="the coarse mesh size (default: the case's)")
    parser.add_argument("--steps", type=int, default=3)
    parser.add_argument("--ranks", default="2,3", help="comma-separated rank counts besides the serial run")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    ranks = [1, *(int(r) for r in re.split(r"[, ]+", args.ranks) if r)]
    with tempfile.TemporaryDirectory() as tmp:
        case = Path(tmp) / f"{args.case.stem}.toml"
        case.write_text(case_text(args.case, args.refine, args.steps, args.maxh))
        records = [run(case, Path(tmp) / f"np{n}", n) for n in ranks]
    serial = records[0]["l2_norms"]
    print(f"{args.case.name}, maxh {args.maxh or 'default'}, refine {args.refine}, {args.steps} steps, "
          f"{records[0]['free_dofs']} free unknowns, {os.cpu_count()} cores")
    print("ranks  solver       its   setup s  solver setup s  s/step  peak GiB per rank  max rel. diff of L² norms")
    for r in records:
        diff = max(abs(r["l2_norms"][k] - v) / abs(v) for k, v in serial.items() if v)
        memory = ", ".join(f"{m:.2f}" for m in r["peak_memory_gib"])
        its = f"{r['iterations_mean']:.0f}" if r["iterations_mean"] is not None else "-"
        print(f"{r['ranks']:5d}  {r['solver']:11s} {its:>4s}  {r['setup_seconds']:8.1f}"
              f"  {r['solver_setup_seconds']:14.1f}  {r['seconds_per_step']:6.2f}  {memory:17s}  {diff:.1e}")
    if args.json:
        args.json.write_text(json.dumps({"case": args.case.name, "maxh": args.maxh, "refine": args.refine,
                                         "steps": args.steps, "cores": os.cpu_count(), "records": records},
                                        indent=1) + "\n")


if __name__ == "__main__":
    main()
