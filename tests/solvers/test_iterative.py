"""``solver = "iterative"``: PETSc's FGMRES (one iterative stack, `fsivsp.solvers.petsc`): the direct solver's
errors on the element families the PETSc tests leave out, bit-identical runs, its failures as errors, and through
the command line."""
import json
import subprocess
import sys

import numpy as np
import pytest

from fsivsp.app.cli import main
from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import case_scheme, manufactured_data, run_level
from fsivsp.geometry import refined
from fsivsp.model.manufactured import ExactSolution
from fsivsp.solvers import NotConverged, SolverSpec, petsc_available
from fsivsp.timestepping.scheme import Scheme

pytestmark = pytest.mark.skipif(petsc_available() is not None, reason=str(petsc_available()))


def test_paper_experiment_equals_direct(same_errors):
    """Levels 0–2 of Section 5.3 (Δt = 1e-2, 100 steps), every error norm to 1e-6; "iterative" is PETSc's."""
    records = same_errors(paper_case(1e-2), range(0, 3), method="iterative")
    assert all(r["iterations"]["solves"] == 100 for r in records)


def test_taylor_hood_k3_in_2d_equals_direct(example, same_errors):
    """A P3 pressure (three sweeps on every level of F's V-cycles); tolerance 1e-14: e(p) is 4.4e-6 on level 0, and
    at 1e-12 the algebraic error in it (2e-11) is 2e-6 of it."""
    same_errors(example("fluid_over_solid_2d", order=3).with_solver(tolerance=1e-14), range(0, 2), method="iterative")


@pytest.mark.parametrize("order", [1, 2])
def test_taylor_hood_in_3d_equals_direct(example, same_errors, order):
    """P2 and P3 velocities in 3D (the 3D examples are MINI)."""
    same_errors(example("solid_in_fluid_3d", family="taylor_hood", order=order), range(0, 1), method="iterative")


_FINAL_STATE = """
import hashlib
from fsivsp.geometry import refined
from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import case_scheme
from fsivsp.runtime.threads import using
from fsivsp.solvers import SolverSpec
case = paper_case(1e-2, solver=SolverSpec("iterative"))
with using(1):  # bit-identical on one thread; on more, runs agree to round-off (docs/solvers.md, "Threads")
    scheme = case_scheme(case, refined(case.coarse_mesh(), 2, case.discretisation.project_refinement))
    scheme.march(3)
print(hashlib.sha1(scheme.state.vec.FV().NumPy().tobytes()).hexdigest())
"""


def test_iterative_runs_are_bit_identical():
    """Two processes, the same iterative run (BoomerAMG, the least-squares commutator): the same final state bit
    for bit."""
    runs = [subprocess.run([sys.executable, "-c", _FINAL_STATE], capture_output=True, text=True, check=True).stdout
            for _ in range(2)]
    assert runs[0] == runs[1] and len(runs[0].strip()) == 40, runs


def test_not_converged_is_an_error():
    case = paper_case(1e-2, solver=SolverSpec("iterative", max_iterations=3))
    with pytest.raises(NotConverged, match="did not reach the tolerance"):
        run_level(case, refined(case.coarse_mesh(), 0, False), 0)


def test_zero_data_is_a_zero_solution():
    """All data zero: every step's right-hand side vanishes; FGMRES returns zero in 0 iterations."""
    case = paper_case(1e-2, solver=SolverSpec("iterative"))
    spaces = case_scheme(case, refined(case.coarse_mesh(), 0, False)).spaces
    zero = ExactSolution.parse(["0", "0"], "0", ["0", "0"], 2)
    scheme = Scheme(spaces, case.materials, manufactured_data(zero, case.materials, spaces.dirichlet,
                                                              case.discretisation.initial_stress),
                    case.dt, solver=case.solver)
    scheme.march(2)
    assert scheme.solver.iterations == [0, 0]
    assert np.abs(scheme.state.vec.FV().NumPy()).max() == 0.0


def test_cli_paper_iterative(tmp_path):
    out = tmp_path / "paper.json"
    assert main(["paper", "--dt", "1e-1", "--levels", "0-1", "--solver", "iterative", "--json", str(out),
                 "--quiet"]) == 0
    records = json.loads(out.read_text())
    assert [r["solver"] for r in records] == ["petsc", "petsc"]
    assert all(r["iterations"]["max"] >= r["iterations"]["mean"] > 0 for r in records)


@pytest.mark.parametrize("args, field", [
    (["--solver", "magic"], "--solver"),
    (["--tolerance", "0"], "--tolerance"),
    (["--tolerance", "1"], "--tolerance"),
])
def test_cli_bad_solver_options(args, field, capsys):
    assert main(["paper", "--levels", "0", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert field in err and "\n" not in err
