"""Mesh files: gmsh ``.msh`` read by meshio as a geometry-free netgen mesh (second-order cells as an
attached quadratic map), and netgen ``.vol``."""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

import ngsolve as ngs
import numpy as np

from . import curved as quadratic
from .params import MESH_SUFFIXES, existing_file, one_line
from .refine import netgen_mesh
from .regions import FLUID, FLUID_WALL, INTERFACE, SOLID, SOLID_WALL, GeometryError, check_regions, mesh_phases

#: meshio cell type → (dimension, corner count); the nodes after the corners are mid-edge nodes.
GMSH_CELLS = {"line": (1, 2), "line3": (1, 2), "triangle": (2, 3), "triangle6": (2, 3),
              "tetra": (3, 4), "tetra10": (3, 4)}
#: the edge (pair of corners) of each mid-edge node, in meshio's order (which it converts from gmsh's)
MID_EDGES = {"line3": [(0, 1)], "triangle6": [(0, 1), (1, 2), (0, 2)],
             "tetra10": [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]}
IGNORED_CELLS = {"vertex"}  # physical points
NAMES_HINT = f"name the physical groups '{FLUID}', '{SOLID}', '{INTERFACE}' (and '{FLUID_WALL}', '{SOLID_WALL}')"


def _read_gmsh(path: Path):
    """The file as a ``meshio.Mesh`` (gmsh 2.2, 4.0 or 4.1, ASCII or binary)."""
    import warnings

    import meshio

    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            return meshio.gmsh.read(str(path))  # not meshio.read: that exits on a ReadError
    except Exception as error:  # noqa: BLE001 - meshio raises ReadError, KeyError, struct.error, ...
        raise GeometryError(f"mesh file {path}: cannot read as a gmsh mesh ({one_line(error)})") from None


def _gmsh_blocks(msh, path: Path) -> tuple[int, list[tuple[int, np.ndarray, list[str]]], list[np.ndarray]]:
    """The mesh dimension; per cell block of dimension dim or dim - 1, (dimension, corner numbers,
    physical name of each cell); and the mid-edge nodes of the second-order blocks as rows
    (corner, corner, node)."""
    unknown = sorted({block.type for block in msh.cells} - set(GMSH_CELLS) - IGNORED_CELLS)
    if unknown:
        raise GeometryError(f"mesh file {path}: cells of type {', '.join(unknown)} are not supported "
                            "(expected triangles and lines in 2D, tetrahedra and triangles in 3D)")
    tags = msh.cell_data.get("gmsh:physical")
    if not msh.field_data or tags is None:
        raise GeometryError(f"mesh file {path}: no physical names; {NAMES_HINT}")
    names = {(int(dim), int(tag)): name for name, (tag, dim) in msh.field_data.items()}
    blocks = [(b.type, b.data, t) for b, t in zip(msh.cells, tags) if b.type in GMSH_CELLS]
    dim = max((GMSH_CELLS[kind][0] for kind, _, _ in blocks), default=0)
    if dim not in (2, 3):
        raise GeometryError(f"mesh file {path}: no triangles or tetrahedra")
    result, middles = [], []
    for kind, data, block_tags in blocks:
        d, corners = GMSH_CELLS[kind]
        if d < dim - 1:
            continue
        missing = sorted({int(t) for t in block_tags if (d, int(t)) not in names})
        if missing:
            raise GeometryError(f"mesh file {path}: physical group {missing[0]} of dimension {d} has no name; "
                                f"{NAMES_HINT}")
        result.append((d, data[:, :corners], [names[d, int(t)] for t in block_tags]))
        middles += [data[:, [i, j, corners + k]] for k, (i, j) in enumerate(MID_EDGES.get(kind, []))]
    return dim, result, middles


def _coincident_vertices(points: np.ndarray, path: Path) -> None:
    """Refuse distinct vertices at one place: a fluid and a solid meshed separately."""
    from scipy.spatial import cKDTree

    size = float(np.ptp(points, axis=0).max()) or 1.0
    pairs = cKDTree(points).query_pairs(1e-10 * size, output_type="ndarray")
    if len(pairs):
        where = tuple(round(float(c), 6) for c in points[pairs[0, 0]])
        raise GeometryError(f"mesh file {path}: {len(pairs)} pairs of coincident vertices, e.g. at {where}; the "
                            "interface is not conforming (mesh the fluid and solid together so they share its nodes)")


def _facet_neighbours(cells: list[list[int]]) -> dict[tuple[int, ...], list[tuple[int, int]]]:
    """Each facet (sorted vertex numbers) → its cells as (cell number, the cell's vertex opposite the facet)."""
    neighbours: dict[tuple[int, ...], list[tuple[int, int]]] = {}
    for number, cell in enumerate(cells):
        for k, opposite in enumerate(cell):
            neighbours.setdefault(tuple(sorted(cell[:k] + cell[k + 1:])), []).append((number, opposite))
    return neighbours


def _outward(points: np.ndarray, facet: list[int], opposite: int) -> list[int]:
    """The facet's vertices ordered so that its normal points away from ``opposite`` (see `netgen_mesh`)."""
    edges = [points[v, : len(facet)] - points[facet[0], : len(facet)] for v in (*facet[1:], opposite)]
    inward = np.linalg.det(np.array(edges))
    return facet if (inward > 0) == (len(facet) == 2) else facet[::-1]


def _gmsh_boundaries(path: Path, points: np.ndarray, cells: list[list[int]], materials: list[str],
                     regions: list[int], facets: list[tuple[str, list[int]]]):
    """Boundary parts (name, domin, domout) and the facets oriented out of domin, for `netgen_mesh`;
    refuses a facet bordering no cell and an interface facet not between a fluid and a solid cell (``materials``:
    the medium of each region)."""
    neighbours = _facet_neighbours(cells)
    parts: dict[tuple[str, int, int], int] = {}
    oriented = []
    for name, facet in facets:
        sides = sorted(neighbours.get(tuple(sorted(facet)), []), key=lambda side: regions[side[0]])
        media = [materials[regions[c] - 1] for c, _ in sides]
        if not sides or (name == INTERFACE and media != [FLUID, SOLID] and media != [SOLID, FLUID]):
            where = tuple(round(float(c), 6) for c in points[facet].mean(axis=0))
            found = " and ".join(f"a {medium} cell" for medium in media) or "no cell"
            raise GeometryError(f"mesh file {path}: a facet of '{name}' at {where} borders {found}"
                                + (" (non-conforming interface)" if name == INTERFACE else ""))
        domains = [regions[c] for c, _ in sides] + [0]
        number = parts.setdefault((name, domains[0], domains[1]), len(parts) + 1)
        oriented.append((number, _outward(points, facet, sides[0][1])))
    media = [materials[region - 1] for region in regions]
    _unnamed_facets(path, neighbours, {tuple(sorted(facet)) for _, facet in facets}, media)
    return list(parts), oriented


def _unnamed_facets(path: Path, neighbours: dict, named: set, media: list[str]) -> None:
    """Refuse outer facets and fluid–solid facets that are in no physical group (``media``: each cell's medium;
    facets between regions of one medium need no name)."""
    unnamed = [sides for key, sides in neighbours.items()
               if key not in named and (len(sides) == 1 or media[sides[0][0]] != media[sides[1][0]])]
    inner = sum(len(sides) == 2 for sides in unnamed)
    if inner:
        raise GeometryError(f"mesh file {path}: {inner} facets between fluid and solid cells are not in the "
                            f"physical group '{INTERFACE}'")
    if unnamed:
        raise GeometryError(f"mesh file {path}: {len(unnamed)} outer facets are in no physical group "
                            f"(e.g. '{FLUID_WALL}' or '{SOLID_WALL}')")


def _load_gmsh(path: Path, regions: dict) -> ngs.Mesh:
    """A gmsh mesh read by meshio, as a geometry-free netgen mesh (see `load_mesh`; ``regions``: the media of cell
    regions not called fluid or solid)."""
    msh = _read_gmsh(path)
    dim, blocks, middles = _gmsh_blocks(msh, path)
    cells = [(name, c) for d, data, names in blocks if d == dim for name, c in zip(names, data)]
    facets = [(name, c) for d, data, names in blocks if d < dim for name, c in zip(names, data)]
    materials = list(dict.fromkeys(name for name, _ in cells))
    media = [regions.get(name, name) for name in materials]
    strange = [name for name, medium in zip(materials, media) if medium not in (FLUID, SOLID)]
    if strange:
        raise GeometryError(f"mesh file {path}: volume region '{strange[0]}' is neither '{FLUID}' nor '{SOLID}' "
                            f"(map it with [geometry] regions, e.g. regions = {{ {strange[0]} = \"{SOLID}\" }})")
    used = np.unique(np.concatenate([c for _, c in cells]))
    number = np.full(len(msh.points), -1)
    number[used] = np.arange(len(used))  # the corners; mid-edge nodes are not vertices
    points = np.zeros((len(used), 3))
    points[:, : msh.points.shape[1]] = msh.points[used]
    if dim == 2 and np.abs(points[:, 2]).max() > 0:
        raise GeometryError(f"mesh file {path}: a 2D mesh must lie in the plane z = 0")
    _coincident_vertices(points, path)
    corners = [number[c].tolist() for _, c in cells]
    regions = [materials.index(name) + 1 for name, _ in cells]
    boundaries, oriented = _gmsh_boundaries(path, points, corners, media, regions,
                                            [(name, number[c].tolist()) for name, c in facets])
    mesh = netgen_mesh(dim, points, materials, list(zip(regions, corners)), boundaries, oriented)
    if middles:
        _mid_edge_nodes(path, mesh, points, msh.points, number, np.vstack(middles))
    return mesh


def _mid_edge_nodes(path: Path, mesh: ngs.Mesh, points: np.ndarray, nodes: np.ndarray, number: np.ndarray,
                    middles: np.ndarray) -> None:
    """Curve ``mesh`` by the mid-edge nodes of its second-order cells (rows: corner, corner, node of the
    file), unless every one is its edge's midpoint; refuse an edge whose cells disagree on its node."""
    edges = np.sort(number[middles[:, :2]], axis=1)
    where = np.zeros((len(middles), 3))
    where[:, : nodes.shape[1]] = nodes[middles[:, 2]]
    size = float(np.ptp(points, axis=0).max()) or 1.0
    if np.abs(where - (points[edges[:, 0]] + points[edges[:, 1]]) / 2).max() <= 1e-12 * size:
        return
    unique, first, inverse = np.unique(edges, axis=0, return_index=True, return_inverse=True)
    apart = np.linalg.norm(where - where[first][inverse.ravel()], axis=1)
    if apart.max() > 1e-10 * size:
        at = tuple(round(float(c), 6) for c in points[edges[apart.argmax()]].mean(axis=0))
        raise GeometryError(f"mesh file {path}: the cells along the edge at {at} have different mid-edge nodes")
    quadratic.attach(mesh, {(int(a), int(b)): where[k] for (a, b), k in zip(unique, first)}, str(path))


def load_mesh(path: str | Path, regions: dict | None = None) -> ngs.Mesh:
    """A mesh from a file: gmsh ``.msh`` (format 2.2, 4.0 or 4.1, ASCII or binary, read by meshio;
    the physical names become the region names) or netgen ``.vol`` / ``.vol.gz``.

    The mesh must have the volume regions ``fluid`` and ``solid`` and the boundary region
    ``interface`` (`check_regions`), or other cell regions that ``regions`` (``[geometry] regions``) maps to
    ``fluid`` or ``solid`` (`mesh_phases`); anything else is a one-line `GeometryError` naming the file.
    A gmsh mesh is 2D (triangles; boundary lines) or 3D (tetrahedra; boundary triangles), every
    cell in a physical group (``fluid``, ``solid`` or a name ``regions`` maps), every outer facet in a named group
    (walls: ``fluid_wall``, ``solid_wall`` or other names), every fluid–solid facet in ``interface``, and the
    fluid and solid share their interface nodes (no coincident vertices). Second-order cells
    (triangle6, tetra10) are the straight mesh on their corners with their quadratic map attached
    (`quadratic`: `quadratic.curve` applies it, refinement keeps it); mid-edge nodes that all sit at
    their edges' midpoints leave it straight. A gmsh mesh has no other geometry (refinement splits
    edges at their midpoints); a ``.vol`` file saved from a mesh of an OCC geometry
    (``mesh.ngmesh.Save``) carries that geometry along."""
    path, suffix = existing_file(path, MESH_SUFFIXES, "mesh file")
    regions = dict(regions or {})
    if suffix == ".msh":
        mesh = _load_gmsh(path, regions)
    else:
        try:
            mesh = ngs.Mesh(str(path))
        except Exception as error:  # noqa: BLE001 - netgen raises bare Exceptions
            raise GeometryError(f"mesh file {path}: cannot read ({one_line(error)})") from None
    try:
        check_regions(mesh, mesh_phases(mesh, regions))
    except GeometryError as error:
        if str(error).startswith("geometry."):
            raise
        raise GeometryError(f"mesh file {path}: {str(error).removeprefix('mesh: ')}") from None
    return mesh
