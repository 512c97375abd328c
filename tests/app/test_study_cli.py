"""`fsivsp study`: case files, output, and one-line errors with exit code 2."""
import json
from pathlib import Path

import pytest

from fsivsp.app.cli import main

EXAMPLE = Path(__file__).parents[2] / "examples" / "fluid_over_solid_2d.toml"


def test_study_writes_records(tmp_path, capsys):
    out = tmp_path / "study.json"
    assert main(["study", str(EXAMPLE), "--levels", "0-1", "--json", str(out), "--quiet"]) == 0
    records = json.loads(out.read_text())
    for record in records:
        assert {"level", "vertices", "h", "dofs", "errors", "rates", "seconds"} <= set(record)
        assert set(record["errors"]) == set(record["rates"]) == {"v1", "v2", "p", "sigma", "total"}
    assert records[0]["rates"]["v1"] is None and records[1]["rates"]["v1"] > 1.5
    assert "r(σ)" in capsys.readouterr().out


def edited(tmp_path, old, new):
    text = EXAMPLE.read_text()
    assert old in text
    path = tmp_path / "case.toml"
    path.write_text(text.replace(old, new))
    return path


@pytest.mark.parametrize("old, new, field", [
    ('displacement = ["x*y + (1 + t)*sin(pi*y)"', 'displacement = ["x*y + (1 + 2*t)*sin(pi*y)"',
     "exact.displacement[0]"),
    ("[materials]", "[materials]\nrho = 1.0", "materials.rho"),
    ("[time]", "[clock]", "clock"),
    ("mu = 0.75", "mu = -1", "materials.mu"),
    ("lam = 1.5", "lam = -1", "materials.lam"),
    ("dt = 0.02", "dt = 1.0", "time.dt"),
    ("dt = 0.02", 'dt = "small"', "time.dt"),
    ('family = "taylor_hood"', 'family = "crouzeix"', "discretisation.family"),
    ("order = 1", "order = 7", "discretisation.order"),
    ("order = 1", 'order = 1\ninitial_velocity = "stokes"', "discretisation.initial_velocity"),
    ('kind = "fluid_over_solid"', 'kind = "blob"', "geometry.kind"),
    ("dim = 2", "dim = 4", "geometry.dim"),
    ("maxh = 0.15", "maxh = -0.1", "geometry.maxh"),
    ('pressure = "cos(pi*x)*cos(pi*y)"', 'pressure = "cos(pi*x"', "exact.pressure"),
    ('pressure = "cos(pi*x)*cos(pi*y)"', 'pressure = "__import__(1)"', "exact.pressure"),
    ('velocity = ["sin(pi*y)", "sin(pi*x)"]', 'velocity = ["sin(pi*y)"]', "exact.velocity"),
])
def test_bad_case_files(tmp_path, capsys, old, new, field):
    assert main(["study", str(edited(tmp_path, old, new)), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and field in err and "Traceback" not in err


def test_unknown_key_gets_a_suggestion(tmp_path, capsys):
    assert main(["study", str(edited(tmp_path, "nu = 0.5", "nuu = 0.5")), "--quiet"]) == 2
    assert "did you mean 'nu'" in capsys.readouterr().err


def test_a_mesh_without_an_interface_is_refused(tmp_path, capsys):
    import ngsolve as ngs
    mesh_file = tmp_path / "square.vol"
    ngs.unit_square.GenerateMesh(maxh=0.5).Save(str(mesh_file))
    text = EXAMPLE.read_text().replace('kind = "fluid_over_solid"\ndim = 2\nmaxh = 0.15',
                                        f'kind = "mesh"\ndim = 2\npath = "{mesh_file}"')
    case = tmp_path / "case.toml"
    case.write_text(text)
    assert main(["study", str(case), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "fluid" in err and "\n" not in err.strip()


def test_missing_case_file(capsys):
    assert main(["study", "no-such-case.toml"]) == 2
    assert "no-such-case.toml" in capsys.readouterr().err
