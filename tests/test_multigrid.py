"""The geometric multigrid of the iterative solver (`fsivsp.solvers.multigrid`) against a plain scipy V-cycle
built from the same hierarchy: Galerkin coarse operators, forward Gauss–Seidel before and backward after the
coarse correction, the coarsest level solved exactly."""
import numpy as np
import ngsolve as ngs
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fsivsp.forms import velocity_block
from fsivsp.geometry import refined
from fsivsp.paper import paper_case
from fsivsp.solvers import to_scipy_csr
from fsivsp.solvers.multigrid import Multigrid, vertex_levels
from fsivsp.spaces import build_spaces
from fsivsp.study import dirichlet_boundaries


def p1_velocity_block(level: int):
    """The P1 velocity block of the paper's step (Δt = 1e-2) on level ``level`` and its free dofs."""
    case = paper_case(1e-2)
    mesh = refined(case.coarse_mesh(), level, False)
    spaces = build_spaces(mesh, "mini", 1, dirichlet_boundaries(mesh))
    p1 = ngs.VectorH1(mesh, order=1, dirichlet=spaces.dirichlet)
    form = ngs.BilinearForm(p1)
    form += velocity_block(*p1.TnT(), spaces, case.materials, case.dt)
    form.Assemble()
    return mesh, form, p1.FreeDofs()


def scipy_cycle(matrices, prolongations, frees, smoothing, rhs):
    """The symmetric V-cycle, written out with scipy on the free dofs of each level."""
    def solve(level, b):
        a, f = matrices[level], frees[level]
        x = np.zeros_like(b)
        if level == len(matrices) - 1:
            x[f] = spla.spsolve(a[f][:, f].tocsc(), b[f])
            return x
        lower = sp.tril(a[f][:, f]).tocsr()
        upper = sp.triu(a[f][:, f]).tocsr()
        for _ in range(smoothing):
            x[f] += spla.spsolve_triangular(lower, b[f] - a[f] @ x, lower=True)
        p = prolongations[level]
        x += p @ solve(level + 1, p.T @ (b - a @ x))
        for _ in range(smoothing):
            x[f] += spla.spsolve_triangular(upper, b[f] - a[f] @ x, lower=False)
        return x
    return solve(0, rhs)


@pytest.mark.parametrize("smoothing, iterations", [(1, 1), (2, 1), (4, 2)])
def test_cycle_equals_a_plain_v_cycle(smoothing, iterations):
    """Four levels (level 3 of the paper's mesh): the cycle's every level, not only the finest and the coarsest;
    ``iterations`` V-cycles, each on the residual of the ones before."""
    mesh, form, free = p1_velocity_block(3)
    cycle = Multigrid(form.mat, free, *vertex_levels(mesh), smoothing=smoothing, iterations=iterations)
    assert cycle.levels == 4
    matrices = [to_scipy_csr(a, verify=False) for a in cycle.matrices]
    prolongations = [to_scipy_csr(p, verify=False) for p in cycle.prolongations]
    for fine, coarse, p in zip(matrices, matrices[1:], prolongations):
        assert abs(p.T @ fine @ p - coarse).max() <= 1e-12 * abs(coarse).max()
    frees = [np.fromiter(f, dtype=bool, count=a.shape[0]) for f, a in zip(cycle.frees, matrices)]
    rhs = np.random.default_rng(0).standard_normal(matrices[0].shape[0]) * frees[0]
    x, y = cycle.CreateColVector(), cycle.CreateColVector()
    x.FV().NumPy()[:] = rhs
    y.data = cycle * x
    expected = scipy_cycle(matrices, prolongations, frees, smoothing, rhs)
    for _ in range(iterations - 1):
        expected += scipy_cycle(matrices, prolongations, frees, smoothing, rhs - matrices[0] @ expected)
    assert np.abs(y.FV().NumPy() - expected).max() <= 1e-10 * np.abs(expected).max()
