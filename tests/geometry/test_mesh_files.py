"""Mesh files written by meshio (gmsh 2.2 and 4.1, ASCII and binary) and CAD files (kind 'cad'):
round trips, studies equal to netgen's own format, the STEP example, and one-line errors."""
import importlib.util
import json
import math
import shutil
from pathlib import Path

import meshio
import ngsolve as ngs
import numpy as np
import pytest
from support.meshes import FORMATS, ball, curved_ball, mid_edge_nodes, second_order, write

from fsivsp.app.cli import main
from fsivsp.geometry import (
    FLUID,
    INTERFACE,
    SOLID,
    SOLID_WALL,
    GeometryError,
    build_geometry,
    interface_normal,
    load_mesh,
    refined,
)
from fsivsp.geometry.curved import curve, quadratic_cells
from fsivsp.geometry.export import to_meshio

EXAMPLES = Path(__file__).parents[2] / "examples"
STEP = EXAMPLES / "cylinder_in_box.step"
DATA = Path(__file__).parents[1] / "data"
STUDIES = {2: ("fluid_over_solid_2d.toml", 'kind = "fluid_over_solid"\ndim = 2\nmaxh = 0.15'),
           3: ("fluid_in_solid_3d.toml", 'kind = "fluid_in_solid"\ndim = 3\nmaxh = 0.4\ncurvature_safety = 1.0')}






def measures(mesh: ngs.Mesh, order: int = 0) -> list[float]:
    """|Ω_F|, |Ω_S|, |Γ| and the flux of x - centre through the outer wall (> 0: outward normals), integrated
    with NGSolve's rules of at least ``order``."""
    centre = ngs.CF((ngs.x - 0.5, ngs.y - 0.5) + ((ngs.z - 0.5,) if mesh.dim == 3 else ()))
    return [ngs.Integrate(1, mesh, definedon=mesh.Materials(FLUID), order=order),
            ngs.Integrate(1, mesh, definedon=mesh.Materials(SOLID), order=order),
            ngs.Integrate(1, mesh, ngs.BND, definedon=mesh.Boundaries(INTERFACE), order=order),
            ngs.Integrate(ngs.specialcf.normal(mesh.dim) * centre, mesh, ngs.BND,
                          definedon=mesh.Boundaries(SOLID_WALL), order=order)]


# --------------------------------------------------------------------------------------------
# gmsh files
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("form", FORMATS)
@pytest.mark.parametrize("dim", [2, 3])
def test_gmsh_formats_round_trip(tmp_path, dim, form):
    mesh = ball(dim)
    loaded = load_mesh(write(to_meshio(mesh), tmp_path / "ball.msh", form))
    assert (loaded.dim, loaded.nv, loaded.ne) == (dim, mesh.nv, mesh.ne)
    assert set(loaded.GetMaterials()) == {FLUID, SOLID}
    assert set(loaded.GetBoundaries()) == {INTERFACE, SOLID_WALL}
    assert measures(loaded) == pytest.approx(measures(mesh), rel=1e-12)
    assert measures(loaded)[3] == pytest.approx(dim)  # outward: ∫ n·(x - c) = d |box|
    outward = ngs.Integrate(interface_normal(loaded) * ngs.CF((ngs.x - 0.5, ngs.y - 0.5, ngs.z - 0.5)[:dim]),
                            loaded, ngs.BND, definedon=loaded.Boundaries(INTERFACE))
    assert outward > 0
    assert refined(loaded, 1).ne == 2**dim * mesh.ne










@pytest.mark.parametrize("dim", [2, 3])
def test_straight_second_order_cells_keep_their_corners(tmp_path, dim):
    """triangle6/tetra10 (and line3/triangle6 facets) with every mid-edge node at its edge's midpoint: the
    straight mesh on the corners, without quadratic cells."""
    loaded = load_mesh(write(second_order(to_meshio(ball(dim))), tmp_path / "quadratic.msh", "22-ascii"))
    assert (loaded.nv, loaded.ne) == (ball(dim).nv, ball(dim).ne)
    assert quadratic_cells(loaded) is None
    assert measures(loaded) == pytest.approx(measures(ball(dim)), rel=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_second_order_cells_curve_the_mesh(tmp_path, dim):
    """Mid-edge nodes on netgen's order-2 curved cells: `curve` to order 2 gives netgen's curved mesh (volumes,
    interface, normals) to round-off, and so does its uniform refinement (whose cells are the same quadratic
    map; volumes by rules of order 6, exact for the cubic det ∇x, surfaces by order 12, for their
    non-polynomial length element); order 1 leaves it straight."""
    netgen = curved_ball(dim)
    path = write(second_order(to_meshio(netgen), mid_edge_nodes(netgen)), tmp_path / "curved.msh", "41-binary")
    expected = measures(netgen)
    assert expected != pytest.approx(measures(ball(dim)), rel=1e-4)  # the curvature is visible
    loaded = load_mesh(path)
    curve(loaded, 1)
    assert measures(loaded) == pytest.approx(measures(ball(dim)), rel=1e-12)
    curve(loaded := load_mesh(path), 2)
    assert measures(loaded) == pytest.approx(expected, rel=1e-12)
    curve(fine := refined(load_mesh(path), 1), 2)
    for order, parts in ((6, slice(0, 2)), (12, slice(2, 4))):
        assert measures(fine, order)[parts] == pytest.approx(measures(netgen, order)[parts], rel=1e-10)


def test_second_order_cells_must_agree(tmp_path):
    """Two cells along one edge with different mid-edge nodes: one line naming the edge."""
    first = to_meshio(ball(2))
    nodes = {edge: point + 0.01 for edge, point in mid_edge_nodes(ball(2)).items()}
    quadratic = second_order(first, nodes)
    quadratic.points[quadratic.cells[0].data[0, 3]] += 0.02  # one fluid triangle's node only
    with pytest.raises(GeometryError,
                       match=r"mesh file .*: the cells along the edge at \(.*\) have different mid-edge nodes"):
        load_mesh(write(quadratic, tmp_path / "apart.msh", "41-ascii"))


def study_errors(tmp_path, dim, geometry: str, name: str) -> list[dict]:
    example, old = STUDIES[dim]
    text = (EXAMPLES / example).read_text()
    assert old in text
    if "curved" not in text:  # straight cells: the netgen file's geometry is not used either
        text = text.replace("[discretisation]", "[discretisation]\ncurved = false")
    case = tmp_path / f"{name}.toml"
    case.write_text(text.replace(old, geometry))
    out = tmp_path / f"{name}.json"
    assert main(["study", str(case), "--levels", "0-1" if dim == 2 else "0", "--json", str(out), "--quiet"]) == 0
    return [record["errors"] for record in json.loads(out.read_text())]


@pytest.mark.parametrize("dim", [2, 3])
def test_study_on_gmsh_equals_netgen_format(tmp_path, dim):
    """`fsivsp study` on the gmsh 4.1 binary file gives the errors of the same mesh saved by netgen."""
    mesh = ball(dim) if dim == 3 else build_geometry("fluid_over_solid", 2, 0.15)
    netgen_file, gmsh_file = tmp_path / "mesh.vol", tmp_path / "mesh.msh"
    mesh.ngmesh.Save(str(netgen_file))
    write(to_meshio(mesh), gmsh_file, "41-binary")
    own = study_errors(tmp_path, dim, f'kind = "mesh"\ndim = {dim}\npath = "{netgen_file}"', "netgen")
    gmsh = study_errors(tmp_path, dim, f'kind = "mesh"\ndim = {dim}\npath = "{gmsh_file}"', "gmsh")
    assert len(own) == (2 if dim == 2 else 1)
    for a, b in zip(own, gmsh):
        assert b == pytest.approx(a, rel=1e-10, abs=1e-14)


@pytest.mark.parametrize("dim", [2, 3])
def test_study_on_second_order_gmsh_equals_curved_netgen(tmp_path, dim):
    """Taylor–Hood k = 1 on curved cells: `fsivsp study` on a gmsh 4.1 file of tetra10/triangle6 cells gives the
    errors of the netgen mesh curved to order 2 (the same cells), on the coarse level."""
    netgen_file, gmsh_file = tmp_path / "mesh.vol", tmp_path / "mesh.msh"
    ball(dim).ngmesh.Save(str(netgen_file))
    write(second_order(to_meshio(ball(dim)), mid_edge_nodes(curved_ball(dim))), gmsh_file, "41-binary")
    example = (EXAMPLES / f"fluid_in_solid_{dim}d.toml").read_text()
    example = example.replace('family = "mini"', 'family = "taylor_hood"').replace("curved = false", "curved = true")
    errors = []
    for path in (netgen_file, gmsh_file):
        case, out = tmp_path / f"{path.suffix[1:]}.toml", tmp_path / f"{path.suffix[1:]}.json"
        case.write_text(example.replace(STUDIES[3][1] if dim == 3 else 'kind = "fluid_in_solid"\ndim = 2\nmaxh = 0.15',
                                        f'kind = "mesh"\ndim = {dim}\npath = "{path}"'))
        assert 'family = "taylor_hood"' in case.read_text() and "path" in case.read_text()
        assert main(["study", str(case), "--levels", "0", "--json", str(out), "--quiet"]) == 0
        errors.append(json.loads(out.read_text())[0]["errors"])
    assert errors[1] == pytest.approx(errors[0], rel=1e-10, abs=1e-14)


def test_run_on_a_gmsh_file(tmp_path):
    """`fsivsp run` end to end on a gmsh 4.1 file (2D): the run's case with `kind = "mesh"`."""
    mesh_file = write(to_meshio(build_geometry("fluid_over_solid", 2, 0.15)), tmp_path / "layers.msh", "41-ascii")
    run_on(tmp_path, mesh_file)


def test_run_on_a_second_order_gmsh_file(tmp_path):
    """`fsivsp run` with Taylor–Hood on triangle6 cells: the VTK output shows the curved interface (its
    subdivided cells have points off the straight chords, on the circle to the quadratic cells' accuracy)."""
    mesh_file = write(second_order(to_meshio(ball(2)), mid_edge_nodes(curved_ball(2))), tmp_path / "disk.msh")
    out = run_on(tmp_path, mesh_file, '[discretisation]\nfamily = "taylor_hood"\n\n[output]\nsubdivision = 2')
    radii = np.linalg.norm(meshio.read(sorted((out / "vtk").glob("fields_*.vtu"))[-1]).points[:, :2] - 0.5, axis=1)
    near = radii[np.abs(radii - 0.25) < 0.02]
    chords = sum(el.mat == INTERFACE for el in ball(2).Elements(ngs.BND))
    assert np.abs(near - 0.25).max() < 1e-3 < 0.25 * (1 - math.cos(math.pi / chords))  # measured 1.6e-4; chords: 1.2e-2


def run_on(tmp_path: Path, mesh_file: Path, extra: str = "") -> Path:
    """`fsivsp run` of a short forced case on ``mesh_file``; its output folder."""
    case = tmp_path / "case.toml"
    case.write_text(f"""
[geometry]
kind = "mesh"
dim = 2
path = "{mesh_file}"

[materials]
rho_fluid = 1.0
rho_solid = 2.0
nu = 0.5
lam = 1.5
mu = 0.75

[time]
T = 0.03
dt = 0.01

[data]
force_fluid = ["1", "0"]

{extra or "[output]"}
probes = [[0.5, 0.75]]
""")
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["step"] == 3 and summary["l2_norms"]["velocity"] > 0
    assert len(list((out / "vtk").glob("fields_*.vtu"))) >= 2
    return out


def test_study_on_step_equals_netgen_format(tmp_path):
    """`fsivsp study` on the STEP example gives the errors of the same mesh saved by netgen."""
    netgen_file = tmp_path / "cad.vol"
    build_geometry("cad", 3, 0.4, path=str(STEP)).ngmesh.Save(str(netgen_file))
    own = study_errors(tmp_path, 3, f'kind = "mesh"\ndim = 3\npath = "{netgen_file}"', "netgen")
    cad = study_errors(tmp_path, 3, f'kind = "cad"\ndim = 3\nmaxh = 0.4\npath = "{STEP}"', "cad")
    assert len(own) == len(cad) == 1
    assert cad[0] == pytest.approx(own[0], rel=1e-10, abs=1e-14)


@pytest.mark.parametrize("suffix", [".iges", ".igs"])
def test_study_on_iges_equals_step(tmp_path, suffix):
    """`fsivsp study` on an IGES file of solids (BRep mode; made with OCP, which the venv lacks, so it is checked
    in), its solids mapped by number, gives the errors of the same boxes written as STEP by netgen.occ."""
    iges = tmp_path / f"boxes{suffix}"
    shutil.copy(DATA / "two_boxes_solids.iges", iges)
    step = two_boxes(tmp_path / "boxes.step")
    regions = '\nregions = { "1" = "fluid", "2" = "solid" }'
    cad = study_errors(tmp_path, 3, f'kind = "cad"\ndim = 3\nmaxh = 0.4\npath = "{iges}"{regions}', "iges")
    own = study_errors(tmp_path, 3, f'kind = "cad"\ndim = 3\nmaxh = 0.4\npath = "{step}"', "step")
    assert cad[0] == pytest.approx(own[0], rel=1e-10, abs=1e-14)


# --------------------------------------------------------------------------------------------
# CAD files
# --------------------------------------------------------------------------------------------

def test_step_example_meshes_and_curves():
    mesh = build_geometry("cad", 3, 0.4, path=str(STEP))
    assert set(mesh.GetMaterials()) == {FLUID, SOLID}
    assert set(mesh.GetBoundaries()) == {INTERFACE, SOLID_WALL, "load"}  # "load": named in the file
    assert 100 < mesh.nv < 600 < build_geometry("cad", 3, None, path=STEP).nv  # default maxh: 0.1
    cylinder = math.pi * 0.25**2 * 0.5
    straight = ngs.Integrate(1, mesh, definedon=mesh.Materials(FLUID))
    try:
        mesh.Curve(3)
        curved = ngs.Integrate(1, mesh, definedon=mesh.Materials(FLUID))
    finally:
        mesh.Curve(1)
    assert abs(curved - cylinder) < abs(straight - cylinder) / 10
    fine = refined(mesh, 1, project=True)
    points = np.array([fine.vertices[v.nr].point for el in fine.Elements(ngs.BND) if el.mat == INTERFACE
                       for v in el.vertices])
    mantle = (points[:, 2] > 0.25 + 1e-9) & (points[:, 2] < 0.75 - 1e-9)
    assert mantle.sum() > 20
    assert np.hypot(points[mantle, 0] - 0.5, points[mantle, 1] - 0.5) == pytest.approx(0.25, abs=1e-12)
    n = interface_normal(mesh)
    assert ngs.Integrate(n * ngs.CF((ngs.x - 0.5, ngs.y - 0.5, ngs.z - 0.5)), mesh, ngs.BND,
                         definedon=mesh.Boundaries(INTERFACE)) > 0


def test_step_example_is_what_the_script_writes(tmp_path):
    spec = importlib.util.spec_from_file_location("make_cad_example", EXAMPLES / "make_cad_example.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.cylinder_in_box().WriteStep(str(tmp_path / "again.step"))
    shipped = build_geometry("cad", 3, 0.4, path=STEP)
    again = build_geometry("cad", 3, 0.4, path=tmp_path / "again.step")
    assert (again.nv, again.ne) == (shipped.nv, shipped.ne)


def test_regions_table_maps_solids(tmp_path):
    from netgen.occ import Box, Glue, Pnt

    Glue([Box(Pnt(0, 0, 0), Pnt(1, 1, 1)), Box(Pnt(1, 0, 0), Pnt(2, 1, 1))]).WriteStep(str(tmp_path / "two.step"))
    mesh = build_geometry("cad", 3, 0.5, path=tmp_path / "two.step", regions={"1": "fluid", 2: "solid"})
    assert set(mesh.GetBoundaries()) == {INTERFACE, "fluid_wall", SOLID_WALL}
    assert ngs.Integrate(1, mesh, ngs.BND, definedon=mesh.Boundaries(INTERFACE)) == pytest.approx(1.0)
    named = build_geometry("cad", 3, 0.4, path=STEP)
    swapped = build_geometry("cad", 3, 0.4, path=STEP, regions={"fluid": "solid", "solid": "fluid"})
    assert ngs.Integrate(1, swapped, definedon=swapped.Materials(SOLID)) == pytest.approx(
        ngs.Integrate(1, named, definedon=named.Materials(FLUID)), rel=1e-12)
    assert "fluid_wall" in swapped.GetBoundaries()


def disk_in_square(path: Path, named: bool = True) -> Path:
    """A plane STEP file: a fluid disk of radius 0.25 in the solid unit square, its top edge ``load``."""
    from netgen.occ import Circle, Glue, Rectangle, Y

    square, disk = Rectangle(1, 1).Face(), Circle((0.5, 0.5), 0.25).Face()
    square.edges.Max(Y).name = "load"
    solid = square - disk
    if named:
        solid.name, disk.name = SOLID, FLUID
    Glue([solid, disk]).WriteStep(str(path))
    return path


def test_plane_step_file_is_2d(tmp_path):
    mesh = build_geometry("cad", 2, 0.2, path=disk_in_square(tmp_path / "disk.step"))
    assert mesh.dim == 2 and set(mesh.GetMaterials()) == {FLUID, SOLID}
    assert set(mesh.GetBoundaries()) == {INTERFACE, SOLID_WALL, "load"}
    fine = refined(mesh, 1, project=True)
    points = np.array([fine.vertices[v.nr].point for el in fine.Elements(ngs.BND) if el.mat == INTERFACE
                       for v in el.vertices])
    assert np.hypot(points[:, 0] - 0.5, points[:, 1] - 0.5) == pytest.approx(0.25, abs=1e-12)
    unnamed = disk_in_square(tmp_path / "unnamed.step", named=False)
    mapped = build_geometry("cad", 2, 0.2, path=unnamed, regions={"1": "solid", "2": "fluid"})
    assert mapped.nv == mesh.nv and set(mapped.GetBoundaries()) == set(mesh.GetBoundaries())
    with pytest.raises(GeometryError, match=r"^CAD file .*disk.step: no solids \(plane faces: use dim = 2\)$"):
        build_geometry("cad", 3, 0.2, path=tmp_path / "disk.step")


def test_run_on_the_step_example(tmp_path):
    case = tmp_path / "cad.toml"
    case.write_text((EXAMPLES / "cad_3d.toml").read_text()
                    .replace('path = "cylinder_in_box.step"', f'path = "{STEP}"').replace("T = 0.05", "T = 0.03"))
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["step"] == 3
    assert 0 < summary["l2_norms"]["velocity"] < 1 and summary["l2_norms"]["pressure"] > 0


# --------------------------------------------------------------------------------------------
# bad input: exit code 2 and one line through the CLI
# --------------------------------------------------------------------------------------------

def separated(mesh: meshio.Mesh) -> meshio.Mesh:
    """The fluid with its own copies of the interface nodes (meshed apart from the solid)."""
    fluid_tag = mesh.field_data[FLUID][0]
    block = next(i for i, b in enumerate(mesh.cells)
                 if b.type == "triangle" and mesh.cell_data["gmsh:physical"][i][0] == fluid_tag)
    copies = np.arange(len(mesh.points), 2 * len(mesh.points))
    cells = [(b.type, copies[b.data] if i == block else b.data) for i, b in enumerate(mesh.cells)]
    return meshio.Mesh(np.vstack([mesh.points, mesh.points]), cells, cell_data=mesh.cell_data,
                       field_data=mesh.field_data)


def relabelled(mesh: meshio.Mesh, old: str, new: str) -> meshio.Mesh:
    """Some of the facets of boundary ``old`` moved to the boundary ``new``."""
    tag = mesh.field_data[old][0]
    d = mesh.field_data[old][1]
    tags = [t.copy() for t in mesh.cell_data["gmsh:physical"]]
    block = next(i for i, b in enumerate(mesh.cells) if b.dim == d and tags[i][0] == tag)
    tags[block][::2] = mesh.field_data[new][0]
    return meshio.Mesh(mesh.points, mesh.cells, cell_data={"gmsh:physical": tags}, field_data=mesh.field_data)


def without_block(mesh: meshio.Mesh, name: str) -> meshio.Mesh:
    tag, d = mesh.field_data[name]
    keep = [i for i, b in enumerate(mesh.cells) if not (b.dim == d and mesh.cell_data["gmsh:physical"][i][0] == tag)]
    return meshio.Mesh(mesh.points, [mesh.cells[i] for i in keep],
                       cell_data={"gmsh:physical": [mesh.cell_data["gmsh:physical"][i] for i in keep]},
                       field_data=mesh.field_data)


def msh_text(form: str, edit) -> callable:
    """A fault: the 2D ball written in ``form`` and edited as text."""
    def make(path: Path) -> Path:
        write(to_meshio(ball(2)), path, form)
        path.write_bytes(edit(path.read_bytes()))
        return path
    return make


def msh_mesh(edit) -> callable:
    """A fault: the 2D ball as meshio data, edited, written as gmsh 2.2."""
    return lambda path: write(edit(to_meshio(ball(2))), path, "22-ascii")


MESH_FAULTS = {
    "no-physical-names": (msh_text("41-ascii",
                                   lambda b: b.split(b"$PhysicalNames")[0] + b.split(b"$EndPhysicalNames\n")[1]),
                          "no physical names"),
    "unknown-volume": (msh_text("22-ascii", lambda b: b.replace(b'"fluid"', b'"water"')),
                       "volume region 'water' is neither 'fluid' nor 'solid'"),
    "no-interface": (msh_text("41-ascii", lambda b: b.replace(b'"interface"', b'"membrane"')),
                     "no boundary region named 'interface' (found ['membrane', 'solid_wall'])"),
    "unnamed-interface": (msh_mesh(lambda m: without_block(m, INTERFACE)),
                          "facets between fluid and solid cells are not in the physical group 'interface'"),
    "truncated-ascii": (msh_text("41-ascii", lambda b: b[: len(b) // 2]), "cannot read as a gmsh mesh"),
    "truncated-binary": (msh_text("41-binary", lambda b: b[: len(b) * 3 // 4]), "cannot read as a gmsh mesh"),
    "empty": (msh_text("41-ascii", lambda b: b""), "cannot read as a gmsh mesh"),
    "separate-meshes": (msh_mesh(separated), "coincident vertices"),
    "one-sided-interface": (msh_mesh(lambda m: relabelled(m, SOLID_WALL, INTERFACE)),
                            "a facet of 'interface' at"),
    "unnamed-walls": (msh_mesh(lambda m: without_block(m, SOLID_WALL)), "outer facets are in no physical group"),
}


def study_case(tmp_path, geometry: str) -> Path:
    example, old = STUDIES[2]
    case = tmp_path / "case.toml"
    case.write_text((EXAMPLES / example).read_text().replace(old, geometry))
    return case


def refused(case: Path, capsys) -> str:
    capsys.readouterr()  # meshio's warnings while the test wrote the file
    assert main(["study", str(case), "--quiet"]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err and "\n" not in err and "Traceback" not in err and not captured.out
    return err


@pytest.mark.parametrize("name", MESH_FAULTS)
def test_bad_mesh_files(tmp_path, capsys, name):
    make, expected = MESH_FAULTS[name]
    path = make(tmp_path / "bad.msh")
    err = refused(study_case(tmp_path, f'kind = "mesh"\ndim = 2\npath = "{path}"'), capsys)
    assert err.startswith(f"error: mesh file {path}: ") and expected in err


def garbage(path: Path) -> Path:
    path.write_text("ISO-10303-21;\nHEADER;\n")
    return path


def two_boxes(path: Path, gap: float = 0.0, named: bool = True, outer: str | None = None) -> Path:
    """A fluid box next to a solid one (``gap`` apart), ``outer`` the name of the fluid's far face."""
    from netgen.occ import Box, Glue, Pnt, X

    fluid, solid = Box(Pnt(0, 0, 0), Pnt(1, 1, 1)), Box(Pnt(1 + gap, 0, 0), Pnt(2 + gap, 1, 1))
    if named:
        fluid.name, solid.name = FLUID, SOLID
    if outer:
        fluid.faces.Min(X).name = outer
    Glue([fluid, solid]).WriteStep(str(path))
    return path


CAD_FAULTS = {
    "missing": (lambda p: p, "", "error: CAD file {path}: no such file"),
    "garbage": (garbage, "", "error: CAD file {path}: cannot read"),
    "apart": (lambda p: two_boxes(p, gap=0.5), "", "no face is shared by the fluid and the solid"),
    "unnamed": (lambda p: two_boxes(p, named=False), "", "error: geometry.regions: solid 1 of {path} is neither"),
    "outer-interface": (lambda p: two_boxes(p, outer=INTERFACE), "",
                        "error: CAD file {path}: a boundary named 'interface' is not shared by the fluid and the solid "
                        "(it borders fluid only)"),
    "unknown-key": (two_boxes, 'regions = { "3" = "fluid" }',
                    "error: geometry.regions.3: no solid of that name or number"),
    "bad-value": (two_boxes, 'regions = { "1" = "water" }',
                  "error: geometry.regions.1: expected 'fluid' or 'solid', got 'water'"),
    "one-medium": (two_boxes, 'regions = { "2" = "fluid" }', "error: geometry.regions: no solid of {path} is 'solid'"),
    "not-a-table": (two_boxes, 'regions = ["1"]', "error: geometry.regions: expected a table"),
    "dim": (two_boxes, "", "error: CAD file {path}: has solids: use dim = 3"),
    "extension": (lambda p: p.with_suffix(".stl"), "", "error: CAD file {path}: unknown extension '.stl'"),
    "iges-faces": (lambda p: Path(shutil.copy(DATA / "two_boxes_faces.iges", p.with_suffix(".iges"))), "",
                   "error: CAD file {path}: no solids, only 12 faces (IGES in face mode?): export the solids"),
}


@pytest.mark.parametrize("name", CAD_FAULTS)
def test_bad_cad_files(tmp_path, capsys, name):
    make, extra, expected = CAD_FAULTS[name]
    path = make(tmp_path / "part.step")
    dim = 2 if name == "dim" else 3
    case = study_case(tmp_path, f'kind = "cad"\ndim = {dim}\npath = "{path}"\n{extra}')
    if dim == 3:  # a 3D exact solution for the 3D geometry
        text = (case.read_text().split("[exact]")[0] + "[exact]"
                + (EXAMPLES / STUDIES[3][0]).read_text().split("[exact]")[1])
        case.write_text(text)
    err = refused(case, capsys)
    assert expected.format(path=path) in err
