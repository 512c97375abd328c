"""Cost of the time schemes: backward Euler, θ = 1/2 and BDF2 on the same mesh, in one run.

Per mesh (the paper's experiment, `paper_case(dt, time_scheme=...)`, MINI, at the given refinement levels, and
optionally the 3D example `examples/pressure_wave.toml`), the three schemes are built on the same mesh (set-up:
`Scheme.__init__`, assembly and factorisation), the first step is timed on its own (BDF2's is a Crank–Nicolson
step solved by Richardson iterations with the run's solver: its time and the number of solves are reported), then
the schemes take their next steps *interleaved* (one step of each in turn, so that the machine's drift and the other
jobs hit them alike) and `Scheme.step()` is timed per step, with the solve inside it timed separately. Reported:
medians, the ratio new/backward Euler per step (ratio of the medians and median of the per-round ratios), and, in
one process per scheme (``--memory``), the peak resident memory and its growth per free unknown. Also
`Scheme.march` (what `fsivsp run`/`paper` use), timed in interleaved blocks.

    python benchmarks/time_schemes.py --levels 2-4 --steps 200 --example3d --memory --json benchmarks/time_schemes.json
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import ngsolve as ngs

from fsivsp.app.arguments import levels_arg
from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import dirichlet_boundaries, manufactured_data
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import refined
from fsivsp.io.atomic import write_json
from fsivsp.solvers import SolverSpec
from fsivsp.timestepping.scheme import Scheme
from fsivsp.timestepping.schemes import time_scheme

SCHEMES = ("backward_euler", "theta", "bdf2")
EXAMPLE3D = Path(__file__).resolve().parent.parent / "examples" / "pressure_wave.toml"


def rss() -> int:
    """The current resident memory of this process, bytes."""
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def peak() -> int:
    """The peak resident memory of this process, bytes: VmHWM, not getrusage's ru_maxrss, which in a process
    started by subprocess keeps its parent's peak (Linux carries maxrss over the exec of a vfork'ed child: a
    child of a 1.5 GB parent reports 1.5 GB)."""
    with open("/proc/self/status") as handle:
        for line in handle:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


class Counted:
    """Wraps a scheme's solver: counts and times its solve_step calls."""

    def __init__(self, scheme: Scheme):
        self.inner, self.calls, self.seconds = scheme.solver.solve_step, 0, 0.0
        scheme.solver.solve_step = self

    def __call__(self, *args, **kwargs):
        start = time.perf_counter()
        self.inner(*args, **kwargs)
        self.seconds += time.perf_counter() - start
        self.calls += 1

    def reset(self) -> tuple[int, float]:
        calls, seconds = self.calls, self.seconds
        self.calls, self.seconds = 0, 0.0
        return calls, seconds


def paper_builder(level: int, dt: float, solver: str | None):
    """(mesh description, builder(scheme name) -> Scheme) for the paper's experiment at ``level``."""
    spec = SolverSpec(solver or "auto")
    base = paper_case(dt, solver=spec)
    mesh = refined(base.coarse_mesh(), level, base.discretisation.project_refinement)
    dirichlet = dirichlet_boundaries(mesh)

    def build(name: str) -> Scheme:
        case = paper_case(dt, solver=spec, time_scheme=time_scheme(name))
        spaces = build_spaces(mesh, "mini", 1, dirichlet)
        data = manufactured_data(case.exact, case.materials, dirichlet, case.discretisation.initial_stress)
        return Scheme(spaces, case.materials, data, dt, solver=spec, time_scheme=case.time_scheme)

    return {"mesh": f"paper level {level}", "dim": 2, "vertices": mesh.nv, "dt": dt}, build


def example_builder(path: Path, solver: str | None):
    from fsivsp.app.loop import build_scheme
    from fsivsp.config.production import load_run_case
    case = load_run_case(path)
    if solver is not None:
        case = dataclasses.replace(case, solver=dataclasses.replace(case.solver, method=solver))

    def build(name: str) -> Scheme:
        return build_scheme(dataclasses.replace(case, time_scheme=time_scheme(name)))

    return {"mesh": path.name, "dim": case.dim, "vertices": case.mesh.nv, "dt": case.dt}, build


def timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def measure(info: dict, build, steps: int, march_blocks: int, march_block: int) -> dict:
    schemes, record = {}, dict(info, schemes={})
    warm = build("backward_euler")      # first-call set-up of NGSolve and the solver, not timed
    warm.step()
    del warm
    for name in SCHEMES:
        t = time.perf_counter()
        scheme = build(name)
        setup = time.perf_counter() - t
        schemes[name] = (scheme, Counted(scheme))
        record["schemes"][name] = {"setup": setup, "factorisation": getattr(scheme.solver, "factor_seconds", None),
                                   "solver": scheme.solver.statistics().get("method", type(scheme.solver).__name__)}
        record["dofs"] = scheme.spaces.free_dofs()
    for name, (scheme, counter) in schemes.items():        # the first step, alone
        before = len(getattr(scheme.solver, "iterations", []))
        first = timed(scheme.step)
        calls, solve = counter.reset()
        record["schemes"][name].update(first_step=first, first_step_solves=calls, first_step_solve_seconds=solve)
        if hasattr(scheme.solver, "iterations"):    # the iterative solver: MinRes iterations of the first step
            record["schemes"][name]["first_step_minres_iterations"] = sum(scheme.solver.iterations[before:])
    per_step = {name: [] for name in SCHEMES}
    cpu_step = {name: [] for name in SCHEMES}       # process CPU time (all threads): robust to other jobs' load
    per_solve = {name: [] for name in SCHEMES}
    for _ in range(steps):                                 # interleaved: one step of each in turn
        for name, (scheme, counter) in schemes.items():
            cpu = time.process_time()
            per_step[name].append(timed(scheme.step))
            cpu_step[name].append(time.process_time() - cpu)
            per_solve[name].append(counter.reset()[1])
    marched = {name: [] for name in SCHEMES}
    cpu_marched = {name: [] for name in SCHEMES}
    for _ in range(march_blocks):                          # march, interleaved in blocks
        for name, (scheme, counter) in schemes.items():
            cpu = time.process_time()
            marched[name].append(timed(lambda scheme=scheme: scheme.march(march_block)) / march_block)
            cpu_marched[name].append((time.process_time() - cpu) / march_block)
            counter.reset()
    be = per_step["backward_euler"]
    for name, (scheme, _) in schemes.items():
        if hasattr(scheme.solver, "iterations"):
            record["schemes"][name]["minres_iterations_median"] = statistics.median(scheme.solver.iterations[1:])
    for name in SCHEMES:
        r = record["schemes"][name]
        r.update(step=statistics.median(per_step[name]), step_min=min(per_step[name]),
                 solve=statistics.median(per_solve[name]),
                 rest=statistics.median(a - b for a, b in zip(per_step[name], per_solve[name])),
                 march_step=statistics.median(marched[name]) if marched[name] else None)
        r["step_ratio"] = r["step"] / record["schemes"]["backward_euler"]["step"]
        r["step_ratio_paired"] = statistics.median(a / b for a, b in zip(per_step[name], be))
        r["cpu_step"] = statistics.median(cpu_step[name])
        r["cpu_step_ratio"] = r["cpu_step"] / statistics.median(cpu_step["backward_euler"])
        r["cpu_march_step"] = statistics.median(cpu_marched[name]) if cpu_marched[name] else None
        r["cpu_march_ratio"] = (r["cpu_march_step"] / statistics.median(cpu_marched["backward_euler"])
                                if cpu_marched[name] else None)
        r["march_ratio"] = (r["march_step"] / statistics.median(marched["backward_euler"])
                            if marched[name] else None)
        r["first_over_step"] = r["first_step"] / r["step"]
    record["steps"] = steps
    record["march"] = {"blocks": march_blocks, "block": march_block}
    return record


def combine(repeats: list[dict]) -> dict:
    """The median over repeated measurements of every number per scheme; the ratios of each repeat kept."""
    record = dict(repeats[0], repeats=len(repeats))
    for name in SCHEMES:
        merged = {}
        for key, value in repeats[0]["schemes"][name].items():
            values = [r["schemes"][name][key] for r in repeats]
            merged[key] = (statistics.median(values) if isinstance(value, (int, float)) and not isinstance(value, bool)
                           and all(v is not None for v in values) else value)
        for key in ("step_ratio", "step_ratio_paired", "march_ratio", "first_step", "cpu_step_ratio",
                    "cpu_march_ratio"):
            merged[f"{key}_each"] = [r["schemes"][name][key] for r in repeats]
        record["schemes"][name] = merged
    return record


def memory_child(target: str, name: str, dt: float, solver: str | None, steps: int) -> None:
    """One scheme in this process: print JSON with the resident memory before and after building it."""
    if target == "3d":
        info, build = example_builder(EXAMPLE3D, solver)
    else:
        info, build = paper_builder(int(target), dt, solver)
    before = rss()
    scheme = build(name)
    for _ in range(steps):
        scheme.step()
    print(json.dumps({"rss_before": before, "rss_after": rss(), "peak": peak(), "dofs": scheme.spaces.free_dofs()}))


def memory(target: str, dt: float, solver: str | None, steps: int) -> dict:
    out = {}
    for name in SCHEMES:
        command = [sys.executable, __file__, "--memory-child", target, name, "--dt", str(dt), "--steps", str(steps)]
        if solver:
            command += ["--solver", solver]
        result = subprocess.run(command, capture_output=True, text=True, check=True)
        m = json.loads(result.stdout.strip().splitlines()[-1])
        m["bytes_per_dof"] = (m["peak"] - m["rss_before"]) / m["dofs"]
        out[name] = m
    return out


def print_memory(r: dict) -> None:
    print(f"memory, {r['mesh']} (one process per scheme, 5 steps; peak RSS (VmHWM) / its growth from before the "
          "scheme per free dof / resident after the steps and its growth per free dof): "
          + "; ".join(f"{n}: {m['peak'] / 2**20:.0f} MiB / {m['bytes_per_dof']:.0f} B/dof / "
                      f"{m['rss_after'] / 2**20:.0f} MiB / {(m['rss_after'] - m['rss_before']) / m['dofs']:.0f} B/dof"
                      for n, m in r["memory"].items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=levels_arg, default=range(2, 5))
    parser.add_argument("--dt", type=float, default=1e-2)
    parser.add_argument("--steps", type=int, default=200, help="timed steps per scheme after the first")
    parser.add_argument("--repeats", type=int, default=3, help="measurements per mesh (fresh schemes each); medians")
    parser.add_argument("--march-blocks", type=int, default=5)
    parser.add_argument("--march-block", type=int, default=20)
    parser.add_argument("--solver", default=None)
    parser.add_argument("--example3d", action="store_true", help="also examples/pressure_wave.toml (3D, MINI)")
    parser.add_argument("--steps3d", type=int, default=40)
    parser.add_argument("--memory", action="store_true", help="peak memory per scheme, one process each")
    parser.add_argument("--memory-child", nargs=2, metavar=("TARGET", "SCHEME"), help=argparse.SUPPRESS)
    parser.add_argument("--memory-only", action="store_true",
                        help="only the memory processes, into the records of an existing --json file")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    if args.memory_child:
        memory_child(*args.memory_child, args.dt, args.solver, min(args.steps, 5))
        return
    if args.memory_only:
        with open(args.json) as handle:
            stored = json.load(handle)
        for record in stored["records"]:
            target = "3d" if record["mesh"] == EXAMPLE3D.name else record["mesh"].split()[-1]
            if target == "3d" or int(target) == max(args.levels):
                record["memory"] = memory(target, args.dt, args.solver, 5)
                print_memory(record)
        write_json(args.json, stored)
        return

    records = []
    targets = [str(level) for level in args.levels] + (["3d"] if args.example3d else [])
    for target in targets:
        if target == "3d":
            info, build = example_builder(EXAMPLE3D, args.solver)
            repeats = [measure(info, build, args.steps3d, max(1, args.march_blocks // 2), args.march_block)
                       for _ in range(args.repeats)]
        else:
            info, build = paper_builder(int(target), args.dt, args.solver)
            repeats = [measure(info, build, args.steps, args.march_blocks, args.march_block)
                       for _ in range(args.repeats)]
        record = combine(repeats)
        if args.memory and (target == "3d" or int(target) == max(args.levels)):
            record["memory"] = memory(target, args.dt, args.solver, 5)
        records.append(record)
        print(f"{record['mesh']}: {record['dofs']} free dofs, done", flush=True)

    print(f"\nmachine: {platform.machine()}, {os.cpu_count()} cpus, ngsolve {ngs.__version__}; load {os.getloadavg()}")
    print(f"medians over {args.repeats} repeats (each: {args.steps} interleaved steps per scheme; 3D {args.steps3d}); "
          "ratio ranges over the repeats in brackets")
    print("| mesh | free dofs | scheme | solver | set-up [s] | first step [s] (solves; their time [s]) | step [ms] | "
          "solve [ms] | rest [ms] | step / BE (medians) | step / BE (paired) | step CPU / BE | march [ms/step] | "
          "march / BE | march CPU / BE |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in records:
        for name in SCHEMES:
            s = r["schemes"][name]
            span = lambda key, s=s: f"[{min(s[key + '_each']):.3f}–{max(s[key + '_each']):.3f}]"
            march = (f"{1e3 * s['march_step']:.3f} | {s['march_ratio']:.3f} {span('march_ratio')} | "
                     f"{s['cpu_march_ratio']:.3f} {span('cpu_march_ratio')}" if s["march_step"] else "– | – | –")
            solver = s["solver"] + (f" ({s['minres_iterations_median']:g} its/step, first step "
                                    f"{s['first_step_minres_iterations']})" if "minres_iterations_median" in s else "")
            print(f"| {r['mesh']} | {r['dofs']} | {name} | {solver} | {s['setup']:.2f} | {s['first_step']:.4f} "
                  f"({s['first_step_solves']:g}; {s['first_step_solve_seconds']:.4f}) | {1e3 * s['step']:.3f} | "
                  f"{1e3 * s['solve']:.3f} | {1e3 * s['rest']:.3f} | "
                  f"{s['step_ratio']:.3f} {span('step_ratio')} | "
                  f"{s['step_ratio_paired']:.3f} {span('step_ratio_paired')} | "
                  f"{s['cpu_step_ratio']:.3f} {span('cpu_step_ratio')} | "
                  f"{march} |")
    for r in records:
        if "memory" in r:
            print_memory(r)
    if args.json:
        write_json(args.json, {"machine": platform.platform(), "cpus": os.cpu_count(), "ngsolve": ngs.__version__,
                               "args": {k: (list(v) if isinstance(v, range) else v) for k, v in vars(args).items()},
                               "records": records})


if __name__ == "__main__":
    main()
