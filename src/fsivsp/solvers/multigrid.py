"""Geometric multigrid for the continuous P1 velocity block, over the uniform refinement hierarchy.

fsivsp refines meshes by red refinement (`geometry.refined`): the vertices of level l − 1 keep their numbers
on level l, and every new vertex has two parents (`Mesh.GetParentVertices`). That is all a Galerkin hierarchy
needs: the prolongation P_l copies the old vertices and averages the parents for the new ones, the coarse
operators are A_{l−1} = P_lᵀ A_l P_l (NGSolve's sparse products), the smoother is Gauss–Seidel forward before
and backward after the coarse correction (a symmetric V-cycle), and the coarsest level is factorised. The
d velocity components are kept coupled (the ε:ε and div div of the step), which component-wise AMG is not:
on the paper's experiment the coupled P1 block needs 56, 56, 55 MinRes iterations on levels 1–3, the
component-wise blocks 76, 89, 94 even when inverted exactly.
"""
from __future__ import annotations

import numpy as np
import ngsolve as ngs

#: Gauss–Seidel sweeps before and after the coarse correction.
SMOOTHING = 2  # V(2,2): 56, 71, 79 MinRes iterations on levels 1-3 of the paper; V(1,1) 61, 86, 104; V(3,3) 56, 69, 74

#: The coarsest level must have at most this many free unknowns to be factorised (else no multigrid).
COARSE_MAX_DOFS = 60_000


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


class Multigrid(ngs.BaseMatrix):
    """A symmetric V-cycle for ``matrix`` (the P1 velocity block, component-major, ``freedofs`` free) over the
    hierarchy ``parents``, ``counts`` of `vertex_levels`."""

    def __init__(self, matrix: ngs.BaseMatrix, freedofs: ngs.BitArray, parents: np.ndarray, counts: list[int]):
        super().__init__()
        dim = matrix.height // counts[-1]
        free = np.fromiter(freedofs, dtype=bool, count=matrix.height)
        vertex_free = free.reshape(dim, -1)
        self.matrices, self.prolongations, self.restrictions, self.smoothers = [matrix], [], [], []
        self.frees = [freedofs]
        for coarse, fine in zip(counts[-2::-1], counts[:0:-1]):
            free_coarse = vertex_free[:, :coarse].ravel()
            prolongation = _prolongation(parents, coarse, fine, dim, vertex_free[:, :fine].ravel(), free_coarse)
            restriction = prolongation.CreateTranspose()
            self.matrices.append(restriction @ (self.matrices[-1] @ prolongation))
            self.prolongations.append(prolongation)
            self.restrictions.append(restriction)
            self.frees.append(ngs.BitArray(free_coarse.tolist()))
        self.smoothers = [a.CreateSmoother(f) for a, f in zip(self.matrices[:-1], self.frees[:-1])]
        self.coarse = self.matrices[-1].Inverse(self.frees[-1], inverse="sparsecholesky")
        self.levels = len(self.matrices)
        self._vectors = [(a.CreateColVector(), a.CreateColVector()) for a in self.matrices]

    def _cycle(self, level: int, rhs: ngs.BaseVector, out: ngs.BaseVector) -> None:
        if level == self.levels - 1:
            out.data = self.coarse * rhs
            return
        matrix, smoother = self.matrices[level], self.smoothers[level]
        residual = self._vectors[level][0]
        coarse_rhs, coarse_out = self._vectors[level + 1]
        out[:] = 0.0
        for _ in range(SMOOTHING):
            smoother.Smooth(out, rhs)
        residual.data = rhs - matrix * out
        coarse_rhs.data = self.restrictions[level] * residual
        self._cycle(level + 1, coarse_rhs, coarse_out)
        out.data += self.prolongations[level] * coarse_out
        for _ in range(SMOOTHING):
            smoother.SmoothBack(out, rhs)

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        self._cycle(0, x, y)

    def IsComplex(self) -> bool:
        return False

    def Height(self) -> int:
        return self.matrices[0].height

    def Width(self) -> int:
        return self.matrices[0].width

    def CreateColVector(self) -> ngs.BaseVector:
        return self.matrices[0].CreateColVector()

    def CreateRowVector(self) -> ngs.BaseVector:
        return self.matrices[0].CreateRowVector()
