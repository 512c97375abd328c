"""Solves with the Gram matrix G of an error norm: the G-orthogonal projections of the exact fields (`norms`).

Small spaces factorise G (Cholesky). Above `DIRECT_MAX` used dofs the factorisation's fill grows faster than
the dofs (on level 4 of the 3D fluid ball it doubled the run's peak memory), and the projections are
solved by conjugate gradients instead, preconditioned by `solvers.multigrid.TwoLevel` as the step's velocity:
symmetric Gauss–Seidel on all used dofs (bubbles, edges, faces) around a V-cycle of `solvers.multigrid.Multigrid`
on the used vertex dofs (G's vertex–vertex block is the P1 Gram matrix, so the refinement hierarchy of
`geometry.refined` serves as for the step).

A singular G (the stress norm ‖Cε(u)‖ on the solid, whose kernel is the rigid motions) is consistent for
every load ∫ Cε(E):Cε(w); its preconditioner factorises the coarsest level with `PRECONDITIONER_SHIFT` and
removes the kernel from its output, so the iterates stay clear of it.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import ngsolve as ngs
import scipy.sparse as sp
from ngsolve.krylovspace import CGSolver

from .solvers import NotConverged, to_ngsolve, to_scipy_csr
from .solvers.multigrid import Multigrid, coarse_inverse, TwoLevel, bits, has_hierarchy, vertex_gather, vertex_levels

#: Used dofs above which G is not factorised (CG instead, if the mesh has a refinement hierarchy). On level 4 of the
#: 3D fluid ball (MINI, 190 000 dofs in one velocity component's norm) CG took 55 s and 0.35 GB where the Cholesky
#: factorisation took 84 s and 2.2 GB.
DIRECT_MAX = 50_000
#: CG stops when the preconditioned residual is below this fraction of the load's: the norms then equal the
#: factorised projections' to 1e-9 relative (tests/test_norms.py).
TOLERANCE = 1e-13
MAX_ITERATIONS = 2000
#: The shift of a singular G's diagonal in its multigrid (relative to the diagonal).
PRECONDITIONER_SHIFT = 1e-6
#: The shift of a singular G's diagonal for its factorisation, relative to the diagonal; `REFINEMENT_STEPS` of
#: iterative refinement with G then remove its effect on the projections.
SINGULAR_SHIFT, REFINEMENT_STEPS = 1e-10, 3

Solve = Callable[[ngs.BaseVector, ngs.BaseVector], None]


def gram_solver(gram: ngs.BaseMatrix, space: ngs.FESpace, used: np.ndarray,
                kernel: tuple[np.ndarray, slice | np.ndarray] | None) -> Solve:
    """load, out ↦ out = G⁺ load on the ``used`` dofs (a mask) of ``space``. ``kernel``: an orthonormal basis
    (columns) of G's kernel on the dofs it names, or None. CG where G has more than `DIRECT_MAX` used dofs and
    the mesh a refinement hierarchy whose coarsest level can be factorised, else Cholesky."""
    vertices = vertex_dofs(space)
    vertices = vertices[[bool(used[row[row >= 0]].any()) for row in vertices]]  # the unknowns G sees
    if used.sum() <= DIRECT_MAX or not has_hierarchy(space.mesh, len(vertices)):
        return _cholesky(gram, used, kernel is not None)
    return _conjugate_gradients(gram, space.ndof, used, kernel, vertices, vertex_levels(space.mesh))


def _cholesky(gram: ngs.BaseMatrix, used: np.ndarray, singular: bool) -> Solve:
    """A Cholesky factorisation of G, or if ``singular`` of G + `SINGULAR_SHIFT` diag(G) followed by
    `REFINEMENT_STEPS` of iterative refinement with G."""
    factorised = gram
    if singular:
        csr = to_scipy_csr(gram)
        factorised = to_ngsolve(csr + SINGULAR_SHIFT * sp.diags(csr.diagonal()))
    inverse = coarse_inverse(factorised, bits(used))

    def solve(load: ngs.BaseVector, out: ngs.BaseVector) -> None:
        out.data = inverse * load
        residual = load.CreateVector()
        for _ in range(REFINEMENT_STEPS if singular else 0):
            residual.data = load - gram * out
            out.data += inverse * residual

    return solve


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


def _conjugate_gradients(gram: ngs.BaseMatrix, ndof: int, used: np.ndarray,
                         kernel: tuple[np.ndarray, slice | np.ndarray] | None, vertices: np.ndarray,
                         levels: tuple[np.ndarray, list[int]]) -> Solve:
    """CG with `TwoLevel` (Gauss–Seidel on the used dofs, `Multigrid` on the used ``vertices``: unknowns ×
    vertices, component-major); the kernel, if any, cleared from the preconditioner's output."""
    csr = to_scipy_csr(gram)
    index = np.where(vertices >= 0, vertices, 0).ravel()
    free = (vertices >= 0).ravel() & used[index]
    block = csr[index][:, index]
    if kernel is not None:
        block = block + PRECONDITIONER_SHIFT * sp.diags(block.diagonal())
    cycle = Multigrid(to_ngsolve(block), bits(free), *levels)
    preconditioner = TwoLevel(gram, bits(used), vertex_gather(vertices, used), cycle)
    if kernel is not None:
        clear = _KernelClearing(*kernel, ndof)
        preconditioner = clear @ preconditioner @ clear
    solver = CGSolver(mat=gram, pre=preconditioner, tol=TOLERANCE, maxiter=MAX_ITERATIONS)

    def solve(load: ngs.BaseVector, out: ngs.BaseVector) -> None:
        out[:] = 0.0
        solver.Solve(rhs=load, sol=out, initialize=False)
        if solver.residuals[-1] > TOLERANCE * solver.residuals[0]:
            raise NotConverged(f"error norms: CG did not reach {TOLERANCE:g} in {MAX_ITERATIONS} iterations")
        solve.iterations.append(solver.iterations)  # type: ignore[attr-defined]

    solve.iterations = []  # type: ignore[attr-defined]
    solve.operators = (cycle, preconditioner)  # type: ignore[attr-defined]
    return solve


class _KernelClearing(ngs.BaseMatrix):
    """x ↦ x − K Kᵀ x on the ``dofs`` (a slice or an index array) of K's columns; the other dofs are copied."""

    def __init__(self, kernel: np.ndarray, dofs: slice | np.ndarray, size: int):
        super().__init__()
        self.kernel, self.dofs, self.size = kernel, dofs, size

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        values = x.FV().NumPy()[self.dofs]
        y.data = x
        y.FV().NumPy()[self.dofs] = values - self.kernel @ (self.kernel.T @ values)

    def IsComplex(self) -> bool:
        return False

    def Height(self) -> int:
        return self.size

    def Width(self) -> int:
        return self.size
