"""Threads (`fsivsp.threads`): bit-identical runs for a given count, round-off between counts, the option."""
import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest

from fsivsp.cli import main
from fsivsp.threads import check, default_threads

_RUN = """
import sys
import numpy as np
from fsivsp.geometry import refined
from fsivsp.paper import paper_case
from fsivsp.study import discretise
from fsivsp.threads import using
with using(int(sys.argv[2])):
    case = paper_case(1e-2, solver=sys.argv[1])
    scheme, _ = discretise(case, refined(case.coarse_mesh(), 1, case.project_refinement))
    scheme.march(3)
    values = scheme.state.vec.FV().NumPy()
    print(values.tobytes().hex(), repr(float(np.linalg.norm(values))))
"""


def _run(solver: str, threads: int) -> tuple[str, float]:
    out = subprocess.run([sys.executable, "-c", _RUN, solver, str(threads)], capture_output=True, text=True,
                         check=True).stdout.split()
    return hashlib.sha1(out[0].encode()).hexdigest(), float(out[1])


@pytest.mark.xfail(reason="not yet bit-identical under 2 threads: a piece under NGSolve's TaskManager other than the "
                          "coarse solves and MKL varies at round-off (issue 24, docs/solvers.md)", strict=False)
@pytest.mark.parametrize("solver", ["direct", "iterative"])
def test_two_threads_bit_identical_and_one_thread_round_off(solver):
    first, second, one = _run(solver, 2), _run(solver, 2), _run(solver, 1)
    assert first == second
    assert abs(first[1] - one[1]) <= 1e-10 * abs(one[1])


@pytest.mark.parametrize("value", ["0", "abc", "1.5"])
def test_bad_threads_is_one_line_exit_2(value, capsys):
    assert main(["run", "examples/fluid_in_solid_3d.toml", "--threads", value]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--threads" in err


def test_one_thread_is_bit_identical():
    """threads = 1: today's sequential code, bit for bit from one process to the next."""
    assert _run("iterative", 1) == _run("iterative", 1)


def test_check_and_default():
    assert check(3, "threads") == 3 and default_threads() >= 1
    for bad in (0, True, 1.5, "x"):
        with pytest.raises(ValueError, match="threads"):
            check(bad, "threads")


def test_run_reports_its_threads(tmp_path, capsys):
    from test_run import write_case

    case = write_case(tmp_path, T=0.001, every=20)
    assert main(["run", str(case), "--out", str(tmp_path / "out"), "--threads", "2"]) == 0
    assert "on 2 threads" in capsys.readouterr().out
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["threads"] == 2 and "ranks" in summary
