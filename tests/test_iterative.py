"""The iterative solver (MinRes, block preconditioner): the direct solver's errors, bounded iterations,
and its errors through the CLI."""
import json
import subprocess
import sys
from pathlib import Path

import ngsolve as ngs
import numpy as np
import pytest

from fsivsp.case import load_study_case
from fsivsp.cli import main
from fsivsp.geometry import refined
from fsivsp.paper import paper_case
from fsivsp.solvers import NotConverged, SolverSpec, schur
from fsivsp.study import discretise, run_level, study

EXAMPLES = Path(__file__).parent.parent / "examples"


def same_errors(case, levels, rtol=1e-6) -> list[dict]:
    """Run ``case`` with both solvers; assert equal error norms; return the iterative records."""
    direct = study(case.with_solver(method="direct"), levels)
    iterative = study(case.with_solver(method="iterative"), levels)
    for a, b in zip(direct, iterative):
        assert a["solver"] != "iterative" and b["solver"] == "iterative"
        for name, error in a["errors"].items():
            assert b["errors"][name] == pytest.approx(error, rel=rtol), (a["level"], name)
    return iterative


def test_paper_experiment_equals_direct():
    """Levels 0–2 of Section 5.3 (Δt = 1e-2, 100 steps), every error norm to 1e-6."""
    records = same_errors(paper_case(1e-2), range(0, 3))
    assert all(r["iterations"]["solves"] == 100 for r in records)


@pytest.mark.parametrize("example, levels", [
    ("fluid_over_solid_2d", range(0, 2)),   # Taylor–Hood k = 1, both walls
    ("solid_in_fluid_2d", range(0, 2)),
    ("fluid_in_solid_2d", range(0, 2)),
    ("fluid_in_solid_3d", range(0, 2)),     # MINI with quartic bubbles
    ("fluid_over_solid_3d", range(0, 1)),
])
def test_examples_equal_direct(example, levels):
    same_errors(load_study_case(EXAMPLES / f"{example}.toml"), levels)


@pytest.mark.parametrize("order", [2, 3])
def test_taylor_hood_higher_orders_equal_direct(order):
    """A P_k pressure, k ≥ 2: F's V-cycle under block Gauss–Seidel over the pressure's vertex patches, the plain
    commutator; level 0 factorises F, level 1 has a hierarchy."""
    case = load_study_case(EXAMPLES / "fluid_over_solid_2d.toml")
    same_errors(case.with_discretisation(order=order), range(0, 2))


@pytest.mark.parametrize("order", [1, 2])
def test_taylor_hood_in_3d_equals_direct(order):
    """P2 and P3 velocities in 3D (the 3D examples are MINI): Gauss–Seidel on the whole velocity space around
    the V-cycle of its vertex block."""
    case = load_study_case(EXAMPLES / "solid_in_fluid_3d.toml")
    same_errors(case.with_discretisation(family="taylor_hood", order=order), range(0, 2))


def test_cahouet_chabard_equals_direct(monkeypatch):
    """A mesh without a refinement hierarchy whose F is too large to factorise takes Cahouet–Chabard."""
    monkeypatch.setattr(schur, "FACTORISE_MAX_DOFS", 0)
    for name in ("fluid_in_solid_2d", "fluid_in_solid_3d"):
        records = same_errors(load_study_case(EXAMPLES / f"{name}.toml"), range(0, 1))
        assert records[0]["preconditioner"]["pressure"] == "Cahouet-Chabard"


def mean_iterations(case, level, jacobi_velocity=False) -> float:
    scheme, _ = discretise(case, refined(case.coarse_mesh(), level, case.discretisation.project_refinement))
    if jacobi_velocity:  # the velocity block by its diagonal alone, the pressure block unchanged
        solver, spaces = scheme.solver, scheme.spaces
        velocity = np.fromiter(spaces.mixed.FreeDofs(), dtype=bool, count=spaces.mixed.ndof)
        velocity[spaces.velocity.ndof:] = False
        jacobi = solver.matrix.CreateSmoother(ngs.BitArray(velocity.tolist()))
        solver.preconditioner.mat = jacobi + solver.preconditioner.schur
        solver._minres.pre = solver.preconditioner.mat
    scheme.march(5)
    return float(np.mean(scheme.solver.iterations))


def test_iterations_bounded_over_levels():
    """Mean MinRes iterations per step on levels 1 → 2 → 3 of the paper's experiment grow by less than
    1.2 per level (measured 22.4, 24.8, 28.2: 1.11, 1.14; before the commutator and the two-level velocity
    cycle 60.8, 75.8, 81.4); with the velocity block by its diagonal they grow by more than 1.6 (140.6, 358.4:
    2.55)."""
    case = paper_case(1e-2, solver=SolverSpec("iterative"))
    ours = [mean_iterations(case, level) for level in (1, 2, 3)]
    assert ours[1] / ours[0] < 1.2 and ours[2] / ours[1] < 1.2, ours
    jacobi = [mean_iterations(case, level, jacobi_velocity=True) for level in (1, 2)]
    assert jacobi[1] / jacobi[0] > 1.6, jacobi
    assert jacobi[1] > 1.5 * ours[1], (jacobi, ours)


_FINAL_STATE = """
import hashlib
from fsivsp.geometry import refined
from fsivsp.paper import paper_case
from fsivsp.study import discretise
from fsivsp.threads import using
from fsivsp.solvers import SolverSpec
case = paper_case(1e-2, solver=SolverSpec("iterative"))
with using(1):  # bit-identical on one thread; on more, runs agree to round-off (docs/solvers.md, "Threads")
    scheme, _ = discretise(case, refined(case.coarse_mesh(), 2, case.discretisation.project_refinement))
    scheme.march(3)
print(hashlib.sha1(scheme.state.vec.FV().NumPy().tobytes()).hexdigest())
"""


def test_iterative_runs_are_bit_identical():
    """Two processes, the same iterative run (multigrid, least-squares commutator): the same final state bit for
    bit (with NGSolve's default threads its sparsecholesky factors, on the coarsest level, differed by 4e-12)."""
    runs = [subprocess.run([sys.executable, "-c", _FINAL_STATE], capture_output=True, text=True, check=True).stdout
            for _ in range(2)]
    assert runs[0] == runs[1] and len(runs[0].strip()) == 40, runs


def test_not_converged_is_an_error():
    case = paper_case(1e-2, solver=SolverSpec("iterative", max_iterations=3))
    with pytest.raises(NotConverged, match="did not reach the tolerance"):
        run_level(case, refined(case.coarse_mesh(), 0, False), 0)


def test_zero_data_is_a_zero_solution():
    """All data zero: every step's right-hand side vanishes; the solver returns zero in 0 iterations (MinRes,
    given a zero norm to start from, divided by it)."""
    from fsivsp.manufactured import ExactSolution
    from fsivsp.scheme import Scheme
    from fsivsp.study import manufactured_data

    case = paper_case(1e-2, solver=SolverSpec("iterative"))
    spaces = discretise(case, refined(case.coarse_mesh(), 0, False))[0].spaces
    zero = ExactSolution.parse(["0", "0"], "0", ["0", "0"], 2)
    scheme = Scheme(spaces, case.materials, manufactured_data(zero, case.materials, spaces.dirichlet,
                                                              case.discretisation.initial_stress), case.dt, solver=case.solver)
    scheme.march(2)
    assert scheme.solver.iterations == [0, 0]
    assert np.abs(scheme.state.vec.FV().NumPy()).max() == 0.0


def test_cli_paper_iterative(tmp_path, capsys):
    out = tmp_path / "paper.json"
    assert main(["paper", "--dt", "1e-1", "--levels", "0-1", "--solver", "iterative", "--json", str(out),
                 "--quiet"]) == 0
    records = json.loads(out.read_text())
    assert [r["solver"] for r in records] == ["iterative", "iterative"]
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


def test_refinement_hierarchy_is_found():
    """The vertex counts of the levels come back from the parents of the finest mesh's vertices, and the
    preconditioner takes the multigrid where there is a hierarchy, the component-wise AMG where not."""
    from fsivsp.solvers.multigrid import vertex_levels
    case = load_study_case(EXAMPLES / "fluid_in_solid_3d.toml")
    coarse = case.coarse_mesh()
    counts = [refined(coarse, level, False).nv for level in range(3)]
    assert vertex_levels(refined(coarse, 2, False))[1] == counts
    assert vertex_levels(coarse)[1] == counts[:1]
    iterative = case.with_solver(method="iterative")
    assert discretise(iterative, refined(coarse, 1, False))[0].solver.preconditioner.multigrid
    assert not discretise(iterative, refined(coarse, 0, False))[0].solver.preconditioner.multigrid
