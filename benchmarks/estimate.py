"""The estimate of `fsivsp.estimate` against the measured run: unknowns, estimated and measured peak memory
(``/usr/bin/time``'s maximum resident set of ``fsivsp run``), estimated and written output bytes.

    PYTHONPATH=src .venv/bin/python benchmarks/estimate.py [NAME ...] --json benchmarks/estimate.json

Each case is an example's geometry, materials and boundaries with a few steps (`CASES`), run in a process of
its own (``--force``, so that the estimate does not stop it). BENCHMARKS.md, "The estimate before set-up", has the
figures.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

STIR_2D = '\n[data]\nforce_fluid = ["-10*(y - 0.5)", "10*(x - 0.5)"]\n'
STIR_3D = '\n[data]\nforce_fluid = ["-10*(y - 0.5)", "10*(x - 0.5)", "0"]\n'

#: name → (example, refinements, [discretisation] lines, steps[, data]): the fluid balls and disks stirred as
#: examples/large_ball_3d.toml is (zero data would leave MinRes nothing to solve)
CASES = {
    "tube-2d-mini": ("pressure_wave_2d.toml", 0, 'family = "mini"', 10),
    "wave-2d-th": ("pressure_wave_2d.toml", 1, 'family = "taylor_hood"', 10),
    "disk-2d-mini": ("fluid_in_solid_2d.toml", 3, 'family = "mini"\ncurved = false', 5, STIR_2D),
    "disk-2d-th": ("fluid_in_solid_2d.toml", 3, 'family = "taylor_hood"\ncurved = false', 5, STIR_2D),
    "ball-3d-mini": ("fluid_in_solid_3d.toml", 1, 'family = "mini"\ncurved = false', 3, STIR_3D),
    "ball-3d-mini-2": ("fluid_in_solid_3d.toml", 2, 'family = "mini"\ncurved = false', 3, STIR_3D),
    "ball-3d-mini-3": ("fluid_in_solid_3d.toml", 3, 'family = "mini"\ncurved = false', 2, STIR_3D),
    "ball-3d-iterative-3": ("fluid_in_solid_3d.toml", 3, 'family = "mini"\ncurved = false\nsolver = "iterative"',
                            2, STIR_3D),
    "wave-3d-mini": ("pressure_wave.toml", 0, 'family = "mini"', 3),
    "ball-3d-th-2": ("fluid_in_solid_3d.toml", 2, 'family = "taylor_hood"\ncurved = false', 2, STIR_3D),
}


def case_text(example: str, refine: int, discretisation: str, steps: int, data: str = "") -> str:
    """The example's geometry, materials and boundaries with ``steps`` steps of its Δt and no VTK files."""
    text = (ROOT / "examples" / example).read_text()
    head = text.split("[discretisation]")[0].split("[time]")[0]
    boundaries = "".join("[boundary." + part.split("[output]")[0] for part in text.split("[boundary.")[1:])
    dt = float(text.split("dt = ")[1].split()[0])
    head = head.replace("[geometry]\n", f"[geometry]\nrefine = {refine}\n")
    return (f"{head}[time]\nT = {steps * dt!r}\ndt = {dt!r}\n\n[discretisation]\n{discretisation}\n\n"
            f"{boundaries}{data}\n[output]\nevery = {steps}\n")


def measure(name: str, folder: Path) -> dict:
    """One case: the estimate (in this process) and the run's peak and output (in a child of /usr/bin/time)."""
    from fsivsp.app.estimate import estimate
    from fsivsp.config.production import load_run_case

    path = folder / f"{name}.toml"
    path.write_text(case_text(*CASES[name]))
    figures = estimate(load_run_case(path))
    out = folder / name
    done = subprocess.run(["/usr/bin/time", "-f", "%M", sys.executable, "-m", "fsivsp", "run", str(path),
                           "--out", str(out), "--quiet", "--force"], capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(f"{name}: {done.stderr}")
    peak = int(done.stderr.split()[-1]) * 1024
    written = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    summary = json.loads((out / "summary.json").read_text())
    return {"case": name, "unknowns": figures.unknowns, "solver": figures.solver, "estimate_bytes": figures.memory,
            "peak_bytes": peak, "ratio": figures.memory / peak, "output_estimate": figures.output,
            "output_bytes": written, "output_ratio": figures.output / written,
            "seconds_per_step_estimate": figures.seconds_per_step, "loop_seconds":
            summary["seconds"]["total"] - summary["seconds"]["setup"], "steps": summary["step"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"cases (default all): {', '.join(CASES)}")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    if unknown := set(args.names) - set(CASES):
        parser.error(f"NAME: expected some of {', '.join(CASES)}, got {', '.join(sorted(unknown))}")
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name in args.names or list(CASES):
            rows.append(measure(name, Path(folder)))
            row = rows[-1]
            print(f"{name}: {row['unknowns']} unknowns ({row['solver']}), estimate {row['estimate_bytes'] / 2**20:.0f} "
                  f"MiB, peak {row['peak_bytes'] / 2**20:.0f} MiB, ratio {row['ratio']:.2f}; output estimate "
                  f"{row['output_estimate'] / 1e6:.2f} MB, written {row['output_bytes'] / 1e6:.2f} MB", flush=True)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
