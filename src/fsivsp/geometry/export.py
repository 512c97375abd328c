"""An NGSolve mesh as a gmsh file (via meshio), with its region names as physical names, which `geometry.load_mesh`
reads back (docs/meshes.md):

    write_gmsh(build_geometry("fluid_over_solid", 2, 0.15), "layers.msh")        # gmsh 4.1 ASCII
"""
from __future__ import annotations

from pathlib import Path

import meshio
import ngsolve as ngs
import numpy as np


def to_meshio(mesh: ngs.Mesh) -> meshio.Mesh:
    """The mesh with one cell block per region (entity tag = physical tag, named in field_data).
    meshio's msh 4.1 writer lists only the entities that own nodes, so each block also gets one
    unused copy of one of its nodes (a fluid ball may have no inner node); `load_mesh` drops it."""
    dim = mesh.dim
    points = [np.array([v.point + (0.0,) * (3 - dim) for v in mesh.vertices])]
    owners = [np.zeros((mesh.nv, 2), dtype=int)]
    cells, tags, names = [], [], {}
    for vb, d, cell_type, regions in ((ngs.VOL, dim, ("triangle", "tetra")[dim - 2], mesh.GetMaterials()),
                                      (ngs.BND, dim - 1, ("line", "triangle")[dim - 2], mesh.GetBoundaries())):
        for tag, name in enumerate(dict.fromkeys(regions), start=1):
            block = np.array([[v.nr for v in el.vertices] for el in mesh.Elements(vb) if el.mat == name])
            cells.append((cell_type, block))
            tags.append(np.full(len(block), tag))
            names[name] = np.array([tag, d])
            owners[0][block.ravel()] = (d, tag)
            points.append(points[0][block[:1, 0]])
            owners.append(np.array([[d, tag]]))
    return meshio.Mesh(np.vstack(points), cells, point_data={"gmsh:dim_tags": np.vstack(owners)},
                       cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags}, field_data=names)


def write_gmsh(mesh: ngs.Mesh, path: str | Path, binary: bool = False) -> Path:
    """Write ``mesh`` to ``path`` as gmsh 4.1 (ASCII unless ``binary``)."""
    meshio.write(path, to_meshio(mesh), file_format="gmsh", binary=binary)
    return Path(path)
