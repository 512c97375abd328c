"""The separation of time from space: an expression as a short sum of time factors times space factors."""

from __future__ import annotations

from collections.abc import Iterable

import sympy

from .nodes import MAX_EXPONENT
from .symbols import T, as_expr

MAX_SEPARATED_TERMS = 20000  # separate_time gives up (returns None) beyond this

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
    comps = [as_expr(e) for e in exprs]
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
    expr = as_expr(expr)
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
