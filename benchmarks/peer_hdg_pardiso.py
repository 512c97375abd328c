"""The residual check of each direct method on the peer case's step matrix (Taylor–Hood k = 2, Δt = 1/1024,
θ = 1/2) per refinement level (benchmarks/peer_hdg.md, "PARDISO's fallback").

Run: PYTHONPATH=src python benchmarks/peer_hdg_pardiso.py 2 3 4 5
"""
import sys
import time
from pathlib import Path

from fsivsp import forms
from fsivsp.case import load_study_case, to_study
from fsivsp.geometry import refined
from fsivsp.solvers import DirectSolver, SolverError, compact
from fsivsp.spaces import build_spaces
from fsivsp.study import dirichlet_boundaries

ATTEMPTS = (("pardiso", None), ("pardiso", {"refinement": 16}), ("umfpack", None))

case = to_study(load_study_case(Path(__file__).resolve().parent.parent / "examples" / "peer_hdg_example1.toml"))
coarse = case.coarse_mesh()
for level in map(int, sys.argv[1:]):
    mesh = refined(coarse, level, False)
    spaces = build_spaces(mesh, "taylor_hood", 2, dirichlet_boundaries(mesh))
    matrix = compact(forms.step_matrix(spaces, case.materials, case.time_scheme.tau(1 / 1024)).Assemble().mat)
    for method, options in ATTEMPTS:
        start = time.perf_counter()
        try:
            residual = DirectSolver(matrix, spaces.mixed.FreeDofs(), method=method, options=options).residual
        except SolverError as error:
            residual = error.residual
        print(f"level {level} unknowns {spaces.free_dofs()} {method} {options or ''} residual {residual:.3e} "
              f"{time.perf_counter() - start:.2f} s", flush=True)
