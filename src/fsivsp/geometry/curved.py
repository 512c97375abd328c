"""Second-order cells of a mesh file (gmsh triangle6 / tetra10): their quadratic map, applied to the
straight mesh on the corners as an NGSolve deformation.

A quadratic map is fixed by its values at the corners and at the mid-edge nodes. As a displacement
D = map − identity it vanishes at the corners and lies in [P2]^d, whose dofs are the vertex values and one
edge bubble per edge, so D is set from the mid-edge nodes alone. NGSolve applies the deformation to every
integral, normal and point search (``Mesh.SetDeformation``), cells and boundary alike; on a mesh of order-2
curved netgen cells it reproduces netgen's map to round-off (tests/test_mesh_files.py).

Refinement: the coarse D restricted to a sub-cell of a uniform refinement is again quadratic and continuous,
so ``Set`` reproduces it exactly on the fine mesh. Refined meshes thus follow the file's quadratic cells
(the file has no exact surface to project onto).
"""
from __future__ import annotations

from collections.abc import Mapping

import ngsolve as ngs
import numpy as np

from ..runtime.threads import sequential

#: the attribute of an ``ngsolve.Mesh`` (the straight mesh on the corners) that holds its `QuadraticCells`
ATTRIBUTE = "quadratic_cells"


class QuadraticCells:
    """The displacement D ∈ [P2]^d of a straight mesh's cells to the quadratic cells of a mesh file."""

    def __init__(self, mesh: ngs.Mesh, midpoints: Mapping[tuple[int, int], np.ndarray], source: str):
        """``midpoints``: (smaller, larger vertex number) of an edge → its mid-edge node (an edge without
        one stays straight); ``source``: the file, for messages."""
        self.source = source
        self.mesh = ngs.Mesh(mesh.ngmesh.Copy())  # kept straight: `deformation` searches points in it
        self.displacement = ngs.GridFunction(ngs.VectorH1(self.mesh, order=2))
        dim, nv = self.mesh.dim, self.mesh.nv
        corners = np.array([v.point for v in self.mesh.vertices])
        edges = np.array([sorted(v.nr for v in edge.vertices) for edge in self.mesh.edges])
        components = self.displacement.components
        assert components[0].space.ndof == nv + len(edges), "H1 order 2: one dof per vertex and per edge"
        components[0].vec[nv] = 1.0  # the edge bubble's value at its edge's midpoint
        bubble = components[0](self.mesh(*corners[edges[0]].mean(axis=0)))
        shift = np.zeros((len(edges), dim))
        for k, (a, b) in enumerate(edges):
            if (a, b) in midpoints:
                shift[k] = np.asarray(midpoints[a, b])[:dim] - (corners[a] + corners[b]) / 2
        for i, component in enumerate(components):
            values = np.zeros(nv + len(edges))
            values[nv:] = shift[:, i] / bubble
            component.vec.FV().NumPy()[:] = values

    def deformation(self, mesh: ngs.Mesh) -> ngs.GridFunction:
        """D on ``mesh``: this mesh or a uniform refinement of it, straight."""
        with sequential():   # the same element colouring in every process (`Set` adds in its order)
            field = ngs.GridFunction(ngs.VectorH1(mesh, order=2))
        field.Set(self.displacement)
        return field


def attach(mesh: ngs.Mesh, midpoints: Mapping[tuple[int, int], np.ndarray], source: str) -> None:
    """Give the straight ``mesh`` the quadratic cells of its mid-edge nodes (see `QuadraticCells`)."""
    setattr(mesh, ATTRIBUTE, QuadraticCells(mesh, midpoints, source))


def carry(source: ngs.Mesh, target: ngs.Mesh) -> ngs.Mesh:
    """``target`` (a copy or refinement of ``source``) with ``source``'s quadratic cells, if it has any."""
    cells = quadratic_cells(source)
    if cells is not None:
        setattr(target, ATTRIBUTE, cells)
    return target


def quadratic_cells(mesh: ngs.Mesh) -> QuadraticCells | None:
    """The mesh's `QuadraticCells`, if it has any."""
    return getattr(mesh, ATTRIBUTE, None)


def curve(mesh: ngs.Mesh, order: int) -> None:
    """``mesh.Curve(order)`` (onto its geometry, if it has one), and for ``order`` ≥ 2 the quadratic cells of
    its mesh file, if it has them."""
    mesh.Curve(order)
    cells = quadratic_cells(mesh)
    if order >= 2 and cells is not None:
        mesh.SetDeformation(cells.deformation(mesh))
