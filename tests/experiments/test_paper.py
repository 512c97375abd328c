"""The experiment of Section 5.3 on levels 0–2 against the paper's Tables 1–8.

Our meshes are not the paper's (netgen grades towards the disk: 136 vertices, 45 on ∂Ω,
12 on Γ against the paper's 128, 38 and 8), hence factors rather than digits. With the paper's
recipe (σ⁰ from the interpolated displacement, the default) and red refinement every error is
0.4–0.85 of the paper's (docs/paper.md); the L² projection (26) of σ(0) gives
e(σ) about 1.7× smaller on the coarse levels.
"""
import pytest

from fsivsp.experiments.paper import TIME_STEPS, paper_case, reference_table, stress_time_floor
from fsivsp.experiments.study import rates, study

LEVELS = range(3)


@pytest.fixture(scope="module", params=[1e-2, 1e-3], ids=["dt=1e-2", "dt=1e-3"])
def dt(request):
    return request.param


@pytest.fixture(scope="module")
def displacement_run(dt):
    return study(paper_case(dt, initial_stress="displacement"), LEVELS), reference_table(dt)


@pytest.fixture(scope="module")
def projection_run(dt):
    return study(paper_case(dt, initial_stress="projection"), LEVELS), reference_table(dt)


def within(ours, theirs, keys, factor, coarse_factor=None):
    for a, b in zip(ours, theirs):
        f = coarse_factor if (coarse_factor and a["level"] == 0) else factor
        for key in keys:
            ratio = a["errors"][key] / b["errors"][key]
            assert 1 / f < ratio < f, (a["level"], key, ratio)


def test_reference_tables_ship_with_the_package():
    for step in TIME_STEPS:
        table = reference_table(step)
        assert [r["vertices"] for r in table] == [128, 471, 1805, 7065, 27953]


def test_errors_match_the_paper(displacement_run):
    """Levels 0–2: v and σ within 2× of Tables 2–3 (2.5× on level 0), p within 3×."""
    ours, theirs = displacement_run
    within(ours, theirs, ("v1", "v2", "sigma"), 2.0, 2.5)
    within(ours, theirs, ("p",), 3.0)


def test_projected_initial_stress_halves_the_coarse_stress_error(displacement_run, projection_run):
    """The two initial stresses of the issue: about 2× apart in e(σ) on the coarse levels
    (1.73× measured on levels 0–1)."""
    for ours, projected in zip(displacement_run[0][:2], projection_run[0][:2]):
        assert 1.5 < ours["errors"]["sigma"] / projected["errors"]["sigma"] < 2.5


def assert_first_order(records, keys):
    """r ≥ 0.9 from level 1 on (Tables 6–7)."""
    for record in records[2:]:
        for key in keys:
            assert record["rates"][key] >= 0.9, (record["level"], key, record["rates"][key])


@pytest.mark.parametrize("initial_stress", ["displacement", "projection"])
def test_first_order_in_h(initial_stress, displacement_run, projection_run):
    run = displacement_run if initial_stress == "displacement" else projection_run
    assert_first_order(run[0], ("v1", "v2", "p", "sigma", "total"))


def test_pressure_converges_at_least_as_fast_as_the_papers(displacement_run, dt):
    """r(p) on 1→2 against Tables 6–7 (1.62 and 1.65 for Δt = 1e-2 and 1e-3): ours 1.69 and 1.71."""
    ours, theirs = displacement_run[0], reference_table(dt)
    rates(theirs, 2)
    assert ours[2]["rates"]["p"] >= theirs[2]["rates"]["p"], (ours[2]["rates"]["p"], theirs[2]["rates"]["p"])


def test_paper_dof_convention(projection_run):
    """2·(interior vertices) + 2·(fluid triangles) + (fluid vertices) = our free dofs when Γ_F = ∅."""
    for record in projection_run[0]:
        assert record["paper_dofs"] == record["dofs"]
    assert [r["paper_dofs"] for r in projection_run[0]] == [249, 1065, 4407]


def test_rates_of_the_reference_tables_reproduce_table_6_last_row():
    table = reference_table(1e-2)
    rates(table, 2)
    measured = [table[4]["rates"][k] for k in ("v1", "v2", "p", "sigma")]
    # e(p) = 0.000075 has two significant digits in Table 2, hence 5e-3.
    assert measured == pytest.approx([1.013050, 0.984037, 1.324761, 1.005257], abs=5e-3)


def test_time_error_floor_with_dt_1e_1():
    """With Δt = 0.1 e(σ) stalls at the backward-Euler floor (≈ 0.203), not at Table 1's 0.063."""
    floor = stress_time_floor(1e-1)
    assert 0.19 < floor < 0.21
    (record,) = study(paper_case(1e-1), range(3, 4))
    assert abs(record["errors"]["sigma"] - floor) < 0.1 * floor
