"""The NGSolve compiler: a sympy expression (or a vector or matrix of them) as a CoefficientFunction."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import sympy

from .floats import compile_float
from .functions import FUNCTIONS
from .symbols import T, X, Y, Z, as_expr

if TYPE_CHECKING:  # ngsolve is imported lazily: parsing works without it
    import ngsolve


def to_coefficient(expr: Any, t: Any) -> ngsolve.CoefficientFunction:
    """Turn a sympy expression (or vector/matrix of them) into an NGSolve CoefficientFunction.

    ``t`` is an ``ngsolve.Parameter`` (or a float) standing for the time variable.
    """
    import ngsolve

    if isinstance(expr, sympy.MatrixBase):
        rows, cols = expr.shape
        entries = tuple(_cf_wrap(_to_cf(as_expr(e), t, {}, ngsolve), ngsolve) for e in expr)
        if rows == 1 or cols == 1:
            return ngsolve.CoefficientFunction(entries)
        return ngsolve.CoefficientFunction(entries, dims=(rows, cols))
    if isinstance(expr, (list, tuple)):
        if expr and all(isinstance(row, (list, tuple)) for row in expr):
            return to_coefficient(sympy.Matrix([[as_expr(e) for e in row] for row in expr]), t)
        memo: dict[sympy.Expr, Any] = {}
        entries = tuple(_cf_wrap(_to_cf(as_expr(e), t, memo, ngsolve), ngsolve) for e in expr)
        return ngsolve.CoefficientFunction(entries)
    return _cf_wrap(_to_cf(as_expr(expr), t, {}, ngsolve), ngsolve)


def _cf_wrap(value: Any, ngsolve: Any) -> Any:
    if isinstance(value, float):
        return ngsolve.CoefficientFunction(value)
    return value


def _cf_power(base: Any, n: int) -> Any:
    """base**n for n >= 1 by repeated multiplication (binary powering)."""
    result = None
    square = base
    while True:
        if n & 1:
            result = square if result is None else result * square
        n >>= 1
        if not n:
            return result
        square = square * square


def _to_cf(expr: sympy.Expr, t: Any, memo: dict[sympy.Expr, Any], ngsolve: Any) -> Any:
    """CoefficientFunction for ``expr``; plain floats for constants."""
    if expr in memo:
        return memo[expr]
    if not expr.free_symbols:
        value = compile_float(expr, T)
        result: Any = float(value) if not callable(value) else value(0.0)
    elif expr == X:
        result = ngsolve.x
    elif expr == Y:
        result = ngsolve.y
    elif expr == Z:
        result = ngsolve.z
    elif expr == T:
        result = float(t) if isinstance(t, (int, float)) else t
    elif isinstance(expr, (sympy.Add, sympy.Mul)):
        is_add = isinstance(expr, sympy.Add)
        const = 0.0 if is_add else 1.0
        acc = None
        for arg in expr.args:
            part = _to_cf(arg, t, memo, ngsolve)
            if isinstance(part, float):
                const = const + part if is_add else const * part
            elif acc is None:
                acc = part
            else:
                acc = acc + part if is_add else acc * part
        if acc is None:
            result = const
        elif is_add:
            result = acc if const == 0.0 else acc + const
        else:
            result = acc if const == 1.0 else (-acc if const == -1.0 else const * acc)
    elif isinstance(expr, sympy.Pow):
        result = _to_cf_pow(expr, t, memo, ngsolve)
    else:
        result = _to_cf_function(expr, t, memo, ngsolve)
    memo[expr] = result
    return result


def _to_cf_pow(expr: sympy.Pow, t: Any, memo: dict[sympy.Expr, Any], ngsolve: Any) -> Any:
    base_expr, exp_expr = expr.args
    if base_expr is sympy.E:
        return ngsolve.exp(_to_cf(exp_expr, t, memo, ngsolve))
    base = _to_cf(base_expr, t, memo, ngsolve)
    if exp_expr.is_Integer:
        n = int(exp_expr)
        if isinstance(base, float):
            return float(base**n) if n >= 0 else 1.0 / base ** (-n)
        if n == 0:
            return 1.0
        power = _cf_power(base, abs(n))
        return power if n > 0 else 1.0 / power
    exponent = _to_cf(exp_expr, t, memo, ngsolve)
    if isinstance(exponent, float):
        if isinstance(base, float):
            return math.pow(base, exponent)
        if exponent == 0.5:
            return ngsolve.sqrt(base)
        if exponent == -0.5:
            return 1.0 / ngsolve.sqrt(base)
        return base**exponent
    if isinstance(base, float):
        if base > 0:
            return ngsolve.exp(exponent * math.log(base))
        return ngsolve.CoefficientFunction(base) ** exponent
    return base**exponent


def _to_cf_function(expr: sympy.Expr, t: Any, memo: dict[sympy.Expr, Any], ngsolve: Any) -> Any:
    if len(expr.args) != 1:
        raise ValueError(f"to_coefficient: unsupported expression {expr}")
    a = _to_cf(expr.args[0], t, memo, ngsolve)
    if expr.func not in FUNCTIONS:
        raise ValueError(f"to_coefficient: unsupported expression {expr}")
    value, coefficient = FUNCTIONS[expr.func]
    if isinstance(a, float):  # e.g. a function of t for a float t
        return float(value(a))
    return coefficient(a, ngsolve)
