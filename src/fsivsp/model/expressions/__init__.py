"""Safe user expressions of x, y, z, t.

User text (forcing terms, initial data, exact solutions from TOML case files) is parsed by a small
recursive-descent parser (`parser`) that builds sympy objects directly from a whitelist of tokens.
Nothing here ever calls ``eval``/``exec`` or the sympy helpers built on them (``sympify``,
``parse_expr``, ``lambdify``): the compilers to float callables (`floats`) and to NGSolve coefficient
functions (`coefficients`) walk the sympy tree; `separate` writes an expression as a sum of time
factors times space factors. `functions` is the one table of the maths functions all of them know.
"""

from .coefficients import to_coefficient
from .floats import to_function
from .parser import parse, parse_vector
from .separate import separate_time, separate_time_vector
from .symbols import SPACE, ExpressionError, T, X, Y, Z

__all__ = [
    "X",
    "Y",
    "Z",
    "T",
    "SPACE",
    "ExpressionError",
    "parse",
    "parse_vector",
    "to_function",
    "to_coefficient",
    "separate_time",
    "separate_time_vector",
]
