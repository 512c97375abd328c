"""Locking (issue 33): the errors of a manufactured case at λ/μ = 1, 10², 10⁴ on three levels, with and without the
solid pressure (`[discretisation] solid_pressure`), direct solves. The case is examples/fluid_in_solid_2d.toml's
with a divergence-free displacement (P = −λ div u bounded as λ grows: a nearly incompressible solid), v independent
of t and u linear in t, so backward Euler adds no time error.

    python benchmarks/locking.py --json benchmarks/locking.json
"""
from __future__ import annotations

import argparse
from pathlib import Path

from fsivsp.config.case import load_study_case
from fsivsp.experiments.study import study
from fsivsp.io.atomic import write_json

RATIOS = (1.0, 1e2, 1e4)
ELEMENTS = ("mini", "taylor_hood")


def case(ratio: float, family: str, solid_pressure: str):
    """The manufactured case at λ = ``ratio`` μ."""
    return load_study_case({
        "geometry": {"kind": "fluid_in_solid", "dim": 2, "maxh": 0.15},
        "materials": {"rho_fluid": 1.0, "rho_solid": 2.0, "nu": 0.5, "lam": ratio * 0.75, "mu": 0.75},
        "time": {"T": 0.1, "dt": 0.02},
        "discretisation": {"family": family, "order": 1, "solid_pressure": solid_pressure, "solver": "direct"},
        "exact": {"velocity": ["sin(pi*y)", "sin(pi*x)"], "pressure": "cos(pi*x)*cos(pi*y)",
                  "displacement": ["x**2 + (1 + t)*sin(pi*y)", "-2*x*y + (1 + t)*sin(pi*x)"]}})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", default="0-2")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    first, last = (int(x) for x in args.levels.split("-"))
    rows = []
    print("| element | λ/μ | level | e(v) none | e(v) continuous | e(σ) none | e(σ) continuous |")
    print("|---|---|---|---|---|---|---|")
    for family in ELEMENTS:
        for ratio in RATIOS:
            old, new = (study(case(ratio, family, kind), range(first, last + 1)) for kind in ("none", "continuous"))
            for a, b in zip(old, new):
                ev = [(r["errors"]["v1"] ** 2 + r["errors"]["v2"] ** 2) ** 0.5 for r in (a, b)]
                rows.append({"element": family, "lam/mu": ratio, "level": a["level"],
                             "dofs": {"none": a["dofs"], "continuous": b["dofs"]},
                             "errors": {"none": a["errors"], "continuous": b["errors"]}})
                print(f"| {family} | {ratio:g} | {a['level']} | {ev[0]:.3g} | {ev[1]:.3g} | "
                      f"{a['errors']['sigma']:.3g} | {b['errors']['sigma']:.3g} |", flush=True)
    if args.json:
        write_json(args.json, {"rows": rows})


if __name__ == "__main__":
    main()
