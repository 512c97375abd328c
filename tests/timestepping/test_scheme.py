"""Properties of the scheme (5.1) beyond the paper's tables: energy, the lean operators against the
stress-space algorithm, one factorisation per run, `march` against `step`."""
import threading

import ngsolve as ngs
import numpy as np
import pytest
import scipy.sparse as sp

from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import case_scheme, discretise
from fsivsp.fem import forms
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import SOLID
from fsivsp.model.data import Data
from fsivsp.model.expressions import parse, parse_vector
from fsivsp.model.fields import Field
from fsivsp.model.materials import Materials
from fsivsp.solvers import to_ngsolve, to_scipy_csr
from fsivsp.timestepping import marching
from fsivsp.timestepping.scheme import Scheme


@pytest.fixture(scope="module")
def spaces(paper_meshes):
    return build_spaces(paper_meshes[1], "mini", dirichlet="solid_wall")


def bump(dim=2):
    """A smooth field vanishing on the channel walls."""
    return Field(parse_vector(["sin(pi*x/2.5)*sin(pi*y/0.41)", "0"], "bump", dim))


def test_energy_does_not_increase_without_forcing(spaces):
    """Backward Euler dissipates: ½∫ρ|vⁿ|² + ½∫_S Aσⁿ:σⁿ is non-increasing when f = 0."""
    scheme = Scheme(spaces, Materials(), Data(velocity0=bump(), displacement0=bump()), dt=1e-2)
    energies = [scheme.energy()]
    for _ in range(30):
        scheme.step()
        energies.append(scheme.energy())
    assert energies[0] > 0
    assert all(b <= a * (1 + 1e-12) for a, b in zip(energies, energies[1:]))
    assert energies[-1] < 0.999 * energies[0]


def block_inverse(mass: ngs.BaseMatrix, space: ngs.FESpace) -> ngs.BaseMatrix:
    """The inverse of the mass matrix of a discontinuous space, one dense block per cell."""
    cells = np.array([el.dofs for el in space.Elements(ngs.VOL) if len(el.dofs) and min(el.dofs) >= 0])
    n, size = cells.shape
    rows = np.repeat(cells, size, axis=1).reshape(n, size, size)
    cols = np.tile(cells, size).reshape(n, size, size)
    blocks = np.linalg.inv(np.asarray(to_scipy_csr(mass)[rows.ravel(), cols.ravel()]).reshape(n, size, size))
    return to_ngsolve(sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(mass.height, mass.width)))


def explicit_reference(scheme: Scheme, steps: int) -> list[tuple[float, float]]:
    """The scheme as it ran up to session 6, with stress-space operators: σ⁰_h = M_σ⁻¹C I_h u⁰ or Π σ⁰,
    step 1 with −Δt ∫_S σⁿ⁻¹:ε(w), step 2 σⁿ = σⁿ⁻¹ + Δt M_σ⁻¹C vⁿ. From the scheme's initial state, with its
    solver, data and mass; the lean scheme stepped alongside. Returns per step the largest difference of
    (vⁿ, pⁿ) relative to the largest entry, and ‖σⁿ_explicit − σⁿ_lean‖_{L²(Ω_S)} / ‖σⁿ_explicit‖."""
    spaces, mat, dt, data = scheme.spaces, scheme.materials, scheme.dt, scheme.data
    S, X, mesh = spaces.stress, spaces.mixed, spaces.mesh
    sigma, w = S.TrialFunction(), X.TestFunction()[0]
    divergence = ngs.BilinearForm(trialspace=S, testspace=X)
    divergence += forms.integral(ngs.InnerProduct(sigma, forms.eps(w)), spaces, SOLID)
    divergence.Assemble()
    rate = forms.stress_rate(spaces, mat).Assemble().mat
    inverse = block_inverse(forms.stress_mass(spaces).Assemble().mat, S)
    stress = ngs.GridFunction(S)
    if data.stress0 is not None:
        tau = S.TestFunction()
        projection = ngs.LinearForm(S)
        projection += ngs.InnerProduct(data.stress0.coefficient(0.0), tau) * ngs.dx(SOLID, bonus_intorder=4)
        stress.vec.data = inverse * projection.Assemble().vec
    else:
        stress.vec.data = inverse * (rate * scheme.carried.vec)
    state, rhs, boundary = (scheme.state.vec.CreateVector() for _ in range(3))
    state.data = scheme.state.vec
    solid = mesh.Materials(SOLID)
    results = []
    for n in range(1, steps + 1):
        rhs.data = scheme._lagged * state + dt**2 * (scheme._stiffness * state) - dt * (divergence.mat * stress.vec)
        scheme.loads.add_to(rhs, boundary, [(n * dt, dt)], n * dt)
        scheme.solver.solve_step(rhs, boundary, state, state)
        stress.vec.data += dt * (inverse * (rate * state))
        scheme.step()
        gap = stress - scheme.stress
        explicit, lean = state.FV().NumPy(), scheme.state.vec.FV().NumPy()
        results.append((np.abs(lean - explicit).max() / np.abs(explicit).max(), np.sqrt(
            ngs.Integrate(ngs.InnerProduct(gap, gap), mesh, definedon=solid)
            / ngs.Integrate(ngs.InnerProduct(stress, stress), mesh, definedon=solid))))
    return results


@pytest.mark.parametrize("case", ["paper", "fluid_in_solid_3d"])
def test_lean_operators_equal_the_explicit_stress_update(paper_meshes, case):
    """σⁿ_h = σ*_h + Cε(uⁿ_h) and −Δt(b* + K uⁿ⁻¹_h) reproduce the stress-space algorithm to round-off: the
    paper's experiment (σ⁰ from the displacement, 2D) and the 3D fluid ball (σ⁰ by the projection (26))."""
    from pathlib import Path

    from fsivsp.config.case import load_study_case
    from fsivsp.geometry import refined
    if case == "paper":
        scheme, _ = paper_scheme(paper_meshes[1])
    else:
        study = load_study_case(Path(__file__).parents[2] / "examples" / f"{case}.toml")
        scheme = case_scheme(study, refined(study.coarse_mesh(), 0, False))
    for state, stress in explicit_reference(scheme, 5):
        assert state < 1e-11 and stress < 1e-11, (state, stress)


@pytest.fixture
def threaded(monkeypatch):
    """`march` hands work to its second thread however small the problem."""
    monkeypatch.setattr(marching, "MARCH_THREAD_MIN_DOFS", 0)




def test_the_step_matrix_is_factorised_once(spaces, monkeypatch, threaded, record_assembly):
    """The time loop applies precomputed operators only: no assembly, no factorisation."""
    scheme = Scheme(spaces, Materials(), Data(velocity0=bump(), displacement0=bump()), dt=1e-2)
    calls = record_assembly()
    for _ in range(3):
        scheme.step()
    scheme.march(3)
    assert calls == [] and scheme.n == 6
    # the patches are live: the same calls outside the loop are seen
    forms.step_matrix(spaces, Materials(), 1e-2).Assemble()
    ngs.LinearForm(spaces.mixed).Assemble()
    scheme.step_matrix.Inverse(spaces.mixed.FreeDofs())
    assert calls == ["assemble", "assemble load", "inverse"]


def paper_scheme(mesh):
    """The paper's experiment (time-dependent loads and Dirichlet data) and its error norms."""
    return discretise(paper_case(1e-2), mesh)




@pytest.mark.parametrize("threads", ["one", "two"])
def test_march_equals_step(paper_meshes, request, threads, same_state):
    """`march` observes every step once, in order, with the states of `step`. With two threads the
    right-hand side is (M − Δt² K) vⁿ − Δt (b* + K uⁿ⁻¹_h) (a lagged displacement): equal up to round-off;
    with one `march` is `step` in a loop, bit for bit."""
    if threads == "two":
        request.getfixturevalue("threaded")
    stepped, errors = paper_scheme(paper_meshes[1])
    marched, _ = paper_scheme(paper_meshes[1])
    expected = []
    for _ in range(7):
        stepped.step()
        expected.append((stepped.n, stepped.time, errors(stepped)))
    seen, names = [], set()

    def observe(scheme):
        seen.append((scheme.n, scheme.time, errors(scheme)))
        names.add(threading.current_thread().name.startswith("fsivsp-march"))

    marched.march(7, observe)
    assert [step[:2] for step in seen] == [step[:2] for step in expected]
    for (*_, mine), (*_, theirs) in zip(seen, expected):
        assert mine == pytest.approx(theirs, rel=1e-9, abs=0)
    assert same_state(marched, stepped)
    assert names == ({True, False} if threads == "two" else {False})
    if threads == "one":
        for mine, theirs in ((marched.state.vec, stepped.state.vec), (marched.carried.vec, stepped.carried.vec)):
            assert np.array_equal(mine.FV().NumPy(), theirs.FV().NumPy())


def test_march_stops_at_a_consistent_step(paper_meshes, threaded, same_state):
    """An observer that raises leaves the scheme at the step it saw, whole, and stepping goes on from there."""
    stepped, _ = paper_scheme(paper_meshes[1])
    marched, _ = paper_scheme(paper_meshes[1])

    def observe(scheme):
        if scheme.n == 3:
            raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        marched.march(7, observe)
    for _ in range(3):
        stepped.step()
    assert same_state(marched, stepped)
    marched.march(2)
    stepped.step()
    stepped.step()
    assert same_state(marched, stepped)


def test_negative_time_step_is_refused(spaces):
    with pytest.raises(ValueError, match="dt"):
        Scheme(spaces, Materials(), Data(velocity0=bump()), dt=-1.0)


@pytest.mark.parametrize("family, order", [("mini", 1), ("taylor_hood", 1)])
def test_initial_projection_reproduces_discrete_data(paper_meshes, family, order):
    """The projections (22)–(23) are Galerkin projections: data already in V_h × Q_h come back
    unchanged (a linear, divergence-free v⁰ and an affine p⁰, both nonzero on ∂Ω)."""
    mesh = paper_meshes[0]
    spaces = build_spaces(mesh, family, order, dirichlet="solid_wall")
    velocity = Field(parse_vector(["1 + 2*y", "3*x - 1"], "v0", 2))
    pressure = Field(parse("2 - x + 4*y", "p0", 2))
    data = Data(velocity0=velocity, pressure0=pressure, initial_velocity="projection",
                boundary_velocity={"solid_wall": velocity})
    scheme = Scheme(spaces, Materials(), data, dt=1e-2)
    v_error = scheme.velocity - velocity.coefficient(0.0)
    p_error = scheme.pressure - pressure.coefficient(0.0)
    fluid = mesh.Materials("fluid")
    assert ngs.Integrate(ngs.InnerProduct(v_error, v_error), mesh) < 1e-24
    gradient_error = ngs.Grad(scheme.velocity) - ngs.CF((0, 2, 3, 0), dims=(2, 2))
    assert ngs.Integrate(ngs.InnerProduct(gradient_error, gradient_error), mesh) < 1e-20
    assert ngs.Integrate(p_error * p_error, mesh, definedon=fluid) < 1e-24


def test_initial_projection_is_discretely_divergence_free(spaces, discrete_divergence):
    """v⁰_h from (22) satisfies ∫_F q div v⁰_h = 0 for every q ∈ Q_h; the interpolant does not."""
    velocity = Field(parse_vector(["sin(3*x)*cos(5*y)", "-0.6*cos(3*x)*sin(5*y)"], "v0", 2))  # div v = 0
    boundary = {"solid_wall": velocity}
    divergence = {}
    for how in ("interpolation", "projection"):
        scheme = Scheme(spaces, Materials(), Data(velocity0=velocity, initial_velocity=how,
                                                         boundary_velocity=boundary), dt=1e-2)
        divergence[how] = discrete_divergence(scheme)
    assert divergence["projection"] < 1e-12
    assert divergence["interpolation"] > 1e-6
