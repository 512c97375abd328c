"""Space–time data as symbolic fields, and their discrete images over time.

A `Field` holds sympy expressions of x, y, z, t. Where it separates as
f(x, t) = Σ_k T_k(t) F_k(x), anything linear in f (a load vector, Dirichlet values,
an error projection) is computed once per term and combined per step at O(unknowns)
cost; otherwise it is recomputed from the field at each time.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import ngsolve as ngs
import sympy

from .expressions import separate_time_vector, to_coefficient, to_function


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

    def is_zero(self) -> bool:
        return all(sympy.simplify(c) == 0 for c in self.components())

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
