"""fsivsp's side of benchmarks/peer_hdg.md: Meddahi's HDG Example 1 (examples/peer_hdg_example1.toml) on
refinement levels, with the peer code's own error measures at the final time T: ‖v − v_h‖_{L²(Ω)} and the
A = C⁻¹-weighted stress error over Ω (Table 1 materials: a_F = (1/2, λ_F/(4μ_F(λ_F+μ_F))), λ_F = 1e6,
a_S = (1/2, λ_S/(4μ_S(λ_S+μ_S)))), σ_h = −p_h I + 2ν ε(v_h) in Ω_F and the scheme's σⁿ_h in Ω_S.

Run: PYTHONPATH=src python benchmarks/peer_hdg.py [--levels 3] [--order 1]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import ngsolve as ngs

from fsivsp.config.case import load_study_case
from fsivsp.experiments.study import case_scheme, max_edge_length
from fsivsp.fem.forms import eps
from fsivsp.geometry import FLUID, SOLID, refined
from fsivsp.model.fields import Field

CASE = Path(__file__).resolve().parent.parent / "examples" / "peer_hdg_example1.toml"
A_FLUID = (0.5, 1e6 / (4 * (1e6 + 1)))    # the peer's a_F1, a_F2 (μ_F = 1, λ_F = 1e6)
A_SOLID = (0.5, 1.0 / (4 * 2.0))          # a_S1, a_S2 (μ_S = λ_S = 1)


def a_norm2(e, a):
    return a[0] * ngs.InnerProduct(e, e) - a[1] * ngs.Trace(e) ** 2


def level(case, mesh, lvl):
    start = time.perf_counter()
    scheme = case_scheme(case, mesh)
    setup = time.perf_counter() - start
    start = time.perf_counter()
    scheme.march(case.steps)
    loop = time.perf_counter() - start
    T, mat, d = scheme.time, case.materials, mesh.dim
    v = Field(case.exact.velocity).coefficient(T)
    sf, ss = Field(case.exact.fluid_stress(mat)).coefficient(T), Field(case.exact.solid_stress(mat)).coefficient(T)
    sf_h = -scheme.pressure * ngs.Id(d) + 2 * mat.nu * eps(scheme.velocity)
    order = 2 * scheme.spaces.velocity_order + 4
    ev = ngs.sqrt(ngs.Integrate(ngs.InnerProduct(v - scheme.velocity, v - scheme.velocity), mesh, order=order))
    es = ngs.sqrt(ngs.Integrate(a_norm2(sf - sf_h, A_FLUID), mesh, definedon=mesh.Materials(FLUID), order=order)
                  + ngs.Integrate(a_norm2(ss - scheme.stress, A_SOLID), mesh, definedon=mesh.Materials(SOLID),
                                  order=order))
    return {"level": lvl, "h": max_edge_length(mesh), "unknowns": scheme.spaces.free_dofs(), "v": ev, "sigmaA": es,
            "per_step": loop / case.steps, "setup": setup, "total": setup + loop}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, default=3)
    parser.add_argument("--order", type=int, default=1)
    args = parser.parse_args()
    study_case = load_study_case(CASE)
    study_case.discretisation.order = args.order
    coarse = study_case.coarse_mesh()
    for lvl in range(args.levels):
        r = level(study_case, refined(coarse, lvl, study_case.discretisation.project_refinement), lvl)
        print(f"TH k={args.order} level={lvl} h={r['h']:.4f} unknowns={r['unknowns']} v={r['v']:.4e} "
              f"sigmaA={r['sigmaA']:.4e} per_step={r['per_step']:.4e} setup={r['setup']:.3f} total={r['total']:.3f}",
              flush=True)


if __name__ == "__main__":
    main()
