"""VTK series and ParaView collection, probes, plots and summary of fsivsp.output."""
import csv
import json
import math
import xml.etree.ElementTree as ET

import ngsolve as ngs
import numpy as np
import pytest

import fsivsp
from fsivsp.io import Probes, VTKSeries, energy_plot, probe_plot, scheme_fields, write_summary
from fsivsp.model.expressions import parse_vector

meshio = pytest.importorskip("meshio")

FIELDS = {"velocity", "pressure", "stress", "von_mises", "displacement", "region"}


@pytest.fixture(scope="module")
def mesh():
    return fsivsp.refined(fsivsp.paper_channel(), 0)


def make_scheme(mesh, dt=1e-2):
    spaces = fsivsp.build_spaces(mesh, "mini", dirichlet="solid_wall")
    bump = fsivsp.Field(parse_vector(["sin(pi*x/2.5)*sin(pi*y/0.41)", "0"], "velocity0", 2))
    data = fsivsp.Data(velocity0=bump, displacement0=bump)
    return fsivsp.Scheme(spaces, fsivsp.Materials(lam=2.0, mu=0.5), data, dt=dt)


@pytest.fixture
def scheme(mesh):
    return make_scheme(mesh)


def pvd_entries(path):
    root = ET.parse(path).getroot()
    return [(float(ds.get("timestep")), ds.get("file")) for ds in root.iter("DataSet")]


def hidden(directory):
    return sorted(p.name for p in directory.iterdir() if p.name.startswith("."))


def test_vtk_series_fields_points_and_collection(tmp_path, scheme, mesh):
    fields, stress = scheme_fields(scheme)
    series = VTKSeries(tmp_path, mesh, fields, refresh=stress)
    times = []
    for _ in range(3):
        scheme.step()
        series.write(scheme.time, scheme.n)
        times.append(scheme.time)

    assert pvd_entries(tmp_path / "fields.pvd") == [(t, f"fields_{n:06d}.vtu") for n, t in enumerate(times, 1)]
    assert series.entries == pvd_entries(tmp_path / "fields.pvd")
    assert hidden(tmp_path) == []

    points = mesh.ne * (mesh.dim + 1)  # VTKOutput writes every cell's own vertices
    for step in (1, 2, 3):
        data = meshio.read(tmp_path / f"fields_{step:06d}.vtu")
        assert data.points.shape == (points, 3)
        assert set(data.point_data) == FIELDS
        shapes = {name: values.reshape(points, -1).shape[1] for name, values in data.point_data.items()}
        assert shapes == {"velocity": 2, "pressure": 1, "stress": 6, "von_mises": 1, "displacement": 2, "region": 1}

    # the last file holds the current state: velocity at the written points, von Mises from σ
    located = mesh(data.points[:, 0], data.points[:, 1])
    assert np.allclose(data.point_data["velocity"], scheme.velocity(located), atol=1e-12)
    # ParaView's symmetric tensor: XX YY ZZ XY YZ XZ, the z components zero in 2D
    xx, yy, zz0, xy, yz, xz = data.point_data["stress"].reshape(-1, 6).T
    assert np.abs(zz0).max() == 0 and np.abs(yz).max() == 0 and np.abs(xz).max() == 0
    s = np.stack([np.stack([xx, xy], -1), np.stack([xy, yy], -1)], -2)
    lam, mu = scheme.materials.lam, scheme.materials.mu
    zz = lam / (2 * (lam + mu)) * (s[:, 0, 0] + s[:, 1, 1])
    full = np.zeros((len(s), 3, 3))
    full[:, :2, :2], full[:, 2, 2] = s, zz
    dev = full - np.trace(full, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)
    expected = np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))
    assert np.abs(s).max() > 0
    assert np.allclose(data.point_data["von_mises"].ravel(), expected, atol=1e-10)
    # the region array (fluid 0, solid 1) per cell, and the displacement only in the solid
    region = data.cell_data["region"][0].ravel()
    assert set(np.unique(region)) == {0, 1}
    fluid_points = np.flatnonzero(data.point_data["region"].ravel() == 0)
    assert np.abs(data.point_data["displacement"][fluid_points]).max() == 0
    assert np.abs(data.point_data["displacement"]).max() > 0


def test_continuous_output_shares_vertices(tmp_path, scheme, mesh):
    """``continuous=True``: one point per vertex."""
    fields, stress = scheme_fields(scheme)
    series = VTKSeries(tmp_path, mesh, fields, refresh=stress, continuous=True)
    scheme.step()
    series.write(scheme.time, scheme.n)
    data = meshio.read(tmp_path / "fields_000001.vtu")
    assert data.points.shape == (mesh.nv, 3)
    assert set(data.point_data) == FIELDS


def test_files_follow_the_umask(tmp_path, scheme, mesh):
    """The PVD and the VTU pieces get the umask's modes (0644 under 022), not mkstemp's 0600."""
    import os
    old = os.umask(0o022)
    try:
        series = VTKSeries(tmp_path, mesh, {"velocity": scheme.velocity})
        scheme.step()
        series.write(scheme.time, scheme.n)
    finally:
        os.umask(old)
    for name in ("fields.pvd", "fields_000001.vtu"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o644, name


def test_vtk_series_restore_continues_and_truncates(tmp_path, scheme, mesh):
    fields = {"velocity": scheme.velocity}
    first = VTKSeries(tmp_path, mesh, fields, name="run")
    for _ in range(3):
        scheme.step()
        first.write(scheme.time, scheme.n)
    saved = json.loads(json.dumps(first.entries))  # as a checkpoint would store them

    resumed = VTKSeries(tmp_path, mesh, fields, name="run")
    resumed.restore(saved[:2])  # checkpoint taken at step 2
    resumed.write(0.02, 2)  # rewriting a listed step replaces it
    resumed.write(0.03, 3)
    resumed.write(0.04, 4)
    assert [name for _, name in pvd_entries(tmp_path / "run.pvd")] == [f"run_{n:06d}.vtu" for n in (1, 2, 3, 4)]
    assert pvd_entries(tmp_path / "run.pvd")[-1][0] == 0.04


def test_failed_vtk_write_keeps_previous_files(tmp_path, scheme, mesh, monkeypatch):
    series = VTKSeries(tmp_path, mesh, {"velocity": scheme.velocity})
    for _ in range(2):
        scheme.step()
        series.write(scheme.time, scheme.n)
    pvd = (tmp_path / "fields.pvd").read_bytes()
    good = (tmp_path / "fields_000002.vtu").read_bytes()

    class Crashing:
        def __init__(self, mesh, coefs, names, filename, **kwargs):
            self.filename = filename

        def Do(self, **kwargs):
            with open(self.filename + ".vtu", "w") as handle:
                handle.write("<?xml version=\"1.0\"?>\n<VTKFile")  # half a file
            raise RuntimeError("disk full")

    monkeypatch.setattr(ngs, "VTKOutput", Crashing)
    scheme.step()
    with pytest.raises(RuntimeError, match="disk full"):
        series.write(scheme.time, scheme.n)
    with pytest.raises(RuntimeError, match="disk full"):
        series.write(0.02, 2)  # an existing step is not clobbered either

    assert (tmp_path / "fields.pvd").read_bytes() == pvd
    assert (tmp_path / "fields_000002.vtu").read_bytes() == good
    assert not (tmp_path / "fields_000003.vtu").exists()
    assert hidden(tmp_path) == []
    assert len(series.entries) == 2


def read_csv(path):
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return rows[0], rows[1:]


def test_probes_csv(tmp_path, scheme, mesh):
    probes = Probes(mesh, points=[(0.2, 0.2), (1.0, 0.2)], lines=[((0.1, 0.2), (0.3, 0.2), 5)])
    probes.record(scheme)
    for _ in range(2):
        scheme.step()
        probes.record(scheme)
    probes.write_csv(tmp_path)

    head, rows = read_csv(tmp_path / "probes.csv")
    assert head == ["step", "time", "p0_v1", "p0_v2", "p0_p", "p1_v1", "p1_v2", "p1_p"]
    assert [int(r[0]) for r in rows] == [0, 1, 2]
    last = [float(c) for c in rows[-1]]
    assert last[1] == scheme.time
    close = lambda a, b: np.allclose(a, b, rtol=1e-13, atol=1e-15)  # SIMD vs scalar evaluation
    assert close(last[2:4], scheme.velocity(mesh(0.2, 0.2)))
    assert close(last[4], scheme.pressure(mesh(0.2, 0.2))) and math.isfinite(last[4])  # the fluid disk
    assert close(last[5:7], scheme.velocity(mesh(1.0, 0.2)))
    assert math.isnan(last[7])  # in the solid

    head, rows = read_csv(tmp_path / "lines.csv")
    assert head == ["step", "time", "line", "s", "x", "y", "v1", "v2", "p"]
    assert len(rows) == 3 * 5
    final = [[float(c) for c in r] for r in rows[-5:]]
    assert np.allclose([r[3] for r in final], np.linspace(0, 0.2, 5))
    assert np.allclose([r[4] for r in final], np.linspace(0.1, 0.3, 5))
    assert close(final[2][6:8], scheme.velocity(mesh(0.2, 0.2)))
    assert math.isnan(final[0][8]) and math.isfinite(final[2][8])  # x = 0.1 is outside the disk
    assert hidden(tmp_path) == []

    # a checkpoint's JSON round trip continues the same history
    state = json.loads(json.dumps(probes.state(), allow_nan=False))
    again = Probes(mesh, points=[(0.2, 0.2), (1.0, 0.2)], lines=[((0.1, 0.2), (0.3, 0.2), 5)])
    again.restore(state)
    copy = tmp_path / "copy"
    again.write_csv(copy)
    for name in ("probes.csv", "lines.csv"):
        assert (copy / name).read_text() == (tmp_path / name).read_text()


def test_probe_on_the_interface_reads_the_fluid_pressure():
    """A probe on Γ (here a vertex of the flat interface and a point of an edge) is evaluated in a fluid cell: its
    pressure is the fluid's there (NGSolve's point search puts a point less than about 1e-8 above Γ in the solid cell
    below, where the pressure is NaN), and velocity and pressure those of points just inside the fluid."""
    mesh = fsivsp.geometry.fluid_over_solid(2, 0.25)
    spaces = fsivsp.build_spaces(mesh, "taylor_hood", 2)
    state = ngs.GridFunction(spaces.mixed)
    velocity, pressure = state.components
    velocity.Set(ngs.CF((ngs.x * ngs.y, ngs.y)))
    pressure.Set(1 + ngs.x + ngs.y**2)
    on = [(0.5, 0.5), (0.3, 0.5)]
    found = Probes(mesh, points=on).sample(velocity, pressure)
    above = Probes(mesh, points=[(x, y + 1e-4) for x, y in on]).sample(velocity, pressure)
    assert np.allclose(found[1], [1.75, 1.55], atol=1e-5) and np.allclose(found[1], above[1], atol=2e-4)
    assert np.allclose(found[0], [[0.25, 0.5], [0.15, 0.5]], atol=1e-5)


def test_probe_outside_mesh(mesh):
    box = r"; expected a point in its bounding box \[0, 2\.5\] × \[0, 0\.41\]$"
    with pytest.raises(ValueError, match=r"^probe 1 at \(3, 0\.2\) is outside the mesh" + box):
        Probes(mesh, points=[(0.2, 0.2), (3.0, 0.2)])
    with pytest.raises(ValueError, match=r"^line 0 point 3 at \(2\.75, 0\.2\) is outside the mesh" + box):
        Probes(mesh, lines=[((2.0, 0.2), (3.0, 0.2), 5)])
    with pytest.raises(ValueError, match="probe 0: expected 2 finite coordinates"):
        Probes(mesh, points=[(0.2, 0.2, 0.0)])


def test_plots_and_summary(tmp_path, scheme, mesh):
    probes = Probes(mesh, points=[(0.2, 0.2), (1.0, 0.2)])
    times, energies = [], []
    for _ in range(3):
        scheme.step()
        probes.record(scheme)
        times.append(scheme.time)
        energies.append(scheme.energy())
    energy_plot(times, energies, tmp_path / "energy.png")
    probe_plot(probes, tmp_path / "probes.png")
    for name in ("energy.png", "probes.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    write_summary(tmp_path / "summary.json", {"steps": 3, "energy": energies})
    assert json.loads((tmp_path / "summary.json").read_text()) == {"steps": 3, "energy": energies}
    assert hidden(tmp_path) == []
