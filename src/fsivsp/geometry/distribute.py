"""Meshes over MPI ranks (``mpirun -np N fsivsp ...``): rank 0 meshes, `distribute` hands every rank its part
(netgen's ``Distribute``/``Receive``; NGSolve keeps rank 0 free of cells), `shared_case` does so for a case loaded on
rank 0. Serial: the identity."""
from __future__ import annotations

import dataclasses
from collections.abc import Callable

from ..runtime import parallel
from .regions import check_distributable


def distribute(mesh):
    """Rank 0's ``ngsolve.Mesh`` split over the ranks: every rank gets its part (rank 0 passes its mesh,
    the others None); a mesh that cannot be distributed is refused on every rank. Serial: the mesh itself."""
    comm = parallel.world()
    if comm is None:
        return mesh
    import netgen.meshing
    import ngsolve as ngs

    parallel.shared(check_distributable, mesh)
    ngmesh = mesh.ngmesh.Distribute(comm) if comm.rank == 0 else netgen.meshing.Mesh.Receive(comm)
    return ngs.Mesh(ngmesh)


def shared_case(load: Callable, path, **options):
    """``load(path, **options)`` (a case with a ``mesh`` field) on rank 0, then the case on every rank with
    its part of the mesh (`distribute`). Errors of ``load`` are raised on every rank. Serial: ``load``."""
    if parallel.world() is None:
        return load(path, **options)
    meshes = []

    def detached():
        case = load(path, **options)
        meshes.append(case.mesh)
        return dataclasses.replace(case, mesh=None)

    case = parallel.shared(detached)
    return dataclasses.replace(case, mesh=distribute(meshes[0] if meshes else None))
