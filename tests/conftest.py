import os
import signal

import ngsolve as ngs
import pytest

# In-process code outside `fsivsp.runtime.threads.using` runs on one NGSolve thread (the package sets no thread count at
# import); runs through the CLI or `fsivsp.run` take the default threads (the cores, used where they pay:
# `threads.fit`), tests of a given count enter `using(n)` or pass `--threads n`. Under `pytest -n N` the workers
# share the cores: each run's default is the cores divided among the workers (FSIVSP_THREADS, at least 1).
if (workers := os.environ.get("PYTEST_XDIST_WORKER_COUNT", "")).isdigit():
    os.environ.setdefault("FSIVSP_THREADS", str(max(1, len(os.sched_getaffinity(0)) // int(workers))))
ngs.SetNumThreads(1)

from pathlib import Path

import numpy as np

from fsivsp.config.case import load_study_case
from fsivsp.experiments.study import study
from fsivsp.fem import forms
from fsivsp.geometry import FLUID, paper_channel, refined
from fsivsp.solvers import AUTO, TOLERANCE

EXAMPLES = Path(__file__).parents[1] / "examples"


@pytest.fixture(autouse=True)
def ctrl_c_as_in_a_terminal():
    """SIGINT caught by Python's KeyboardInterrupt, here and (reset to the default at exec) in the commands started,
    as in a terminal's foreground, however the suite was started. A shell without job control starts a background
    job (``pytest ... &`` in a script) with SIGINT ignored, and its processes inherit that: Ctrl-C then stops no run,
    study or pool, as POSIX intends (`fsivsp.runtime.stopping.catch`), and the tests that send it would fail."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.fixture(scope="session")
def paper_meshes():
    """The paper's coarse mesh and its first two refinements (with projection)."""
    coarse = paper_channel()
    return [refined(coarse, level) for level in range(3)]


def _discrete_divergence(scheme) -> float:
    (v, _), (_, q) = scheme.spaces.mixed.TnT()
    form = ngs.BilinearForm(scheme.spaces.mixed)
    form += forms.integral(q * ngs.div(v), scheme.spaces, FLUID)
    return ngs.Norm(form.Assemble().mat * scheme.state.vec)


@pytest.fixture
def discrete_divergence():
    """The norm of (∫_F q_i div v_h)_i for the scheme's current velocity (zero if discretely divergence-free)."""
    return _discrete_divergence


@pytest.fixture(scope="session")
def examples() -> Path:
    """The folder of the example case files."""
    return EXAMPLES


@pytest.fixture
def example():
    """``example(name, **changes)``: the study case examples/NAME.toml with the `Discretisation` ``changes``."""
    def load(name: str, **changes):
        return load_study_case(EXAMPLES / f"{name}.toml").with_discretisation(**changes)
    return load


@pytest.fixture
def same_errors():
    """``same_errors(case, levels, method="petsc", rtol=1e-6)``: study ``case`` with the direct solver and with
    ``method`` (at the case's tolerance if it sets a number, else 1e-12: the solver's, not the auto tolerance's,
    accuracy); assert equal error norms on every level; return ``method``'s records (their solver PETSc's)."""
    def compare(case, levels, method: str = "petsc", rtol: float = 1e-6) -> list[dict]:
        direct = study(case.with_solver(method="direct"), levels)
        tolerance = TOLERANCE if case.solver.tolerance == AUTO else case.solver.tolerance
        records = study(case.with_solver(method=method, tolerance=tolerance), levels)
        for a, b in zip(direct, records):
            assert b["solver"] == "petsc" and a["solver"] != "petsc"
            for name, error in a["errors"].items():
                assert b["errors"][name] == pytest.approx(error, rel=rtol), (a["level"], name)
        return records
    return compare


@pytest.fixture
def record_assembly(monkeypatch):
    """``record_assembly()``: from then on, assemblies and factorisations are not done but listed (returned)."""
    def start() -> list[str]:
        calls = []
        monkeypatch.setattr(ngs.BilinearForm, "Assemble", lambda *a, **k: calls.append("assemble"))
        monkeypatch.setattr(ngs.LinearForm, "Assemble", lambda *a, **k: calls.append("assemble load"))
        monkeypatch.setattr(ngs.la.SparseMatrixd, "Inverse", lambda *a, **k: calls.append("inverse"))
        return calls
    return start


@pytest.fixture
def same_state():
    """``same_state(a, b)``: two schemes at the same step with equal (v, p) and u_h (so σ_h) up to round-off."""
    def equal(a, b) -> bool:
        pairs = ((a.state.vec, b.state.vec), (a.carried.vec, b.carried.vec))
        return a.n == b.n and a.time == b.time and all(
            np.abs(x.FV().NumPy() - y.FV().NumPy()).max() <= 1e-12 * np.abs(y.FV().NumPy()).max() for x, y in pairs)
    return equal


@pytest.fixture
def tiny_disk(tmp_path):
    """A folder on a 700 kB tmpfs (a nearly full disk); skipped where this user cannot mount one."""
    import subprocess

    disk = tmp_path / "disk"
    disk.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=700k", "tmpfs", str(disk)], capture_output=True,
                          text=True)
    if done.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    yield disk
    subprocess.run(["umount", str(disk)], check=False)


#: Tests that must not run at once under `pytest -n N` (pytest-xdist), each group on one worker in turn: "two_cores",
#: the tests that keep both cores busy (mpirun with 2–3 ranks: test_mpi.py and test_run_options.py's; 2 NGSolve
#: threads: test_threads.py; `paper --jobs 2`), two of which at once would oversubscribe a 2-core machine; and
#: "wave2d", the README's pressure-wave run and its --resume, which continues in the run's folder (test_readme.py's
#: `ran`); "layers", the tests of test_modes.py's module fixture, computed once on one worker. Groups of (test file,
#: test name prefix). Not xdist_group marks: xdist 3.8 applies them by rewriting
#: `item._nodeid`, which pytest 9.2 no longer reads, so they group nothing.
GROUPS = {"two_cores": [("test_mpi.py", ""), ("test_threads.py", ""),
                        ("test_run_options.py", "test_set_and_stages_on_two_ranks"),
                        ("test_faults.py", "test_ctrl_c_in_paper_all")],
          "wave2d": [("test_readme.py",
                      "test_cheap_commands_run[fsivsp run examples/pressure_wave_2d.toml --out wave2d")],
          "layers": [("test_modes.py", "test_shear_modes"), ("test_modes.py", "test_a_run_started")]}


def group_of(nodeid: str) -> str | None:
    """The group of a test's node id (``tests/test_mpi.py::test_x[...]``), None for most."""
    path, _, name = nodeid.partition("::")
    return next((group for group, tests in GROUPS.items()
                 for file, prefix in tests if path.rsplit("/", 1)[-1] == file and name.startswith(prefix)), None)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``-n N`` (``--dist load``, xdist's default, or ``loadgroup``): each test a unit of its own but for `GROUPS`,
    one unit each."""
    if config.getvalue("dist") not in ("load", "loadgroup"):
        return None
    from xdist.scheduler import LoadScopeScheduling

    class Groups(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return group_of(nodeid) or nodeid

    return Groups(config, log)


#: The slow tests' hang guard in place of pyproject's `timeout` (600 s): the longest, MINI in the fluid ball on
#: levels 3–5, runs 1 h 30 min.
SLOW_TIMEOUT = 4 * 3600


def pytest_collection_modifyitems(items):
    for item in items:
        if item.get_closest_marker("slow") and not item.get_closest_marker("timeout"):
            item.add_marker(pytest.mark.timeout(SLOW_TIMEOUT))
