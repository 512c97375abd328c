"""Patch test: data that the discrete spaces contain are reproduced to round-off.

A divergence-free velocity that is affine in x, an affine pressure and a displacement
u = u⁰ + t v with affine u⁰ lie in V_h × Q_h × S_h for every family (the stress is constant),
and backward Euler is exact for them (v is constant in t, σ affine in t). On curved
(isoparametric) meshes the velocity space still contains affine fields but the P_k pressure is
polynomial in reference coordinates only, so there the pressure is a constant. Any inconsistency of
the forms, the interface load g = (σ_F − σ_S) n, the Dirichlet lift or the stress update shows
here as an O(1) error, in every configuration and dimension, in a second.
"""
import dataclasses

import pytest

from fsivsp.case import load_study_case, to_study
from fsivsp.manufactured import ExactSolution
from fsivsp.study import study
from fsivsp.verification import CONFIGURATIONS, EXAMPLES

FIELDS = {
    2: (["y + 1", "3*x - 2"], "1 + x - 2*y", ["0.1*x - 0.3*y + t*(y + 1)", "0.2*x + 0.05*y + t*(3*x - 2)"]),
    3: (["y - 2*z + 1", "z + 3*x", "x - y + 0.5"], "1 + x - 2*y + 3*z",
        ["0.1*x + 0.2*z + t*(y - 2*z + 1)", "0.3*y - 0.1*x + t*(z + 3*x)", "0.05*z + 0.2*y + t*(x - y + 0.5)"]),
}
ELEMENTS = [("mini", 1, "projection"), ("mini", 1, "displacement"), ("taylor_hood", 1, "projection")]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("configuration", CONFIGURATIONS)
@pytest.mark.parametrize("family, order, initial_stress", ELEMENTS)
def test_affine_data_are_reproduced(configuration, dim, family, order, initial_stress):
    velocity, pressure, displacement = FIELDS[dim]
    case = to_study(load_study_case(EXAMPLES / f"{configuration}_{dim}d.toml"))
    if case.curved and family == "taylor_hood":
        pressure = "1.5"
    exact = ExactSolution.parse(velocity, pressure, displacement, dim=dim, field="patch")
    case = dataclasses.replace(case, family=family, order=order, initial_stress=initial_stress, exact=exact)
    record, = study(case, range(0, 1))
    errors = record["errors"]
    assert errors["total"] < 1e-11, errors
