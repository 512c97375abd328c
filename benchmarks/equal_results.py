"""The errors of ``fsivsp paper --dt 1e-2 --levels 0-3`` and ``fsivsp matrix`` against a recorded reference.

A refactor must not change results: this runs both commands (fresh processes, the default threads) and
compares every error norm of every level and entry with `REFERENCE`, recorded before the change
(issue 23: at commit 77a76cb, on one thread). Prints the largest relative difference per command and exits 1
above ``--tolerance`` (default 1e-12). ``--threads N`` runs the commands on N threads (FSIVSP_THREADS; default
1, the reference's): between thread counts the errors agree to round-off, not to 1e-12 (docs/solvers.md).

    python benchmarks/equal_results.py                     # compare
    python benchmarks/equal_results.py --record            # run both and record them as the reference
    python benchmarks/equal_results.py --record --paper P.json --matrix M.json   # record from earlier outputs
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REFERENCE = Path(__file__).with_suffix(".json")
COMMANDS = {"paper": ["paper", "--dt", "1e-2", "--levels", "0-3"], "matrix": ["matrix"]}


def run(command: str, folder: Path, threads: int) -> Path:
    """``fsivsp <command> --json`` into ``folder`` on ``threads`` threads; the JSON's path."""
    out = folder / f"{command}.json"
    subprocess.run([sys.executable, "-m", "fsivsp", *COMMANDS[command], "--json", str(out), "--quiet"],
                   check=True, stdout=subprocess.DEVNULL, env=dict(os.environ, FSIVSP_THREADS=str(threads)))
    return out


def errors(command: str, path: Path) -> dict[str, float]:
    """Every error norm of a command's JSON as ``{"entry/level/norm": value}``."""
    records = json.loads(path.read_text())
    entries = [("paper", records)] if command == "paper" else [(e["entry"], e["records"]) for e in records]
    return {f"{name}/{r['level']}/{norm}": value for name, levels in entries for r in levels
            for norm, value in r["errors"].items()}


def largest_difference(now: dict[str, float], then: dict[str, float]) -> tuple[float, str]:
    """The largest relative difference and where; a key missing on either side is infinitely far."""
    if missing := set(now) ^ set(then):
        return float("inf"), sorted(missing)[0]
    return max((abs(now[k] - then[k]) / max(abs(then[k]), 1e-300), k) for k in then)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record", action="store_true", help="record the reference instead of comparing")
    parser.add_argument("--paper", type=Path, help="an earlier `fsivsp paper --dt 1e-2 --levels 0-3 --json` output")
    parser.add_argument("--matrix", type=Path, help="an earlier `fsivsp matrix --json` output")
    parser.add_argument("--tolerance", type=float, default=1e-12)
    parser.add_argument("--threads", type=int, default=1, help="threads of the runs (default 1, the reference's)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        given = {"paper": args.paper, "matrix": args.matrix}
        now = {c: errors(c, given[c] or run(c, Path(folder), args.threads)) for c in COMMANDS}
    if args.record:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        REFERENCE.write_text(json.dumps({"commit": commit, "errors": now}, indent=1) + "\n")
        print(f"recorded {sum(map(len, now.values()))} errors at {commit} in {REFERENCE}")
        return 0
    reference = json.loads(REFERENCE.read_text())
    worst = 0.0
    for command in COMMANDS:
        difference, where = largest_difference(now[command], reference["errors"][command])
        print(f"{command}: {len(now[command])} errors, largest relative difference {difference:.2e} ({where}) "
              f"against {reference['commit']}")
        worst = max(worst, difference)
    return 0 if worst <= args.tolerance else 1


if __name__ == "__main__":
    sys.exit(main())
