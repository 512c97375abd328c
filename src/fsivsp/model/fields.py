"""Space–time data as symbolic fields, and their discrete images over time.

A `Field` holds sympy expressions of x, y, z, t. Where it separates as
f(x, t) = Σ_k T_k(t) F_k(x), anything linear in f (a load vector, Dirichlet values,
an error projection) is computed once per term and combined per step at O(unknowns)
cost; otherwise it is recomputed from the field at each time.
"""
from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
import sympy

from .expressions import SPACE, T, separate_time_vector, to_coefficient, to_function

#: Sample points of the numerical zero test (seeded: the verdict is deterministic).
ZERO_SAMPLES = 256
#: |f| <= ZERO_RTOL · Σ|terms of f| at every sample point counts as zero (cancellation to round-off).
ZERO_RTOL = 1e-10


@functools.cache
def expression_is_zero(expr: sympy.Expr, box: tuple = ((0.0, 1.0),) * 3, times: tuple = (0.0, 1.0)) -> bool:
    """Whether ``expr`` of x, y, z, t vanishes: structurally after `expand`, else numerically at
    `ZERO_SAMPLES` seeded points of ``box`` × ``times``, within `ZERO_RTOL` of the magnitude of its terms.
    Cached, so a study decides each expression once, not per level (no ``simplify``: ~1 s per trigonometric
    expression)."""
    expanded = sympy.expand(expr)
    if expanded == 0:
        return True
    if not expanded.free_symbols <= {*SPACE, T}:
        raise ValueError(f"zero test: unexpected symbols {sorted(map(str, expanded.free_symbols - {*SPACE, T}))}")
    rng = np.random.default_rng(20180101)
    lows, highs = zip(*box, times)
    points = rng.uniform(lows, highs, size=(ZERO_SAMPLES, 4)).T
    terms = sympy.Add.make_args(expanded)
    values = [np.broadcast_to(sympy.lambdify((*SPACE, T), term, "numpy")(*points), (ZERO_SAMPLES,))
              for term in terms]
    total = np.abs(np.sum(values, axis=0))
    scale = np.sum(np.abs(values), axis=0)
    return bool(np.all(np.isfinite(total)) and np.all(total <= ZERO_RTOL * scale))


@dataclass
class Field:
    """Scalar, vector (list) or matrix (sympy.Matrix) field of x, y, z, t."""

    expr: sympy.Expr | sympy.Matrix | list

    def components(self) -> list[sympy.Expr]:
        if isinstance(self.expr, sympy.MatrixBase):
            return list(self.expr)
        if isinstance(self.expr, (list, tuple)):
            return list(self.expr)
        return [self.expr]

    def _shaped(self, comps: list[sympy.Expr]):
        if isinstance(self.expr, sympy.MatrixBase):
            return sympy.Matrix(self.expr.rows, self.expr.cols, comps)
        if isinstance(self.expr, (list, tuple)):
            return list(comps)
        return comps[0]

    def coefficient(self, t) -> ngs.CoefficientFunction:
        """The whole field as a CoefficientFunction, time from ``t`` (Parameter or float)."""
        return to_coefficient(self.expr, t).Compile()

    def is_zero(self, box: tuple, times: tuple = (0.0, 1.0)) -> bool:
        """Whether every component vanishes on ``box`` (the domain's x, y[, z] ranges) × ``times``
        (`expression_is_zero`)."""
        box = tuple(map(tuple, box)) + ((0.0, 1.0),) * (3 - len(box))
        return all(expression_is_zero(sympy.sympify(c), box, tuple(times))
                   for c in self.components())

    def separated(self) -> list[tuple[Callable[[float], float], ngs.CoefficientFunction]] | None:
        """[(T_k, F_k)] with f = Σ T_k(t) F_k(x), or None if f does not separate."""
        terms = separate_time_vector(self.components())
        if terms is None:
            return None
        return [(to_function(tk), to_coefficient(self._shaped(sk), 0.0).Compile()) for tk, sk in terms]


class TimeVector:
    """b(t) = L(f(·, t)) for a linear map L from fields to vectors (assembling a load,
    setting boundary values), evaluated as Σ_k T_k(t) L(F_k) when f separates.

    ``image(cf)`` must return a function that (re)computes L(cf) into a vector and
    returns it; the scheme calls it once per term, or once per step if f does not separate.
    """

    def __init__(self, field: Field, image: Callable[[ngs.CoefficientFunction], Callable[[], ngs.BaseVector]]):
        self._terms = field.separated()
        self._vectors: list[ngs.BaseVector] = []
        self._recompute = None
        if self._terms is not None:
            for _, cf in self._terms:
                computed = image(cf)()
                vec = computed.CreateVector()
                vec.data = computed
                self._vectors.append(vec)
        else:
            self._time = ngs.Parameter(0.0)
            self._recompute = image(field.coefficient(self._time))

    @property
    def separable(self) -> bool:
        return self._recompute is None

    def add_to(self, out: ngs.BaseVector, time: float, scale: float = 1.0) -> None:
        """out += scale · b(time)."""
        if self._recompute is None:
            for (fn, _), vec in zip(self._terms, self._vectors):
                out.data += (scale * fn(time)) * vec
        else:
            self._time.Set(time)
            out.data += scale * self._recompute()
