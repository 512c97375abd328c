import os

import ngsolve as ngs
import pytest

# In-process code outside `fsivsp.threads.using` runs on one NGSolve thread (the package sets no thread count at
# import); runs through the CLI or `fsivsp.run` take the default threads (the cores, used where they pay:
# `threads.fit`), tests of a given count enter `using(n)` or pass `--threads n`. Under `pytest -n N` the workers
# share the cores: each run's default is the cores divided among the workers (FSIVSP_THREADS, at least 1).
if (workers := os.environ.get("PYTEST_XDIST_WORKER_COUNT", "")).isdigit():
    os.environ.setdefault("FSIVSP_THREADS", str(max(1, len(os.sched_getaffinity(0)) // int(workers))))
ngs.SetNumThreads(1)

from fsivsp import forms
from fsivsp.geometry import FLUID, paper_channel, refined


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
#: `ran`). Groups of (test file, test name prefix). Not xdist_group marks: xdist 3.8 applies them by rewriting
#: `item._nodeid`, which pytest 9.2 no longer reads, so they group nothing.
GROUPS = {"two_cores": [("test_mpi.py", ""), ("test_threads.py", ""), ("test_run_options.py", "test_set_and_stages_on_two_ranks"),
                        ("test_faults.py", "test_ctrl_c_in_paper_all")],
          "wave2d": [("test_readme.py", "test_cheap_commands_run[fsivsp run examples/pressure_wave_2d.toml --out wave2d")]}


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
