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


def two_outlets():
    """Step 1 of a channel with two outlets (one of them on a boundary with Dirichlet dofs at its ends), solved: the
    scheme, its right-hand side, Dirichlet values and solution, the free dofs, and in scipy the outlets' terms
    Σ γ_i c_i c_iᵀ and the step matrix A."""
    data = at_rest(velocity={"solid_ends": [0, 0]}, traction={"inflow": ["100*t", 0]},
                   outlets={"outflow": resistance(50.0), "solid_wall": Windkessel(2.0, 0.1, 5.0)})
    run = channel_scheme(data, compliant(), 0.05, "backward_euler", dirichlet="solid_ends")
    rhs, boundary, raw = (run.state.vec.CreateVector() for _ in range(3))
    run.right_hand_side(run.time_scheme, 1, rhs, boundary)
    run.solver.solve_step(rhs, boundary, raw)
    free = np.flatnonzero(free_mask(run.spaces.mixed.FreeDofs(), len(raw)))
    c = sp.csr_matrix(np.column_stack([v.FV().NumPy() for v in run.flux_vectors]))
    update = (c @ sp.diags(run.solver.weights) @ c.T).tocsr()
    return run, rhs, boundary, raw, free, update, to_scipy_csr(run.step_matrix)


def test_woodbury_solves_the_assembled_system():
    """The relative residual of `two_outlets`' solution in the assembled A + Σ γ_i c_i c_iᵀ on the free dofs, with the
    Dirichlet values lifted by the rank-one terms too, is at round-off (measured 1.7e-13; scipy's LU of that matrix
    6.0e-13), and its difference from scipy's solution that of the base solver's from scipy's without outlets
    (2.4e-12 against 1.0e-12)."""
    run, rhs, boundary, raw, free, update, matrix = two_outlets()
    assert isinstance(run.solver, WoodburySolver) and len(run.solver.vectors) == 2
    plain = raw.CreateVector()
    run.solver.base.solve_step(rhs, boundary, plain)
    g = boundary.FV().NumPy()
    b = rhs.FV().NumPy()[free] - (update @ g)[free]  # the right-hand side is lifted by A g, not by the updates
    updated = (matrix + update)[np.ix_(free, free)]
    x = raw.FV().NumPy()[free]
    assert np.linalg.norm(updated @ x - b) <= 1e-11 * np.linalg.norm(b)
    gap = lambda mine, a, rhs: (np.linalg.norm(mine - sla.spsolve(a.tocsc(), rhs))  # noqa: E731
                                / np.linalg.norm(mine))
    assert gap(x, updated, b) <= 10 * gap(plain.FV().NumPy()[free], matrix[np.ix_(free, free)], rhs.FV().NumPy()[free])


def test_base_start_has_the_whole_systems_residual():
    """The base solve's start x⁰ = x₀ + Y Γ Cᵀx₀ (`WoodburySolver.base_start`) has, under A, the residual that x₀ has
    under A + Σ γ c cᵀ (the Dirichlet values lifted as in the test above): the auto tolerance's target, made against
    the whole system, measures the base solve. `two_outlets` from a start off its solution by 1e-3 (measured: equal
    to 1.7e-13 of the residual, the factorisation's Y; x₀'s residual under A alone differs from it by 0.39 of it)."""
    run, rhs, boundary, raw, free, update, matrix = two_outlets()
    guess = raw.CreateVector()
    guess.FV().NumPy()[:] = raw.FV().NumPy() * (1 + 1e-3 * np.cos(np.arange(len(raw))))
    g, b = boundary.FV().NumPy(), rhs.FV().NumPy()[free]
    start = g.copy()
    start[free] = guess.FV().NumPy()[free]
    whole = b - ((matrix + update) @ start)[free] + (matrix @ g)[free]   # the right-hand side is lifted by A g
    plain = b - (matrix @ start)[free] + (matrix @ g)[free]
    base = np.zeros(len(g))
    base[free] = run.solver.base_start(guess, boundary).FV().NumPy()[free]
    mine = b - (matrix @ base)[free]
    assert np.linalg.norm(mine - whole) <= 1e-10 * np.linalg.norm(whole)
    assert np.linalg.norm(plain - whole) >= 0.1 * np.linalg.norm(whole)


@pytest.mark.skipif(petsc_available() is not None, reason=f"PETSc: {petsc_available()}")
@pytest.mark.parametrize("tolerance, bounds", [(1e-10, (1e-7, 1e-7, 1e-7)), ("auto", (2e-5, 2e-5, 3e-5))])
def test_petsc_with_outlets_and_support_equals_the_factorisation(tolerance, bounds):
    """40 BDF2 steps with an RCR outlet and tissue support, by PETSc's FGMRES and by the factorisation: the states, the
    outlet's pressures and flows within ``bounds`` of the factorisation's. At 1e-10 measured 2.8e-9, 2.3e-10 and
    8.6e-10; at the auto tolerance 3.0e-6, 3.3e-6, 8.2e-6, its start and target the whole system's (`warmstart`'s
    products with the outlet's term, `WoodburySolver.base_start`). Measured against A alone they were the outlet's
    term's, and the gaps 1.1e-4, 5.5e-5, 9.9e-5 (730 iterations against 541)."""
    data = at_rest(velocity={"solid_ends": [0, 0]}, traction={"inflow": ["100*sin(2*pi*t)", 0]},
                   outlets={"outflow": Windkessel(5.0, 0.02, 50.0)}, supports={"solid_wall": Support(1e4, 20.0)})
    results = []
    for solver in (SolverSpec(method="direct"), SolverSpec(method="petsc", tolerance=tolerance)):
        run = channel_scheme(data, compliant(), 0.01, "bdf2", dirichlet="solid_ends", solver=solver)
        measured = history(run, 40, pressure=lambda s: s.outlets[0].pressure, flow=lambda s: s.outlet_flows()[0])
        results.append((run.state.vec.FV().NumPy().copy(), measured["pressure"], measured["flow"]))
    assert run.solver.method == "petsc"
    for name, direct, iterative, bound in zip(("state", "pressure", "flow"), *results, bounds):
        assert np.abs(direct - iterative).max() <= bound * np.abs(direct).max(), name
