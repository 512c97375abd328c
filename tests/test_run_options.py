"""`fsivsp run` options of issue 25: continuous output, the line plot, --set, set-up messages, relative paths."""
import json

import meshio
import numpy as np
import pytest

from fsivsp.cli import main

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
