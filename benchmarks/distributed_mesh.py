"""Meshes refined where they live (docs/mpi.md, issue 36): ``mpirun -np N fsivsp run`` of a 3D case at several
refinement counts, every rank's cells, unknowns, peak memory when its part of the mesh is ready (before spaces and
assembly) and over the whole run, set-up time, and the time per step, from summary.json's ``ranks``.

    python benchmarks/distributed_mesh.py --case examples/large_ball_3d.toml --refine 2 3 --ranks 3 --steps 2 \\
        --json benchmarks/distributed_mesh.json
    python benchmarks/distributed_mesh.py ... --share 1000000000   # rank 0 refines everything, as before issue 36

The case is copied as `mpi_scaling.case_text` does (``refine``, ``T = steps·dt``, no VTK, probes or checkpoints).
``--share`` sets `geometry.distribute.FAIR_SHARE` (cells per rank before rank 0 hands the mesh out). Memory does not
depend on the machine's load; times do: the record keeps the load average of the run.
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from mpi_scaling import case_text

ROOT = Path(__file__).resolve().parents[1]
MIB = 2**20

#: ``fsivsp ARGS`` with `geometry.distribute.FAIR_SHARE` set to the first argument.
SHARED = ("import importlib, sys; importlib.import_module('fsivsp.geometry.distribute').FAIR_SHARE = "
          "int(sys.argv.pop(1)); from fsivsp.app.cli import main; sys.exit(main(sys.argv[1:]))")


def run(case: Path, out: Path, ranks: int, share: int | None) -> dict:
    """One ``mpirun -np ranks fsivsp run`` and its record: the global counts and every rank's figures."""
    distribute = importlib.import_module("fsivsp.geometry.distribute")   # the module (the package exports a function)
    if share is not None:
        distribute.FAIR_SHARE = share
    mpirun = shutil.which("mpirun", path=str(Path(sys.executable).parent)) or "mpirun"
    program = ["-c", SHARED, str(share)] if share is not None else ["-m", "fsivsp"]
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    subprocess.run([mpirun, "-np", str(ranks), sys.executable, *program, "run", str(case), "--out", str(out),
                    "--quiet", "--force"], check=True, env=env)
    summary = json.loads((out / "summary.json").read_text())
    seconds, per_rank = summary["seconds"], summary["ranks"]
    refine, cells = summary["inputs"]["geometry"].get("refine", 0), summary["mesh"]["cells"]
    return {"ranks": ranks, "refine": refine, "cells": cells, "unknowns": summary["dofs"]["free"],
            "fair_share": distribute.FAIR_SHARE,
            "root_levels": min(refine, distribute.root_levels(cells // 8**refine, 3, ranks)),
            "seconds_per_step": (seconds["total"] - seconds["setup"]) / summary["step"],
            "iterations": summary["solver"]["iterations"]["mean"], "load_average": os.getloadavg()[0],
            "per_rank": [dict(zip(("cells", "unknowns", "mesh_peak_memory_bytes", "peak_memory_bytes",
                                   "setup_seconds"), values))
                         for values in zip(*(per_rank[key] for key in ("cells", "unknowns", "mesh_peak_memory_bytes",
                                                                       "peak_memory_bytes", "setup_seconds")))]}


def table(records: list[dict]) -> str:
    """One row per rank and run, Markdown."""
    lines = ["| refine | cells | unknowns | rank | its cells | its unknowns | mesh-stage peak | whole-run peak | "
             "set-up | s per step |", "|" + "---|" * 10]
    for r in records:
        for rank, mine in enumerate(r["per_rank"]):
            head = (f"{r['refine']} | {r['cells']:,} | {r['unknowns']:,}" if rank == 0 else " | | ").replace(",", " ")
            peaks = (mine["mesh_peak_memory_bytes"] / MIB, mine["peak_memory_bytes"] / MIB)
            lines.append(f"| {head} | {rank} | {mine['cells']:,} | {mine['unknowns']:,} | {peaks[0]:.0f} MiB | "
                         f"{peaks[1]:.0f} MiB | {mine['setup_seconds']:.1f} s | {r['seconds_per_step']:.2f} |"
                         .replace(",", " "))
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case", type=Path, default=ROOT / "examples" / "large_ball_3d.toml")
    parser.add_argument("--refine", type=int, nargs="+", default=[2, 3])
    parser.add_argument("--ranks", type=int, default=3)
    parser.add_argument("--steps", type=int, default=2)
    parser.add_argument("--share", type=int, default=None, help="FAIR_SHARE (default: fsivsp's)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT / "src"))
    records = []
    with tempfile.TemporaryDirectory() as folder:
        for refine in args.refine:
            case = Path(folder) / f"refine{refine}.toml"
            case.write_text(case_text(args.case, refine, args.steps))
            records.append(run(case, Path(folder) / f"out{refine}", args.ranks, args.share))
            print(table(records[-1:]), flush=True)
    print(table(records))
    first, last = records[0]["per_rank"][0], records[-1]["per_rank"][0]
    others = [r["per_rank"][0]["peak_memory_bytes"] / max(m["peak_memory_bytes"] for m in r["per_rank"][1:])
              for r in records]
    print(f"rank 0's mesh-stage peak: ×{last['mesh_peak_memory_bytes'] / first['mesh_peak_memory_bytes']:.2f} "
          f"for ×{records[-1]['cells'] / records[0]['cells']:.0f} the cells; its whole-run peak over the largest "
          f"other rank's: {', '.join(f'{ratio:.2f}' for ratio in others)}")
    if args.json:
        args.json.write_text(json.dumps({"case": str(args.case.relative_to(ROOT)), "steps": args.steps,
                                         "records": records}, indent=2) + "\n")


if __name__ == "__main__":
    main()
