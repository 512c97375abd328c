"""summary.json's cost of a step (`fsivsp.timestepping.cost`): the mean iterations, the seconds per step and one
product with the step matrix, timed in the same run, and their ratio."""
import json

import pytest
from support.cases import TUBE, mpirun, needs_mpi

from fsivsp.app.cli import main
from fsivsp.solvers import petsc_available


@pytest.mark.parametrize("solver", ["petsc", "direct"])
def test_summary_records_the_cost_of_a_step(tmp_path, solver):
    """Five steps of the 2D tube: ``iterations_mean`` is the solver's own mean (None for a factorisation), the
    five steps were timed, and a step costs more than one product with the step matrix (PETSc: FGMRES iterations of
    a product, a preconditioner and more each; direct: two triangular substitutions with the factors' fill)."""
    if solver == "petsc" and petsc_available() is not None:
        pytest.skip(str(petsc_available()))
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini").replace("[discretisation]", f'[discretisation]\nsolver = "{solver}"'))
    assert main(["run", str(case), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    record = json.loads((tmp_path / "out" / "summary.json").read_text())["solver"]
    assert record["timed_steps"] == 5 and record["step_seconds"] > 0 and record["product_seconds"] > 0
    assert record["matvec_ratio"] == pytest.approx(record["step_seconds"] / record["product_seconds"], rel=1e-12)
    assert record["matvec_ratio"] > 1
    if solver == "petsc":
        assert record["iterations_mean"] == record["iterations"]["mean"] > 1
    else:
        assert record["iterations_mean"] is None and "iterations" not in record


@needs_mpi
def test_summary_records_the_cost_on_two_ranks(tmp_path):
    """Under mpirun (PETSc over both ranks) the same fields, the slowest rank's times."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini"))
    done = mpirun("run", str(case), "--out", str(tmp_path / "out"), "--quiet")
    assert done.returncode == 0, done.stderr
    record = json.loads((tmp_path / "out" / "summary.json").read_text())["solver"]
    assert record["method"] == "petsc" and record["ranks"] == 2 and record["timed_steps"] == 5
    assert record["iterations_mean"] == record["iterations"]["mean"] > 1 and record["matvec_ratio"] > 1
