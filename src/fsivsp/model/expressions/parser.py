"""The parser of user text: a tokenizer and a recursive-descent grammar over a whitelist of tokens that
builds sympy objects directly (nothing is passed to ``eval``, ``exec`` or ``compile``)."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import Any

import sympy

from .functions import CALLABLE
from .nodes import MAX_EXPONENT, Builder, Node
from .symbols import ExpressionError, T, X, Y, Z, show

MAX_LENGTH = 2000
MAX_DEPTH = 100
SIMPLE_TOKENS = 24  # longer function arguments / powers are built unevaluated
MAX_DECIMAL_EXPONENT = 400  # bound on the power of ten of a literal (1e-3, 2.5e10 ...)


def _expected(dim: int) -> str:
    names = "x, y, z, t" if dim == 3 else "x, y, t"
    return (
        f"expected numbers, {names}, pi, + - * / ** ( ) and "
        + " ".join(CALLABLE)
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


class _Parser(Builder):
    """Recursive-descent parser; each node is a pair (sympy expr, float value or None)."""

    def __init__(self, text: str, field: str, dim: int) -> None:
        super().__init__(text, field)
        self.dim = dim
        self.tokens = self._tokenize()
        self.i = 0
        self.depth = 0

    # -- errors -------------------------------------------------------------
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

    def _level(self, operand, operators: str) -> Node:
        """A left-associative chain ``operand (op operand)*`` of one precedence level."""
        left = operand()
        while True:
            op = next((o for o in operators if self.accept(o)), None)
            if op is None:
                return left
            left = self.binary(op, left, operand())

    def expr(self) -> Node:
        return self._level(self.term, "+-")

    def term(self) -> Node:
        return self._level(self.unary, "*/")

    def unary(self) -> Node:
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

    def power(self) -> Node:
        start = self.i
        base = self.primary()
        if not self.accept("**"):
            return base
        self.enter()
        exponent = self.unary()  # right-associative, and 2**-1 is allowed
        self.depth -= 1
        return self.binary("**", base, exponent, simple=self.i - start <= SIMPLE_TOKENS)

    def primary(self) -> Node:
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

    def number(self, tok: _Token) -> Node:
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

    def name(self, tok: _Token) -> Node:
        name = tok.text
        if name in CALLABLE:
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

    def call(self, tok: _Token) -> Node:
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
        return self.apply(name, (arg, value), simple)


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
            f"{field}: cannot process {show(text)} ({type(err).__name__})"
        ) from err


def parse_vector(items: Any, field: str, dim: int) -> list[sympy.Expr]:
    """Parse a list of exactly ``dim`` expressions; errors name ``field[i]``."""
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence) or len(items) != dim:
        if isinstance(items, Sequence) and not isinstance(items, (str, bytes)):
            got = f"{len(items)} item{'s' if len(items) != 1 else ''}"
        else:
            got = show(str(items), 60)
        raise ExpressionError(f"{field}: expected a list of {dim} expressions, got {got}")
    return [parse(item, f"{field}[{i}]", dim) for i, item in enumerate(items)]
