"""A default run (no ``--threads``) against ``--threads 1``, the whole command, side by side (issue 33).

Runs ``fsivsp paper --dt 1e-3 --levels 4-4`` (the paper's finest level, 72 339 unknowns, direct solver, 1 000 steps)
with the default threads and with ``--threads 1``, alternately, ``--repeats`` times each, each in a fresh process,
and prints the wall times, the best of each and the ratio default / one thread (≤ 1: the default costs nothing).
A default run of a 2D direct solve takes one thread (`threads.ONE_THREAD`): the two are then the same run. Needs a
quiet machine: the
load average is printed before and after, and a run beside other jobs says nothing (docs/solvers.md, "Threads").

    python benchmarks/threads_default.py                          # ~4 × 40 s
    python benchmarks/threads_default.py --repeats 3 --also 2 --json benchmarks/threads_default.json
    python benchmarks/threads_default.py --args "paper --dt 1e-2 --levels 2-2"    # a quick check that it runs
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

COMMAND = "paper --dt 1e-3 --levels 4-4"


def run(arguments: list[str], threads: int | None) -> dict:
    """One fresh ``fsivsp`` process: its wall time, the unknowns and solver of its first record."""
    env = {key: value for key, value in os.environ.items() if key != "FSIVSP_THREADS"}   # the default: the cores
    with tempfile.TemporaryDirectory() as folder:
        record = Path(folder) / "record.json"
        command = [sys.executable, "-m", "fsivsp", *arguments, "--quiet", "--json", str(record)]
        if threads is not None:
            command += ["--threads", str(threads)]
        start = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True, text=True, env=env)
        seconds = time.perf_counter() - start
        records = json.loads(record.read_text())
    first = records[0] if isinstance(records, list) and records else {}
    return {"threads_given": threads, "seconds": seconds, "unknowns": first.get("dofs"), "solver": first.get("solver")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--args", default=COMMAND, help=f"the fsivsp command line (default {COMMAND!r})")
    parser.add_argument("--repeats", type=int, default=2, help="runs of each, alternating (default 2)")
    parser.add_argument("--also", type=int, nargs="*", default=[],
                        help="thread counts to run beside them, e.g. 2 (what the default ran before issue 33)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    arguments = shlex.split(args.args)
    load = os.getloadavg()[0]
    print(f"load average before: {load:.2f} on {len(os.sched_getaffinity(0))} cores"
          + ("  (not quiet: the times below say little)" if load > 0.5 else ""), flush=True)
    rows = []
    for repeat in range(args.repeats):
        for threads in (None, 1, *args.also):
            row = run(arguments, threads)
            rows.append(row)
            label = "default" if threads is None else f"--threads {threads}"
            print(f"run {repeat + 1}  {label:>12}: {row['seconds']:7.2f} s  "
                  f"({row['solver']}, {row['unknowns']} unknowns)", flush=True)
    best = {("default" if given is None else f"--threads {given}"): min(r["seconds"] for r in rows
                                                                         if r["threads_given"] == given)
            for given in (None, 1, *args.also)}
    for label, seconds in best.items():
        if label not in ("default", "--threads 1"):
            print(f"best {label}: {seconds:.2f} s = {seconds / best['--threads 1']:.3f} × --threads 1")
    ratio = best["default"] / best["--threads 1"]
    after = os.getloadavg()[0]
    print(f"best: default {best['default']:.2f} s, --threads 1 {best['--threads 1']:.2f} s: "
          f"default / one = {ratio:.3f} "
          f"({'no slower' if ratio <= 1.0 else 'slower'}); load average after: {after:.2f}")
    if args.json:
        args.json.write_text(json.dumps({"command": args.args, "machine": platform.platform(), "load_before": load,
                                         "load_after": after, "rows": rows, "best": best, "ratio": ratio}, indent=1))


if __name__ == "__main__":
    main()
