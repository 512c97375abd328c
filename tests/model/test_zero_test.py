"""The zero test of `fields` (issue 27): cancellations found without sympy's simplify, small data kept."""
import sympy

from fsivsp.model.expressions import T, X, Y
from fsivsp.model.fields import Field, expression_is_zero

UNIT = ((0.0, 1.0), (0.0, 1.0))


def test_trigonometric_cancellations_are_zero():
    assert Field(sympy.sin(X * T) ** 2 + sympy.cos(X * T) ** 2 - 1).is_zero(UNIT)
    psi = sympy.sin(sympy.pi * X) * sympy.cos(2 * Y) * sympy.exp(T)      # div curl ψ = 0
    curl = [sympy.diff(psi, Y), -sympy.diff(psi, X)]
    assert Field(sympy.diff(curl[0], X) + sympy.diff(curl[1], Y)).is_zero(UNIT)
    assert Field([sympy.sin(2 * T) - 2 * sympy.sin(T) * sympy.cos(T), sympy.Integer(0)]).is_zero(UNIT)
    assert Field(sympy.Matrix([[0, 0], [0, 0]])).is_zero(UNIT)


def test_small_but_nonzero_data_is_not_zero():
    assert not Field(1e-3 * sympy.sin(X)).is_zero(UNIT)
    assert not Field([sympy.Integer(0), 1e-12 * (sympy.sin(X) ** 2 + sympy.cos(X) ** 2)]).is_zero(UNIT)
    assert not Field(sympy.sin(X) ** 2 + sympy.cos(X) ** 2 - 1 + 1e-6 * X * Y).is_zero(UNIT)
    # zero on the unit box but not on a larger one
    assert not expression_is_zero(sympy.Max(X - 1, 0), ((0.0, 2.0),) * 3)


def test_a_field_is_tested_on_the_box_it_is_given():
    """The scheme passes its mesh's extent (`geometry.extent`): data zero only on the unit box is kept on a larger
    domain (the 5 cm tube of examples/pressure_wave.toml, say)."""
    beyond = Field(sympy.Max(X - 1, 0))
    assert beyond.is_zero(UNIT) and not beyond.is_zero(((0.0, 2.0), (0.0, 1.0)))
