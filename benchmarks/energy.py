"""Discrete energy of the three time schemes over many steps, with f = 0 and the boundary at rest.

Geometry `fluid_over_solid` (2D: solid (0, 1) × (0, 0.5) under the fluid (0, 1) × (0.5, 1)), zero velocity on
fluid_wall and solid_wall, no loads, v⁰ = 0 and an initial displacement u⁰ ≠ 0 in the solid (σ⁰ = Cε(I_h u⁰)).
Each step records `Scheme.energy()`:

- BDF2: its G-norm, which must never increase (the max relative increase per step is reported);
- θ = 1/2: the energy E plus the cumulated viscous dissipation D = Σ Δt K_F(v^{n−½}, v^{n−½}) (K_F = 2ν∫_F ε:ε,
  ``scheme._viscous``; v^{n−½} = (vⁿ + vⁿ⁻¹)/2), which must equal E⁰ (max |E + D − E⁰| / E⁰ is reported); and
  θ = 1/2 with ν = 0, whose plain energy is conserved;
- backward Euler: its energy, which decays (numerical dissipation on top of the viscous one).

    python benchmarks/energy.py --steps 10000 --json benchmarks/energy.json --plot benchmarks/energy.png
"""
from __future__ import annotations

import argparse
import platform
import time

import ngsolve as ngs
import numpy as np

from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import build_geometry
from fsivsp.io.atomic import write_json
from fsivsp.model.data import Data
from fsivsp.model.expressions import parse_vector
from fsivsp.model.fields import Field
from fsivsp.model.materials import Materials
from fsivsp.solvers import SolverSpec
from fsivsp.timestepping.scheme import Scheme
from fsivsp.timestepping.schemes import time_scheme

#: examples/fluid_over_solid_2d.toml's materials (ν is an option)
MATERIALS = dict(rho_fluid=1.0, rho_solid=2.0, lam=1.5, mu=0.75)
DISPLACEMENT0 = ["0.1*sin(pi*x)*sin(2*pi*y)", "0.1*sin(2*pi*x)*sin(pi*y)"]


def run(label: str, scheme_name: str, nu: float, args) -> dict:
    mesh = build_geometry("fluid_over_solid", 2, args.maxh)
    walls = "fluid_wall|solid_wall"
    spaces = build_spaces(mesh, args.family, 1, walls)
    materials = Materials(nu=nu, **MATERIALS)
    data = Data(velocity0=Field([0, 0]), displacement0=Field(parse_vector(DISPLACEMENT0, "displacement0", 2)),
                boundary_velocity={walls: Field([0, 0])})
    scheme = Scheme(spaces, materials, data, args.dt, solver=SolverSpec(args.solver),
                    time_scheme=time_scheme(scheme_name))
    energy = [scheme.energy()]
    dissipated = [0.0]
    viscous = scheme._viscous
    previous = scheme.state.vec.CreateVector()
    half = scheme.state.vec.CreateVector()
    start = time.perf_counter()
    for _ in range(args.steps):
        previous.data = scheme.state.vec
        scheme.step()
        energy.append(scheme.energy())
        if viscous is not None:
            half.data = 0.5 * scheme.state.vec + 0.5 * previous
            dissipated.append(dissipated[-1] + args.dt * ngs.InnerProduct(half, viscous * half))
    seconds = time.perf_counter() - start
    e = np.array(energy)
    e0 = e[0]
    increase = np.diff(e)
    record = {
        "label": label, "scheme": scheme_name, "nu": nu, "dofs": spaces.free_dofs(), "steps": args.steps,
        "seconds": seconds, "E0": e0, "E_final": e[-1], "E_final_over_E0": e[-1] / e0,
        # from step 1 on (BDF2's first step is a Crank–Nicolson step: its G-norm at n = 1 is not E⁰'s successor)
        "max_increase_over_previous": float(np.max(increase[1:] / e[1:-1])),
        "max_increase_over_E0": float(np.max(increase[1:]) / e0),
        "steps_increasing": int(np.sum(increase[1:] > 0)),
        "first_step_change_over_E0": float(increase[0] / e0),
        "energy": e.tolist(),
    }
    if viscous is not None:
        total = e + np.array(dissipated)
        record["dissipated_final_over_E0"] = dissipated[-1] / e0
        record["max_balance_deviation_over_E0"] = float(np.max(np.abs(total - e0)) / e0)
        record["balance_deviation_final_over_E0"] = float((total[-1] - e0) / e0)
        record["dissipated"] = dissipated
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=10_000)
    parser.add_argument("--dt", type=float, default=1e-2)
    parser.add_argument("--maxh", type=float, default=0.15)
    parser.add_argument("--nu", type=float, default=0.5, help="fluid viscosity (the example's 0.5)")
    parser.add_argument("--family", default="taylor_hood")
    parser.add_argument("--solver", default="auto")
    parser.add_argument("--json", default=None)
    parser.add_argument("--plot", default=None)
    args = parser.parse_args()
    plan = [("backward Euler", "backward_euler", args.nu), ("θ = 1/2", "theta", args.nu),
            ("θ = 1/2, ν = 0", "theta", 0.0), ("BDF2", "bdf2", args.nu), ("BDF2, ν = 0", "bdf2", 0.0),
            ("backward Euler, ν = 0", "backward_euler", 0.0)]
    runs = []
    for label, name, nu in plan:
        r = run(label, name, nu, args)
        runs.append(r)
        line = (f"{label:>16}: {r['dofs']} dofs, {r['steps']} steps in {r['seconds']:.1f} s; E0 = {r['E0']:.6e}, "
                f"E_N/E0 = {r['E_final_over_E0']:.3e}; "
                f"max (E^n - E^(n-1))/E^(n-1) = {r['max_increase_over_previous']:.2e}, "
                f"max (E^n - E^(n-1))/E0 = {r['max_increase_over_E0']:.2e} ({r['steps_increasing']} steps increase); "
                f"step 1: {r['first_step_change_over_E0']:+.2e}")
        if "dissipated" in r:
            line += (f"; E + D: max |E + D - E0|/E0 = {r['max_balance_deviation_over_E0']:.2e}, "
                     f"D_N/E0 = {r['dissipated_final_over_E0']:.4f}")
        print(line, flush=True)
    print(f"machine: {platform.machine()}, ngsolve {ngs.__version__}; fluid_over_solid 2D, {args.family}, "
          f"maxh {args.maxh}, dt {args.dt:g}, nu {args.nu:g}")
    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, (top, middle, bottom) = plt.subplots(3, 1, figsize=(8, 11), sharex=True)
        t = args.dt * np.arange(args.steps + 1)
        for r in runs:
            top.semilogy(t, np.array(r["energy"]) / r["E0"], label=f"{r['label']}: energy()")
            if "dissipated" in r and r["nu"] > 0:
                top.semilogy(t, (np.array(r["energy"]) + np.array(r["dissipated"])) / r["E0"], "--",
                             label=f"{r['label']}: E + Σ Δt K_F(v^(n-1/2))")
        top.set_ylabel("energy / E⁰")
        top.legend(fontsize=7)
        top.set_title(f"fluid_over_solid 2D, {args.family}, Δt = {args.dt:g}, f = 0, walls at rest")
        for r in runs:
            if r["scheme"] == "theta":
                dev = np.abs(np.array(r["energy"]) + np.array(r["dissipated"]) - r["E0"]) / r["E0"]
                middle.semilogy(t[1:], np.maximum(dev[1:], 1e-18), label=f"{r['label']}: |E + D − E⁰| / E⁰")
        middle.axhline(1e-10, color="k", ls=":", label="goal 1e-10")
        middle.set_ylabel("θ = 1/2: energy balance")
        middle.legend(fontsize=7)
        for r in runs:
            if r["scheme"] == "bdf2":
                e = np.array(r["energy"])
                bottom.semilogy(t[2:], -np.diff(e)[1:] / e[1:-1], label=f"{r['label']}: −(Gⁿ − Gⁿ⁻¹)/Gⁿ⁻¹", alpha=0.7)
        bottom.set_ylabel("BDF2: decrease of G per step")
        bottom.set_title("BDF2 (n ≥ 2): every value > 0 is a decrease (an increase would be missing on a log axis)",
                         fontsize=8)
        bottom.set_xlabel("t")
        bottom.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
    if args.json:
        keep = [{k: v for k, v in r.items() if k not in ("energy", "dissipated")} for r in runs]
        stride = max(1, args.steps // 1000)
        for k, r in zip(keep, runs):   # the histories, every stride-th step
            k["history_stride"] = stride
            k["energy_history"] = r["energy"][::stride]
            if "dissipated" in r:
                k["dissipated_history"] = r["dissipated"][::stride]
        write_json(args.json, {"machine": platform.platform(), "args": vars(args), "displacement0": DISPLACEMENT0,
                               "materials": MATERIALS, "runs": keep})


if __name__ == "__main__":
    main()
