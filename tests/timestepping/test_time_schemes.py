"""The θ-scheme and BDF2 (`fsivsp.timeschemes`) beyond their rates (tests/test_time_convergence.py):
BDF2's Crank–Nicolson start, energy, one matrix per run, `march`, checkpoints, input checks."""
import json

import ngsolve as ngs
import numpy as np
import pytest
from support.cases import CASE, final_fields, write_case

from fsivsp.app.cli import main
from fsivsp.experiments.paper import paper_case
from fsivsp.experiments.study import discretise
from fsivsp.fem import forms
from fsivsp.fem.spaces import build_spaces
from fsivsp.geometry import build_geometry
from fsivsp.model.data import Data
from fsivsp.model.expressions import parse_vector
from fsivsp.model.fields import Field
from fsivsp.model.materials import Materials
from fsivsp.solvers import SolverSpec, petsc_available
from fsivsp.timestepping import marching
from fsivsp.timestepping.scheme import Scheme
from fsivsp.timestepping.schemes import BDF2, Theta, time_scheme


@pytest.fixture(scope="module")
def layers():
    """fluid_over_solid 2D, walls at rest, MINI."""
    mesh = build_geometry("fluid_over_solid", 2, 0.2)
    return build_spaces(mesh, "mini", dirichlet="fluid_wall|solid_wall")


def released(spaces, scheme, dt=0.05, nu=0.5):
    """f = 0, the boundary at rest, v⁰ = 0 and a deformed solid let go (u⁰ vanishing on the walls)."""
    displacement = Field(parse_vector(["0.1*sin(pi*x)*y*(y + 1)", "0.1*sin(pi*x)*y*(y + 1)"], "u0", 2))
    zero = Field(parse_vector(["0", "0"], "v0", 2))
    materials = Materials(rho_fluid=1.0, rho_solid=2.0, nu=nu, lam=1.5, mu=0.75)
    return Scheme(spaces, materials, Data(velocity0=zero, displacement0=displacement), dt, solver=SolverSpec("direct"),
                  time_scheme=scheme)


def test_bdf2_starts_with_a_crank_nicolson_step(paper_meshes):
    """BDF2's first step, solved with its own A(2Δt/3) by Richardson, is the Crank–Nicolson step
    (solved with A(Δt/2) directly): (v¹, p¹) and u¹_h agree to 1e-10."""
    bdf2, _ = discretise(paper_case(1e-2, time_scheme=BDF2()), paper_meshes[1])
    crank_nicolson, _ = discretise(paper_case(1e-2, time_scheme=Theta(0.5)), paper_meshes[1])
    bdf2.step()
    crank_nicolson.step()
    for mine, theirs in ((bdf2.state.vec, crank_nicolson.state.vec), (bdf2.carried.vec, crank_nicolson.carried.vec)):
        gap = np.abs(mine.FV().NumPy() - theirs.FV().NumPy()).max() / np.abs(theirs.FV().NumPy()).max()
        assert gap < 1e-10, gap


@pytest.mark.skipif(petsc_available() is not None, reason=str(petsc_available()))
def test_bdf2_start_with_inexact_solves_is_the_crank_nicolson_step(paper_meshes):
    """At the auto tolerance the start's Richardson iteration solves with A(τ) to ρ only, and still ends at the
    Crank–Nicolson step solved directly (to 1e-10; measured 8e-13), in fewer PETSc iterations than with solves to
    1e-12 (measured on level 2: 21 solves against 20, 77 iterations against 283)."""
    crank_nicolson, _ = discretise(paper_case(1e-2, time_scheme=Theta(0.5)), paper_meshes[2])
    crank_nicolson.step()
    iterations = {}
    for tolerance in ("auto", 1e-12):
        spec = SolverSpec("petsc", tolerance=tolerance)
        bdf2, _ = discretise(paper_case(1e-2, solver=spec, time_scheme=BDF2()), paper_meshes[2])
        bdf2.step()
        iterations[tolerance] = bdf2.solver.iterations
        for mine, theirs in ((bdf2.state.vec, crank_nicolson.state.vec),
                             (bdf2.carried.vec, crank_nicolson.carried.vec)):
            gap = np.abs(mine.FV().NumPy() - theirs.FV().NumPy()).max() / np.abs(theirs.FV().NumPy()).max()
            assert gap < 1e-10, (tolerance, gap)
    assert len(iterations["auto"]) <= len(iterations[1e-12]) + 1, iterations
    assert sum(iterations["auto"]) < 0.5 * sum(iterations[1e-12]), iterations


def test_crank_nicolson_keeps_the_energy_up_to_the_viscous_dissipation(layers):
    """θ = 1/2, f = 0, boundary at rest: Eⁿ + Σ_k Δt K_F(v^{k−½}) = E⁰ to 1e-10 (200 steps), and Eⁿ itself
    with ν = 0; backward Euler loses energy beyond the viscous dissipation."""
    for nu in (0.5, 0.0):
        scheme = released(layers, Theta(0.5), nu=nu)
        viscous = forms.fluid_viscous(layers, scheme.materials).Assemble().mat
        start, dissipated = scheme.energy(), 0.0
        middle = scheme.state.vec.CreateVector()
        worst = 0.0
        for _ in range(200):
            middle.data = 0.5 * scheme.state.vec
            scheme.step()
            middle.data += 0.5 * scheme.state.vec
            dissipated += scheme.dt * ngs.InnerProduct(middle, viscous * middle)
            worst = max(worst, abs(scheme.energy() + dissipated - start) / start)
        assert worst < 1e-10, (nu, worst)
        assert nu == 0.0 or dissipated > 1e-3 * start
    euler = released(layers, Theta(1.0), nu=0.0)
    start = euler.energy()
    for _ in range(200):
        euler.step()
    assert euler.energy() < 0.9 * start


def test_bdf2_g_norm_does_not_increase(layers):
    """BDF2's G-norm energy ¼(‖Uⁿ‖² + ‖2Uⁿ − Uⁿ⁻¹‖²) is non-increasing with f = 0 at rest (300 steps)."""
    scheme = released(layers, BDF2(), nu=0.05)
    scheme.step()  # the Crank–Nicolson start: its own (plain) energy
    energies = [scheme.energy()]
    for _ in range(300):
        scheme.step()
        energies.append(scheme.energy())
    assert all(b <= a * (1 + 1e-12) for a, b in zip(energies, energies[1:]))
    assert energies[-1] < 0.99 * energies[0]


@pytest.mark.parametrize("name", ["theta", "bdf2"])
def test_no_assembly_or_factorisation_after_the_start(layers, monkeypatch, name, record_assembly):
    """One matrix per run: after BDF2's start, steps apply precomputed operators only."""
    monkeypatch.setattr(marching, "MARCH_THREAD_MIN_DOFS", 0)
    scheme = released(layers, time_scheme(name))
    scheme.step()
    calls = record_assembly()
    for _ in range(3):
        scheme.step()
    scheme.march(3)
    assert calls == [] and scheme.n == 7


@pytest.mark.parametrize("name", ["theta", "bdf2"])
def test_march_equals_step(paper_meshes, monkeypatch, name, same_state):
    """`march` with its second thread (lagged right-hand side) ends where `step` does, to round-off."""
    monkeypatch.setattr(marching, "MARCH_THREAD_MIN_DOFS", 0)
    stepped, _ = discretise(paper_case(1e-2, time_scheme=time_scheme(name)), paper_meshes[1])
    marched, _ = discretise(paper_case(1e-2, time_scheme=time_scheme(name)), paper_meshes[1])
    for _ in range(6):
        stepped.step()
    seen = []
    marched.march(6, lambda s: seen.append(s.n))
    assert seen == list(range(1, 7)) and same_state(marched, stepped)


def with_scheme(text: str, scheme: str) -> str:
    return text.replace("dt = 5.0e-5", f"dt = 5.0e-5\n{scheme}")


@pytest.mark.parametrize("scheme", ['scheme = "bdf2"', 'scheme = "theta"\ntheta = 0.6'])
def test_resume_equals_uninterrupted(tmp_path, scheme):
    """Checkpoints hold BDF2's two levels and the θ-scheme's multiplier: a run continued from step 20
    ends bit for bit where an uninterrupted one does (direct solver)."""
    reference, out = tmp_path / "reference", tmp_path / "resumed"
    full = write_case(tmp_path, text=with_scheme(CASE.format(T=0.002, every=10), scheme))
    assert main(["run", str(full), "--out", str(reference), "--quiet"]) == 0
    half = write_case(tmp_path, text=with_scheme(CASE.format(T=0.001, every=10), scheme))
    assert main(["run", str(half), "--out", str(out), "--quiet"]) == 0
    full = write_case(tmp_path, text=with_scheme(CASE.format(T=0.002, every=10), scheme))
    assert main(["run", str(full), "--out", str(out), "--resume", "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["resumed_from"] == 20
    assert summary["energy"] == json.loads((reference / "summary.json").read_text())["energy"]
    ours, theirs = final_fields(out), final_fields(reference)
    for name in theirs:
        assert np.array_equal(ours[name], theirs[name]), name


def test_a_checkpoint_of_another_scheme_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, T=0.001)), "--out", str(out), "--quiet"]) == 0
    resumed = write_case(tmp_path, text=with_scheme(CASE.format(T=0.002, every=10), 'scheme = "bdf2"'))
    assert main(["run", str(resumed), "--out", str(out), "--resume", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "time_scheme" in err and "\n" not in err.strip()


@pytest.mark.parametrize("lines, field", [
    ('scheme = "rk4"', "time.scheme"),
    ('scheme = "theta"\ntheta = 0.4', "time.theta"),
    ('scheme = "theta"\ntheta = 1.5', "time.theta"),
    ('scheme = "bdf2"\ntheta = 0.5', "time.theta"),
])
def test_bad_time_scheme_exit_2(tmp_path, capsys, lines, field):
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, text=with_scheme(CASE.format(T=0.002, every=10), lines))),
                 "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert field in err and "\n" not in err and "Traceback" not in err, err
    assert not out.exists()


@pytest.mark.parametrize("args", [["--dt", "0.1,0.1"], ["--dt", "0.05,0.1"], ["--dt", "0.1,-0.05"], ["--dt", "x"],
                                  ["--scheme", "rk4"], ["--scheme", "theta", "--theta", "0.3"],
                                  ["--scheme", "bdf2", "--theta", "0.5"], ["--dt", "0.1", "--level", "9"],
                                  ["--dt", "0.1", "--level", "1-2"]])
def test_bad_study_options_exit_2(capsys, args):
    assert main(["study", "examples/time_convergence_2d.toml", *args, "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err, err


def test_time_study_cli(tmp_path, capsys):
    """`fsivsp study --dt` prints errors and rates in Δt and writes one record per Δt."""
    path = tmp_path / "time.json"
    assert main(["study", "examples/time_convergence_2d.toml", "--dt", "0.1,0.05", "--scheme", "theta",
                 "--json", str(path), "--quiet"]) == 0
    records = json.loads(path.read_text())
    assert [r["dt"] for r in records] == [0.1, 0.05] and records[0]["rates"]["p"] is None
    assert abs(records[1]["rates"]["total"] - 2) < 0.15
    assert "r(v,p,σ)" in capsys.readouterr().out
