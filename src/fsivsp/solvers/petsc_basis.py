"""The pressure Laplacian F of `petsc_schur` in the Lagrange basis, for BoomerAMG: a pressure of degree 2 (Taylor–Hood
k = 2) in NGSolve's hierarchical basis, a vertex's hat function and an edge's quadratic bubble, makes F a poor matrix
for algebraic multigrid (its edge rows carry the smooth part of a vertex's value). With P the change of basis,
hierarchical coefficients = P × Lagrange coefficients (the values at the vertices and the edges' midpoints),

    F⁻¹ ≈ P (Pᵀ F P)⁻¹ Pᵀ,   P: identity on a vertex, on an edge e = (a, b) (u_e − (u_a + u_b)/2) / c,

c the bubble's value at its midpoint (`EDGE_MIDPOINT`), and BoomerAMG cycles on Pᵀ F P. The paper's case, Taylor–Hood
k = 2, Δt = 0.1, level 1 (issue 33's eleventh session): 15.3 iterations a step with F's cycles in this basis or F
solved exactly, 25.7 with the cycles in the hierarchical basis (docs/solvers.md, "F in the Lagrange basis").
"""
from __future__ import annotations

from collections.abc import Mapping

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..fem.spaces import Spaces
from .petsc_layout import from_summands
from .sparse import to_scipy_csr

#: The value of NGSolve's degree-2 edge function (hierarchical H1) at its edge's midpoint.
EDGE_MIDPOINT = -0.125


def takes_lagrange(spaces: Spaces, options: Mapping[str, str]) -> bool:
    """Whether the pressure Laplacian's AMG runs in the Lagrange basis: a pressure of degree 2 (Taylor–Hood k = 2),
    unless PETSc's ``options`` (`petsc.DEFAULTS` and the user's) say ``schur_laplacian_basis = "hierarchical"``."""
    return spaces.family == "taylor_hood" and spaces.order == 2 and options["schur_laplacian_basis"] == "lagrange"


def edge_ends(space: ngs.FESpace) -> tuple[np.ndarray, np.ndarray]:
    """(edges, ends) of a degree-2 H1 ``space`` (this rank's local dofs): each edge dof with its two vertex dofs
    (``ends``, shape (n, 2)), read from the pattern of the mass on the cells' edges (facets in 2D), where an edge's
    bubble meets only its own two ends' hat functions."""
    u, v = space.TnT()
    form = ngs.BilinearForm(space, check_unused=False)
    form += u * v * ngs.dx(element_vb=ngs.BND if space.mesh.dim == 2 else ngs.BBND)
    form.Assemble()
    pattern = sp.coo_matrix(to_scipy_csr(form.mat.local_mat if isinstance(form.mat, ngs.la.ParallelMatrix)
                                         else form.mat))
    vertices = space.mesh.nv
    keep = (pattern.row >= vertices) & (pattern.col < vertices) & (pattern.data != 0)
    rows, cols = pattern.row[keep], pattern.col[keep]
    order = np.lexsort((cols, rows))
    rows, cols = rows[order], cols[order]
    if len(rows) % 2 or np.any(rows[::2] != rows[1::2]):
        raise ValueError("a degree-2 edge dof not coupled to exactly two vertex dofs")
    return rows[::2], cols.reshape(-1, 2)


def lagrange_basis(solver, spaces: Spaces):
    """P of the module's docstring on the pressure field of ``solver`` (Q_h and, with a solid pressure, P_h), as a
    PETSc matrix in PETSc's order (collective under MPI): rows inserted by the dofs' masters alone."""
    L, X = solver.layout, spaces.mixed
    position = np.full(X.ndof, -1)
    position[L.local] = np.arange(len(L.local))
    rows, cols, values = [], [], []
    for index, space in enumerate((spaces.pressure, spaces.solid_pressure), start=1):
        if space is None:
            continue
        offset = X.Range(index).start
        mine = position[offset:offset + space.ndof]
        owned = (mine >= 0) & np.where(mine >= 0, L.master[mine], False)
        vertices = np.flatnonzero(owned[:space.mesh.nv])
        edges, ends = edge_ends(space)
        edges, ends = edges[owned[edges]], ends[owned[edges]]
        rows += [mine[vertices], mine[edges], mine[edges], mine[edges]]
        cols += [mine[vertices], mine[edges], mine[ends[:, 0]], mine[ends[:, 1]]]
        half = np.full(len(edges), -0.5 / EDGE_MIDPOINT)
        values += [np.ones(len(vertices)), np.full(len(edges), 1 / EDGE_MIDPOINT), half, half]
    rows, cols, values = np.concatenate(rows), np.concatenate(cols), np.concatenate(values)
    free = cols >= 0  # a vertex dof that is not free (none in Q_h, P_h as built) leaves its column out
    csr = sp.csr_matrix((values[free], (rows[free], cols[free])), shape=(len(L.local),) * 2)
    whole = from_summands(solver.PETSc, csr, L.numbers, L.rows[1] - L.rows[0], L.size)
    pressure = solver.fields[1]
    basis = whole.createSubMatrix(pressure, pressure)
    whole.destroy()
    return basis
