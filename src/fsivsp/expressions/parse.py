"""Safe user expressions of x, y, z, t.

User text (forcing terms, initial data, exact solutions from TOML case files) is
parsed by a small recursive-descent parser that builds sympy objects directly
from a whitelist of tokens.  Nothing here ever calls ``eval``/``exec`` or the
sympy helpers built on them (``sympify``, ``parse_expr``, ``lambdify``):
compilation to Python callables and to NGSolve coefficient functions is done
by walking the sympy tree.
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Any

import sympy

if TYPE_CHECKING:  # ngsolve is imported lazily: parsing works without it
    import ngsolve

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

X, Y, Z, T = sympy.symbols("x y z t", real=True)
SPACE = (X, Y, Z)

MAX_LENGTH = 2000
MAX_DEPTH = 100
MAX_EXPONENT = 64
SIMPLE_TOKENS = 24  # longer function arguments / powers are built unevaluated
MAX_EXPONENT_NESTING = 8  # x**y**z has 2 levels; sympy gets slow on tall towers
MAX_EXACT_ROOT_BASE = 2**64  # larger rational bases of fractional powers become floats
MAX_DECIMAL_EXPONENT = 400  # bound on the power of ten of a literal (1e-3, 2.5e10 ...)
MAX_SEPARATED_TERMS = 20000  # separate_time gives up (returns None) beyond this

_FUNCTIONS: dict[str, Callable[[sympy.Expr], sympy.Expr]] = {
    "sin": sympy.sin,
    "cos": sympy.cos,
    "tan": sympy.tan,
    "exp": sympy.exp,
    "log": sympy.log,
    "sqrt": sympy.sqrt,
    "abs": sympy.Abs,
}


class ExpressionError(ValueError):
    """Bad user expression; ``str(err)`` is one line naming the offending field."""

    def __init__(self, message: str) -> None:
        super().__init__(_one_line(message))


def _one_line(text: str) -> str:
    """Escape every non-printable character (newlines, tabs, ...) of ``text``."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _show(text: str, limit: int = 80) -> str:
    """Quoted, one-line, possibly shortened rendering of user text."""
    if len(text) > limit:
        text = text[: limit - 3] + "..."
    return repr(text)


def _expected(dim: int) -> str:
    names = "x, y, z, t" if dim == 3 else "x, y, t"
    return (
        f"expected numbers, {names}, pi, + - * / ** ( ) and "
        + " ".join(_FUNCTIONS)
    )


# --------------------------------------------------------------------------- tokens

_TOKEN_RE = re.compile(
    r"""
    (?P<space>[ \t\r\n]+)
  | (?P<number>(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
  | (?P<op>\*\*|[-+*/(),])
    """,
    re.VERBOSE,
)

_HINTS = {
    "^": " (use ** for powers)",
    "[": " (brackets are not allowed; use parentheses)",
    "]": " (brackets are not allowed; use parentheses)",
    ".": " (attribute access is not allowed)",
    "=": "",
}


class _Token:
    __slots__ = ("kind", "text", "pos")

    def __init__(self, kind: str, text: str, pos: int) -> None:
        self.kind = kind
        self.text = text
        self.pos = pos


class _Parser:
    """Recursive-descent parser; each node is a pair (sympy expr, float value or None)."""

    def __init__(self, text: str, field: str, dim: int) -> None:
        self.text = text
        self.field = field
        self.dim = dim
        self.tokens = self._tokenize()
        self.i = 0
        self.depth = 0

    # -- errors -------------------------------------------------------------
    def error(self, problem: str, hint: str = "") -> ExpressionError:
        return ExpressionError(f"{self.field}: {problem} in {_show(self.text)}{hint}")

    def unexpected(self, tok: _Token | None) -> ExpressionError:
        if tok is None:
            return self.error("unexpected end of expression", "; " + _expected(self.dim))
        if tok.kind == "bad":
            return self.error(
                f"unexpected character {tok.text!r} at position {tok.pos}",
                f"{_HINTS.get(tok.text, '')}; {_expected(self.dim)}",
            )
        return self.error(
            f"unexpected {tok.text!r} at position {tok.pos}", "; " + _expected(self.dim)
        )

    # -- tokenizer ----------------------------------------------------------
    def _tokenize(self) -> list[_Token]:
        text = self.text
        tokens: list[_Token] = []
        pos = 0
        while pos < len(text):
            m = _TOKEN_RE.match(text, pos)
            if m is None:  # reported when the parser reaches it
                tokens.append(_Token("bad", text[pos], pos))
                break
            kind = m.lastgroup or ""
            if kind != "space":
                tokens.append(_Token(kind, m.group(), pos))
            pos = m.end()
        return tokens

    def peek(self) -> _Token | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def take(self) -> _Token | None:
        tok = self.peek()
        if tok is not None:
            self.i += 1
        return tok

    def accept(self, op: str) -> bool:
        tok = self.peek()
        if tok is not None and tok.kind == "op" and tok.text == op:
            self.i += 1
            return True
        return False

    def enter(self) -> None:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise self.error(f"expression nested too deeply (more than {MAX_DEPTH} levels)")

    # -- grammar --------------------------------------------------------------
    def parse(self) -> sympy.Expr:
        if not self.tokens:
            raise self.error("empty expression")
        expr, _ = self.expr()
        tok = self.peek()
        if tok is not None:
            if tok.kind == "op" and tok.text == ")":
                raise self.error(f"unmatched ')' at position {tok.pos}")
            raise self.unexpected(tok)
        if expr.has(sympy.zoo, sympy.nan, sympy.oo, -sympy.oo):
            raise self.error("expression is not finite (division by zero?)")
        if expr.has(sympy.I):
            raise self.error("expression is not real-valued")
        for node in sympy.preorder_traversal(expr):
            if isinstance(node, sympy.Pow) and node.exp.is_Number:
                if abs(node.exp) > MAX_EXPONENT:
                    raise self.error(
                        f"exponent {node.exp} too large after combining powers "
                        f"(at most {MAX_EXPONENT} in absolute value)"
                    )
        return expr

    def _level(self, operand, operators: str) -> tuple[sympy.Expr, float | None]:
        """A left-associative chain ``operand (op operand)*`` of one precedence level."""
        left = operand()
        while True:
            op = next((o for o in operators if self.accept(o)), None)
            if op is None:
                return left
            left = self.binary(op, left, operand())

    def expr(self) -> tuple[sympy.Expr, float | None]:
        return self._level(self.term, "+-")

    def term(self) -> tuple[sympy.Expr, float | None]:
        return self._level(self.unary, "*/")

    def unary(self) -> tuple[sympy.Expr, float | None]:
        tok = self.peek()
        if tok is not None and tok.kind == "op" and tok.text in "+-":
            self.i += 1
            self.enter()
            operand, value = self.unary()
            self.depth -= 1
            if tok.text == "+":
                return operand, value
            return self.finish(-operand, None if value is None else -value)
        return self.power()

    def power(self) -> tuple[sympy.Expr, float | None]:
        start = self.i
        base = self.primary()
        if not self.accept("**"):
            return base
        self.enter()
        exponent = self.unary()  # right-associative, and 2**-1 is allowed
        self.depth -= 1
        return self.binary("**", base, exponent, simple=self.i - start <= SIMPLE_TOKENS)

    def primary(self) -> tuple[sympy.Expr, float | None]:
        tok = self.take()
        if tok is None:
            raise self.unexpected(None)
        if tok.kind == "number":
            return self.number(tok)
        if tok.kind == "name":
            return self.name(tok)
        if tok.kind == "op" and tok.text == "(":
            self.enter()
            inner = self.expr()
            self.close(tok)
            self.depth -= 1
            return inner
        raise self.unexpected(tok)

    def close(self, opening: _Token) -> None:
        if self.accept(")"):
            return
        tok = self.peek()
        if tok is None:
            raise self.error(f"missing ')' for '(' at position {opening.pos}")
        raise self.unexpected(tok)

    def number(self, tok: _Token) -> tuple[sympy.Expr, float | None]:
        mantissa, _, exp_text = tok.text.lower().partition("e")
        whole, _, frac = mantissa.partition(".")
        exponent = (int(exp_text) if exp_text else 0) - len(frac)
        digits = int((whole + frac) or "0")
        if digits and abs(exponent) > MAX_DECIMAL_EXPONENT:
            raise self.error(f"number {tok.text!r} out of range")
        value = float(tok.text)
        if not math.isfinite(value):
            raise self.error(f"number {tok.text!r} too large for a float")
        if exponent >= 0:
            return sympy.Integer(digits * 10**exponent), value
        return sympy.Rational(digits, 10**-exponent), value

    def name(self, tok: _Token) -> tuple[sympy.Expr, float | None]:
        name = tok.text
        if name in _FUNCTIONS:
            return self.call(tok)
        if name == "x":
            return X, None
        if name == "y":
            return Y, None
        if name == "t":
            return T, None
        if name == "z" and self.dim == 3:
            return Z, None
        if name == "pi":
            return sympy.pi, math.pi
        hint = ""
        if name in ("e", "E"):
            hint = " (write exp(1) for Euler's number)"
        elif name == "z":
            hint = f" (z is not available in {self.dim}D)"
        elif name in ("ln", "Abs", "fabs"):
            hint = " (use log or abs)"
        raise self.error(f"unknown name {name!r}", f"{hint}; {_expected(self.dim)}")

    def call(self, tok: _Token) -> tuple[sympy.Expr, float | None]:
        name = tok.text
        opening = self.peek()
        if not self.accept("("):
            raise self.error(
                f"function {name!r} must be called with one argument, e.g. {name}(x),"
            )
        self.enter()
        start = self.i
        arg, value = self.expr()
        simple = self.i - start <= SIMPLE_TOKENS
        if self.peek() is not None and self.peek().text == ",":  # type: ignore[union-attr]
            raise self.error(f"{name} takes exactly one argument")
        assert opening is not None
        self.close(opening)
        self.depth -= 1
        if value is not None:
            try:
                value = _FLOAT_FUNCTIONS[name](value)
            except (ValueError, OverflowError, ZeroDivisionError):
                raise self.error(f"{name}({_float_text(value)}) is not a finite real number")
            self.check_value(value)
        func = _FUNCTIONS[name]
        if not simple or (value is not None and _has_function(arg)):
            # sympy's automatic simplification of functions of long arguments, or of
            # nested functions of constants (sin(sin(...(1)))), can be very slow:
            # keep such nodes as they are.
            return self.finish(func(arg, evaluate=False), value)
        return self.finish(func(arg), value)

    # -- node construction ------------------------------------------------------
    def check_value(self, value: float) -> None:
        if not math.isfinite(value):
            raise self.error("numeric value too large for a float")

    def binary(
        self,
        op: str,
        left: tuple[sympy.Expr, float | None],
        right: tuple[sympy.Expr, float | None],
        simple: bool = True,
    ) -> tuple[sympy.Expr, float | None]:
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
                    raise self.error("numeric value too large for a float")
                except (ValueError, ZeroDivisionError):
                    if av == 0:
                        raise self.error("division by zero")
                    raise self.error(
                        f"({_float_text(av)})**({_float_text(bv)}) is not a real number"
                    )
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
                    raise self.error("numeric value out of float range")
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

    def finish(self, expr: sympy.Expr, value: float | None) -> tuple[sympy.Expr, float | None]:
        """Check a freshly built node; compute its float value if it became constant."""
        if value is None and not expr.free_symbols:
            try:
                value = _compile(expr, T)
            except (ValueError, OverflowError, ZeroDivisionError, TypeError):
                raise self.error("expression is not a finite real number")
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


_FLOAT_FUNCTIONS: dict[str, Callable[[float], float]] = {
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "exp": math.exp,
    "log": math.log,
    "sqrt": math.sqrt,
    "abs": abs,
}


def parse(text: str, field: str, dim: int = 3) -> sympy.Expr:
    """Parse user text into a sympy expression of x, y, (z,) t.

    Raises :class:`ExpressionError` (a one-line message naming ``field``) for
    anything outside the whitelist grammar or numerically unreasonable.
    """
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise ExpressionError(
            f"{field}: expected an expression string, got {type(text).__name__}"
        )
    text = str(text)
    if len(text) > MAX_LENGTH:
        raise ExpressionError(
            f"{field}: expression too long ({len(text)} characters, at most {MAX_LENGTH})"
        )
    try:
        return _Parser(text, field, dim).parse()
    except ExpressionError:
        raise
    except Exception as err:  # noqa: BLE001 - parse promises ExpressionError only
        # internal failures of sympy's automatic simplification on odd input
        raise ExpressionError(
            f"{field}: cannot process {_show(text)} ({type(err).__name__})"
        ) from err


def parse_vector(items: Any, field: str, dim: int) -> list[sympy.Expr]:
    """Parse a list of exactly ``dim`` expressions; errors name ``field[i]``."""
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence) or len(items) != dim:
        if isinstance(items, Sequence) and not isinstance(items, (str, bytes)):
            got = f"{len(items)} item{'s' if len(items) != 1 else ''}"
        else:
            got = _show(str(items), 60)
        raise ExpressionError(f"{field}: expected a list of {dim} expressions, got {got}")
    return [parse(item, f"{field}[{i}]", dim) for i, item in enumerate(items)]


# ------------------------------------------------------------------ to_function


def _as_expr(obj: Any) -> sympy.Expr:
    if isinstance(obj, sympy.Basic):
        return obj  # type: ignore[return-value]
    if isinstance(obj, bool):
        raise TypeError("expected a sympy expression, got bool")
    if isinstance(obj, int):
        return sympy.Integer(obj)
    if isinstance(obj, float):
        return sympy.Float(obj)
    raise TypeError(f"expected a sympy expression, got {type(obj).__name__}")


def _sec(v: float) -> float:
    return 1.0 / math.cos(v)


def _csc(v: float) -> float:
    return 1.0 / math.sin(v)


def _cot(v: float) -> float:
    return 1.0 / math.tan(v)


def _zero(v: float) -> float:
    return 0.0


def _sign(v: float) -> float:
    return float((v > 0) - (v < 0))


_MATH: dict[Any, Callable[[float], float]] = {
    sympy.sin: math.sin,
    sympy.cos: math.cos,
    sympy.tan: math.tan,
    sympy.cot: _cot,
    sympy.sec: _sec,
    sympy.csc: _csc,
    sympy.exp: math.exp,
    sympy.log: math.log,
    sympy.Abs: abs,
    sympy.sign: _sign,
    sympy.re: float,
    sympy.im: _zero,
    sympy.sinh: math.sinh,
    sympy.cosh: math.cosh,
    sympy.tanh: math.tanh,
    sympy.asin: math.asin,
    sympy.acos: math.acos,
    sympy.atan: math.atan,
}

_Compiled = float | Callable[[float], float]


def _number(expr: sympy.Expr) -> float:
    value = float(expr)
    if not math.isfinite(value):
        raise OverflowError(f"{expr} is not a finite float")
    return value


def _compile(expr: sympy.Expr, var: sympy.Symbol) -> _Compiled:
    """Closure of one float argument for ``expr`` (a float when ``expr`` is constant)."""
    if expr is var or expr == var:
        return _identity
    if expr.is_Number or expr.is_NumberSymbol:
        if expr.is_Number and not expr.is_finite:
            raise ValueError(f"{expr} is not finite")
        return _number(expr)
    if isinstance(expr, sympy.Add):
        return _compile_fold([_compile(a, var) for a in expr.args], 0.0, operator.add)
    if isinstance(expr, sympy.Mul):
        return _compile_fold([_compile(a, var) for a in expr.args], 1.0, operator.mul)
    if isinstance(expr, sympy.Pow):
        return _compile_pow(expr, var)
    func = _MATH.get(expr.func)
    if func is not None and len(expr.args) == 1:
        arg = _compile(expr.args[0], var)
        if callable(arg):
            return lambda v: func(arg(v))
        return float(func(arg))
    raise ValueError(f"unsupported expression {expr} (type {type(expr).__name__})")


def _identity(v: float) -> float:
    return v


def _compile_fold(parts: list[_Compiled], unit: float, combine: Callable[[float, float], float]) -> _Compiled:
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


def _compile_pow(expr: sympy.Pow, var: sympy.Symbol) -> _Compiled:
    base_expr, exp_expr = expr.args
    if base_expr is sympy.E:
        e = _compile(exp_expr, var)
        return (lambda v: math.exp(e(v))) if callable(e) else math.exp(e)
    b = _compile(base_expr, var)
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
    e = _compile(exp_expr, var)
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
    expr = _as_expr(expr)
    extra = expr.free_symbols - {var}
    if extra:
        names = ", ".join(sorted(str(s) for s in extra))
        raise ValueError(f"to_function: {expr} depends on {names}, not only on {var}")
    try:
        compiled = _compile(expr, var)
    except (OverflowError, ZeroDivisionError) as err:
        raise ValueError(f"to_function: cannot evaluate {expr}: {err}") from err
    if callable(compiled):
        return compiled
    value = float(compiled)
    return lambda v: value


# --------------------------------------------------------------- to_coefficient


def to_coefficient(expr: Any, t: Any) -> ngsolve.CoefficientFunction:
    """Turn a sympy expression (or vector/matrix of them) into an NGSolve CoefficientFunction.

    ``t`` is an ``ngsolve.Parameter`` (or a float) standing for the time variable.
    """
    import ngsolve

    if isinstance(expr, sympy.MatrixBase):
        rows, cols = expr.shape
        entries = tuple(_cf_wrap(_to_cf(_as_expr(e), t, {}, ngsolve), ngsolve) for e in expr)
        if rows == 1 or cols == 1:
            return ngsolve.CoefficientFunction(entries)
        return ngsolve.CoefficientFunction(entries, dims=(rows, cols))
    if isinstance(expr, (list, tuple)):
        if expr and all(isinstance(row, (list, tuple)) for row in expr):
            return to_coefficient(sympy.Matrix([[_as_expr(e) for e in row] for row in expr]), t)
        memo: dict[sympy.Expr, Any] = {}
        entries = tuple(_cf_wrap(_to_cf(_as_expr(e), t, memo, ngsolve), ngsolve) for e in expr)
        return ngsolve.CoefficientFunction(entries)
    return _cf_wrap(_to_cf(_as_expr(expr), t, {}, ngsolve), ngsolve)


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
        value = _compile(expr, T)
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
    elif expr.func is sympy.Abs:
        a = _to_cf(expr.args[0], t, memo, ngsolve)
        result = abs(a) if isinstance(a, float) else ngsolve.IfPos(a, a, -a)
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
    f = expr.func
    if isinstance(a, float) and f in _MATH:  # e.g. a function of t for a float t
        return float(_MATH[f](a))
    direct = {
        sympy.sin: "sin",
        sympy.cos: "cos",
        sympy.tan: "tan",
        sympy.exp: "exp",
        sympy.log: "log",
        sympy.atan: "atan",
        sympy.asin: "asin",
        sympy.acos: "acos",
        sympy.sinh: "sinh",
        sympy.cosh: "cosh",
    }
    if f in direct and hasattr(ngsolve, direct[f]):
        return getattr(ngsolve, direct[f])(a)
    if f is sympy.cot:
        return ngsolve.cos(a) / ngsolve.sin(a)
    if f is sympy.sec:
        return 1.0 / ngsolve.cos(a)
    if f is sympy.csc:
        return 1.0 / ngsolve.sin(a)
    if f is sympy.tanh:
        e2 = ngsolve.exp(2.0 * a)
        return (e2 - 1.0) / (e2 + 1.0)
    if f is sympy.sign:
        return ngsolve.IfPos(a, 1.0, ngsolve.IfPos(-a, -1.0, 0.0))
    if f is sympy.re:  # sympy's simplification may wrap real values in re(...)
        return a
    if f is sympy.im:
        return 0.0
    raise ValueError(f"to_coefficient: unsupported expression {expr}")


# ---------------------------------------------------------------- separate_time

# A separated expansion: {(time_factor, space_factor): numeric coefficient}.
_Terms = dict[tuple[sympy.Expr, sympy.Expr], sympy.Expr]
_ONE = sympy.Integer(1)


def _normalize(expr: sympy.Expr) -> tuple[sympy.Expr, sympy.Expr]:
    """Split a pure (time-only or space-only) product into (numeric content, rest)."""
    coeff = _ONE
    rest = []
    for f in sympy.Mul.make_args(expr):
        if f.free_symbols:
            rest.append(f)
        else:
            coeff *= f
    prim = sympy.Mul(*rest)
    if isinstance(prim, sympy.Add):
        content, prim = prim.as_content_primitive()
        coeff *= content
        if prim.could_extract_minus_sign():
            coeff, prim = -coeff, -prim
    return coeff, prim


def _kind(expr: sympy.Expr) -> str:
    syms = expr.free_symbols
    if not syms:
        return "const"
    if T not in syms:
        return "space"
    return "time" if syms == {T} else "mixed"


def _leaf(expr: sympy.Expr) -> _Terms:
    kind = _kind(expr)
    if kind == "const":
        return {(_ONE, _ONE): expr} if expr != 0 else {}
    coeff, prim = _normalize(expr)
    return {(prim, _ONE) if kind == "time" else (_ONE, prim): coeff}


def _add_into(acc: _Terms, key: tuple[sympy.Expr, sympy.Expr], coeff: sympy.Expr) -> None:
    value = acc.get(key, 0) + coeff
    if value == 0:
        acc.pop(key, None)
    else:
        acc[key] = value


def _product(a: _Terms, b: _Terms) -> _Terms | None:
    if len(a) * len(b) > MAX_SEPARATED_TERMS:
        return None
    out: _Terms = {}
    for (ta, sa), ca in a.items():
        for (tb, sb), cb in b.items():
            c1, tm = _normalize(ta * tb)
            c2, sm = _normalize(sa * sb)
            _add_into(out, (tm, sm), ca * cb * c1 * c2)
    return out


def _split_sum(arg: sympy.Expr) -> tuple[sympy.Expr, sympy.Expr] | None:
    """Write ``arg`` = A(t) + B(x, y, z) or return None."""
    terms = _separate(arg)
    if terms is None:
        return None
    a, b = [], []
    for (tm, sm), c in terms.items():
        if sm == 1:
            a.append(c * tm)
        elif tm == 1:
            b.append(c * sm)
        else:
            return None
    return sympy.Add(*a), sympy.Add(*b)


def _separate(expr: sympy.Expr) -> _Terms | None:
    """Separated expansion of ``expr`` (only mixed parts are expanded), or None."""
    if _kind(expr) != "mixed":
        return _leaf(expr)
    if isinstance(expr, sympy.Add):
        out: _Terms = {}
        for arg in expr.args:
            part = _separate(arg)
            if part is None:
                return None
            for key, c in part.items():
                _add_into(out, key, c)
            if len(out) > MAX_SEPARATED_TERMS:
                return None
        return out
    if isinstance(expr, sympy.Mul):
        acc: _Terms | None = {(_ONE, _ONE): _ONE}
        for arg in expr.args:
            part = _separate(arg)
            if part is None or acc is None:
                return None
            acc = _product(acc, part)
        return acc
    if isinstance(expr, sympy.Pow):
        base, exponent = expr.args
        if exponent.is_Integer and int(exponent) > 0:
            n = int(exponent)
            split = _split_sum(base)
            if split is not None:  # binomial theorem, keeping A(t)**k and B(x)**(n-k) whole
                a, b = split
                out = {}
                for k in range(n + 1):
                    c1, tm = _normalize(a**k)
                    c2, sm = _normalize(b ** (n - k))
                    _add_into(out, (tm, sm), sympy.binomial(n, k) * c1 * c2)
                return out
            part = _separate(base)
            if part is None or n > MAX_EXPONENT:
                return None
            acc = part
            for _ in range(n - 1):
                acc = _product(acc, part)
                if acc is None:
                    return None
            return acc
        if _kind(base) == "const" and base.is_positive:
            split = _split_sum(exponent)
            if split is None:
                return None
            a, b = split
            return _product(_leaf(sympy.Pow(base, a)), _leaf(sympy.Pow(base, b)))
        return None
    if expr.func in (sympy.exp, sympy.sin, sympy.cos) and len(expr.args) == 1:
        split = _split_sum(expr.args[0])
        if split is None:
            return None
        a, b = split
        if expr.func is sympy.exp:
            return _product(_leaf(sympy.exp(a)), _leaf(sympy.exp(b)))
        sa, ca = _leaf(sympy.sin(a)), _leaf(sympy.cos(a))
        sb, cb = _leaf(sympy.sin(b)), _leaf(sympy.cos(b))
        first = _product(sa, cb) if expr.func is sympy.sin else _product(ca, cb)
        second = _product(ca, sb) if expr.func is sympy.sin else _product(sa, sb)
        if first is None or second is None:
            return None
        sign = 1 if expr.func is sympy.sin else -1
        for key, c in second.items():
            _add_into(first, key, sign * c)
        return first
    return None


def separate_time_vector(
    exprs: Iterable[sympy.Expr],
) -> list[tuple[sympy.Expr, list[sympy.Expr]]] | None:
    """Write ``exprs`` = sum_k T_k(t) * [S_k0, S_k1, ...] with few terms, or return None.

    The time factors T_k are free of x, y, z and the space factors free of t;
    the number of terms is the rank of the coefficient matrix of the separated
    expansion (equal time factors are grouped).  None if some part cannot be split.
    """
    comps = [_as_expr(e) for e in exprs]
    n = len(comps)
    if all(e == 0 for e in comps):
        return []
    if all(T not in e.free_symbols for e in comps):
        return [(_ONE, comps)]
    if all(e.free_symbols <= {T} for e in comps) and sum(e != 0 for e in comps) == 1:
        i = next(i for i, e in enumerate(comps) if e != 0)
        return [(comps[i], [_ONE if j == i else sympy.Integer(0) for j in range(n)])]

    # rows: time factors; columns: (component, space factor)
    rows: dict[sympy.Expr, dict[tuple[int, sympy.Expr], sympy.Expr]] = {}
    for i, e in enumerate(comps):
        terms = _separate(e)
        if terms is None:
            return None
        for (tm, sm), c in terms.items():
            rows.setdefault(tm, {})[(i, sm)] = c
    rows = {tm: r for tm, r in rows.items() if r}
    if not rows:
        return []
    row_keys = sorted(rows, key=sympy.default_sort_key)
    col_keys = sorted(
        {k for r in rows.values() for k in r},
        key=lambda k: (k[0], sympy.default_sort_key(k[1])),
    )

    def space_parts(row: dict[tuple[int, sympy.Expr], sympy.Expr]) -> list[sympy.Expr]:
        parts: list[list[sympy.Expr]] = [[] for _ in range(n)]
        for (i, sm), c in row.items():
            parts[i].append(c * sm)
        return [sympy.Add(*p) for p in parts]

    if len(row_keys) == 1:
        tm = row_keys[0]
        return [(tm, space_parts(rows[tm]))]
    # Rank factorisation M = R^T M[P, :] from the rref of M^T (P = pivot rows).
    mt = sympy.Matrix(
        [[rows[tm].get(col, 0) for tm in row_keys] for col in col_keys]
    )
    reduced, pivots = mt.rref()
    result = []
    for k, p in enumerate(pivots):
        time = sympy.Add(*[reduced[k, i] * tm for i, tm in enumerate(row_keys)])
        result.append((time, space_parts(rows[row_keys[p]])))
    return result


def separate_time(expr: sympy.Expr) -> list[tuple[sympy.Expr, sympy.Expr]] | None:
    """Write ``expr`` = sum_k T_k(t) * S_k(x, y, z) with few terms, or return None."""
    expr = _as_expr(expr)
    if expr == 0:
        return []
    if T not in expr.free_symbols:
        return [(_ONE, expr)]
    if expr.free_symbols <= {T}:
        return [(expr, _ONE)]
    result = separate_time_vector([expr])
    if result is None:
        return None
    return [(tk, sk[0]) for tk, sk in result]
