"""The parser's nodes: a sympy expression and its float value (None unless constant), each checked to be
finite and real, and built unevaluated where sympy's automatic simplification would be slow."""

from __future__ import annotations

import math

import sympy

from .floats import compile_float
from .functions import CALLABLE, FUNCTIONS
from .symbols import ExpressionError, T, show

MAX_EXPONENT = 64
MAX_EXPONENT_NESTING = 8  # x**y**z has 2 levels; sympy gets slow on tall towers
MAX_EXACT_ROOT_BASE = 2**64  # larger rational bases of fractional powers become floats

Node = tuple[sympy.Expr, float | None]


class Builder:
    """Builds and checks the nodes of one parse of ``text``; errors name ``field``."""

    def __init__(self, text: str, field: str) -> None:
        self.text = text
        self.field = field

    def error(self, problem: str, hint: str = "") -> ExpressionError:
        return ExpressionError(f"{self.field}: {problem} in {show(self.text)}{hint}")

    def apply(self, name: str, argument: Node, simple: bool) -> Node:
        """The callable function ``name`` of ``argument``; ``simple``: a short argument."""
        arg, value = argument
        if value is not None:
            try:
                value = FUNCTIONS[CALLABLE[name]][0](value)
            except (ValueError, OverflowError, ZeroDivisionError):
                raise self.error(f"{name}({_float_text(value)}) is not a finite real number") from None
            self.check_value(value)
        func = CALLABLE[name]
        if not simple or (value is not None and _has_function(arg)):
            # sympy's automatic simplification of functions of long arguments, or of
            # nested functions of constants (sin(sin(...(1)))), can be very slow:
            # keep such nodes as they are.
            return self.finish(func(arg, evaluate=False), value)
        return self.finish(func(arg), value)

    def check_value(self, value: float) -> None:
        if not math.isfinite(value):
            raise self.error("numeric value too large for a float")

    def binary(self, op: str, left: Node, right: Node, simple: bool = True) -> Node:
        """``left op right`` for op in + - * / **; ``simple``: a short power."""
        a, av = left
        b, bv = right
        value: float | None = None
        if op == "**":
            if bv is not None and abs(bv) > MAX_EXPONENT:
                raise self.error(
                    f"exponent {_float_text(bv)} too large (at most {MAX_EXPONENT} "
                    "in absolute value)"
                )
            if bv is None or not b.is_Number:
                if 1 + _exponent_height(b) > MAX_EXPONENT_NESTING:
                    raise self.error(
                        f"powers nested too deeply (at most {MAX_EXPONENT_NESTING} "
                        "levels of non-numeric exponents)"
                    )
            if av is not None and bv is not None:
                try:
                    value = math.pow(av, bv)
                except OverflowError:
                    raise self.error("numeric value too large for a float") from None
                except (ValueError, ZeroDivisionError):
                    if av == 0:
                        raise self.error("division by zero") from None
                    raise self.error(
                        f"({_float_text(av)})**({_float_text(bv)}) is not a real number"
                    ) from None
                self.check_value(value)
            if a.is_Rational and b.is_Rational and not b.is_Integer:
                if b.q > MAX_EXPONENT or max(abs(a.p), a.q) > MAX_EXACT_ROOT_BASE:
                    # sympy's exact roots factor the base (of a power of it): far too
                    # slow for huge numbers, so use the float value instead
                    assert value is not None
                    return self.finish(sympy.Float(value), value)
            if a.is_Rational and b.is_Rational:
                return self.finish(sympy.Pow(a, b), value)
            if not simple or (value is not None and (_has_function(a) or _has_function(b))):
                # as for functions: sympy's evaluation of large powers can be very slow
                return self.finish(sympy.Pow(a, b, evaluate=False), value)
            return self.finish(sympy.Pow(a, b), value)
        if op == "/":
            if bv is not None and b.is_zero:
                raise self.error("division by zero")
            if av is not None and bv is not None:
                try:
                    value = av / bv
                except (ZeroDivisionError, OverflowError):
                    raise self.error("numeric value out of float range") from None
                self.check_value(value)
            return self.finish(a / b, value)
        if av is not None and bv is not None:
            value = {"+": av + bv, "-": av - bv, "*": av * bv}[op]
            self.check_value(value)
        if op == "+":
            return self.finish(a + b, value)
        if op == "-":
            return self.finish(a - b, value)
        return self.finish(a * b, value)

    def finish(self, expr: sympy.Expr, value: float | None) -> Node:
        """Check a freshly built node; compute its float value if it became constant."""
        if value is None and not expr.free_symbols:
            try:
                value = compile_float(expr, T)
            except (ValueError, OverflowError, ZeroDivisionError, TypeError):
                raise self.error("expression is not a finite real number") from None
            if callable(value):  # pragma: no cover - constants always fold
                value = value(0.0)
            self.check_value(value)
        if value is not None and (expr.has(sympy.zoo, sympy.nan) or expr.has(sympy.I)):
            raise self.error("expression is not a finite real number")
        return expr, value


def _exponent_height(expr: sympy.Basic) -> int:
    """Height of the tower of non-numeric exponents in ``expr`` (x**y**z -> 2)."""
    if not expr.args:
        return 0
    if isinstance(expr, sympy.Pow):
        base, exponent = expr.args
        height = _exponent_height(base)
        if not exponent.is_Number:
            height = max(height, 1 + _exponent_height(exponent))
        return height
    return max(_exponent_height(a) for a in expr.args)


def _has_function(expr: sympy.Expr) -> bool:
    return bool(expr.atoms(sympy.Function))


def _float_text(value: float) -> str:
    return f"{value:.6g}"

