"""The experiment of Section 5.3 on levels 0–2: error magnitudes and rates against Tables 1–8.

The meshes are not the paper's (netgen grades towards the disk: 136 vertices, 45 on ∂Ω,
12 on Γ against the paper's 128, 38 and 8), hence factors rather than digits.
"""
import pytest

from fsivsp.paper import TIME_STEPS, paper_case, reference_table, stress_time_floor
from fsivsp.study import study

LEVELS = range(3)


@pytest.fixture(scope="module", params=[1e-2, 1e-3], ids=["dt=1e-2", "dt=1e-3"])
def run(request):
    dt = request.param
    return dt, study(paper_case(dt), LEVELS), reference_table(dt)


def test_reference_tables_ship_with_the_package():
    for dt in TIME_STEPS:
        table = reference_table(dt)
        assert [r["level"] for r in table] == [0, 1, 2, 3, 4]
        assert [r["vertices"] for r in table] == [128, 471, 1805, 7065, 27953]


def test_errors_match_the_paper_level_by_level(run):
    dt, records, reference = run
    for ours, theirs in zip(records, reference):
        for key in ("v1", "v2", "sigma"):
            factor = 2.5 if ours["level"] == 0 else 2.0
            ratio = ours["errors"][key] / theirs["errors"][key]
            assert 1 / factor < ratio < factor, (dt, ours["level"], key, ratio)
        ratio = ours["errors"]["p"] / theirs["errors"]["p"]
        assert 1 / 3 < ratio < 3, (dt, ours["level"], "p", ratio)


def test_first_order_in_h(run):
    """r ≥ 0.9 for every unknown from level 1 on (Tables 6–7)."""
    dt, records, reference = run
    for record in records[2:]:
        for key in ("v1", "v2", "p", "sigma", "total"):
            assert record["rates"][key] >= 0.9, (dt, record["level"], key, record["rates"][key])


def test_pressure_converges_at_least_as_fast_as_the_papers(run):
    from fsivsp.study import rates

    dt, records, reference = run
    rates(reference, 2)
    for ours, theirs in zip(records[2:], reference[2:]):
        assert ours["rates"]["p"] >= theirs["rates"]["p"] - 0.1, (dt, ours["rates"]["p"], theirs["rates"]["p"])


def test_paper_dof_convention(run):
    """2·(interior vertices) + 2·(fluid triangles) + (fluid vertices) = free dofs when Γ_F = ∅."""
    _, records, _ = run
    for record in records:
        assert record["paper_dofs"] == record["dofs"]


def test_time_error_floor_with_dt_1e_1():
    """With Δt = 0.1 the stress error stalls at the backward-Euler floor, not at Table 1's 0.063."""
    floor = stress_time_floor(1e-1)
    assert 0.17 < floor < 0.2
    (record,) = study(paper_case(1e-1), range(3, 4))
    assert abs(record["errors"]["sigma"] - floor) < 0.2 * floor
