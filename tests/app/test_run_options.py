"""`fsivsp run` options of issue 25: continuous output, the line plot, --set, set-up messages, relative paths."""
import json
import re
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest
from support.cases import TUBE, mpirun, needs_mpi

from fsivsp.app.cli import main
from fsivsp.runtime.logs import FsivspWarning

CASE = """
[geometry]
kind = "fluid_over_solid"
dim = 2
maxh = 0.25

[materials]
rho_fluid = 1.0
rho_solid = 1.0
nu = 0.1
lam = 1.0
mu = 1.0

[time]
T = 0.02
dt = 0.01

[boundary.fluid_wall]
velocity = ["x*(1 - x)*t", "0"]

[output]
every = 1
lines = [{ start = [0.5, 0.0], end = [0.5, 1.0], n = 5 }]
"""


def write_case(folder, extra="", name="case.toml"):
    path = folder / name
    path.write_text(CASE + extra)
    return path


def run(case, out, *options):
    return main(["run", str(case), "--out", str(out), "--quiet", *options])


def test_continuous_output_from_the_case_file_and_the_line_plot(tmp_path):
    """``[output] continuous = true``: one VTU point per mesh vertex; lines.csv is plotted as lines.png."""
    out = tmp_path / "out"
    assert run(write_case(tmp_path, "continuous = true\n"), out) == 0
    data = meshio.read(out / "vtk" / "fields_000002.vtu")
    summary = json.loads((out / "summary.json").read_text())
    assert len(data.points) == summary["mesh"]["vertices"]
    assert np.all(np.isfinite(data.point_data["velocity"]))
    assert (out / "lines.png").read_bytes()[:4] == b"\x89PNG"


def test_continuous_must_be_a_boolean(tmp_path, capsys):
    assert run(write_case(tmp_path, "continuous = 1\n"), tmp_path / "out") == 2
    assert capsys.readouterr().err.strip() == "error: output.continuous: expected true or false, got 1"


def test_set_overrides_case_keys_and_is_recorded(tmp_path):
    """``--set`` replaces keys before validation (nested, strings as bare words) and summary.json records them."""
    out = tmp_path / "out"
    assert run(write_case(tmp_path), out, "--set", "time.dt=0.005", "--set", "materials.nu=0.01",
               "--set", "discretisation.family=taylor_hood", "--set", 'boundary.fluid_wall.velocity=["0", "0"]') == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["step"] == 4 and summary["inputs"]["dt"] == 0.005 and summary["inputs"]["family"] == "taylor_hood"
    assert summary["inputs"]["materials"]["nu"] == 0.01
    assert summary["overrides"] == {"time.dt": 0.005, "materials.nu": 0.01, "discretisation.family": "taylor_hood",
                                    "boundary.fluid_wall.velocity": ["0", "0"]}


@pytest.mark.parametrize("option, message", [
    ("time.dtt=1", "time.dtt: unknown key (did you mean 'dt'?); expected one of T, dt, scheme, theta"),
    ("time.dt=-1", "time.dt: expected a positive number, got -1"),
    ("materials.nu", "--set: expected SECTION.KEY=VALUE (e.g. time.dt=1e-4), got 'materials.nu'"),
    ("dt=1", "--set: expected SECTION.KEY=VALUE (e.g. time.dt=1e-4), got 'dt=1'"),
    ("time.dt=[1,", "--set time.dt: expected a TOML value (a number, true/false, \"text\", [...]), got '[1,'"),
    ("time.T.x=1", "--set time.T.x: time.T is not a table in the case file"),
    ("mesh.kind=1", "mesh: unknown section; expected one of boundary, checkpoint, data, "
     "discretisation, geometry, materials, output, solver, time"),
])
def test_bad_set_is_one_line_exit_2(tmp_path, capsys, option, message):
    assert run(write_case(tmp_path), tmp_path / "out", "--set", option) == 2
    assert capsys.readouterr().err.strip() == f"error: {message}"


def test_python_run_returns_the_summary(tmp_path):
    """``fsivsp.run`` takes a path or a dict (with overrides) and returns what summary.json holds."""
    import tomllib

    import fsivsp
    import fsivsp.app.loop  # the submodule does not hide the function
    from fsivsp.app.loop import run_case  # noqa: F401

    out = tmp_path / "out"
    summary = fsivsp.run(write_case(tmp_path), out, overrides={"time.T": 0.01}, quiet=True)
    assert summary == json.loads((out / "summary.json").read_text())
    assert summary["step"] == 1 and summary["overrides"] == {"time.T": 0.01}
    assert fsivsp.run(tomllib.loads(CASE), tmp_path / "dict", quiet=True)["step"] == 2
    with pytest.raises(fsivsp.CaseError, match="^time.dt: expected a positive number, got 0$"):
        fsivsp.run(write_case(tmp_path), out, overrides={"time.dt": 0})


def test_quiet_keeps_the_final_line(tmp_path, capsys):
    out = tmp_path / "out"
    assert run(write_case(tmp_path), out) == 0
    captured = capsys.readouterr()
    assert captured.out == f"completed: 2 steps to t = 0.02 on 1 thread; results in {out}\n"


MESH_CASE = CASE.replace('kind = "fluid_over_solid"\ndim = 2\nmaxh = 0.25', 'kind = "mesh"\ndim = 2\npath = "{path}"')


def test_relative_paths_are_the_case_files(tmp_path, monkeypatch, capsys):
    """A relative ``path`` is read from the case file's folder, whatever the working directory; an absolute one
    as it is; one that exists only from the working directory is used with a warning."""
    from fsivsp.geometry import build_geometry

    folder, elsewhere = tmp_path / "cases", tmp_path / "elsewhere"
    (folder / "meshes").mkdir(parents=True)
    elsewhere.mkdir()
    build_geometry("fluid_over_solid", 2, 0.25).ngmesh.Save(str(folder / "meshes" / "layers.vol"))
    monkeypatch.chdir(elsewhere)
    case = folder / "case.toml"
    case.write_text(MESH_CASE.replace("{path}", "meshes/layers.vol"))
    assert run(case, "out") == 0
    summary = json.loads((elsewhere / "out" / "summary.json").read_text())
    assert summary["inputs"]["geometry"]["path"] == str(folder / "meshes" / "layers.vol")
    case.write_text(MESH_CASE.replace("{path}", str(folder / "meshes" / "layers.vol")))
    assert run(case, "out") == 0
    monkeypatch.chdir(folder)
    other = tmp_path / "other.toml"
    other.write_text(MESH_CASE.replace("{path}", "meshes/layers.vol"))
    with pytest.warns(FsivspWarning) as caught:
        assert run(other, "out") == 0
    assert [str(w.message) for w in caught] == [
        f"geometry.path: meshes/layers.vol is not in the case file's folder {tmp_path}; using meshes/layers.vol "
        "relative to the working directory (write it relative to the case file)"]


def test_set_up_stages_on_stderr_unless_quiet(tmp_path, capsys):
    """One line per set-up stage with its time, in order; none with --quiet."""

    case = write_case(tmp_path)
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 0
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("set-up:")]
    stages = [re.fullmatch(r"set-up: (.+) \d+\.\d\d s", line).group(1) for line in lines]
    assert stages[:4] == ["mesh", "refinement", "spaces", "assembly"] and stages[5:] == ["initial data"]
    assert re.fullmatch(r"(factorisation|preconditioner) \(\w+\)", stages[4])
    assert run(case, tmp_path / "quiet") == 0
    assert "set-up" not in capsys.readouterr().err


def test_the_wrong_command_says_which_to_use(tmp_path, capsys):
    """A run case given to ``study`` and a study case given to ``run``: one line naming the right command."""

    run_case = write_case(tmp_path)
    assert main(["study", str(run_case), "--quiet"]) == 2
    assert capsys.readouterr().err == (f"error: {run_case}: a case for `fsivsp run` (it has no [exact] section); "
                                       f"use `fsivsp run {run_case}`\n")
    study_case = Path(__file__).parents[2] / "examples" / "fluid_over_solid_2d.toml"
    assert run(study_case, tmp_path / "out") == 2
    assert capsys.readouterr().err == (f"error: {study_case}: a case for `fsivsp study` (it has an [exact] section); "
                                       f"use `fsivsp study {study_case}`\n")


def test_a_kinematic_looking_viscosity_is_warned_about(tmp_path, capsys):
    """ν = 1e-6 with ρ_F = 1000 (water's kinematic viscosity in SI): one warning; the run goes on; none for 1e-3."""
    water = ["--set", "materials.rho_fluid=1000", "--set", "materials.rho_solid=1000", "--set", "materials.lam=1e6",
             "--set", "materials.mu=1e6"]
    with pytest.warns(FsivspWarning) as caught:
        assert run(write_case(tmp_path), tmp_path / "out", *water, "--set", "materials.nu=1e-6") == 0
    assert [str(w.message) for w in caught] == [
        "materials.nu = 1e-06 is the dynamic viscosity (σ_F = −pI + 2ν ε(v), Pa·s in SI); with rho_fluid = 1000 this "
        "looks like a kinematic one (m²/s): water's dynamic viscosity is about 1e-3 Pa·s"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", FsivspWarning)
        assert run(write_case(tmp_path), tmp_path / "dynamic", *water, "--set", "materials.nu=1e-3") == 0


def test_progress_in_a_log_is_plain_lines(tmp_path):
    """stderr redirected to a file: no carriage returns or escape codes, a plain line at the end of each bar."""
    import os
    import subprocess
    import sys

    import fsivsp

    env = {**os.environ, "PYTHONPATH": str(Path(fsivsp.__file__).parents[1])}
    example = Path(__file__).parents[2] / "examples" / "fluid_over_solid_2d.toml"
    commands = {"run": ["run", str(write_case(tmp_path)), "--out", str(tmp_path / "out")],
                "study": ["study", str(example), "--levels", "0"]}
    for name, args in commands.items():
        log = tmp_path / f"{name}.log"
        with log.open("w") as stderr:
            assert subprocess.run([sys.executable, "-m", "fsivsp", *args], stdout=subprocess.DEVNULL,
                                  stderr=stderr, env=env).returncode == 0
        text = log.read_text()
        assert "\r" not in text and "\x1b" not in text
        progress = [line for line in text.splitlines() if not line.startswith(("set-up:", "estimate:"))]
        if name == "run":
            assert len(progress) == 1 and re.fullmatch(r"case: 2/2 steps \(100%\), \d+ s, \w+, \d+\.\d\d GiB",
                                                       progress[0])
        else:
            assert len(progress) == 1 and re.fullmatch(r"fluid_over_solid_2d: 1/1 level \(100%\), \d+ s", progress[0])


def test_log_bar_writes_a_line_per_interval(monkeypatch, capsys):
    """`progress.LogBar` (stderr not a terminal): a line whenever `INTERVAL` has passed and one at the end; none for
    an inner bar (leave=False) at its end."""
    from fsivsp.runtime import progress

    monkeypatch.setattr(progress, "INTERVAL", 0.0)
    assert list(progress.tqdm(range(2), desc="jobs", unit="run")) == [0, 1]
    with progress.tqdm(total=3, desc="inner", leave=False, unit="step") as bar:
        bar.set_postfix_str("pardiso")
        bar.update(1)
    lines = [re.sub(r", \d+ s", ", T s", line) for line in capsys.readouterr().err.splitlines()]
    assert lines == ["jobs: 1/2 runs (50%), T s", "jobs: 2/2 runs (100%), T s", "jobs: 2/2 runs (100%), T s",
                     "inner: 1/3 steps (33%), T s, pardiso"]


EXAMPLES = Path(__file__).parents[2] / "examples"


def test_msh_example_runs_from_any_folder(tmp_path, monkeypatch):
    """examples/channel_2d.toml on examples/channel_2d.msh (gmsh 4.1), its path relative to the case file."""
    from fsivsp.geometry import load_mesh

    monkeypatch.chdir(tmp_path)
    assert run(EXAMPLES / "channel_2d.toml", "out", "--set", "time.T=0.05") == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    mesh = load_mesh(EXAMPLES / "channel_2d.msh")
    assert summary["status"] == "completed" and summary["mesh"] == {"vertices": mesh.nv, "cells": mesh.ne}
    assert sorted(set(mesh.GetBoundaries())) == ["fluid_wall", "inflow", "interface", "outflow", "solid_wall"]
    assert EXAMPLES.joinpath("channel_2d.msh").read_text().startswith("$MeshFormat\n4.1 0 8\n")


def test_msh_example_is_what_the_script_writes(tmp_path):
    import importlib.util

    from fsivsp.geometry import load_mesh

    spec = importlib.util.spec_from_file_location("make_msh_example", EXAMPLES / "make_msh_example.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    again = load_mesh(module.write_gmsh(module.channel(), tmp_path / "again.msh"))
    shipped = load_mesh(EXAMPLES / "channel_2d.msh")
    assert (again.nv, again.ne) == (shipped.nv, shipped.ne)


@needs_mpi
def test_set_and_stages_on_two_ranks(tmp_path):
    """Under mpirun: ``--set`` reaches every rank and each set-up stage is one line (rank 0's), not one per rank."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini"))
    done = mpirun("run", str(case), "--out", str(tmp_path / "out"), "--set", "time.T=1e-4")
    assert done.returncode == 0, done.stderr
    stages = [line.split()[1] for line in done.stderr.splitlines() if line.startswith("set-up:")]
    assert stages == ["mesh", "refinement", "spaces", "assembly", "preconditioner", "initial"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["step"] == 2 and summary["overrides"] == {"time.T": 1e-4}
