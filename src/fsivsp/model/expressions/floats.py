"""The float compiler: a sympy expression of one variable as a fast float -> float closure."""

from __future__ import annotations

import math
import operator
from collections.abc import Callable

import sympy

from .functions import FUNCTIONS
from .symbols import T, as_expr

Compiled = float | Callable[[float], float]


def _number(expr: sympy.Expr) -> float:
    value = float(expr)
    if not math.isfinite(value):
        raise OverflowError(f"{expr} is not a finite float")
    return value


def compile_float(expr: sympy.Expr, var: sympy.Symbol) -> Compiled:
    """Closure of one float argument for ``expr`` (a float when ``expr`` is constant)."""
    if expr is var or expr == var:
        return _identity
    if expr.is_Number or expr.is_NumberSymbol:
        if expr.is_Number and not expr.is_finite:
            raise ValueError(f"{expr} is not finite")
        return _number(expr)
    if isinstance(expr, sympy.Add):
        return _compile_fold([compile_float(a, var) for a in expr.args], 0.0, operator.add)
    if isinstance(expr, sympy.Mul):
        return _compile_fold([compile_float(a, var) for a in expr.args], 1.0, operator.mul)
    if isinstance(expr, sympy.Pow):
        return _compile_pow(expr, var)
    if expr.func in FUNCTIONS and len(expr.args) == 1:
        func = FUNCTIONS[expr.func][0]
        arg = compile_float(expr.args[0], var)
        if callable(arg):
            return lambda v: func(arg(v))
        return float(func(arg))
    raise ValueError(f"unsupported expression {expr} (type {type(expr).__name__})")


def _identity(v: float) -> float:
    return v


def _compile_fold(parts: list[Compiled], unit: float, combine: Callable[[float, float], float]) -> Compiled:
    """The sum (``operator.add``, unit 0) or product (``operator.mul``, unit 1) of compiled parts:
    constant parts folded once, the others evaluated in turn."""
    constant = unit
    functions: list[Callable[[float], float]] = []
    for part in parts:
        if callable(part):
            functions.append(part)
        else:
            constant = combine(constant, part)
    if not functions:
        return constant
    if len(functions) == 1 and constant == unit:
        return functions[0]
    functions_t = tuple(functions)

    def folded(v: float) -> float:
        value = constant
        for f in functions_t:
            value = combine(value, f(v))
        return value

    return folded


def _compile_pow(expr: sympy.Pow, var: sympy.Symbol) -> Compiled:
    base_expr, exp_expr = expr.args
    if base_expr is sympy.E:
        e = compile_float(exp_expr, var)
        return (lambda v: math.exp(e(v))) if callable(e) else math.exp(e)
    b = compile_float(base_expr, var)
    if exp_expr.is_Integer:
        n = int(exp_expr)
        if not callable(b):
            return float(b**n) if n >= 0 else 1.0 / b ** (-n)
        if n == 2:
            def square(v: float) -> float:
                u = b(v)
                return u * u

            return square
        if n == -1:
            return lambda v: 1.0 / b(v)
        return lambda v: b(v) ** n
    e = compile_float(exp_expr, var)
    if not callable(e):
        if not callable(b):
            return math.pow(b, e)
        if e == 0.5:
            return lambda v: math.sqrt(b(v))
        if e == -0.5:
            return lambda v: 1.0 / math.sqrt(b(v))
        return lambda v: math.pow(b(v), e)
    if not callable(b):
        return lambda v: math.pow(b, e(v))
    return lambda v: math.pow(b(v), e(v))


def to_function(expr: sympy.Expr, var: sympy.Symbol = T) -> Callable[[float], float]:
    """Compile ``expr`` (depending on ``var`` only) into a fast float -> float callable."""
    expr = as_expr(expr)
    extra = expr.free_symbols - {var}
    if extra:
        names = ", ".join(sorted(str(s) for s in extra))
        raise ValueError(f"to_function: {expr} depends on {names}, not only on {var}")
    try:
        compiled = compile_float(expr, var)
    except (OverflowError, ZeroDivisionError) as err:
        raise ValueError(f"to_function: cannot evaluate {expr}: {err}") from err
    if callable(compiled):
        return compiled
    value = float(compiled)
    return lambda v: value

