"""PARDISO on the peer case's step matrix (Taylor–Hood k = 2, Δt = 1/1024, θ = 1/2) per refinement level, with
and without MKL's symmetric weighted matching, with refinement steps, against UMFPACK: residual check
(‖b − Ax‖/‖b‖ on the free dofs, one seeded b), perturbed pivots, factorisation and solve times, and the
matrix's 1-norm condition estimate (benchmarks/peer_hdg.md, "PARDISO's fallback").

Run: PYTHONPATH=src python benchmarks/peer_hdg_pardiso.py 2 3 4 5
"""
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as sla

from fsivsp.config.case import load_study_case
from fsivsp.experiments.study import dirichlet_boundaries
from fsivsp.fem import forms
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import refined
from fsivsp.solvers import DirectSolver, compact, free_mask, to_scipy_csr

#: (label, method, options, refinement steps)
VARIANTS = (
    ("PARDISO before (no matching)", "pardiso", {"matching": False}, 0),
    ("before + 1 refinement step", "pardiso", {"matching": False}, 1),
    ("before + 2 refinement steps", "pardiso", {"matching": False}, 2),
    ("PARDISO after (default: matching, as pivots were perturbed)", "pardiso", None, 0),
    ("UMFPACK", "umfpack", None, 0),
)


def solve_seconds(solver, matrix, repeat=5):
    """The median time of one solve."""
    b, x = matrix.CreateColVector(), matrix.CreateColVector()
    b.FV().NumPy()[:] = 1.0
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        solver.solve(b, x)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def condition(matrix, free):
    """The 1-norm condition estimate of the free block (SuperLU and Hager–Higham's estimator)."""
    mask = free_mask(free, matrix.height)
    a = to_scipy_csr(matrix)[mask][:, mask].tocsc()
    lu = sla.splu(a, permc_spec="COLAMD")
    inverse = sla.LinearOperator(a.shape, matvec=lu.solve, rmatvec=lambda y: lu.solve(y, trans="T"), dtype=float)
    return sla.onenormest(a) * sla.onenormest(inverse)


case = load_study_case(Path(__file__).resolve().parent.parent / "examples" / "peer_hdg_example1.toml")
coarse = case.coarse_mesh()
print("| level | unknowns | cond₁ | variant | residual | perturbed pivots | factorise s | solve ms |")
print("|---|---|---|---|---|---|---|---|")
for level in map(int, sys.argv[1:]):
    mesh = refined(coarse, level, False)
    spaces = build_spaces(mesh, "taylor_hood", 2, dirichlet_boundaries(mesh))
    matrix = compact(forms.step_matrix(spaces, case.materials, case.time_scheme.tau(1 / 1024)).Assemble().mat)
    free = spaces.mixed.FreeDofs()
    head = f"| {level} | {spaces.free_dofs()} | {condition(matrix, free):.1e} |"
    for label, method, options, steps in VARIANTS:
        solver = DirectSolver(matrix, free, method=method, options=options, refinement=steps)
        pivots = "" if solver.perturbed_pivots is None else solver.perturbed_pivots
        print(f"{head} {label} | {solver.residual:.1e} | {pivots} | {solver.factor_seconds:.3f} | "
              f"{1e3 * solve_seconds(solver, matrix):.2f} |", flush=True)
        head = "| | | |"
        del solver
