"""The variables x, y, z, t, the error of bad user text, and plain numbers as sympy objects."""

from __future__ import annotations

from typing import Any

import sympy

X, Y, Z, T = sympy.symbols("x y z t", real=True)
SPACE = (X, Y, Z)


class ExpressionError(ValueError):
    """Bad user expression; ``str(err)`` is one line naming the offending field."""

    def __init__(self, message: str) -> None:
        super().__init__(_one_line(message))


def _one_line(text: str) -> str:
    """Escape every non-printable character (newlines, tabs, ...) of ``text``."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def show(text: str, limit: int = 80) -> str:
    """Quoted, one-line, possibly shortened rendering of user text."""
    if len(text) > limit:
        text = text[: limit - 3] + "..."
    return repr(text)


def as_expr(obj: Any) -> sympy.Expr:
    """``obj`` as a sympy expression (ints and floats converted; bools refused)."""
    if isinstance(obj, sympy.Basic):
        return obj  # type: ignore[return-value]
    if isinstance(obj, bool):
        raise TypeError("expected a sympy expression, got bool")
    if isinstance(obj, int):
        return sympy.Integer(obj)
    if isinstance(obj, float):
        return sympy.Float(obj)
    raise TypeError(f"expected a sympy expression, got {type(obj).__name__}")
