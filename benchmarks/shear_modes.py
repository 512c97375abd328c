"""The eigenvalue convergence table of docs/frequency.md: the coupled modes of the shear layers (`fluid_over_solid`,
periodic in x, h_F = h_S = 0.5, period 0.25, ρ = 1, ν = 0.1, λ = 2, μ = 1) against the roots of the dispersion
relation (D) and the compressional mode (`fsivsp.experiments.shear_layers`), MINI and Taylor–Hood k = 1, 2 on
uniformly refined meshes.

    .venv/bin/python benchmarks/shear_modes.py --levels 0-3 --json benchmarks/shear_modes.json
    .venv/bin/python benchmarks/shear_modes.py --table benchmarks/shear_modes.json   # the table of a saved run

Each exact eigenvalue is matched with the nearest of the 6 eigenvalues nearest it (shift-and-invert at the root
itself), as a coarse mesh may have another mode nearer the target than the one sought.
"""
from __future__ import annotations

import argparse
import json
import math
import time

from fsivsp.solvers.petsc_init import use

use("complex")

from fsivsp.experiments.shear_layers import ShearLayers, compressional  # noqa: E402
from fsivsp.fem.spaces import build_spaces  # noqa: E402
from fsivsp.frequency.modes import ModeSolver  # noqa: E402
from fsivsp.geometry import build_geometry, refined  # noqa: E402
from fsivsp.model.materials import Materials  # noqa: E402
from fsivsp.runtime.threads import using  # noqa: E402

MATERIALS = Materials(1.0, 1.0, 0.1, 2.0, 1.0)
LAYERS = ShearLayers(1.0, 1.0, 0.1, 1.0, 0.5, 0.5)
FAMILIES = (("mini", 1), ("taylor_hood", 1), ("taylor_hood", 2))


def targets() -> list[tuple[str, complex]]:
    """s₁ … s₅ (roots of (D) in Re > −25, Im ≥ 0) and the compressional mode s_c."""
    roots = [s for s in LAYERS.roots((-25.0, 0.5, -1.0, 16.0), starts=14) if s.imag >= -1e-12]
    return [(f"s{i}", s) for i, s in enumerate(roots, start=1)] + [("s_c", compressional(2.0, 1.0, 1.0, 0.5))]


def nearest(spaces, s: complex) -> tuple[complex, float, int]:
    """The eigenvalue nearest ``s`` among the 6 pairs nearest it (shift-and-invert at ``s``), its backward error,
    the pencil's size."""
    solver = ModeSolver(spaces, MATERIALS, s)
    try:
        pairs = [(s_h, residual) for s_h, residual, _ in solver.solve(6)]
        return (*min(pairs, key=lambda pair: abs(pair[0] - s)), solver.pencil.numbering.size)
    finally:
        solver.destroy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", default="0-3")
    parser.add_argument("--json", default=None)
    parser.add_argument("--table", default=None, metavar="JSON", help="print the table of a saved run and stop")
    args = parser.parse_args()
    if args.table:
        with open(args.table) as handle:
            saved = json.load(handle)
        print(table(saved["records"], [(name, complex(*s)) for name, s in saved["exact"]]))
        return
    low, high = (int(x) for x in args.levels.split("-"))
    exact = targets()
    coarse = build_geometry("fluid_over_solid", 2, 0.125, width=0.25, periodic="x")
    records = []
    with using(1):
        for family, order in FAMILIES:
            for level in range(low, high + 1):
                spaces = build_spaces(refined(coarse, level), family, order, "fluid_wall|solid_wall")
                start = time.perf_counter()
                row = {"family": family, "order": order, "level": level, "modes": {}}
                for name, s in exact:
                    s_h, residual, row["unknowns"] = nearest(spaces, s)
                    row["modes"][name] = {"exact": [s.real, s.imag], "computed": [s_h.real, s_h.imag],
                                          "error": abs(s_h - s) / abs(s), "residual": residual}
                row["seconds"] = time.perf_counter() - start
                records.append(row)
                print(json.dumps(row), flush=True)
    print(table(records, exact))
    if args.json:
        with open(args.json, "w") as handle:
            json.dump({"exact": [[n, [s.real, s.imag]] for n, s in exact], "records": records}, handle, indent=1)


def table(records: list[dict], exact) -> str:
    """Relative errors |s_h − s|/|s| (rate log₂ of the ratio to the level before) as Markdown."""
    names = [n for n, _ in exact]
    def value(s: complex) -> str:
        return f"{s.real:.6g}" + (f" {'+−'[s.imag < 0]} {abs(s.imag):.6g}i" if abs(s.imag) > 1e-12 * abs(s) else "")

    lines = ["| element | level | unknowns | " + " | ".join(f"{n} = {value(s)}" for n, s in exact) + " |",
             "|---|---|---|" + "---|" * len(names)]
    for i, row in enumerate(records):
        before = records[i - 1] if i and records[i - 1]["family"] == row["family"] and \
            records[i - 1]["order"] == row["order"] else None
        cells = []
        for n in names:
            error = row["modes"][n]["error"]
            rate = f" ({math.log2(before['modes'][n]['error'] / error):.2f})" if before else ""
            cells.append(f"{error:.2e}{rate}")
        element = "MINI" if row["family"] == "mini" else f"TH{row['order']}"
        lines.append(f"| {element} | {row['level']} | {row['unknowns']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
