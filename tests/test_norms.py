"""The error norms' projections solved by CG with a multigrid (`fsivsp.projection`, used above `DIRECT_MAX` dofs)
give the norms of the factorised Gram matrices, the singular stress norm included."""
import dataclasses
from pathlib import Path

import pytest

import fsivsp.norms as norms
import fsivsp.projection as projection
from fsivsp.case import load_study_case
from fsivsp.geometry import refined
from fsivsp.study import run_level

EXAMPLES = Path(__file__).parents[1] / "examples"


@pytest.mark.parametrize("example, level, most", [("fluid_in_solid_3d.toml", 1, 25), ("solid_in_fluid_2d.toml", 2, 40)],
                         ids=["mini-3d", "taylor-hood-2d"])
def test_conjugate_gradients_equal_cholesky(monkeypatch, example, level, most):
    """At most ``most`` CG iterations a projection (measured: 16 and 24; Gauss–Seidel without the V-cycle of the
    vertex block: 56 and 66)."""
    case = load_study_case(EXAMPLES / example)
    case = dataclasses.replace(case, T=case.dt)
    mesh = refined(case.coarse_mesh(), level, case.discretisation.project_refinement)
    solves = []

    def recorded(*args):
        solves.append(projection.gram_solver(*args))
        return solves[-1]

    monkeypatch.setattr(norms, "gram_solver", recorded)
    factorised = run_level(case, mesh, level)["errors"]
    assert not any(hasattr(solve, "iterations") for solve in solves)
    solves.clear()
    monkeypatch.setattr(projection, "DIRECT_MAX", 0)
    iterated = run_level(case, mesh, level)["errors"]
    counts = [n for solve in solves for n in solve.iterations]
    assert len(solves) == mesh.dim + 2 and counts and max(counts) <= most, counts
    assert iterated == pytest.approx(factorised, rel=1e-9)
