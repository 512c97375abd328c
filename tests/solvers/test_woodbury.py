"""`solvers.woodbury`: the outlets' rank-one terms by the Woodbury formula around the step solver solve the assembled
A + Σ γ c cᵀ, with the factorisation and with PETSc's FGMRES alike."""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from support.channels import at_rest, channel_scheme, compliant, history

from fsivsp.model.data import Support, Windkessel, resistance
from fsivsp.solvers import SolverSpec, free_mask, petsc_available, to_scipy_csr
from fsivsp.solvers.woodbury import WoodburySolver


def test_woodbury_solves_the_assembled_system():
    """Step 1 with two outlets (one of them on a boundary with Dirichlet dofs at its ends): the relative residual of
    the solution in the assembled A + Σ γ_i c_i c_iᵀ on the free dofs, with the Dirichlet values lifted by the rank-one
    terms too, is at round-off (measured 1.7e-13; scipy's LU of that matrix 6.0e-13), and its difference from
    scipy's solution that of the base solver's from scipy's without outlets (2.4e-12 against 1.0e-12)."""
    data = at_rest(velocity={"solid_ends": [0, 0]}, traction={"inflow": ["100*t", 0]},
                   outlets={"outflow": resistance(50.0), "solid_wall": Windkessel(2.0, 0.1, 5.0)})
    run = channel_scheme(data, compliant(), 0.05, "backward_euler", dirichlet="solid_ends")
    assert isinstance(run.solver, WoodburySolver) and len(run.solver.vectors) == 2
    rhs, boundary, raw, plain = (run.state.vec.CreateVector() for _ in range(4))
    run.right_hand_side(run.time_scheme, 1, rhs, boundary)
    run.solver.solve_step(rhs, boundary, raw)
    run.solver.base.solve_step(rhs, boundary, plain)
    free = np.flatnonzero(free_mask(run.spaces.mixed.FreeDofs(), len(raw)))
    c = sp.csr_matrix(np.column_stack([v.FV().NumPy() for v in run.flux_vectors]))
    update = (c @ sp.diags(run.solver.weights) @ c.T).tocsr()
    g = boundary.FV().NumPy()
    b = rhs.FV().NumPy()[free] - (update @ g)[free]  # the right-hand side is lifted by A g, not by the updates
    matrix = to_scipy_csr(run.step_matrix)
    updated = (matrix + update)[np.ix_(free, free)]
    x = raw.FV().NumPy()[free]
    assert np.linalg.norm(updated @ x - b) <= 1e-11 * np.linalg.norm(b)
    gap = lambda mine, a, rhs: (np.linalg.norm(mine - sla.spsolve(a.tocsc(), rhs))  # noqa: E731
                                / np.linalg.norm(mine))
    assert gap(x, updated, b) <= 10 * gap(plain.FV().NumPy()[free], matrix[np.ix_(free, free)], rhs.FV().NumPy()[free])


@pytest.mark.skipif(petsc_available() is not None, reason=f"PETSc: {petsc_available()}")
def test_petsc_with_outlets_and_support_equals_the_factorisation():
    """40 BDF2 steps with an RCR outlet and tissue support, by PETSc's FGMRES at tolerance 1e-10 and by the
    factorisation: the same states and outlet pressures to the tolerance (measured 1.2e-9 and 8.8e-11)."""
    data = at_rest(velocity={"solid_ends": [0, 0]}, traction={"inflow": ["100*sin(2*pi*t)", 0]},
                   outlets={"outflow": Windkessel(5.0, 0.02, 50.0)}, supports={"solid_wall": Support(1e4, 20.0)})
    results = []
    for solver in (SolverSpec(method="direct"), SolverSpec(method="petsc", tolerance=1e-10)):
        run = channel_scheme(data, compliant(), 0.01, "bdf2", dirichlet="solid_ends", solver=solver)
        pressures = history(run, 40, pressure=lambda s: s.outlets[0].pressure)["pressure"]
        results.append((run.state.vec.FV().NumPy().copy(), pressures, run.solver.method))
    (x, p, _), (y, q, method) = results
    assert method == "petsc"
    assert np.abs(x - y).max() <= 1e-7 * np.abs(x).max()
    assert np.abs(p - q).max() <= 1e-7 * np.abs(p).max()


def test_base_start_has_the_whole_systems_residual():
    """The base solve's start x⁰ = x₀ + Y Γ Cᵀx₀ (`WoodburySolver.base_start`) has, under A, the residual that x₀ has
    under A + Σ γ c cᵀ (the Dirichlet values lifted as in the test above): the auto tolerance's target, made against
    the whole system, measures the base solve. Two outlets, a start off the solution by 1e-3 (measured: equal to
    1.7e-13 of the residual, the factorisation's Y; x₀'s residual under A alone differs from it by 0.39 of it)."""
    data = at_rest(velocity={"solid_ends": [0, 0]}, traction={"inflow": ["100*t", 0]},
                   outlets={"outflow": resistance(50.0), "solid_wall": Windkessel(2.0, 0.1, 5.0)})
    run = channel_scheme(data, compliant(), 0.05, "backward_euler", dirichlet="solid_ends")
    rhs, boundary, raw = (run.state.vec.CreateVector() for _ in range(3))
    run.right_hand_side(run.time_scheme, 1, rhs, boundary)
    run.solver.solve_step(rhs, boundary, raw)
    guess = raw.CreateVector()
    guess.FV().NumPy()[:] = raw.FV().NumPy() * (1 + 1e-3 * np.cos(np.arange(len(raw))))
    free = np.flatnonzero(free_mask(run.spaces.mixed.FreeDofs(), len(raw)))
    c = sp.csr_matrix(np.column_stack([v.FV().NumPy() for v in run.flux_vectors]))
    update = (c @ sp.diags(run.solver.weights) @ c.T).tocsr()
    matrix = to_scipy_csr(run.step_matrix)
    g, b = boundary.FV().NumPy(), rhs.FV().NumPy()[free]
    start = g.copy()
    start[free] = guess.FV().NumPy()[free]
    whole = b - ((matrix + update) @ start)[free] + (matrix @ g)[free]   # the right-hand side is lifted by A g
    plain = b - (matrix @ start)[free] + (matrix @ g)[free]
    base = run.solver.base_start(guess, boundary).FV().NumPy().copy()
    base[np.setdiff1d(np.arange(len(base)), free)] = 0.0
    mine = b - (matrix @ base)[free]
    assert np.linalg.norm(mine - whole) <= 1e-10 * np.linalg.norm(whole)
    assert np.linalg.norm(plain - whole) >= 0.1 * np.linalg.norm(whole)


@pytest.mark.skipif(petsc_available() is not None, reason=f"PETSc: {petsc_available()}")
def test_auto_tolerance_with_an_outlet_keeps_the_factorisations_solution():
    """The same 40 BDF2 steps at the auto tolerance: the states, the outlet's pressures and flows within 2e-5, 2e-5 and
    3e-5 of the factorisation's (measured 3.0e-6, 3.3e-6, 8.2e-6). The start and its target are the whole system's
    (`warmstart`'s products with the outlet's term, `WoodburySolver.base_start`); measured against A alone they were
    the outlet's term's, and the gaps 1.1e-4, 5.5e-5, 9.9e-5 (730 iterations against 541)."""
    data = at_rest(velocity={"solid_ends": [0, 0]}, traction={"inflow": ["100*sin(2*pi*t)", 0]},
                   outlets={"outflow": Windkessel(5.0, 0.02, 50.0)}, supports={"solid_wall": Support(1e4, 20.0)})
    results = []
    for solver in (SolverSpec(method="direct"), SolverSpec(method="petsc")):
        run = channel_scheme(data, compliant(), 0.01, "bdf2", dirichlet="solid_ends", solver=solver)
        measured = history(run, 40, pressure=lambda s: s.outlets[0].pressure, flow=lambda s: s.outlet_flows()[0])
        results.append((run.state.vec.FV().NumPy().copy(), measured["pressure"], measured["flow"]))
    for name, direct, auto, bound in zip(("state", "pressure", "flow"), *results, (2e-5, 2e-5, 3e-5)):
        assert np.abs(direct - auto).max() <= bound * np.abs(direct).max(), name
