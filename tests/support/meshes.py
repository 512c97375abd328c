"""Meshes as gmsh files: balls, their second-order cells (straight or curved), written in each format."""
from functools import cache
from pathlib import Path

import meshio
import ngsolve as ngs
import numpy as np

from fsivsp.geometry import build_geometry

FORMATS = {"41-ascii": ("gmsh", False), "41-binary": ("gmsh", True), "22-ascii": ("gmsh22", False)}


@cache
def ball(dim: int) -> ngs.Mesh:
    """The coarse fluid_in_solid mesh of the study examples."""
    return build_geometry("fluid_in_solid", dim, 0.15 if dim == 2 else 0.4, curvature_safety=1.0)


def write(mesh: meshio.Mesh, path: Path, form: str = "41-ascii") -> Path:
    file_format, binary = FORMATS[form]
    meshio.write(path, mesh, file_format=file_format, binary=binary)
    return path


#: the corners of each mid-edge node in meshio's order (`geometry.MID_EDGES`), and NGSolve's reference vertices
MID_EDGES = {"line": [(0, 1)], "triangle": [(0, 1), (1, 2), (0, 2)],
             "tetra": [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]}


SECOND_ORDER = {"line": "line3", "triangle": "triangle6", "tetra": "tetra10"}


REFERENCE = {2: [(1, 0), (0, 1), (0, 0)], 3: [(1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 0)]}


def mid_edge_nodes(mesh: ngs.Mesh) -> dict[tuple[int, int], np.ndarray]:
    """Each edge (sorted vertex numbers) → the point of the mesh's (possibly curved) cell map at the middle of
    the edge's reference edge."""
    dim, reference = mesh.dim, np.array(REFERENCE[mesh.dim], dtype=float)
    pairs = MID_EDGES[("triangle", "tetra")[dim - 2]]
    rule = ngs.IntegrationRule([tuple((reference[i] + reference[j]) / 2) for i, j in pairs], [0.0] * len(pairs))
    mapped = ngs.CF((ngs.x, ngs.y, ngs.z)[:dim])(mesh.MapToAllElements(rule, ngs.VOL)).reshape(mesh.ne, len(pairs), dim)
    nodes = {}
    for el, points in zip(mesh.Elements(ngs.VOL), mapped):
        corners = [v.nr for v in el.vertices]
        for (i, j), point in zip(pairs, points):
            nodes[tuple(sorted((corners[i], corners[j])))] = np.append(point, [0.0] * (3 - dim))
    return nodes


def second_order(first: meshio.Mesh, nodes: dict[tuple[int, int], np.ndarray] | None = None) -> meshio.Mesh:
    """``first`` with line3/triangle6/tetra10 cells: the mid-edge nodes from ``nodes`` (default: the midpoints)."""
    points, cells, count = [first.points], [], len(first.points)
    owners = [first.point_data["gmsh:dim_tags"]]
    for block, tags in zip(first.cells, first.cell_data["gmsh:physical"]):
        middles = [np.array([nodes[tuple(sorted(e))] for e in block.data[:, [i, j]].tolist()]) if nodes else
                   (first.points[block.data[:, i]] + first.points[block.data[:, j]]) / 2
                   for i, j in MID_EDGES[block.type]]
        numbers = count + np.arange(len(middles) * len(block.data)).reshape(len(middles), -1).T
        count += numbers.size
        points += middles
        owners.append(np.tile([block.dim, tags[0]], (numbers.size, 1)))
        cells.append((SECOND_ORDER[block.type], np.hstack([block.data, numbers])))
    return meshio.Mesh(np.vstack(points), cells, point_data={"gmsh:dim_tags": np.vstack(owners)},
                       cell_data={key: first.cell_data[key] for key in ("gmsh:physical", "gmsh:geometrical")},
                       field_data=first.field_data)


def curved_ball(dim: int) -> ngs.Mesh:
    """The coarse fluid_in_solid mesh with netgen's order-2 curved cells."""
    mesh = build_geometry("fluid_in_solid", dim, 0.15 if dim == 2 else 0.4, curvature_safety=1.0)
    mesh.Curve(2)
    return mesh
