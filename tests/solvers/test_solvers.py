"""fsivsp.solvers on the scheme's step-1 saddle-point matrix (small meshes)."""
from __future__ import annotations

import ngsolve as ngs
import numpy as np
import pytest

from fsivsp.fem.forms import step_matrix
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import paper_channel, refined
from fsivsp.model.materials import Materials
from fsivsp.solvers import (
    METHODS,
    DirectSolver,
    SolverError,
    available_methods,
    default_method,
    free_mask,
    is_symmetric,
    to_scipy_csr,
)

ngs.ngsglobals.msg_level = 0


def _mesh(level):
    return refined(paper_channel(), level)


def _system(mesh, **storage):
    """The scheme's step-1 matrix on the paper's channel (MINI, Δt = 1e-2)."""
    spaces = build_spaces(mesh, "mini", dirichlet="solid_wall")
    return spaces.mixed, step_matrix(spaces, Materials(), 1e-2, **storage).Assemble()


STORAGES = {
    "symmetric": {"symmetric": True},
    "nonsymmetric": {"symmetric": False},
    "lower": {"symmetric": True, "symmetric_storage": True},
}


@pytest.fixture(scope="module")
def meshes():
    return {0: _mesh(0), 1: _mesh(1)}


@pytest.fixture(scope="module")
def systems(meshes):
    cache = {}

    def get(level=0, storage="symmetric"):
        key = (level, storage)
        if key not in cache:
            cache[key] = _system(meshes[level], **STORAGES[storage])
        return cache[key]

    return get


def _rhs(a, X, seed=7):
    b = a.mat.CreateColVector()
    b.FV().NumPy()[:] = np.random.default_rng(seed).standard_normal(len(b))
    return b


def _free_residual(a, X, b, x):
    mask = free_mask(X.FreeDofs(), a.mat.height)
    r = b.CreateVector()
    r.data = b - a.mat * x
    return np.linalg.norm(r.FV().NumPy()[mask]) / np.linalg.norm(b.FV().NumPy()[mask])


def test_available_and_default():
    avail = available_methods()
    assert set(avail) <= set(METHODS)
    # these ship with the NGSolve wheel and scipy
    assert {"umfpack", "sparsecholesky", "scipy"} <= set(avail)
    assert default_method() in avail
    if "pardiso" in avail:
        assert default_method() == "pardiso"
    else:
        assert default_method() == "umfpack"


def test_unknown_method():
    with pytest.raises(ValueError, match="unknown solver method"):
        DirectSolver(ngs.la.SparseMatrixd.CreateFromCOO([0], [0], [1.0], 1, 1), None, method="nope")


@pytest.mark.parametrize("storage", list(STORAGES))
@pytest.mark.parametrize("level", [0, 1])
@pytest.mark.parametrize("method", available_methods())
def test_each_method_solves(systems, method, level, storage):
    X, a = systems(level, storage)
    solver = DirectSolver(a.mat, X.FreeDofs(), method=method, rtol=1e-10)
    assert solver.method == method
    assert solver.residual < 1e-10
    assert solver.factor_seconds >= 0
    b = _rhs(a, X)
    x = a.mat.CreateColVector()
    solver.solve(b, x)
    assert _free_residual(a, X, b, x) < 1e-10
    # non-free dofs are zero
    mask = free_mask(X.FreeDofs(), a.mat.height)
    assert not np.any(x.FV().NumPy()[~mask])


@pytest.mark.parametrize("method", available_methods())
def test_inverse_composes_and_is_deterministic(systems, method):
    X, a = systems(1)
    solver = DirectSolver(a.mat, X.FreeDofs(), method=method)
    assert isinstance(solver.inverse, ngs.BaseMatrix)
    b = _rhs(a, X, seed=3)
    x1, x2, x3, x4 = (a.mat.CreateColVector() for _ in range(4))
    x1.data = solver.inverse * b
    x2.data = solver.inverse * b
    x3.data = solver * b
    solver.solve(b, x4)
    ref = x1.FV().NumPy()
    for x in (x2, x3, x4):
        assert np.array_equal(ref, x.FV().NumPy())
    # a second factorisation gives the identical result too, except for NGSolve's
    # sparsecholesky, whose factorisation differs between calls in the last bits
    # (measured: relative differences ~5e-16; under a TaskManager even two solves
    # with one factorisation differ)
    again = DirectSolver(a.mat, X.FreeDofs(), method=method)
    y = a.mat.CreateColVector()
    again.solve(b, y)
    if method == "sparsecholesky":
        assert np.linalg.norm(ref - y.FV().NumPy()) <= 1e-13 * np.linalg.norm(ref)
    else:
        assert np.array_equal(ref, y.FV().NumPy())
        assert again.residual == solver.residual


@pytest.mark.parametrize("storage", ["symmetric", "lower"])
def test_scipy_equals_ngsolve(systems, storage):
    X, a = systems(1, storage)
    b = _rhs(a, X, seed=11)
    xs = a.mat.CreateColVector()
    DirectSolver(a.mat, X.FreeDofs(), method="scipy").solve(b, xs)
    for method in ("umfpack", "sparsecholesky", "pardiso"):
        if method not in available_methods():
            continue
        xn = a.mat.CreateColVector()
        DirectSolver(a.mat, X.FreeDofs(), method=method).solve(b, xn)
        diff = np.linalg.norm(xs.FV().NumPy() - xn.FV().NumPy()) / np.linalg.norm(xn.FV().NumPy())
        assert diff < 1e-10, (method, diff)


def test_csr_conversion_symmetrises_lower_storage(systems):
    import scipy.sparse as sp

    X, full = systems(0, "symmetric")
    _, lower = systems(0, "lower")
    vals, cols, rowptr = lower.mat.CSR()
    raw = sp.csr_matrix((np.array(vals), np.array(cols), np.array(rowptr)), shape=lower.mat.shape)
    assert sp.triu(raw, 1).nnz == 0 and sp.tril(raw, -1).nnz > 0  # really only the lower triangle
    A_lower = to_scipy_csr(lower.mat)
    A_full = to_scipy_csr(full.mat)
    assert abs(A_lower - A_full).max() < 1e-14 * abs(A_full).max()
    assert abs(A_lower - A_lower.T).max() == 0
    x = lower.mat.CreateColVector()
    x.FV().NumPy()[:] = np.arange(len(x)) % 7 - 3.0
    y = x.CreateVector()
    y.data = lower.mat * x
    assert np.allclose(A_lower @ x.FV().NumPy(), y.FV().NumPy(), rtol=0, atol=1e-13)


def test_is_symmetric(systems):
    _, a = systems(0, "symmetric")
    _, lower = systems(0, "lower")
    assert is_symmetric(a.mat) and is_symmetric(lower.mat)
    nonsym = ngs.la.SparseMatrixd.CreateFromCOO([0, 0, 1, 1], [0, 1, 0, 1], [2.0, 1.0, 0.5, 2.0], 2, 2)
    assert not is_symmetric(nonsym)


def _nonsymmetric_matrix(n=30):
    # nonsymmetric values on a symmetric pattern (like any FE matrix; NGSolve's
    # pardiso wrapper rejects structurally nonsymmetric patterns)
    rng = np.random.default_rng(0)
    dense = rng.standard_normal((n, n)) + n * np.eye(n)
    dense[(np.abs(dense) < 0.8) & (np.abs(dense.T) < 0.8)] = 0.0
    rows, cols = np.nonzero(dense)
    return ngs.la.SparseMatrixd.CreateFromCOO(rows.tolist(), cols.tolist(), dense[rows, cols].tolist(), n, n)


def test_nonsymmetric_matrix_solved_correctly():
    # a pivoting method must not assume symmetry (e.g. pardiso's symmetric type)
    mat = _nonsymmetric_matrix()
    assert not is_symmetric(mat)
    for method in set(available_methods()) & {"pardiso", "umfpack", "scipy"}:
        solver = DirectSolver(mat, None, method=method, rtol=1e-12)
        assert solver.residual < 1e-12
    # sparsecholesky silently uses one triangle: the residual check catches it
    with pytest.raises(SolverError, match="sparsecholesky: residual check failed"):
        DirectSolver(mat, None, method="sparsecholesky")


def test_singular_matrix_raises(systems):
    # all dofs "free": the pressure dofs outside the fluid and the Dirichlet rows
    # without equations leave zero rows, so the matrix is singular
    X, a = systems(0)
    allfree = ngs.BitArray(a.mat.height)
    allfree.Set()
    for method in available_methods():
        with pytest.raises(SolverError, match=method):
            DirectSolver(a.mat, allfree, method=method)


def test_sparsecholesky_breaks_down_on_zero_pivot():
    # [[0, 1], [1, 0]] is symmetric indefinite: LDL^T without pivoting meets a zero pivot
    mat = ngs.la.SparseMatrixd.CreateFromCOO([0, 0, 1, 1], [0, 1, 0, 1], [0.0, 1.0, 1.0, 0.0], 2, 2)
    with pytest.raises(SolverError, match="sparsecholesky"):
        DirectSolver(mat, None, method="sparsecholesky")
    # the pivoting methods solve it
    for method in set(available_methods()) & {"pardiso", "umfpack", "scipy"}:
        assert DirectSolver(mat, None, method=method).residual < 1e-14


def test_residual_check_reports_method_and_residual(systems):
    X, a = systems(0)
    with pytest.raises(SolverError, match=r"umfpack: residual check failed, .* = \d\.\d+e-\d+"):
        DirectSolver(a.mat, X.FreeDofs(), method="umfpack", rtol=1e-30)
    unchecked = DirectSolver(a.mat, X.FreeDofs(), method="umfpack", check=False)
    assert np.isnan(unchecked.residual)


@pytest.mark.parametrize("method", available_methods())
def test_lower_storage_spd(method):
    # NGSolve's own UMFPACK inverse silently solves with the lower triangle only on
    # symmetric storage (residual ~1 on this SPD matrix); DirectSolver must not
    from netgen.geom2d import unit_square

    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.3))
    V = ngs.H1(mesh, order=1)
    u, v = V.TnT()
    a = ngs.BilinearForm(V, symmetric=True, symmetric_storage=True)
    a += (u * v + ngs.grad(u) * ngs.grad(v)) * ngs.dx
    a.Assemble()
    assert DirectSolver(a.mat, V.FreeDofs(), method=method).residual < 1e-12


def test_factorise_falls_back_and_reports_a_singular_matrix():
    from fsivsp.solvers import factorise

    X, a = _system(_mesh(0))
    solver = factorise(a.mat, X.FreeDofs())
    assert solver.residual < 1e-10
    free = X.FreeDofs()
    everything = ngs.BitArray(len(free))
    everything.Set()  # pressure dofs outside the fluid have empty rows: singular
    with pytest.raises(SolverError, match="no direct solver passed"):
        factorise(a.mat, everything)


def test_factorise_never_changes_method_silently(monkeypatch, capsys):
    """A forced residual failure of the preferred method (PARDISO, and PARDISO retried with refinement steps)
    is one line on stderr naming both methods and the residual, and is recorded in `statistics`."""
    from fsivsp.solvers import direct, factorise

    X, a = _system(_mesh(0))
    preferred = [m for m in direct.METHODS if m in direct.PIVOTING_METHODS and m in available_methods()]
    failing = 2 if preferred[0] == "pardiso" else 1
    real, calls = direct._free_residual, []

    def forced(*args, **kwargs):
        calls.append(1)
        return 1e-3 if len(calls) <= failing else real(*args, **kwargs)

    monkeypatch.setattr(direct, "_free_residual", forced)
    solver = factorise(a.mat, X.FreeDofs())
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and preferred[0] in lines[0] and solver.method in lines[0] and "1.00e-03" in lines[0]
    assert solver.method == preferred[1] and solver.residual < 1e-10
    fallback = solver.statistics()["fallback"]
    assert fallback["from"] == preferred[0] and fallback["residual"] == 1e-3


def test_factorise_retries_pardiso_with_refinement_in_one_line(monkeypatch, capsys):
    """A forced failure of PARDISO's first check is retried with the same factors' refinement steps: one
    line on stderr names both, and `statistics` keeps the fallback and the residual before the refinement."""
    from fsivsp.solvers import direct, factorise

    if "pardiso" not in available_methods():
        pytest.skip("needs MKL PARDISO")
    X, a = _system(_mesh(0))
    real, calls = direct._free_residual, []

    def forced(*args, **kwargs):
        calls.append(1)
        return 1e-3 if len(calls) == 1 else real(*args, **kwargs)

    factorisations = []
    original = direct.DirectSolver._factorise
    monkeypatch.setattr(direct.DirectSolver, "_factorise",
                        lambda self, options: factorisations.append(self.method) or original(self, options))
    monkeypatch.setattr(direct, "_free_residual", forced)
    solver = factorise(a.mat, X.FreeDofs())
    lines = capsys.readouterr().err.strip().splitlines()
    how = f"pardiso with {direct.RETRY_REFINEMENT_STEPS} refinement steps"
    assert len(lines) == 1 and lines[0].startswith("warning: direct solver: pardiso failed (residual 1.00e-03)")
    assert how in lines[0]
    assert factorisations == ["pardiso"]                       # the retry refines the same factors
    stats = solver.statistics()
    assert stats["fallback"]["to"] == how and stats["fallback"]["residual"] == 1e-3 and stats["residual"] < 1e-12
    assert stats["refinement"]["steps"] == direct.RETRY_REFINEMENT_STEPS
    assert stats["refinement"]["residual_before"] < 1e-8      # the factors' own residual, checked again


@pytest.fixture(scope="module")
def wall_pressure_system():
    """The peer case's step matrix (examples/peer_hdg_example1.toml: Taylor–Hood k = 2, Δt = 1/1024, level 0,
    105 free dofs), whose fluid has a Dirichlet wall: the pressure dofs there have zero pivots unless
    PARDISO pairs them with velocity dofs (matching)."""
    from pathlib import Path

    from fsivsp.config.case import load_study_case
    from fsivsp.experiments.study import dirichlet_boundaries
    from fsivsp.solvers import compact

    case = load_study_case(Path(__file__).resolve().parents[2] / "examples" / "peer_hdg_example1.toml")
    mesh = case.coarse_mesh()
    spaces = build_spaces(mesh, "taylor_hood", 2, dirichlet_boundaries(mesh))
    matrix = step_matrix(spaces, case.materials, case.time_scheme.tau(1 / 1024)).Assemble().mat
    return compact(matrix), spaces.mixed.FreeDofs()


@pytest.mark.skipif("pardiso" not in available_methods(), reason="needs MKL PARDISO")
def test_pardiso_matching_and_refinement_reach_roundoff(wall_pressure_system):
    """Without matching PARDISO perturbs pivots and misses round-off (1.8e-11 measured); one refinement step
    of those factors, or matching (which the default takes here, for the perturbed pivots), reaches it."""
    matrix, free = wall_pressure_system
    plain = DirectSolver(matrix, free, method="pardiso", options={"matching": False})
    assert plain.perturbed_pivots > 0 and plain.residual > 5e-12
    refined = DirectSolver(matrix, free, method="pardiso", options={"matching": False}, refinement=1)
    assert refined.residual < 1e-12 and refined.residual_unrefined == plain.residual
    assert refined.statistics()["refinement"] == {"steps": 1, "residual_before": plain.residual}
    matched = DirectSolver(matrix, free, method="pardiso")
    assert matched.perturbed_pivots == 0 and matched.residual < 1e-12
    stats = matched.statistics()
    assert stats["perturbed_pivots"] == 0 and stats["matching"] is True and "refinement" not in stats
    b, x, y, zero = (matrix.CreateColVector() for _ in range(4))
    b.FV().NumPy()[:] = np.random.default_rng(5).standard_normal(len(b))
    zero[:] = 0.0
    refined.solve(b, x)
    refined.solve_step(b, zero, y)  # the same solve through MultAdd
    assert np.array_equal(x.FV().NumPy(), y.FV().NumPy())


@pytest.mark.skipif("pardiso" not in available_methods(), reason="needs MKL PARDISO")
def test_pardiso_matches_only_where_pivots_are_perturbed(systems):
    """The paper's channel (no fluid Dirichlet wall) perturbs no pivot: the default factorises without
    matching (which adds fill there), the same factors as ``matching = False``."""
    X, a = systems(1)
    default = DirectSolver(a.mat, X.FreeDofs(), method="pardiso")
    plain = DirectSolver(a.mat, X.FreeDofs(), method="pardiso", options={"matching": False})
    assert default.statistics()["matching"] is False and default.perturbed_pivots == 0
    assert default.residual == plain.residual


@pytest.mark.skipif("pardiso" not in available_methods(), reason="needs MKL PARDISO")
@pytest.mark.parametrize("symmetric", [True, False])
def test_pardiso_gives_ngsolves_binding_bits(systems, symmetric):
    """`solvers.pardiso` calls MKL's interface with NGSolve's binding's parameters: the same solution bit for bit
    (the binding's own inverse, without matching, which it leaves off for a symmetric matrix; PARDISO's symmetric
    indefinite type and its general one)."""
    from pyngcore import Flags

    X, a = systems(1, "nonsymmetric")
    ours = DirectSolver(a.mat, X.FreeDofs(), method="pardiso", options={"matching": False, "symmetric": symmetric})
    flags = {"ordering": "minimum_degree", "refinement": 0, "symmetric": symmetric}
    theirs = a.mat.Inverse(X.FreeDofs(), inverse="pardiso", flags=Flags(flags))
    b, x, y = _rhs(a, X), a.mat.CreateColVector(), a.mat.CreateColVector()
    x.data = ours.inverse * b
    y.data = theirs * b
    assert np.array_equal(x.FV().NumPy(), y.FV().NumPy())


@pytest.mark.skipif("pardiso" not in available_methods(), reason="needs MKL PARDISO")
@pytest.mark.parametrize("symmetric", [True, False])
def test_pardiso_solves_a_complex_symmetric_matrix(meshes, symmetric):
    """A harmonic step's kind of matrix (complex symmetric: PARDISO's type 6, or its general 13): iωρM + K on a
    complex velocity space; the solution of UMFPACK's LU to round-off, zero on the Dirichlet dofs."""
    from fsivsp.solvers.pardiso import Pardiso

    V = ngs.VectorH1(meshes[1], order=2, dirichlet="solid_wall", complex=True)
    u, w = V.TnT()
    a = ngs.BilinearForm(V)
    a += (2j * np.pi * 3.0 * u * w + ngs.InnerProduct(ngs.Grad(u), ngs.Grad(w))) * ngs.dx
    a.Assemble()
    b, x, y = a.mat.CreateColVector(), a.mat.CreateColVector(), a.mat.CreateColVector()
    rng = np.random.default_rng(3)
    b.FV().NumPy()[:] = rng.standard_normal(len(b)) + 1j * rng.standard_normal(len(b))
    x.data = Pardiso(a.mat, V.FreeDofs(), symmetric=symmetric) * b
    y.data = a.mat.Inverse(V.FreeDofs(), inverse="umfpack") * b
    assert np.abs(x.FV().NumPy() - y.FV().NumPy()).max() < 1e-11 * np.abs(y.FV().NumPy()).max()
    free = np.fromiter(V.FreeDofs(), dtype=bool, count=V.ndof)
    assert not free.all() and np.all(x.FV().NumPy()[~free] == 0)
