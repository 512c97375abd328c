"""Geometric multigrid over the uniform refinement hierarchy: the V-cycle of a P1 (vertex) block, and a
two-level cycle that puts a whole H1-type space (bubbles, edge, face and cell dofs) above it.

fsivsp refines meshes by red refinement (`geometry.refined`): the vertices of level l − 1 keep their numbers
on level l, and every new vertex has two parents (`Mesh.GetParentVertices`). That is all a Galerkin hierarchy
needs: the prolongation P_l copies the old vertices and averages the parents for the new ones, the coarse
operators are A_{l−1} = P_lᵀ A_l P_l (NGSolve's sparse products), the smoother is Gauss–Seidel forward before
and backward after the coarse correction (a symmetric V-cycle), and the coarsest level is factorised
(`symmetric.factorised`). The d velocity components are kept coupled (the ε:ε and div div of the step).

On a higher-order space (MINI's bubbles, Taylor–Hood's P_{k+1}) `TwoLevel` smooths the whole space by
Gauss–Seidel and corrects with the V-cycle of its vertex block: in NGSolve's hierarchical H1 basis the vertex
functions are the P1 hat functions, so that block is the P1 operator of the same form.
"""
from __future__ import annotations

import numpy as np
import ngsolve as ngs

from .symmetric import factorised

#: Gauss–Seidel sweeps before and after the coarse correction (the velocity: V(2,2)). On the paper's
#: experiment (levels 1–4, first step, tolerance 1e-10) MinRes needs 20, 23, 28, 34 iterations with V(2,2) and
#: 20, 22, 26, 31 with V(4,4), whose cycle costs nearly twice as much.
SMOOTHING = 2

#: The coarsest level must have at most this many free unknowns to be factorised (else no multigrid).
COARSE_MAX_DOFS = 60_000


def bits(mask: np.ndarray) -> ngs.BitArray:
    """A boolean mask as NGSolve's ``BitArray`` (free dofs, used dofs)."""
    return ngs.BitArray(mask.tolist())


def vertex_levels(mesh: ngs.Mesh) -> tuple[np.ndarray, list[int]]:
    """The parents of every vertex (−1 for none) and the vertex counts of the refinement levels, coarsest
    first: level l's new vertices follow level l − 1's and have both parents among them. Kept on the mesh (the
    step's preconditioner and every error norm ask for it; fsivsp never refines a mesh in place)."""
    cached = getattr(mesh, "_vertex_levels", None)
    if cached is None:
        cached = _vertex_levels(mesh)
        cached[0].flags.writeable = False
        mesh._vertex_levels = cached
    return cached


def _vertex_levels(mesh: ngs.Mesh) -> tuple[np.ndarray, list[int]]:
    parents = np.array([mesh.GetParentVertices(v) for v in range(mesh.nv)], dtype=np.int64).reshape(-1, 2)
    youngest = parents.max(axis=1)  # a vertex of level l has a parent of level l − 1 (every old edge is split)
    counts = [int(np.argmax(youngest >= 0)) if (youngest >= 0).any() else mesh.nv]
    while counts[-1] < mesh.nv:
        newer = np.flatnonzero(youngest[counts[-1]:] >= counts[-1])
        counts.append(counts[-1] + int(newer[0]) if len(newer) else mesh.nv)
    return parents, counts


def has_hierarchy(mesh: ngs.Mesh, unknowns: int = 1) -> bool:
    """Whether the mesh was refined and its coarsest level, with ``unknowns`` per vertex, can be factorised."""
    counts = vertex_levels(mesh)[1]
    return len(counts) > 1 and unknowns * counts[0] <= COARSE_MAX_DOFS


def _prolongation(parents: np.ndarray, coarse: int, fine: int, dim: int, free_fine: np.ndarray,
                  free_coarse: np.ndarray) -> ngs.BaseMatrix:
    """P: the d-vector P1 values on ``coarse`` vertices to ``fine`` ones (component-major), free dofs only."""
    old = np.arange(coarse)
    new = np.arange(coarse, fine)
    rows = np.concatenate([old, new, new])
    cols = np.concatenate([old, parents[coarse:fine, 0], parents[coarse:fine, 1]])
    vals = np.concatenate([np.ones(coarse), np.full(2 * (fine - coarse), 0.5)])
    rows = np.concatenate([rows + j * fine for j in range(dim)])
    cols = np.concatenate([cols + j * coarse for j in range(dim)])
    vals = np.tile(vals, dim)
    keep = free_fine[rows] & free_coarse[cols]
    return ngs.la.SparseMatrixd.CreateFromCOO(rows[keep], cols[keep], vals[keep], dim * fine, dim * coarse)


class _Operator(ngs.BaseMatrix):
    """A real BaseMatrix with the shape and vectors of the sparse matrix ``self.shape_of``."""

    shape_of: ngs.BaseMatrix

    def IsComplex(self) -> bool:
        return False

    def Height(self) -> int:
        return self.shape_of.height

    def Width(self) -> int:
        return self.shape_of.width

    def CreateColVector(self) -> ngs.BaseVector:
        return self.shape_of.CreateColVector()

    def CreateRowVector(self) -> ngs.BaseVector:
        return self.shape_of.CreateRowVector()


class GaussSeidel:
    """Point Gauss–Seidel sweeps on the ``free`` dofs (a mask) of a sparse matrix, forward and backward, for
    iterates that are zero off those dofs (as in every cycle here). NGSolve's backward sweep (``SmoothBack``) runs
    about 3x slower than its forward one (19.4 against 6.0 ms on the velocity block of the 3D fluid ball's level
    3), so the backward sweep is a forward one on a copy of the free block in reversed numbering."""

    def __init__(self, matrix: ngs.BaseMatrix, free: np.ndarray):
        from .sparse import to_ngsolve, to_scipy_csr

        self._forward = matrix.CreateSmoother(bits(free))
        self._reversed = np.flatnonzero(free)[::-1].copy()
        block = to_scipy_csr(matrix, verify=False)[self._reversed][:, self._reversed]
        self._reversed_matrix = to_ngsolve(block.tocsr())
        self._backward = self._reversed_matrix.CreateSmoother()
        self._x, self._b = self._reversed_matrix.CreateColVector(), self._reversed_matrix.CreateColVector()

    def forward(self, x: ngs.BaseVector, b: ngs.BaseVector) -> None:
        self._forward.Smooth(x, b)

    def backward(self, x: ngs.BaseVector, b: ngs.BaseVector) -> None:
        values = x.FV().NumPy()
        self._x.FV().NumPy()[:] = values[self._reversed]
        self._b.FV().NumPy()[:] = b.FV().NumPy()[self._reversed]
        self._backward.Smooth(self._x, self._b)
        values[self._reversed] = self._x.FV().NumPy()


class _BlockGaussSeidel:
    """Block Gauss–Seidel sweeps over the dof sets ``blocks``, forward and backward (NGSolve's block smoother)."""

    def __init__(self, matrix: ngs.BaseMatrix, blocks: list[list[int]]):
        self._smoother = matrix.CreateBlockSmoother(blocks)

    def forward(self, x: ngs.BaseVector, b: ngs.BaseVector) -> None:
        self._smoother.Smooth(x, b)

    def backward(self, x: ngs.BaseVector, b: ngs.BaseVector) -> None:
        self._smoother.SmoothBack(x, b)


class Multigrid(_Operator):
    """A symmetric V-cycle for ``matrix`` (a P1 block on the vertices, unknowns component-major, ``freedofs``
    free) over the hierarchy ``parents``, ``counts`` of `vertex_levels`, ``smoothing`` Gauss–Seidel sweeps
    before and after each coarse correction; ``iterations`` > 1 repeats it on the residual (x ← x + V(b − A x),
    still symmetric)."""

    def __init__(self, matrix: ngs.BaseMatrix, freedofs: ngs.BitArray, parents: np.ndarray, counts: list[int],
                 smoothing: int = SMOOTHING, iterations: int = 1):
        super().__init__()
        self.shape_of, self.smoothing, self.iterations = matrix, smoothing, iterations
        dim = matrix.height // counts[-1]
        free = np.fromiter(freedofs, dtype=bool, count=matrix.height)
        vertex_free = free.reshape(dim, -1)
        self.matrices, self.prolongations, self.restrictions = [matrix], [], []
        self.frees = [freedofs]
        for coarse, fine in zip(counts[-2::-1], counts[:0:-1]):
            free_coarse = vertex_free[:, :coarse].ravel()
            prolongation = _prolongation(parents, coarse, fine, dim, vertex_free[:, :fine].ravel(), free_coarse)
            restriction = prolongation.CreateTranspose()
            self.matrices.append(restriction @ (self.matrices[-1] @ prolongation))
            self.prolongations.append(prolongation)
            self.restrictions.append(restriction)
            self.frees.append(bits(free_coarse))
        self.smoothers = [GaussSeidel(a, np.fromiter(f, dtype=bool, count=a.height))
                          for a, f in zip(self.matrices[:-1], self.frees[:-1])]
        self.coarse = factorised(self.matrices[-1], self.frees[-1])
        self.levels = len(self.matrices)
        #: per level: its right-hand side and solution (the level above fills them) and its own residual
        self._vectors = [(a.CreateColVector(), a.CreateColVector(), a.CreateColVector()) for a in self.matrices]
        self._outer = (matrix.CreateColVector(), matrix.CreateColVector())   # the residual and correction of a repeat

    def _cycle(self, level: int, rhs: ngs.BaseVector, out: ngs.BaseVector) -> None:
        if level == self.levels - 1:
            out.data = self.coarse * rhs
            return
        matrix, smoother = self.matrices[level], self.smoothers[level]
        residual = self._vectors[level][2]
        coarse_rhs, coarse_out, _ = self._vectors[level + 1]
        out[:] = 0.0
        for _ in range(self.smoothing):
            smoother.forward(out, rhs)
        residual.data = rhs - matrix * out
        coarse_rhs.data = self.restrictions[level] * residual
        self._cycle(level + 1, coarse_rhs, coarse_out)
        out.data += self.prolongations[level] * coarse_out
        for _ in range(self.smoothing):
            smoother.backward(out, rhs)

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        self._cycle(0, x, y)
        for _ in range(self.iterations - 1):
            self._outer[0].data = x - self.shape_of * y
            self._cycle(0, self._outer[0], self._outer[1])
            y.data += self._outer[1]


def vertex_gather(vertex_dofs: np.ndarray, free: np.ndarray) -> ngs.BaseMatrix:
    """G: a space's vector to its vertex block, unknowns component-major (``vertex_dofs``: the space's dof of
    each (unknown, vertex), −1 for none), the free dofs (mask ``free`` of the space) only."""
    index = np.where(vertex_dofs >= 0, vertex_dofs, 0).ravel()
    rows = np.flatnonzero((vertex_dofs >= 0).ravel() & free[index])
    return ngs.la.SparseMatrixd.CreateFromCOO(rows, index[rows], np.ones(len(rows)), len(index), len(free))


def vertex_block(matrix: ngs.BaseMatrix, gather: ngs.BaseMatrix) -> ngs.BaseMatrix:
    """G A Gᵀ, the vertex block of ``matrix`` (a sparse matrix)."""
    return gather @ (matrix @ gather.CreateTranspose())


class TwoLevel(_Operator):
    """A symmetric two-level cycle for ``matrix`` on its ``freedofs``: ``steps`` Gauss–Seidel sweeps on the
    whole space (point by point, or over the dof sets ``blocks`` if given), the correction Gᵀ C G r of its
    vertex block (``gather`` G, `vertex_gather`; ``coarse`` C ≈ (G A Gᵀ)⁻¹, e.g. its `Multigrid`), and the
    sweeps back. Only the free dofs are touched: ``matrix`` may be the whole step matrix, and ``freedofs`` its
    velocity."""

    def __init__(self, matrix: ngs.BaseMatrix, freedofs: ngs.BitArray, gather: ngs.BaseMatrix,
                 coarse: ngs.BaseMatrix, steps: int = SMOOTHING, blocks: list[list[int]] | None = None):
        super().__init__()
        self.shape_of, self.steps = matrix, steps
        self.gather, self.scatter, self.coarse = gather, gather.CreateTranspose(), coarse
        self.smoother = GaussSeidel(matrix, np.fromiter(freedofs, dtype=bool, count=matrix.height)) if blocks is None \
            else _BlockGaussSeidel(matrix, blocks)
        self._residual = matrix.CreateColVector()
        self._coarse_rhs, self._coarse_out = gather.CreateColVector(), gather.CreateColVector()

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        y[:] = 0.0
        for _ in range(self.steps):
            self.smoother.forward(y, x)
        self._residual.data = x - self.shape_of * y
        self._coarse_rhs.data = self.gather * self._residual
        self._coarse_out.data = self.coarse * self._coarse_rhs
        y.data += self.scatter * self._coarse_out
        for _ in range(self.steps):
            self.smoother.backward(y, x)


def algebraic_multigrid(mesh: ngs.Mesh, integrand, dirichlet: str, definedon: str | None = None):
    """NGSolve's ``h1amg`` for ∫ integrand(u, w) on continuous P1 (the vertex dofs of any H1 space, in vertex
    order), where the mesh has no refinement hierarchy; and what must stay alive with it."""
    from ..threads import sequential

    with sequential():   # the same colouring and hierarchy in every process (under threads they vary)
        p1 = ngs.H1(mesh, order=1, dirichlet=dirichlet, definedon=definedon) if definedon else \
            ngs.H1(mesh, order=1, dirichlet=dirichlet)
        form = ngs.BilinearForm(p1)
        form += integrand(*p1.TnT())
        amg = ngs.Preconditioner(form, "h1amg")
        form.Assemble()
    return amg.mat, (p1, form, amg)

