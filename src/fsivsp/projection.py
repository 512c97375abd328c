"""Solves with the Gram matrix G of an error norm: the G-orthogonal projections of the exact fields (`norms`).

Small spaces factorise G (Cholesky). Above `DIRECT_MAX` used dofs the factorisation's fill grows faster than
the dofs (on level 4 of the 3D fluid ball it doubled the run's peak memory), and the projections are
solved by conjugate gradients instead, preconditioned by `solvers.multigrid.TwoLevel` as the step's velocity:
symmetric Gauss–Seidel on all used dofs (bubbles, edges, faces) around a V-cycle of `solvers.multigrid.Multigrid`
on the used vertex dofs (G's vertex–vertex block is the P1 Gram matrix, so the refinement hierarchy of
`geometry.refined` serves as for the step).

Both solve through `solvers.symmetric` (`symmetric_solver`: the factorisation, or CG with this preconditioner).
A singular G (the stress norm ‖Cε(u)‖ on the solid, whose kernel is the rigid motions) is consistent for
every load ∫ Cε(E):Cε(w); its multigrid factorises the coarsest level with `PRECONDITIONER_SHIFT`.
"""
from __future__ import annotations

import numpy as np
import ngsolve as ngs
import scipy.sparse as sp

from .solvers import to_ngsolve, to_scipy_csr
from .solvers.multigrid import Multigrid, TwoLevel, bits, has_hierarchy, vertex_gather, vertex_levels
from .solvers.symmetric import ConjugateGradients, Factorised, Kernel, symmetric_solver

#: Used dofs above which G is not factorised (CG instead, if the mesh has a refinement hierarchy). On level 4 of the
#: 3D fluid ball (MINI, 190 000 dofs in one velocity component's norm) CG took 55 s and 0.35 GB where the Cholesky
#: factorisation took 84 s and 2.2 GB.
DIRECT_MAX = 50_000
#: The shift of a singular G's diagonal in its multigrid (relative to the diagonal).
PRECONDITIONER_SHIFT = 1e-6


def gram_solver(gram: ngs.BaseMatrix, space: ngs.FESpace, used: np.ndarray,
                kernel: Kernel | None) -> Factorised | ConjugateGradients:
    """load, out ↦ out = G⁺ load on the ``used`` dofs (a mask) of ``space`` (`symmetric_solver`). ``kernel``: an
    orthonormal basis (columns) of G's kernel on the dofs it names, or None. CG with `preconditioner` where G has
    more than `DIRECT_MAX` used dofs and the mesh a refinement hierarchy whose coarsest level can be factorised,
    else the factorisation."""
    vertices = vertex_dofs(space)
    vertices = vertices[[bool(used[row[row >= 0]].any()) for row in vertices]]  # the unknowns G sees
    iterate = used.sum() > DIRECT_MAX and has_hierarchy(space.mesh, len(vertices))
    cycle = preconditioner(gram, used, kernel is not None, vertices, vertex_levels(space.mesh)) if iterate else None
    return symmetric_solver(gram, bits(used), kernel, cycle)


def vertex_dofs(space: ngs.FESpace) -> np.ndarray:
    """The dof of each (scalar unknown, vertex) pair of a product of H1-type spaces (velocity components, then
    pressure): an array of shape (unknowns, vertices), −1 where an unknown has no dof at a vertex (the fluid
    pressure in the solid). Kept on the space (a study's norms share it)."""
    cached = getattr(space, "_vertex_dofs", None)
    if cached is None:
        cached = space._vertex_dofs = _vertex_dofs(space)
        cached.flags.writeable = False
    return cached


def _vertex_dofs(space: ngs.FESpace) -> np.ndarray:
    rows, offset = [], 0
    for part in _scalar_spaces(space):
        row = np.array([(part.GetDofNrs(ngs.NodeId(ngs.VERTEX, v)) or (-1,))[0] for v in range(space.mesh.nv)])
        rows.append(np.where(row >= 0, row + offset, -1))
        offset += part.ndof
    return np.array(rows)


def _scalar_spaces(space: ngs.FESpace) -> list[ngs.FESpace]:
    if isinstance(space, (ngs.comp.ProductSpace, ngs.VectorH1)):
        return [part for component in space.components for part in _scalar_spaces(component)]
    return [space]


def preconditioner(gram: ngs.BaseMatrix, used: np.ndarray, singular: bool, vertices: np.ndarray,
                   levels: tuple[np.ndarray, list[int]]) -> TwoLevel:
    """`TwoLevel` for G: Gauss–Seidel on the used dofs, `Multigrid` on the used ``vertices`` (unknowns ×
    vertices, component-major) of the hierarchy ``levels``, its block shifted by `PRECONDITIONER_SHIFT` if G is
    ``singular``."""
    csr = to_scipy_csr(gram)
    index = np.where(vertices >= 0, vertices, 0).ravel()
    free = (vertices >= 0).ravel() & used[index]
    block = csr[index][:, index]
    if singular:
        block = block + PRECONDITIONER_SHIFT * sp.diags(block.diagonal())
    return TwoLevel(gram, bits(used), vertex_gather(vertices, used), Multigrid(to_ngsolve(block), bits(free), *levels))
