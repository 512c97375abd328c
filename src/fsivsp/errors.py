"""The one vocabulary of bad input: `CaseError`, one line ``<where>.<field>: expected ..., got ...``, and the
tests every reader of a case (file, command line, code) shares."""
from __future__ import annotations

import math
from numbers import Real
from typing import Any


class CaseError(ValueError):
    """A case that cannot be run; one line naming the field."""


def expected(where: str, what: str, got: Any) -> CaseError:
    """``<where>: expected <what>, got <got!r>``."""
    return CaseError(f"{where}: expected {what}, got {got!r}")


def is_whole(value: Any, low: int | None = 1, high: int | None = None) -> bool:
    """Whether ``value`` is a whole number (an int, not a bool) in [low, high] (None: no bound); by default a
    positive one."""
    return (isinstance(value, int) and not isinstance(value, bool) and (low is None or value >= low)
            and (high is None or value <= high))


def read_number(text: str) -> float:
    """``text`` read as a float, NaN where it does not read as one (then `is_number` is false, as for "inf")."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def is_number(value: Any) -> bool:
    """Whether ``value`` is a finite real number (not a bool)."""
    return isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(value)
