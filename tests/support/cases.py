"""A production run case (a 2D elastic tube with a traction pulse), running it, signals at a step, mpirun."""
import json
import os
import shutil
import signal
import subprocess
import sys
from importlib.util import find_spec
from pathlib import Path

import meshio
import pytest

from fsivsp.timestepping.scheme import Scheme

ROOT = Path(__file__).resolve().parents[2]

CASE = """
[geometry]
kind = "elastic_tube"
dim = 2
maxh = 0.1
length = 2.0

[materials]
rho_fluid = 1.0
rho_solid = 1.2
nu = 0.035
young = 3.0e6
poisson = 0.3

[time]
T = {T}
dt = 5.0e-5

[discretisation]
family = "mini"

[boundary.inflow]
traction = ["1.0e4*exp(-((t - 0.0005)/0.0002)**2)", "0"]

[boundary.solid_wall]
traction = ["0", "0"]

[boundary.solid_ends]
velocity = ["0", "0"]

[output]
every = 10
probes = [[0.5, 0.0], [1.0, 0.0]]
lines = [{{ start = [0.0, 0.0], end = [2.0, 0.0], n = 11 }}]

[checkpoint]
every = {every}
"""


def write_case(tmp_path, T=0.002, every=10, text=None):
    path = tmp_path / "tube.toml"
    path.write_text(text if text is not None else CASE.format(T=T, every=every))
    return path


def cli(*args, **kwargs):
    return subprocess.Popen([sys.executable, "-m", "fsivsp", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def final_fields(out: Path) -> dict:
    last = sorted((out / "vtk").glob("fields_*.vtu"))[-1]
    return meshio.read(last).point_data


def signal_at_step(monkeypatch, step: int, signum: int = signal.SIGTERM) -> None:
    """The run sends ``signum`` to itself during step ``step``."""
    original = Scheme.step

    def step_and_signal(self, *args, **kwargs):
        if self.n + 1 == step:
            os.kill(os.getpid(), signum)
        return original(self, *args, **kwargs)
    monkeypatch.setattr(Scheme, "step", step_and_signal)


def final(out):
    return json.loads((out / "summary.json").read_text())


MPIRUN = shutil.which("mpirun", path=str(Path(sys.executable).parent)) or shutil.which("mpirun")


MISSING = ("mpi4py is not installed" if find_spec("mpi4py") is None
           else None if MPIRUN else "no mpirun next to the Python executable or on PATH")


needs_mpi = pytest.mark.skipif(MISSING is not None, reason=f"MPI not installed: {MISSING}")


#: A 2D tube with a traction pulse (as in test_run), five steps, probes in the fluid and the solid, a line and
#: VTK files of steps 0 and 5.
TUBE = (CASE.replace("T = {T}", "T = 2.5e-4").replace('family = "mini"', 'family = "{family}"')
        .replace("(t - 0.0005)/0.0002", "(t - 0.0002)/0.0001").replace("every = 10", "every = 5")
        .replace("probes = [[0.5, 0.0], [1.0, 0.0]]", "probes = [[0.5, 0.0], [1.0, 0.0], [1.0, 0.55]]")
        .replace("[checkpoint]\nevery = {every}\n", ""))


#: Open MPI's settings for the tests' runs: as root if need be (CI), on any number of cores, and the ranks not bound
#: to cores. Open MPI binds 2 ranks to the 2 cores by default; beside the suite's other xdist worker a bound rank then
#: waits for its core at every collective (test_outlets_inflow_support_and_surfaces_equal_serial beside a busy loop:
#: 50 s bound, 12 s unbound, 6 s on a quiet machine).
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_MCA_hwloc_base_binding_policy": "none"}


def mpirun(*args: str, ranks: int = 2, program: tuple[str, ...] = ("-m", "fsivsp")) -> subprocess.CompletedProcess:
    """``mpirun -np ranks fsivsp args`` (``program``: Python's arguments before ``args``) with this checkout's
    sources and `MPI_ENV`."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), **MPI_ENV)
    return subprocess.run([MPIRUN, "-np", str(ranks), sys.executable, *program, *args],
                          capture_output=True, text=True, env=env)
