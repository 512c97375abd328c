"""Bytes per free unknown of the scheme's operators, excluding the solver: the lean scheme against the
stress-space operators it replaced (session 6: step matrix, M, B, M_σ⁻¹C, the compliance, M − Δt² B M_σ⁻¹C).

Stored entries × 12 bytes (a double and a column index) of each operator, plus 8 bytes per entry of the
vectors the scheme keeps per step (state, displacement, right-hand sides), divided by the free unknowns;
2D and 3D, MINI and Taylor–Hood k = 1, on the fluid-in-solid examples.

    python benchmarks/operator_memory.py --json benchmarks/operator_memory.json
"""
from __future__ import annotations

import argparse
from pathlib import Path

import ngsolve as ngs

from fsivsp.config.case import load_study_case
from fsivsp.experiments.report import write_json
from fsivsp.experiments.study import case_scheme
from fsivsp.fem import forms
from fsivsp.geometry import SOLID, refined
from fsivsp.solvers import compact

EXAMPLES = Path(__file__).parent.parent / "examples"
ENTRY = 12


def stress_space_operators(spaces, mat, dt) -> dict[str, int]:
    """Stored entries of the operators the scheme kept before the lean design."""
    X, S = spaces.mixed, spaces.stress
    sigma, tau = S.TnT()
    w = X.TestFunction()[0]
    divergence = ngs.BilinearForm(trialspace=S, testspace=X)
    divergence += forms.integral(ngs.InnerProduct(sigma, forms.eps(w)), spaces, SOLID)
    mass = ngs.BilinearForm(S)
    mass += ngs.InnerProduct(sigma, tau) * ngs.dx(SOLID)
    rate = forms.stress_rate(spaces, mat).Assemble().mat
    cells = sum(1 for el in S.Elements(ngs.VOL) if len(el.dofs) and min(el.dofs) >= 0)
    per_cell = S.ndof // max(cells, 1)
    return {
        "step": compact(forms.step_matrix(spaces, mat, dt).Assemble().mat).nze,  # as the lean scheme stores it
        "mass": compact(forms.velocity_mass(spaces, mat).Assemble().mat).nze,
        "divergence": compact(divergence.Assemble().mat).nze,
        "update": compact(rate).nze,  # M_σ⁻¹C has C's pattern (block-diagonal M_σ)
        "compliance, M_sigma^-1": 2 * cells * per_cell**2,
        "lagged mass": compact(forms.lagged_operator(spaces, mat, dt**2, 0.0).Assemble().mat).nze,
    }


def measure(example: str, family: str, level: int) -> dict:
    case = load_study_case(EXAMPLES / f"{example}.toml").with_discretisation(family=family, order=1) \
        .with_solver(method="iterative")
    scheme = case_scheme(case, refined(case.coarse_mesh(), level, case.discretisation.project_refinement))
    spaces, free = scheme.spaces, scheme.spaces.free_dofs()
    lean = {"step": scheme._matrix.nze, "lagged mass": scheme._lagged_mass.nze, "stiffness": scheme._stiffness.nze}
    vectors = 8 * 6 * spaces.mixed.ndof  # state, displacement, rhs, boundary, work, offset load
    before = stress_space_operators(spaces, case.materials, case.dt)
    stress_vectors = 8 * 2 * spaces.stress.ndof  # σ and the σ-side temporaries of the old loop
    return {"example": example, "family": family, "level": level, "free": free,
            "lean_bytes_per_unknown": (ENTRY * sum(lean.values()) + vectors) / free,
            "before_bytes_per_unknown": (ENTRY * sum(before.values()) + vectors + stress_vectors) / free,
            "lean": lean, "before": before}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    rows = [measure(example, family, level)
            for example, level in (("fluid_in_solid_2d", 3), ("fluid_in_solid_3d", 2))
            for family in ("mini", "taylor_hood")]
    print(f"{'case':20} {'family':12} {'free':>8} {'before B/unknown':>17} {'lean B/unknown':>15}")
    for r in rows:
        print(f"{r['example']:20} {r['family']:12} {r['free']:>8} {r['before_bytes_per_unknown']:>17.0f} "
              f"{r['lean_bytes_per_unknown']:>15.0f}")
    if args.json:
        write_json(args.json, rows)


if __name__ == "__main__":
    main()
