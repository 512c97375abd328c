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

from fsivsp.config.case import load_study_case
from fsivsp.experiments.study import study
from fsivsp.experiments.verification import CONFIGURATIONS, EXAMPLES
from fsivsp.model.manufactured import ExactSolution

FIELDS = {
    2: (["y + 1", "3*x - 2"], "1 + x - 2*y", ["0.1*x - 0.3*y + t*(y + 1)", "0.2*x + 0.05*y + t*(3*x - 2)"]),
    3: (["y - 2*z + 1", "z + 3*x", "x - y + 0.5"], "1 + x - 2*y + 3*z",
        ["0.1*x + 0.2*z + t*(y - 2*z + 1)", "0.3*y - 0.1*x + t*(z + 3*x)", "0.05*z + 0.2*y + t*(x - y + 0.5)"]),
}
ELEMENTS = [("mini", 1, "projection"), ("mini", 1, "displacement"), ("taylor_hood", 1, "projection")]


def total_error(configuration: str, dim: int, fields: tuple, level: int, **changes) -> dict:
    """The errors of the example case of (configuration, dim) run with the exact ``fields`` on ``level``."""
    velocity, pressure, displacement = fields
    case = load_study_case(EXAMPLES / f"{configuration}_{dim}d.toml").with_discretisation(**changes)
    if case.discretisation.curved and case.discretisation.family == "taylor_hood":
        pressure = "1.5"  # P_k pressures on curved cells are polynomials in reference coordinates only
    exact = ExactSolution.parse(velocity, pressure, displacement, dim=dim, field="patch")
    record, = study(dataclasses.replace(case, exact=exact), range(level, level + 1))
    return record["errors"]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("configuration", CONFIGURATIONS)
@pytest.mark.parametrize("family, order, initial_stress", ELEMENTS)
def test_affine_data_are_reproduced(configuration, dim, family, order, initial_stress):
    errors = total_error(configuration, dim, FIELDS[dim], 0, family=family, order=order, initial_stress=initial_stress)
    assert errors["total"] < 1e-11, errors


QUADRATIC = {
    2: (["x*y", "x*x - y**2/2"], "1 + x - 2*y", ["0.1*x*y + t*(x*y)", "0.2*y*y + t*(x*x - y**2/2)"]),
    3: (["y*z + x*y", "x*z - y**2/2", "x*y"], "1 + x - 2*y + 3*z",
        ["0.1*x*y + t*(y*z + x*y)", "0.2*z*z + t*(x*z - y**2/2)", "0.1*x*x + t*(x*y)"]),
}


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("configuration", CONFIGURATIONS)
def test_taylor_hood_reproduces_quadratic_data(configuration, dim):
    """Taylor–Hood k = 1 contains a quadratic divergence-free velocity, a linear pressure and the
    (linear) stress of a quadratic displacement: reproduced to round-off on straight meshes, so any
    error of the 3D enclosed-ball rates is approximation, not consistency."""
    errors = total_error(configuration, dim, QUADRATIC[dim], 1, family="taylor_hood", order=1,
                         initial_stress="projection", curved=False, project_refinement=False)
    assert errors["total"] < 1e-11, errors
