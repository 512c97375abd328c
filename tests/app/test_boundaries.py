"""`fsivsp run` with the boundary conditions users bring: a flow-rate inflow, a Windkessel outlet, tissue support,
surface output; killed and resumed bit for bit; bad input in one line; the artery examples."""
import csv
import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_run import _STOPS_AT

from fsivsp.app.cli import main

ROOT = Path(__file__).resolve().parents[2]

#: A 2D tube: a Womersley inflow, an RCR outlet, the outer wall on tissue support, surfaces and the interface's WSS.
VESSEL = """
[geometry]
kind = "elastic_tube"
dim = 2
maxh = 0.1
length = 2.0

[materials]
rho_fluid = 1.0
rho_solid = 1.2
nu = 0.05
young = 2.0e4
poisson = 0.3

[time]
T = {T}
dt = 0.01
scheme = "bdf2"

[discretisation]
family = "taylor_hood"

[boundary.inflow]
flow = "2*sin(2*pi*t) + 0.5*(1 - cos(4*pi*t))"
profile = "womersley"
period = 1.0
harmonics = 6

[boundary.outflow]
windkessel = {{ proximal = 5.0, capacitance = 0.02, distal = 50.0, distal_pressure = 1.0 }}

[boundary.solid_wall]
support = {{ stiffness = 1.0e4, damping = 20.0 }}

[boundary.solid_ends]
velocity = ["0", "0"]

[output]
every = 5
surfaces = ["inflow", "outflow", "interface", "solid_wall"]

[checkpoint]
every = {every}
"""


def vessel(tmp_path, T=0.1, every=10, text=None) -> Path:
    path = tmp_path / "vessel.toml"
    path.write_text(text if text is not None else VESSEL.format(T=T, every=every))
    return path


def flow(t):
    return 2 * np.sin(2 * np.pi * t) + 0.5 * (1 - np.cos(4 * np.pi * t))


def test_run_writes_surfaces_and_the_interface(tmp_path):
    """surfaces.csv every step (the inflow's flux is Q(t) to 1e-12; the outflow's mean pressure that of the
    Windkessel at its last step, within the outlet's corner effect), surfaces.png, vtk/interface.pvd with the
    traction and wall shear stress on Γ's facets, the outlet's P and Q in summary.json."""
    out = tmp_path / "out"
    assert main(["run", str(vessel(tmp_path)), "--out", str(out), "--quiet"]) == 0
    rows = list(csv.DictReader((out / "surfaces.csv").open()))
    assert len(rows) == 11 and list(rows[0])[:4] == ["time", "inflow.flow", "inflow.pressure", "inflow.area"]
    assert {"interface.force_x", "solid_wall.force_y"} <= set(rows[0]) and rows[0]["solid_wall.pressure"] == "nan"
    for row in rows:
        assert -float(row["inflow.flow"]) == pytest.approx(flow(float(row["time"])), abs=1e-12)
    summary = json.loads((out / "summary.json").read_text())
    outlet = summary["outlets"]["outflow"]
    assert outlet["flow"] == pytest.approx(float(rows[-1]["outflow.flow"]), rel=1e-12)
    assert float(rows[-1]["outflow.pressure"]) == pytest.approx(outlet["pressure"], rel=0.05)
    assert (out / "surfaces.png").read_bytes()[:4] == b"\x89PNG"
    import meshio

    pvd = (out / "vtk" / "interface.pvd").read_text()
    assert pvd.count("<DataSet") == 3
    walls = meshio.read(out / "vtk" / "interface_000010.vtu")
    assert walls.cells[0].type == "line" and set(walls.point_data) == {"traction", "wss", "wss_magnitude"}
    assert np.abs(walls.points[:, 1]).min() == pytest.approx(0.5)  # the facets of Γ only
    assert np.abs(walls.point_data["wss_magnitude"]).max() > 0


def test_killed_run_resumes_to_identical_results(tmp_path):
    """SIGKILL during step 11 of 15: the resume from the checkpoint of step 8 (the outlet's P_c, P_c before and Q
    with the vectors) ends as the uninterrupted run, bit for bit: fields, surfaces.csv, the outlet's state."""
    case = vessel(tmp_path, T=0.15, every=4)
    reference = tmp_path / "reference"
    assert main(["run", str(case), "--out", str(reference), "--quiet"]) == 0
    out = tmp_path / "killed"
    process = subprocess.Popen([sys.executable, "-c", _STOPS_AT, "11", "run", str(case), "--out", str(out),
                                "--quiet"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
    assert process.stdout.readline() == "at step 11\n"
    process.send_signal(signal.SIGKILL)
    assert process.wait() == -signal.SIGKILL
    assert main(["run", str(case), "--out", str(out), "--resume", "--quiet"]) == 0
    summary, expected = (json.loads((folder / "summary.json").read_text()) for folder in (out, reference))
    assert summary["resumed_from"] == 8 and summary["outlets"] == expected["outlets"]
    assert (out / "surfaces.csv").read_text() == (reference / "surfaces.csv").read_text()
    import meshio

    for name in ("fields_000015.vtu", "interface_000015.vtu"):
        ours, theirs = (meshio.read(folder / "vtk" / name).point_data for folder in (out, reference))
        for field in theirs:
            assert np.array_equal(ours[field], theirs[field]), (name, field)


BAD = [
    ('profile = "womersley"', 'profile = "poiseuille"', "boundary.inflow.profile"),
    ("period = 1.0", "period = -1.0", "boundary.inflow.period"),
    ("period = 1.0\n", "", "boundary.inflow.period: missing"),
    ("harmonics = 6", "harmonics = 0", "boundary.inflow.harmonics"),
    ('flow = "2*sin(2*pi*t) + 0.5*(1 - cos(4*pi*t))"', 'flow = "x*t"', "boundary.inflow.flow"),
    ('flow = "2*sin(2*pi*t) + 0.5*(1 - cos(4*pi*t))"', 'flow = "__import__(t)"', "boundary.inflow.flow"),
    ('flow = "2*sin(2*pi*t) + 0.5*(1 - cos(4*pi*t))"', 'flow = { table = "missing.csv" }',
     "boundary.inflow.flow.table"),
    ('flow = "2*sin(2*pi*t) + 0.5*(1 - cos(4*pi*t))"', 'flow = { file = "q.csv" }', "boundary.inflow.flow"),
    ("[boundary.inflow]", "[boundary.interface]", "boundary.interface"),
    ("[boundary.solid_ends]", '[boundary.solid_ends]\nflow = "1"', "boundary.solid_ends"),
    ("capacitance = 0.02", "capacitance = -0.02", "boundary.outflow.windkessel.capacitance"),
    ("distal = 50.0", "distal = 0.0", "boundary.outflow.windkessel.distal"),
    ("distal = 50.0,", "distal = 50.0, resistance = 3.0,", "boundary.outflow.windkessel.resistance"),
    ("distal_pressure = 1.0", 'distal_pressure = "y"', "boundary.outflow.windkessel.distal_pressure"),
    ("windkessel = {", "profile = \"plug\"\nwindkessel = {", "boundary.outflow.profile"),
    ("[boundary.outflow]", "[boundary.outflow]\nresistance = 3.0", "boundary.outflow"),
    ("support = {", "support = 3.0\n#", "boundary.solid_wall.support"),
    ("stiffness = 1.0e4", "stiffness = -1.0e4", "boundary.solid_wall.support.stiffness"),
    ("stiffness = 1.0e4, damping = 20.0", "stiffness = 0.0", "boundary.solid_wall.support"),
    ("[boundary.solid_wall]", "[boundary.inflow2]", "boundary.inflow2"),
    ('surfaces = ["inflow",', 'surfaces = ["inlet",', "output.surfaces"),
    ('surfaces = ["inflow",', 'surfaces = [1, "inflow",', "output.surfaces"),
    ("[discretisation]", "[materials.plaque]\nmu = 1.0\n\n[discretisation]", "materials.plaque"),
    ("[discretisation]", "[materials.solid]\nnu = 1.0\n\n[discretisation]", "materials.solid.nu"),
    ("[discretisation]", "[materials.fluid]\nmu = 1.0\n\n[discretisation]", "materials.fluid.mu"),
    ("[discretisation]", "[materials.solid]\nmu = -1.0\n\n[discretisation]", "materials.solid.mu"),
    ('kind = "elastic_tube"', 'kind = "elastic_tube"\nregions = { solid = "fluid" }', "geometry.regions"),
]


@pytest.mark.parametrize("old, new, field", BAD, ids=[b[2] + f"-{i}" for i, b in enumerate(BAD)])
def test_bad_input_exit_2_naming_the_field(tmp_path, capsys, old, new, field):
    text = VESSEL.format(T=0.02, every=10)
    assert old in text, old
    out = tmp_path / "out"
    assert main(["run", str(vessel(tmp_path, text=text.replace(old, new, 1))), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and field in err and "Traceback" not in err, err
    assert not out.exists()


def without(text: str, name: str) -> str:
    """The case text without the table [boundary.NAME]."""
    start = text.index(f"[boundary.{name}]")
    return text[:start] + text[text.index("\n\n", start) + 2:]


@pytest.mark.parametrize("kept, moved, message", [
    ("solid_wall", "outflow", "boundary.outflow.support: expected a boundary of the solid, got one of the fluid"),
    ("outflow", "solid_wall",
     "boundary.solid_wall.windkessel: expected a boundary of the fluid, got one of the solid")])
def test_conditions_on_the_wrong_medium_are_refused(tmp_path, capsys, kept, moved, message):
    """A support on a fluid boundary, an outlet on a solid one: one line, exit 2."""
    text = without(VESSEL.format(T=0.02, every=10), moved).replace(f"[boundary.{kept}]", f"[boundary.{moved}]")
    assert main(["run", str(vessel(tmp_path, text=text)), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err


def test_flow_table_relative_to_the_case_file(tmp_path):
    """``flow = { table = "q.csv" }``: rows time, Q (a header allowed), read from the case file's folder, periodic
    with ``period``; the inflow's flux follows it at every step."""
    (tmp_path / "q.csv").write_text("time,Q\n0,0\n0.05,1.5\n0.1,0\n")
    text = (VESSEL.format(T=0.05, every=10).replace('flow = "2*sin(2*pi*t) + 0.5*(1 - cos(4*pi*t))"',
                                                     'flow = { table = "q.csv" }')
            .replace('profile = "womersley"', 'profile = "parabolic"').replace("period = 1.0", "period = 0.1"))
    out = tmp_path / "out"
    assert main(["run", str(vessel(tmp_path, text=text)), "--out", str(out), "--quiet"]) == 0
    rows = list(csv.DictReader((out / "surfaces.csv").open()))
    expected = np.interp([float(r["time"]) for r in rows], [0, 0.05, 0.1], [0, 1.5, 0], period=0.1)
    assert np.abs([-float(r["inflow.flow"]) for r in rows] - expected).max() < 1e-12


@pytest.mark.parametrize("name, changes", [
    ("artery_2d", ["time.T=0.006"]),
    pytest.param("artery_3d", ["time.T=0.004", "geometry.maxh=0.3"], marks=pytest.mark.slow)])
def test_artery_examples_run(tmp_path, name, changes):
    """examples/artery_3d.toml (slow: meshing its thin layers takes most of it) and its 2D section run, a few
    steps."""
    out = tmp_path / name
    arguments = [item for change in changes for item in ("--set", change)]
    assert main(["run", str(ROOT / "examples" / f"{name}.toml"), "--out", str(out), "--quiet", *arguments]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["outlets"]["outflow"]["flow"] > 0
    assert summary["inputs"]["materials"]["regions"]["adventitia"]["mu"] < summary["inputs"]["materials"]["mu"]
