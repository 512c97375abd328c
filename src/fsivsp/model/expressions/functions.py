"""The one table of maths functions: what users may call, and each function's float and NGSolve forms."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import sympy


def _sign(v: float) -> float:
    return float((v > 0) - (v < 0))


def _tanh(a: Any, ng: Any) -> Any:  # NGSolve has no tanh
    e2 = ng.exp(2.0 * a)
    return (e2 - 1.0) / (e2 + 1.0)


#: sympy function → (its value for a float, its CoefficientFunction of a CoefficientFunction and the
#: ngsolve module). The functions sympy's simplification may produce from the callable ones are here too.
FUNCTIONS: dict[Any, tuple[Callable[[float], float], Callable[[Any, Any], Any]]] = {
    sympy.sin: (math.sin, lambda a, ng: ng.sin(a)),
    sympy.cos: (math.cos, lambda a, ng: ng.cos(a)),
    sympy.tan: (math.tan, lambda a, ng: ng.tan(a)),
    sympy.cot: (lambda v: 1.0 / math.tan(v), lambda a, ng: ng.cos(a) / ng.sin(a)),
    sympy.sec: (lambda v: 1.0 / math.cos(v), lambda a, ng: 1.0 / ng.cos(a)),
    sympy.csc: (lambda v: 1.0 / math.sin(v), lambda a, ng: 1.0 / ng.sin(a)),
    sympy.exp: (math.exp, lambda a, ng: ng.exp(a)),
    sympy.log: (math.log, lambda a, ng: ng.log(a)),
    sympy.sqrt: (math.sqrt, lambda a, ng: ng.sqrt(a)),  # sympy.sqrt builds a Pow: used by the parser only
    sympy.Abs: (abs, lambda a, ng: ng.IfPos(a, a, -a)),
    sympy.sign: (_sign, lambda a, ng: ng.IfPos(a, 1.0, ng.IfPos(-a, -1.0, 0.0))),
    sympy.re: (float, lambda a, ng: a),  # sympy's simplification may wrap real values in re(...)
    sympy.im: (lambda v: 0.0, lambda a, ng: 0.0),
    sympy.sinh: (math.sinh, lambda a, ng: ng.sinh(a)),
    sympy.cosh: (math.cosh, lambda a, ng: ng.cosh(a)),
    sympy.tanh: (math.tanh, _tanh),
    sympy.asin: (math.asin, lambda a, ng: ng.asin(a)),
    sympy.acos: (math.acos, lambda a, ng: ng.acos(a)),
    sympy.atan: (math.atan, lambda a, ng: ng.atan(a)),
}

#: the functions user text may call, by name
CALLABLE: dict[str, Callable[[sympy.Expr], sympy.Expr]] = {
    "sin": sympy.sin,
    "cos": sympy.cos,
    "tan": sympy.tan,
    "exp": sympy.exp,
    "log": sympy.log,
    "sqrt": sympy.sqrt,
    "abs": sympy.Abs,
}
