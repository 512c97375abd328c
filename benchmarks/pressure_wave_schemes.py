"""The 2D pressure wave (`examples/pressure_wave_2d.toml`) with the three time schemes and large steps.

Runs the example (same mesh, same probes, VTK and checkpoints off) with backward Euler, θ = 1/2 and BDF2 at
several Δt, measures the half-maximum arrival time at each probe with `fsivsp.experiments.moens_korteweg.arrival_times`
on the run's ``probes.csv`` (the run samples the probes every step) and the peak pressure at each probe, and compares
them with a reference run (default: BDF2 at the example's Δt / 4; the script also runs backward Euler at Δt / 4
and BDF2 at Δt so that the reference's own error can be read off). Prints a table and writes JSON.

    python benchmarks/pressure_wave_schemes.py --json benchmarks/pressure_wave_schemes.json
    python benchmarks/pressure_wave_schemes.py --case examples/pressure_wave.toml --reference bdf2:1 \
        --extra theta:1 backward_euler:1 --factors 4 8 --json benchmarks/pressure_wave_schemes_3d.json
"""
from __future__ import annotations

import argparse
import dataclasses
import platform
import tempfile
import time
from pathlib import Path

import ngsolve as ngs

from fsivsp.app.loop import run_case
from fsivsp.config.production import load_run_case
from fsivsp.experiments.moens_korteweg import arrival_times, read_probe_pressures
from fsivsp.experiments.report import write_json
from fsivsp.timestepping.schemes import time_scheme

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "pressure_wave_2d.toml"
LABEL = {"backward_euler": "BE", "theta": "θ=1/2", "bdf2": "BDF2"}


def one_run(path: Path, scheme: str, factor: float, out: Path) -> dict:
    """The example with ``scheme`` at ``factor`` × its Δt; arrivals and peaks at its probes."""
    case = load_run_case(path)
    dt = case.dt * factor
    output = dict(case.output, vtk=False, lines=[])
    case = dataclasses.replace(case, dt=dt, time_scheme=time_scheme(scheme), output=output,
                               checkpoint_every=10**9)
    start = time.perf_counter()
    summary = run_case(case, out, quiet=True)
    wall = time.perf_counter() - start
    t, p = read_probe_pressures(out / "probes.csv")
    return {
        "scheme": scheme, "factor": factor, "dt": dt, "steps": case.steps, "dofs": summary["dofs"]["free"],
        "arrivals": arrival_times(out / "probes.csv"), "peaks": [float(x) for x in p.max(axis=0)],
        "peak_times": [float(t[k]) for k in p.argmax(axis=0)], "seconds": wall,
        "solver": summary["solver"].get("method"),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", type=Path, default=EXAMPLE)
    parser.add_argument("--factors", type=float, nargs="+", default=[2.0, 4.0, 8.0],
                        help="multiples of the example's Δt for the three schemes")
    parser.add_argument("--reference", default="bdf2:0.25", help="SCHEME:FACTOR of the reference run")
    parser.add_argument("--extra", nargs="*",
                        default=["theta:0.25", "backward_euler:0.25", "bdf2:1", "theta:1", "backward_euler:1"],
                        help="further SCHEME:FACTOR runs (the reference's own error, the example's Δt)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()

    plan = [args.reference] + [x for x in args.extra if x != args.reference]
    plan += [f"{s}:{f:g}" for f in args.factors for s in ("backward_euler", "theta", "bdf2")]
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, item in enumerate(plan):
            scheme, factor = item.split(":")
            r = one_run(args.case, scheme, float(factor), Path(tmp) / f"run{k}")
            runs.append(r)
            print(f"  {LABEL[scheme]:>6} Δt = {r['dt']:.4g} ({r['steps']} steps, {r['seconds']:.1f} s): arrivals "
                  + ", ".join(f"{1e3 * a:.3f}" for a in r["arrivals"]) + " ms; peaks "
                  + ", ".join(f"{x:.1f}" for x in r["peaks"]), flush=True)
    ref = runs[0]
    for r in runs:
        r["arrival_error"] = [(a - b) / b for a, b in zip(r["arrivals"], ref["arrivals"])]
        r["max_abs_arrival_error"] = max(abs(e) for e in r["arrival_error"])
        r["peak_ratio_to_reference"] = [a / b for a, b in zip(r["peaks"], ref["peaks"])]
    for r in runs:   # peak at the last probe against backward Euler at the same Δt
        be = [q for q in runs if q["scheme"] == "backward_euler" and q["factor"] == r["factor"]]
        r["last_peak_over_backward_euler"] = r["peaks"][-1] / be[0]["peaks"][-1] if be else None

    case = load_run_case(args.case)
    probes = [p[0] for p in case.output["probes"]]
    print(f"\nmachine: {platform.machine()}, ngsolve {ngs.__version__}; case {args.case.name}, "
          f"example Δt = {case.dt:g}, "
          f"{ref['dofs']} free dofs; reference {LABEL[ref['scheme']]} at Δt = {ref['dt']:g}")
    head = " | ".join(f"x = {x:g}" for x in probes)
    print(f"| scheme | Δt | steps | arrival [ms] ({head}) | rel. error vs ref. | max |err| | "
          f"peak at x = {probes[-1]:g} | peak / ref. | peak / BE same Δt | wall [s] |")
    for r in runs:
        print(f"| {LABEL[r['scheme']]} | {r['dt']:.4g} | {r['steps']} | "
              + " / ".join(f"{1e3 * a:.3f}" for a in r["arrivals"]) + " | "
              + " / ".join(f"{100 * e:+.2f}%" for e in r["arrival_error"])
              + f" | {100 * r['max_abs_arrival_error']:.2f}% | "
              f"{r['peaks'][-1]:.1f} | {r['peak_ratio_to_reference'][-1]:.3f} | "
              + (f"{r['last_peak_over_backward_euler']:.3f}" if r["last_peak_over_backward_euler"] else "–")
              + f" | {r['seconds']:.1f} |")
    if args.json:
        write_json(args.json, {"case": str(args.case), "example_dt": case.dt, "probes_x": probes,
                               "reference": {"scheme": ref["scheme"], "dt": ref["dt"]},
                               "machine": platform.platform(), "runs": runs})


if __name__ == "__main__":
    main()
