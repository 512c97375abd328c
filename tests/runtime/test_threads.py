"""Threads (`fsivsp.threads`): bit-identical runs for a given count, round-off between counts, the option."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from fsivsp.app.cli import main
from fsivsp.runtime.threads import LOCAL_SIZE_VARIABLES, ThreadsError, check, default_threads, per_rank

_RUN = """
import sys
import numpy as np
from fsivsp.config.case import load_study_case
from fsivsp.geometry import refined
from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import case_scheme
from fsivsp.runtime.threads import using
where, solver, threads, level, tolerance = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), \
float(sys.argv[5])
with using(threads):
    case = paper_case(1e-2) if where == "paper" else load_study_case(where)
    case = case.with_solver(method=solver, tolerance=tolerance)
    scheme = case_scheme(case, refined(case.coarse_mesh(), level, case.discretisation.project_refinement))
    scheme.march(3)
    print(scheme.state.vec.FV().NumPy().tobytes().hex())
"""
#: (case, level, the iterative solver's tolerance): the paper's channel (2D, MINI, level 1: 1680 unknowns) and the
#: 3D fluid ball (MINI, level 2: 11 860; 1e-8, fewer iterations: a short test).
CASES = {"2d": ("paper", 1, 1e-12), "3d": ("examples/fluid_in_solid_3d.toml", 2, 1e-8)}


def _run(case: str, solver: str, threads: int) -> np.ndarray:
    """The final state of 3 steps in a fresh process."""
    return _run_at(*CASES[case], solver, threads)


def _run_at(where: str, level: int, tolerance: float, solver: str, threads: int) -> np.ndarray:
    out = subprocess.run([sys.executable, "-c", _RUN, where, solver, str(threads), str(level), str(tolerance)],
                         capture_output=True, text=True, check=True).stdout
    return np.frombuffer(bytes.fromhex(out.strip()), dtype=float)


@pytest.mark.parametrize("case", ["2d", pytest.param("3d", marks=pytest.mark.slow)])
@pytest.mark.parametrize("solver", ["direct", "petsc"])
def test_two_threads_bit_identical(case, solver):
    """Two processes on 2 threads, the same final state bit for bit (docs/solvers.md, "Threads"). 3D: slow (the
    suite's 6 minutes; 2D covers both solvers' threaded paths)."""
    if solver == "petsc":
        pytest.importorskip("petsc4py")
    first, second = _run(case, solver, 2), _run(case, solver, 2)
    assert first.tobytes() == second.tobytes()




@pytest.mark.parametrize("solver", ["direct", "petsc"])
def test_thread_counts_agree_to_round_off(solver):
    """1 and 2 threads: the final states agree entry by entry to 1e-10 of their largest (sums in another order)."""
    if solver == "petsc":
        pytest.importorskip("petsc4py")
    one, two = _run("2d", solver, 1), _run("2d", solver, 2)
    assert np.abs(two - one).max() <= 1e-10 * np.abs(one).max()


def test_run_l2_norms_agree_between_thread_counts(tmp_path):
    """`fsivsp run` on 1 and on 2 threads: the summary's final L² norms agree to 1e-10 relative."""
    from support.cases import write_case

    case = write_case(tmp_path, T=0.001, every=1000)
    norms = []
    for threads in ("1", "2"):
        assert main(["run", str(case), "--out", str(tmp_path / threads), "--threads", threads, "--quiet"]) == 0
        norms.append(json.loads((tmp_path / threads / "summary.json").read_text())["l2_norms"])
    for name, one in norms[0].items():
        assert abs(norms[1][name] - one) <= 1e-10 * abs(one), name


@pytest.mark.parametrize("value", ["0", "abc", "1.5"])
def test_bad_threads_is_one_line_exit_2(value, capsys):
    assert main(["run", "examples/fluid_in_solid_3d.toml", "--threads", value]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--threads" in err


def test_check_and_default():
    assert check(3, "threads") == 3 and default_threads() >= 1
    for bad in (0, True, 1.5, "x"):
        with pytest.raises(ValueError, match="threads"):
            check(bad, "threads")


def test_run_reports_its_threads(tmp_path, capsys):
    from support.cases import write_case

    case = write_case(tmp_path, T=0.001, every=20)
    assert main(["run", str(case), "--out", str(tmp_path / "out"), "--threads", "2"]) == 0
    assert "on 2 threads" in capsys.readouterr().out
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["threads"] == 2 and "ranks" in summary


def test_resume_under_two_threads_is_bit_identical(tmp_path, monkeypatch):
    """A 2-thread run stopped by SIGTERM at step 13 and resumed on 2 threads ends as the uninterrupted one."""
    import signal

    from support.cases import final, signal_at_step, write_case

    case = write_case(tmp_path, T=0.001, every=1000)
    assert main(["run", str(case), "--out", str(tmp_path / "whole"), "--threads", "2", "--quiet"]) == 0
    with monkeypatch.context() as patch:
        signal_at_step(patch, 13)
        assert (main(["run", str(case), "--out", str(tmp_path / "cut"), "--threads", "2", "--quiet"])
                == 128 + signal.SIGTERM)
    assert main(["run", str(case), "--out", str(tmp_path / "cut"), "--threads", "2", "--resume", "--quiet"]) == 0
    whole, resumed = final(tmp_path / "whole"), final(tmp_path / "cut")
    assert resumed["resumed_from"] == 13 and resumed["step"] == whole["step"] == 20 and resumed["threads"] == 2
    assert resumed["l2_norms"] == whole["l2_norms"] and resumed["energy"] == whole["energy"]


def test_default_is_the_cores_or_the_environment_shared_by_the_ranks(monkeypatch):
    for name in ("FSIVSP_THREADS", *LOCAL_SIZE_VARIABLES):
        monkeypatch.delenv(name, raising=False)
    cores = len(os.sched_getaffinity(0))
    assert default_threads() == cores
    monkeypatch.setenv("FSIVSP_THREADS", "3")
    assert default_threads() == 3 and per_rank(3) == 3
    monkeypatch.setenv("OMPI_COMM_WORLD_LOCAL_SIZE", "2")
    assert default_threads() == 1 and per_rank(5) == 2 and per_rank(1) == 1
    monkeypatch.setenv("FSIVSP_THREADS", "0")
    with pytest.raises(ThreadsError, match="FSIVSP_THREADS: expected a positive whole number"):
        default_threads()


def test_bad_environment_threads_is_one_line_exit_2(monkeypatch, capsys):
    monkeypatch.setenv("FSIVSP_THREADS", "two")
    assert main(["study", "examples/fluid_in_solid_3d.toml", "--levels", "0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "FSIVSP_THREADS" in err


def test_default_threads_take_one_for_a_small_problem(monkeypatch):
    """A default block runs a problem below THREADS_MIN_DOFS on one thread and a larger one on its count; a count
    that was given is kept whatever the size."""
    from fsivsp.runtime.threads import THREADS_MIN_DOFS, current, fit, using

    monkeypatch.setenv("FSIVSP_THREADS", "2")
    with using() as count:
        assert count == 2 and current() == 2
        assert fit(THREADS_MIN_DOFS - 1) == 1 and current() == 1
        assert fit(THREADS_MIN_DOFS) == 2 and current() == 2
    with using(2):
        assert fit(10) == 2 and current() == 2
    assert current() == 1


def test_default_threads_take_one_for_a_2d_factorisation(monkeypatch):
    """The policy of `threads.fit` (docs/solvers.md, "Threads"): a default block runs a 2D direct solve on one thread
    at every size (its step does not pay for two: a default run is then the ``--threads 1`` run), a 3D one and PETSc
    in 2D on the block's count from THREADS_MIN_DOFS on; a count that was given is kept. The `Scheme` tells `fit`
    its dimension and solver: the paper's level 0 with THREADS_MIN_DOFS out of the way takes one thread with the
    direct solver and two with PETSc."""
    from fsivsp.experiments.paper import paper_case
    from fsivsp.experiments.study import case_scheme
    from fsivsp.geometry import paper_channel
    from fsivsp.runtime import threads
    from fsivsp.runtime.threads import THREADS_MIN_DOFS, current, fit, using
    from fsivsp.solvers import AUTO_ITERATIVE_DOFS, petsc_available

    monkeypatch.setenv("FSIVSP_THREADS", "2")
    with using():
        assert fit(AUTO_ITERATIVE_DOFS[2] - 1, 2, "direct") == 1 and current() == 1
        assert fit(THREADS_MIN_DOFS, 3, "direct") == 2 and current() == 2
        assert fit(THREADS_MIN_DOFS, 2, "petsc") == 2
        assert fit(THREADS_MIN_DOFS - 1, 3, "petsc") == 1
    with using(2):
        assert fit(THREADS_MIN_DOFS, 2, "direct") == 2 and current() == 2
    monkeypatch.setattr(threads, "THREADS_MIN_DOFS", 0)
    for method, expected in (("direct", 1), ("petsc", 2)):
        if method == "petsc" and petsc_available() is not None:
            continue
        with using():
            case_scheme(paper_case(1e-2).with_solver(method=method), paper_channel())
            assert current() == expected, method
