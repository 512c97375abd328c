"""PETSc iterations per step started from the previous step's solution (today's `Scheme.guess`) and from the
extrapolation 2 xⁿ − xⁿ⁻¹ of the last two (a measurement for issue 22, not yet in the scheme: resuming would need
xⁿ⁻¹ in the checkpoint). The paper's experiment, Δt = 1e-2, 20 steps, the mean over steps 3–20.

    python benchmarks/extrapolated_guess.py
"""

import numpy as np

from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import case_scheme
from fsivsp.geometry import refined
from fsivsp.solvers import SolverSpec
from fsivsp.timestepping.scheme import Scheme


def run(extrapolate, level, steps, tol):
    case = paper_case(1e-2, solver=SolverSpec("petsc", tolerance=tol))
    scheme = case_scheme(case, refined(case.coarse_mesh(), level, False))
    previous = []
    original = Scheme.guess
    def guess(self):
        g = original(self)
        if not extrapolate:
            return g
        out = g.CreateVector()
        out.data = g
        if previous:
            out.data = 2 * g - previous[0]
        previous[:] = [g.CreateVector()]
        previous[0].data = g
        return out
    Scheme.guess = guess
    try:
        for _ in range(steps):
            scheme.step()
    finally:
        Scheme.guess = original
    return np.mean(scheme.solver.iterations[2:])
for level in (2, 3, 4):
    for tol in (1e-8, 1e-12):
        print(level, tol, run(False, level, 20, tol), run(True, level, 20, tol), flush=True)
