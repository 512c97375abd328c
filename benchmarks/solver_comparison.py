"""Compare the direct solvers of fsivsp.solvers on the scheme's step-1 matrix.

The matrix is the symmetric indefinite saddle-point matrix of one time step on
the paper geometry (channel 2.5 x 0.41 with the fluid disk of radius 0.05), MINI
element: P1 velocity with cubic bubbles on the fluid triangles, P1 pressure on
the fluid. Level 0 is the coarse mesh (136 vertices), each level refines once
(level 4: ~30k vertices, ~110k dofs).

For every level and solver variant it measures the factorisation time, the time
of one solve (median and mean of --solves solves) and the relative residual on
the free dofs, prints a table with ratios against sparsecholesky and writes JSON.

    .venv/bin/python benchmarks/solver_comparison.py --levels 0 1 2 3 4 --json out.json
    .venv/bin/python benchmarks/solver_comparison.py --variants all      # also tuning variants
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time

import ngsolve as ngs
import numpy as np

from fsivsp.fem.forms import step_matrix
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import paper_channel, refined
from fsivsp.model.materials import Materials
from fsivsp.solvers import DirectSolver, SolverError, available_methods, default_method

ngs.ngsglobals.msg_level = 0

DT, RHO, NU, LAM, MU = 1e-2, 1.0, 0.5, 1.0, 0.5


def build_mesh(level: int) -> ngs.Mesh:
    """The paper's channel refined ``level`` times."""
    return refined(paper_channel(), level)


def build_system(level: int = 0, symmetric: bool = True, symmetric_storage: bool = False, mesh=None):
    """(mesh, X, a): the assembled step-1 BilinearForm ``a`` on X = V x Q (the scheme's own form)."""
    mesh = build_mesh(level) if mesh is None else mesh
    spaces = build_spaces(mesh, "mini", dirichlet="solid_wall")
    storage = {"symmetric": symmetric} | ({"symmetric_storage": True} if symmetric_storage else {})
    a = step_matrix(spaces, Materials(RHO, RHO, NU, LAM, MU), DT, **storage).Assemble()
    return mesh, spaces.mixed, a


# (label, method, options): "main" are the DirectSolver defaults, the rest tuning variants
# "pardiso" is symmetric type -2, refinement 0, minimum degree (fsivsp.solvers.PARDISO_FLAGS);
# "scipy" is splu with COLAMD (fsivsp.solvers.SCIPY_SPLU_OPTIONS)
MAIN_VARIANTS = [(m, m, None) for m in ("sparsecholesky", "umfpack", "pardiso", "scipy")]
TUNING_VARIANTS = [
    ("pardiso-ngsdefault", "pardiso", {"symmetric": False, "refinement": 16, "ordering": "minimum_degree"}),
    ("pardiso-sym-r16-metis", "pardiso", {"symmetric": True, "refinement": 16, "ordering": "metis"}),
    ("pardiso-sym-r0-metis", "pardiso", {"symmetric": True, "refinement": 0, "ordering": "metis"}),
    ("pardiso-nonsym-r0", "pardiso", {"symmetric": False, "refinement": 0, "ordering": "metis"}),
    ("pardiso-sym-r0-pmetis", "pardiso", {"symmetric": True, "refinement": 0, "ordering": "parallel_metis"}),
    ("scipy-MMD_ATA", "scipy", {"permc_spec": "MMD_ATA", "diag_pivot_thresh": 1.0, "options": {}}),
    ("scipy-MMD_AT_PLUS_A-symmode", "scipy",
     {"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.1, "options": {"SymmetricMode": True}}),
    ("scipy-COLAMD-symmode", "scipy",
     {"permc_spec": "COLAMD", "diag_pivot_thresh": 0.1, "options": {"SymmetricMode": True}}),
    # MMD_AT_PLUS_A with partial pivoting (diag_pivot_thresh=1) took 197 s at level 4: left out

]


def _time_solves(solve, nsolves: int) -> list[float]:
    times = []
    for _ in range(nsolves):
        t = time.perf_counter()
        solve()
        times.append(time.perf_counter() - t)
    return times


def _new_row(label, method, options):
    return {"label": label, "method": method, "options": options,
            "factor_s_all": [], "solve_median_s_all": [], "solve_mean_s_all": []}


def _finish_row(row):
    if row["factor_s_all"] and "error" not in row:
        row["factor_s"] = min(row["factor_s_all"])
        row["solve_median_s"] = min(row["solve_median_s_all"])
        row["solve_mean_s"] = min(row["solve_mean_s_all"])
    return row


def bench_variant(row, a, freedofs, nsolves):
    """One round: factorise, then ``nsolves`` timed solves; appended to ``row``."""
    b = a.mat.CreateColVector()
    b.FV().NumPy()[:] = np.random.default_rng(1).standard_normal(len(b))
    x = b.CreateVector()
    try:
        solver = DirectSolver(a.mat, freedofs, method=row["method"], options=row["options"],
                              check=True, rtol=1e-8)
    except SolverError as exc:
        row["error"] = str(exc)
        return
    row["residual"] = solver.residual
    row["factor_s_all"].append(solver.factor_seconds)
    times = _time_solves(lambda: solver.solve(b, x), nsolves)
    row["solve_median_s_all"].append(statistics.median(times))
    row["solve_mean_s_all"].append(statistics.fmean(times))


def bench_pypardiso(row, a, freedofs, nsolves):
    """pypardiso (the same MKL PARDISO, driven from scipy CSR; its defaults) if importable."""
    try:
        import pypardiso
    except ImportError as exc:
        row["error"] = f"not installed: {exc}"
        return
    from fsivsp.solvers import free_mask, to_scipy_csr

    mask = free_mask(freedofs, a.mat.height)
    A = to_scipy_csr(a.mat)[mask][:, mask].tocsr()
    rhs = np.random.default_rng(1).standard_normal(A.shape[0])
    ps = pypardiso.PyPardisoSolver(mtype=11)
    t = time.perf_counter()
    ps.factorize(A)
    row["factor_s_all"].append(time.perf_counter() - t)
    x = ps.solve(A, rhs)
    row["residual"] = float(np.linalg.norm(rhs - A @ x) / np.linalg.norm(rhs))
    times = _time_solves(lambda: ps.solve(A, rhs), nsolves)
    row["solve_median_s_all"].append(statistics.median(times))
    row["solve_mean_s_all"].append(statistics.fmean(times))
    ps.free_memory(everything=True)


def run(levels, variants, nsolves, taskmanager, symmetric_storage, pypardiso, repeat=1):
    results = {
        "machine": {"platform": platform.platform(), "python": sys.version.split()[0],
                    "ngsolve": ngs.__version__, "cpus": __import__("os").cpu_count()},
        "taskmanager": taskmanager,
        "solves": nsolves,
        "repeat": repeat,
        "symmetric_storage": symmetric_storage,
        "available_methods": available_methods(),
        "default_method": default_method(),
        "levels": [],
    }
    for level in levels:
        t = time.perf_counter()
        mesh, X, a = build_system(level, symmetric=True, symmetric_storage=symmetric_storage)
        build_s = time.perf_counter() - t
        fd = X.FreeDofs()
        info = {"level": level, "nv": mesh.nv, "ne": mesh.ne, "ndof": X.ndof,
                "nfree": fd.NumSet(), "nze": a.mat.nze, "build_s": build_s, "rows": []}
        print(f"\nlevel {level}: {mesh.nv} vertices, {X.ndof} dofs ({fd.NumSet()} free), "
              f"nze {a.mat.nze}, assembled in {build_s:.2f} s", flush=True)
        ctx = ngs.TaskManager() if taskmanager else None
        if ctx is not None:
            ctx.__enter__()
        try:
            from pyngcore import GetNumThreads

            info["threads"] = GetNumThreads()
            rows = [_new_row(*v) for v in variants]
            if pypardiso:
                rows.append(_new_row("pypardiso", "pypardiso", None))
            for row in rows:
                if row["method"] not in results["available_methods"] + ["pypardiso"]:
                    row["error"] = "not available"
            # rounds interleave the variants, so that other load on the machine
            # hits all of them alike; the minimum over the rounds is reported
            for _ in range(repeat):
                for row in rows:
                    if "error" in row:
                        continue
                    if row["method"] == "pypardiso":
                        bench_pypardiso(row, a, fd, nsolves)
                    else:
                        bench_variant(row, a, fd, nsolves)
            for row in rows:
                info["rows"].append(_finish_row(row))
                print("  " + _fmt_row(row), flush=True)
        finally:
            if ctx is not None:
                ctx.__exit__(None, None, None)
        results["levels"].append(info)
    return results


def _fmt_row(row, ref=None):
    if "error" in row:
        return f"{row['label']:28s} ERROR {row['error'][:90]}"
    s = (f"{row['label']:28s} factor {row['factor_s']*1e3:9.1f} ms  solve {row['solve_median_s']*1e3:8.2f} ms"
         f"  residual {row['residual']:.1e}")
    if ref is not None and "error" not in ref:
        s += (f"  factor x{row['factor_s']/ref['factor_s']:5.2f}"
              f"  solve x{row['solve_median_s']/ref['solve_median_s']:5.2f}")
    return s


def print_table(results):
    print(f"\nsummary (taskmanager={results['taskmanager']}, default method {results['default_method']}); "
          "ratios are time / sparsecholesky time (< 1 is faster)")
    for info in results["levels"]:
        print(f"level {info['level']} ({info['ndof']} dofs, {info['nfree']} free)")
        ref = next((r for r in info["rows"] if r["label"] == "sparsecholesky"), None)
        for row in info["rows"]:
            print("  " + _fmt_row(row, ref))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--json", metavar="PATH", help="write the results as JSON")
    ap.add_argument("--solves", type=int, default=20, help="solves timed per variant (median reported)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="factorisations per variant; the minimum times are reported")
    ap.add_argument("--variants", choices=["main", "all"], default="main",
                    help="main: the DirectSolver methods; all: also tuning variants")
    ap.add_argument("--no-taskmanager", action="store_true", help="run without ngsolve.TaskManager (1 thread)")
    ap.add_argument("--symmetric-storage", action="store_true",
                    help="assemble with symmetric_storage=True (lower triangle only)")
    ap.add_argument("--pypardiso", action="store_true", help="also time pypardiso if importable")
    args = ap.parse_args(argv)
    variants = MAIN_VARIANTS + (TUNING_VARIANTS if args.variants == "all" else [])
    results = run(args.levels, variants, args.solves, not args.no_taskmanager,
                  args.symmetric_storage, args.pypardiso, args.repeat)
    print_table(results)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=1)
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
