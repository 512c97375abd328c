"""Manufactured solutions: derived data, the interface load's sign, and refusal of inconsistent cases."""
import pytest
import sympy

from fsivsp.config.case import Case, Discretisation
from fsivsp.experiments.study import run_level
from fsivsp.geometry import paper_channel, refined
from fsivsp.model.expressions import T, X, Y
from fsivsp.model.manufactured import ExactSolution, ManufacturedError
from fsivsp.model.materials import Materials

MAT = Materials(rho_fluid=1.0, rho_solid=2.0, nu=0.5, lam=1.5, mu=0.75)


def test_forces_and_stresses_are_derived_symbolically():
    exact = ExactSolution.parse(["sin(pi*y)", "sin(pi*x)"], "cos(pi*x)*cos(pi*y)",
                                ["x*y + (1 + t)*sin(pi*y)", "x**2/2 + (1 + t)*sin(pi*x)"], 2)
    pi = sympy.pi
    fluid = exact.fluid_force(MAT)
    assert sympy.simplify(fluid[0] - (-pi * sympy.sin(pi * X) * sympy.cos(pi * Y)
                                      + 0.5 * pi**2 * sympy.sin(pi * Y))) == 0
    solid = exact.solid_force(MAT)
    assert sympy.simplify(solid[1] - (0.75 * pi**2 * (1 + T) * sympy.sin(pi * X) - 3.0)) == 0
    assert exact.solid_stress(MAT)[0, 0] == sympy.expand(1.5 * Y + 1.5 * Y)


def test_a_displacement_that_is_not_the_time_integral_of_the_velocity_is_refused():
    with pytest.raises(ManufacturedError, match=r"exact.displacement\[0\]"):
        ExactSolution.parse(["y", "x"], "0", ["t*y + t**2", "t*x"], 2)


@pytest.mark.parametrize("family", ["mini", "taylor_hood"])
@pytest.mark.parametrize("pressure", ["1", "x - 2*y"])
def test_fluid_at_rest_with_a_pressure_is_exact(family, pressure):
    """v = u = 0 and p linear: the load (σ_F − σ_S) n = −p n on Γ must balance it exactly.
    (A wrong sign of the interface load or of n makes p_h = −p.)"""
    exact = ExactSolution.parse(["0", "0"], pressure, ["0", "0"], 2)
    case = Case("rest", paper_channel, MAT, exact, T=0.04, dt=0.02,
                discretisation=Discretisation(family=family, initial_stress="projection"))
    record = run_level(case, refined(paper_channel(), 0), 0)
    assert record["errors"]["total"] < 1e-12
