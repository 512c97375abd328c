"""Meshes over MPI ranks (``mpirun -np N fsivsp ...``), refined where their cells live.

Rank 0 meshes and refines only until the ranks with cells (all but rank 0: NGSolve keeps it free of cells) would
have `FAIR_SHARE` cells each (`root_levels`), hands the mesh out (netgen's ``Distribute``/``Receive``), and every
rank refines its own part for the remaining levels (`refined_parts`), with the geometry sent to every rank so that
new boundary nodes land on it where the serial `refine.refined` projects them: the same cells as the serial
refinement, the mesh never whole on one rank. `shared_case` loads a case on rank 0 and gives it to every rank.
Serial: the serial refinement.
"""
from __future__ import annotations

import dataclasses
import pickle
from collections.abc import Callable, Iterable, Iterator

import netgen.meshing as nm
import ngsolve as ngs
import numpy as np

from ..runtime import parallel
from .refine import RED, refined, without_geometry
from .regions import GeometryError, check_distributable

#: Cells per rank with cells before rank 0 hands its mesh out: METIS's parts stay balanced and compact, and rank 0
#: never holds more than 2^d times this many cells per rank.
FAIR_SHARE = 2000

#: netgen's red refinement of a tetrahedron (`refine.RED`) marks children 5 and 7 of its 8 "reversed": split in
#: turn, their 3rd and 4th vertices are swapped first. ``Distribute`` does not send the mark, so rank 0 writes it
#: into a marked cell's vertex order before handing the mesh out (`_root_refined`): without this, cells refined once
#: on rank 0 and once more on their rank were split along other diagonals than the serial refinement's.
REVERSED_CHILDREN = np.array(RED[3][2])


def root_levels(cells: int, dim: int, ranks: int) -> int:
    """How many uniform refinements rank 0 makes of its mesh of ``cells`` cells before handing it out: the fewest
    that give each of the ``ranks`` − 1 ranks with cells `FAIR_SHARE` cells."""
    levels = 0
    while max(cells, 1) * 2 ** (dim * levels) < FAIR_SHARE * (ranks - 1):
        levels += 1
    return levels


def _root_refined(mesh: ngs.Mesh, levels: int, project: bool) -> nm.Mesh:
    """A copy of rank 0's netgen mesh refined ``levels`` times as `refine.refined` does, without the refinement's
    levels (with them, NGSolve's prolongation on rank 0's emptied part ran without end once the ranks refined
    further), the reversed tetrahedra's marks written into their vertex order (`REVERSED_CHILDREN`)."""
    ngmesh = mesh.ngmesh.Copy() if project else without_geometry(mesh).ngmesh
    marked = np.zeros(mesh.ne if mesh.dim == 3 else 0, dtype=bool)   # the coarse mesh's cells: none
    for _ in range(levels):
        ngmesh.Refine(adaptive=False)
        children = np.arange(7 * len(marked))   # cell k stays child 0 of itself; n + 7k + j - 1 is its child j
        marked = np.concatenate([marked, marked[children // 7] ^ REVERSED_CHILDREN[children % 7 + 1]])
    if levels:
        ngmesh = ngmesh.Copy()   # netgen's copy keeps the cells, their vertex order and the geometry, not the levels
    if marked.any():
        nodes = ngmesh.Elements3D().NumPy()["nodes"]   # a view of netgen's cells
        nodes[marked, 2:4] = nodes[marked, 3:1:-1]
    return ngmesh


def _outline(mesh: ngs.Mesh, project: bool) -> tuple[int, int, bytes | None]:
    """Rank 0's mesh's dimension, cells and (if refinement projects onto it) pickled geometry, for every rank."""
    check_distributable(mesh)
    geometry = mesh.ngmesh.GetGeometry()
    if not project or type(geometry) is nm.NetgenGeometry:   # none: new nodes at the edge midpoints
        return mesh.dim, mesh.ne, None
    try:
        return mesh.dim, mesh.ne, pickle.dumps(geometry)
    except (TypeError, pickle.PicklingError) as error:
        raise GeometryError(f"mesh: its geometry ({type(geometry).__name__}) cannot be sent to the ranks ({error}); "
                            "run serially, or set discretisation.curved = false") from None


def _hand_out(mesh: ngs.Mesh | None, levels: int, project: bool, geometry: object | None) -> nm.Mesh:
    """This rank's part of rank 0's ``mesh`` refined there ``levels`` times, on ``geometry`` if not None."""
    comm = parallel.world()
    ngmesh = _root_refined(mesh, levels, project).Distribute(comm) if comm.rank == 0 else nm.Mesh.Receive(comm)
    if geometry is not None:
        ngmesh.SetGeometry(geometry)
    return ngmesh


def _agree(part: nm.Mesh) -> None:
    """Every rank's copy of a boundary vertex where the serial refinement puts it. Refining its part, a rank places a
    new boundary vertex onto the geometry only if it holds a boundary segment (onto the curve) or boundary face (onto
    the surface) through it, as the serial refinement, which holds them all, does; a rank that holds only a cell
    through it puts it at the edge's midpoint. Each copy takes the mean of the copies of the ranks with a segment
    through the vertex, or else with a face (identical up to round-off)."""
    mesh = ngs.Mesh(part)
    points = part.Coordinates()   # a view of netgen's points
    space = ngs.H1(mesh, order=1)   # one dof per vertex, in the vertices' order
    field = ngs.GridFunction(space)
    values = field.vec.FV().NumPy()
    found = np.zeros(len(points), dtype=bool)
    for elements, corners in ((part.Elements1D(), 2), (part.Elements2D(), 3))[:mesh.dim - 1]:
        held = np.zeros(len(points), dtype=bool)
        held[elements.NumPy()["nodes"][:, :corners].ravel() - 1] = True   # the segments' or faces' corners
        sums = []
        for column in (*points[:, :mesh.dim].T, np.ones(len(points))):
            values[:] = np.where(held, column, 0.0)
            field.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
            field.vec.Cumulate()
            sums.append(values.copy())
        copies = sums.pop()
        chosen = (copies > 0) & ~found
        points[chosen, :mesh.dim] = np.column_stack(sums)[chosen] / copies[chosen, None]
        found |= copies > 0


def refined_parts(mesh: ngs.Mesh | None, levels: Iterable[int], project: bool = True) -> Iterator[ngs.Mesh]:
    """For each of ``levels`` (increasing), this rank's part of ``mesh`` (rank 0's; None on the others) refined
    that many times: the cells of ``refined(mesh, level, project)``, over the ranks. Rank 0 refines until the
    ranks would have a fair share (`root_levels`) and hands the mesh out; every rank then refines its part, from
    one level to the next in place (the part yielded before goes out of date). A mesh that cannot be distributed
    is refused on every rank. Serial: ``refined(mesh, level, project)`` for each level."""
    if parallel.world() is None:
        yield from (refined(mesh, level, project) for level in levels)
        return
    dim, cells, geometry = parallel.shared(_outline, mesh, project)
    geometry = None if geometry is None else pickle.loads(geometry)
    fair = root_levels(cells, dim, parallel.size())
    part, at = None, 0
    for level in levels:
        if part is None or level <= fair or level < at:
            at = min(level, fair)
            part = _hand_out(mesh, at, project, geometry)
        for _ in range(level - at):
            part.Refine(adaptive=False)
            if geometry is not None:
                _agree(part)
        at = level
        yield ngs.Mesh(part)


def refined_part(mesh: ngs.Mesh | None, levels: int, project: bool = True) -> ngs.Mesh:
    """This rank's part of rank 0's ``mesh`` refined ``levels`` times (`refined_parts`). Serial: the refined
    mesh."""
    return next(refined_parts(mesh, [levels], project))


def distribute(mesh: ngs.Mesh | None) -> ngs.Mesh:
    """This rank's part of rank 0's ``mesh`` (None on the others), on its geometry. Serial: the mesh itself."""
    return mesh if parallel.world() is None else refined_part(mesh, 0)


def shared_case(load: Callable, path, **options):
    """``load(path, **options)`` (a case with a ``mesh`` field) on rank 0, the case on every rank with rank 0's mesh
    there only (None on the others: `refined_part` hands it out). Errors of ``load`` are raised on every rank.
    Serial: ``load``."""
    if parallel.world() is None:
        return load(path, **options)
    meshes = []

    def detached():
        case = load(path, **options)
        meshes.append(case.mesh)
        return dataclasses.replace(case, mesh=None)

    case = parallel.shared(detached)
    return dataclasses.replace(case, mesh=meshes[0] if meshes else None)
