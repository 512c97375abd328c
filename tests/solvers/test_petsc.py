"""The PETSc backend (`fsivsp.solvers.petsc`): the direct solver's errors on every family in 2D and 3D,
iteration counts bounded over levels (and not with Jacobi in place of the fieldsplit's blocks), options from
the case file and the command line."""
import dataclasses
import json
import re
from pathlib import Path

import pytest

from fsivsp.app.cli import main
from fsivsp.config.case import CaseError
from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import study
from fsivsp.solvers import petsc_available, read_petsc_options

pytestmark = pytest.mark.skipif(petsc_available() is not None, reason=str(petsc_available()))






@pytest.mark.parametrize("name, levels, changes", [
    ("fluid_over_solid_2d", range(0, 2), {}),                 # Taylor–Hood k = 1
    ("fluid_over_solid_2d", range(0, 2), {"order": 2}),       # a P2 pressure: the plain commutator
    ("fluid_in_solid_2d", range(0, 2), {}),
    ("solid_in_fluid_2d", range(0, 2), {}),
    ("fluid_in_solid_3d", range(0, 2), {}),                   # MINI with quartic bubbles
    ("fluid_over_solid_3d", range(0, 1), {}),
    ("fluid_over_solid_3d", range(0, 1), {"family": "taylor_hood", "order": 1}),
])
def test_equals_direct(name, levels, changes, example, same_errors):
    same_errors(example(name, **changes), levels)


def test_cahouet_chabard_equals_direct(example, same_errors):
    """The pressure block by Cahouet–Chabard (`petsc_schur`) in place of the commutator."""
    case = example("fluid_in_solid_2d").with_solver(petsc={"schur_approximation": "cahouet-chabard"})
    records = same_errors(case, range(0, 2))
    commutator = study(case.with_solver(method="petsc", petsc={}), range(0, 2))
    assert [r["preconditioner"]["pressure"] for r in records] == ["cahouet-chabard"] * 2
    assert [r["iterations"] for r in records] != [r["iterations"] for r in commutator]  # another preconditioner ran


def test_paper_experiment_equals_direct_and_iterations_bounded(same_errors):
    """Levels 1–3 of Section 5.3 (Δt = 1e-2, 100 steps): the direct solver's errors to 1e-6, at most 25
    iterations per step, growing at most 30 % per level (measured 10.1, 11.0, 13.0)."""
    records = same_errors(paper_case(1e-2), range(1, 4))
    counts = [r["iterations"]["mean"] for r in records]
    assert max(counts) <= 25, counts
    assert all(b <= 1.3 * a for a, b in zip(counts, counts[1:])), counts


def test_jacobi_blocks_need_many_more_iterations():
    """The bound above can fail: Jacobi in place of the AMG and the commutator needs far more iterations and
    grows with the level."""
    jacobi = {"fieldsplit_velocity_pc_type": "jacobi", "schur_approximation": "petsc",
              "fieldsplit_pressure_pc_type": "jacobi", "pc_fieldsplit_schur_precondition": "selfp"}
    case = dataclasses.replace(paper_case(1e-2).with_solver(method="petsc", petsc=jacobi, tolerance=1e-12), T=0.05)
    counts = [r["iterations"]["mean"] for r in study(case, range(1, 3))]
    assert counts[0] > 40 and counts[1] > 1.3 * counts[0], counts


def test_case_file_options_reach_petsc(tmp_path):
    """``[solver.petsc]`` sets PETSc options (here GMRES for FGMRES); the JSON records the method and the
    Krylov method; the options are cleared from PETSc's database afterwards."""
    text = (Path(__file__).parents[2] / "examples" / "fluid_in_solid_2d.toml").read_text()
    text = text.replace("[discretisation]", '[discretisation]\nsolver = "petsc"', 1)
    case = tmp_path / "case.toml"
    case.write_text(text + '\n[solver.petsc]\nksp_type = "gmres"\nksp_gmres_restart = 50\n')
    out = tmp_path / "out.json"
    assert main(["study", str(case), "--levels", "0", "--json", str(out), "--quiet"]) == 0
    record = json.loads(out.read_text())[0]
    assert record["solver"] == "petsc" and record["preconditioner"]["ksp"] == "gmres"
    assert record["preconditioner"]["pressure"] == "lsc" and record["preconditioner"]["schur_higher_weight"] == 1.0
    assert record["preconditioner"]["schur_laplacian_basis"] == "hierarchical"   # a pressure of degree 1
    from petsc4py import PETSc
    assert not PETSc.Options().hasName("fsivsp_ksp_type")


def test_petsc_options_validated():
    assert read_petsc_options({"ksp_monitor": True, "ksp_rtol": 1e-8, "pc_type": "lu", "off": False}) == \
        {"ksp_monitor": "", "ksp_rtol": "1e-08", "pc_type": "lu"}
    assert read_petsc_options({"fieldsplit_velocity_pc_hypre_boomeramg_P_max": 2}) == \
        {"fieldsplit_velocity_pc_hypre_boomeramg_P_max": "2"}   # hypre's names have capitals
    with pytest.raises(CaseError, match=r"solver.petsc.KSP type: expected a PETSc option name"):
        read_petsc_options({"KSP type": "gmres"})
    with pytest.raises(CaseError, match=r"solver.petsc.ksp_type: expected a string, a number or true/false"):
        read_petsc_options({"ksp_type": ["gmres"]})
    with pytest.raises(CaseError, match=r"velocity_preconditioner: expected one of boomeramg, ssor, p-multigrid, "
                                        r"condensed, got 'amg'"):
        read_petsc_options({"velocity_preconditioner": "amg"})
    with pytest.raises(CaseError, match=r"schur_approximation: expected one of lsc, cahouet-chabard, petsc, joint-lsc, "
                                        r"joint-lsc-mass, joint-cahouet-chabard, got 'bfbt'"):
        read_petsc_options({"schur_approximation": "bfbt"})
    with pytest.raises(CaseError, match=r"schur_laplacian_basis: expected one of lagrange, hierarchical, got 'nodal'"):
        read_petsc_options({"schur_laplacian_basis": "nodal"})
    assert read_petsc_options({"schur_higher_weight": 4}) == {"schur_higher_weight": "4"}
    for bad in (0, -1, "heavy", True, "nan"):
        with pytest.raises(CaseError, match=rf"solver.petsc.schur_higher_weight: expected a positive number, got "
                                            rf"{re.escape(repr(bad))}"):
            read_petsc_options({"-schur_higher_weight": bad})


def test_command_line_options(capsys):
    """``--petsc-options`` on ``paper``; a malformed one is one line and exit 2."""
    assert main(["paper", "--levels", "0", "--dt", "0.05", "--solver", "petsc", "--quiet",
                 "--petsc-options", "-ksp_type gmres"]) == 0
    assert main(["paper", "--levels", "0", "--solver", "petsc", "--petsc-options", "ksp_type gmres"]) == 2
    assert "--petsc-options: expected '-name [value] ...', got 'ksp_type'" in capsys.readouterr().err


def test_resume_is_bit_identical(tmp_path):
    """PETSc (one thread, a fixed order of operations) warm-starts from the checkpointed state: a run continued
    from step 20 ends bit for bit where the uninterrupted one does (state and displacement in the last
    checkpoint, L² norms and energies in summary.json)."""
    import numpy as np
    from support.cases import CASE, write_case

    def case(T):
        return write_case(tmp_path, text=CASE.format(T=T, every=10).replace(
            'family = "mini"', 'family = "mini"\nsolver = "petsc"'))
    assert main(["run", str(case(0.002)), "--out", str(tmp_path / "whole"), "--quiet"]) == 0
    assert main(["run", str(case(0.001)), "--out", str(tmp_path / "resumed"), "--quiet"]) == 0
    assert main(["run", str(case(0.002)), "--out", str(tmp_path / "resumed"), "--resume", "--quiet"]) == 0
    whole, resumed = (json.loads((tmp_path / n / "summary.json").read_text()) for n in ("whole", "resumed"))
    assert resumed["resumed_from"] == 20 and resumed["solver"]["method"] == "petsc"
    assert resumed["l2_norms"] == whole["l2_norms"] and resumed["energy"] == whole["energy"]
    last = sorted((tmp_path / "whole" / "checkpoints").glob("*.npz"))[-1].name
    a, b = (np.load(tmp_path / n / "checkpoints" / last) for n in ("whole", "resumed"))
    for key in a.files:
        if a[key].dtype.kind == "f":
            assert np.array_equal(a[key], b[key]), key
