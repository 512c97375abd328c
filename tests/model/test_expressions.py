"""Tests for fsivsp.expressions: safe parsing, compilation and time separation."""

from __future__ import annotations

import builtins
import contextlib
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import sympy
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from fsivsp.model.expressions import (
    SPACE,
    ExpressionError,
    T,
    X,
    Y,
    Z,
    parse,
    parse_vector,
    separate_time,
    separate_time_vector,
    to_coefficient,
    to_function,
)

FIELD = "exact.velocity[1]"
EXPECTED_3D = (
    "expected numbers, x, y, z, t, pi, + - * / ** ( ) and sin cos tan exp log sqrt abs"
)

# --------------------------------------------------------------------------- parse


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("2*x*y*exp(t)", 2 * X * Y * sympy.exp(T)),
        ("-x**2", -(X**2)),
        ("(-x)**2", X**2),
        ("-2**2", sympy.Integer(-4)),
        ("2**-1", sympy.Rational(1, 2)),
        ("x**-2", X**-2),
        ("2**3**2", sympy.Integer(512)),
        ("(2**3)**2", sympy.Integer(64)),
        ("1e-3*x", X / 1000),
        ("1E+2", sympy.Integer(100)),
        ("1.5e2", sympy.Integer(150)),
        ("0.05", sympy.Rational(1, 20)),
        (".5", sympy.Rational(1, 2)),
        ("2.", sympy.Integer(2)),
        ("007", sympy.Integer(7)),
        ("sqrt(abs(x))", sympy.sqrt(sympy.Abs(X))),
        ("1 + 2*3", sympy.Integer(7)),
        ("(1 + 2)*3", sympy.Integer(9)),
        ("8/4/2", sympy.Integer(1)),
        ("2 - 3 - 4", sympy.Integer(-5)),
        ("x - y - z", X - Y - Z),
        ("x/y*z", X * Z / Y),
        ("+x", X),
        ("--x", X),
        ("-(-x)", X),
        ("-x*y", -X * Y),
        ("2*-x", -2 * X),
        ("x**y**z", X ** (Y**Z)),
        ("pi*x", sympy.pi * X),
        ("exp(1)", sympy.E),
        ("sin(pi/6)", sympy.Rational(1, 2)),
        ("sin(x)+cos(y)*tan(z)-log(t)", sympy.sin(X) + sympy.cos(Y) * sympy.tan(Z) - sympy.log(T)),
        ("sin(x - t)", sympy.sin(X - T)),
        ("  x\n +\ty\r\n", X + Y),
        ("x**64", X**64),
        ("(x+1)**(1/2)", sympy.sqrt(X + 1)),
        ("sin(pi*x)*sin(pi*y)*exp(-t)", sympy.sin(sympy.pi * X) * sympy.sin(sympy.pi * Y) * sympy.exp(-T)),
        ("2**x", 2**X),
    ],
)
def test_parse_valid(text: str, expected: sympy.Expr) -> None:
    result = parse(text, FIELD)
    assert isinstance(result, sympy.Expr)
    assert result == expected
    assert not result.has(sympy.Float)  # numbers stay exact


def test_parse_uses_module_symbols() -> None:
    expr = parse("x*y*z*t", "f")
    assert expr.free_symbols == {X, Y, Z, T}
    assert all(s.is_real for s in (X, Y, Z, T))
    assert SPACE == (X, Y, Z)


def test_parse_2d_and_numbers() -> None:
    assert parse("x*y + t", "f", dim=2) == X * Y + T
    assert parse(3, "f") == 3
    assert parse(0.25, "f") == sympy.Rational(1, 4)


def test_parse_sample_error_message() -> None:
    with pytest.raises(ExpressionError) as info:
        parse("sin(foo)", FIELD)
    assert str(info.value) == f"{FIELD}: unknown name 'foo' in 'sin(foo)'; {EXPECTED_3D}"
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("foo", "unknown name 'foo'"),
        ("e", "unknown name 'e'"),
        ("e**x", "exp(1)"),
        ("E", "unknown name 'E'"),
        ("ln(x)", "unknown name 'ln'"),
        ("x_1", "unknown name 'x_1'"),
        ("x2", "unknown name 'x2'"),
        ("__import__", "unknown name '__import__'"),
        ('__import__("os").system("ls")', "'__import__'"),
        ("lambda: 1", "unknown name 'lambda'"),
        ("x if y else z", "unexpected 'if'"),
        ("x^2", "unexpected character '^'"),
        ("x.real", "unexpected character '.'"),
        ("().__class__", "unexpected ')'"),
        ("x[0]", "unexpected character '['"),
        ('"x"', "unexpected character '\"'"),
        ("'x'", "unexpected character \"'\""),
        ("x = 1", "unexpected character '='"),
        ("x == 1", "unexpected character '='"),
        ("x, y", "unexpected ','"),
        ("x; y", "unexpected character ';'"),
        ("{x}", "unexpected character '{'"),
        ("x y", "unexpected 'y'"),
        ("2x", "unexpected 'x'"),
        ("x ** * y", "unexpected '*'"),
        ("x % 2", "unexpected character '%'"),
        ("x // 2", "unexpected '/'"),
        ("x @ y", "unexpected character '@'"),
        ("1j", "unexpected 'j'"),
        ("０", "unexpected character"),  # full-width digit
        ("٣", "unexpected character"),  # Arabic-Indic digit
        ("sin", "function 'sin' must be called"),
        ("sin x", "function 'sin' must be called"),
        ("sin()", "unexpected ')'"),
        ("sin(x, y)", "sin takes exactly one argument"),
        ("(x", "missing ')'"),
        ("x)", "unmatched ')'"),
        ("", "empty expression"),
        ("   ", "empty expression"),
        ("x +", "unexpected end of expression"),
        ("x**65", "exponent 65 too large"),
        ("x**-65", "exponent -65 too large"),
        ("2**100", "exponent 100 too large"),
        ("9**9**9**9", "too large"),
        ("10**10**10", "too large"),
        ("(2**64)**64", "too large for a float"),
        ("x**64*x", "too large after combining powers"),
        ("1/0", "division by zero"),
        ("x/(y - y)", "division by zero"),
        ("0**-1", "division by zero"),
        ("sqrt(-1)", "not a finite real number"),
        ("log(0)", "not a finite real number"),
        ("log(-1)", "not a finite real number"),
        ("(-8)**(1/3)", "not a real number"),
        ("tan(pi/2)", "not a finite real number"),
        ("exp(1000)", "not a finite real number"),
        ("1e400", "too large for a float"),
        ("1e-999999999", "out of range"),
        ("1" * 400, "too large for a float"),
        ("x" + "+x" * 1000, "expression too long"),
        ("(" * 101 + "x" + ")" * 101, "nested too deeply"),
        ("-" * 101 + "x", "nested too deeply"),
        ("sin(" * 101 + "x" + ")" * 101, "nested too deeply"),
        ("x**x**x**x**x**x**x**x**x**x", "powers nested too deeply"),
        ("x\ny", "unexpected 'y'"),
        ("x\u2028y", "unexpected character"),
    ],
)
def test_parse_rejects(text: str, fragment: str) -> None:
    with pytest.raises(ExpressionError) as info:
        parse(text, FIELD)
    message = str(info.value)
    assert message.startswith(FIELD + ": ")
    assert fragment in message
    assert len(message.splitlines()) == 1


def test_parse_rejects_z_in_2d() -> None:
    with pytest.raises(ExpressionError, match=r"^f: unknown name 'z'.*not available in 2D"):
        parse("x + z", "f", dim=2)
    assert parse("x + z", "f", dim=3) == X + Z


def test_parse_rejects_non_strings() -> None:
    for bad in (None, [1], b"x", True, {"x": 1}):
        with pytest.raises(ExpressionError, match=r"^f: expected an expression string"):
            parse(bad, "f")  # type: ignore[arg-type]


def test_parse_nesting_limit_is_100() -> None:
    assert parse("(" * 99 + "x" + ")" * 99, "f") == X
    assert parse("sin(" * 50 + "x" + ")" * 50, "f").has(sympy.sin)


def test_long_error_text_is_shortened() -> None:
    text = "x+" * 500 + "foo"
    with pytest.raises(ExpressionError) as info:
        parse(text, "f")
    assert len(str(info.value)) < 300


# ------------------------------------------------------------------- parse_vector


def test_parse_vector() -> None:
    assert parse_vector(["x*t", 1, 2.5], "u", 3) == [X * T, 1, sympy.Rational(5, 2)]
    assert parse_vector(("y", "-x"), "u", 2) == [Y, -X]


@pytest.mark.parametrize(
    ("items", "got"),
    [(["x"], "got 1 item"), (["x", "y", "z"], "got 3 items"), ("xy", "got 'xy'"), (None, "got 'None'"), (5, "got '5'")],
)
def test_parse_vector_wrong_shape(items: object, got: str) -> None:
    with pytest.raises(ExpressionError) as info:
        parse_vector(items, "exact.velocity", 2)
    assert str(info.value) == f"exact.velocity: expected a list of 2 expressions, {got}"


def test_parse_vector_names_component() -> None:
    with pytest.raises(ExpressionError, match=r"^exact\.velocity\[1\]: unknown name 'foo'"):
        parse_vector(["x", "foo"], "exact.velocity", 2)
    with pytest.raises(ExpressionError, match=r"^u\[0\]: expected an expression string"):
        parse_vector([None, "x"], "u", 2)


# ----------------------------------------------------------------- hostile input

HOSTILE = [
    '__import__("os").system("echo hi")',
    "__import__('os').system('echo hi')",
    "x.__class__",
    "().__class__",
    "().__class__.__bases__[0].__subclasses__()",
    "lambda: 1",
    "(lambda: __import__('os'))()",
    "x[0]",
    "[x for x in ()]",
    "'abc'",
    '"abc"',
    "exec('1')",
    "eval('1')",
    "open('/etc/passwd').read()",
    "globals()",
    "x; import os",
    "9**9**9**9",
    "10**10**10",
    "(2**64)**64",
    "2**2**2**2**2",
    "9" * 1999,
    "9" * 308 + "**(-1/63)",  # sympy would factor a 20000-digit integer
    "38680**-38680**-1",
    "*".join(["999999999999989**(1/3)", "999999999999947**(1/3)", "999999999999701**(1/3)"] * 20),
    "1e9999999999999999999",
    "(" * 10000 + "x" + ")" * 10000,
    "(" * 999 + "x" + ")" * 999,
    "-" * 1999 + "x",
    "sin(" * 300 + "x" + ")" * 300,
    "0.5**" * 399 + "0.5",
    "x**" * 600 + "x",
    "(x+1)**" * 250 + "x",
    "(x+1)**" * 8 + "x",
    "*".join(["(x+y+z+t)**64"] * 100),
    "sin(" * 99 + "1" + ")" * 99,
    "exp(" * 99 + "1" + ")" * 99,
    "log(" * 99 + "2" + ")" * 99,
    "\x00",
    "x\x00",
    "\ud7ff",
]

GRAMMAR_ALPHABET = "0123456789.eE+-*/() xyztpisncoaqrbl_,^[]'\"\\\n"


@contextlib.contextmanager
def _no_code_execution(calls: list[str]):
    """Record (instead of running) eval/exec/compile of strings, os.system and subprocesses."""
    real = {name: getattr(builtins, name) for name in ("eval", "exec", "compile")}

    def guard(name):
        def wrapper(source, *args, **kwargs):
            if isinstance(source, (str, bytes)):
                calls.append(f"{name}({source!r})")
            return real[name](source, *args, **kwargs)

        return wrapper

    def forbidden(name):
        def wrapper(*args, **kwargs):
            calls.append(f"{name}{args!r}")
            raise RuntimeError(f"{name} called")

        return wrapper

    saved_system, saved_popen = os.system, subprocess.Popen
    try:
        for name in real:
            setattr(builtins, name, guard(name))
        os.system = forbidden("os.system")  # type: ignore[assignment]
        subprocess.Popen = forbidden("subprocess.Popen")  # type: ignore[assignment,misc]
        yield calls
    finally:
        for name, func in real.items():
            setattr(builtins, name, func)
        os.system = saved_system
        subprocess.Popen = saved_popen  # type: ignore[misc]


#: The work `parse` may do on one string, in Python calls and returns (`sys.setprofile` events): 5 times the costliest
#: input of `HOSTILE` (203 619 events for 100 factors of (x+y+z+t)**64). A bound on work, not on time, so that a
#: loaded machine cannot fail it; sympy's slow paths (factoring a 300-digit integer, expanding a power tower) take
#: millions of calls. A slow path inside one C call (a modular power of huge integers) makes few calls: the tests
#: of hostile input have a hang guard of their own (`HANG`, 100 times what they take), not a limit on one parse.
WORK_BUDGET = 1_000_000
HANG = pytest.mark.timeout(120)


class _OverBudget(BaseException):
    """Raised from the profile function (a BaseException: no ``except Exception`` of the parser swallows it)."""


@contextlib.contextmanager
def _work_budget(budget: int):
    """Fail the block once it has made ``budget`` Python and C calls and returns (it stops there)."""
    count = 0

    def profile(frame, event, arg):
        nonlocal count
        count += 1
        if count >= budget:
            raise _OverBudget

    previous = sys.getprofile()
    sys.setprofile(profile)
    try:
        yield
    except _OverBudget:
        pytest.fail(f"over {budget} calls")
    finally:
        sys.setprofile(previous)


def _parse_safely(text: str) -> None:
    calls: list[str] = []
    with _no_code_execution(calls), _work_budget(WORK_BUDGET):
        try:
            result = parse(text, "hostile")
        except ExpressionError as err:
            message = str(err)
            assert message.startswith("hostile: ")
            assert len(message.splitlines()) == 1
        else:
            assert isinstance(result, sympy.Expr)
            assert result.free_symbols <= {X, Y, Z, T}
    assert calls == [], text[:60]


# warm sympy up (lazy imports, caches) so that the budget counts parsing only
parse("sin(x)*exp(-t) + sqrt(abs(y))**3/log(2) - tan(z)**-1 + cos(pi/7)", "warmup")


@HANG
@pytest.mark.parametrize("text", HOSTILE, ids=range(len(HOSTILE)))
def test_hostile_strings(text: str, tmp_path) -> None:
    sentinel = tmp_path / "pwned"
    _parse_safely(text)
    _parse_safely(text.replace("echo hi", f"touch {sentinel}"))
    _parse_safely(f"__import__('os').system('touch {sentinel}')")
    _parse_safely(f"open('{sentinel}', 'w')")
    assert not sentinel.exists()


_hypothesis_settings = settings(
    max_examples=150,
    deadline=None,  # no wall-clock limit: `_parse_safely` bounds the work instead
    suppress_health_check=[HealthCheck.too_slow],
)


@HANG
@_hypothesis_settings
@given(st.text(max_size=300))
@example('__import__("os").system("echo hi")')
@example("x.__class__")
@example("lambda: 1")
@example("9**9**9**9")
def test_random_text_never_misbehaves(text: str) -> None:
    _parse_safely(text)


@HANG
@_hypothesis_settings
@given(st.text(alphabet=GRAMMAR_ALPHABET, max_size=200))
def test_grammar_like_text_never_misbehaves(text: str) -> None:
    _parse_safely(text)


def _expressions() -> st.SearchStrategy[str]:
    atoms = st.one_of(
        st.sampled_from(["x", "y", "z", "t", "pi", "1", "0", "0.5", "1e-3", "64"]),
        st.integers(0, 10**30).map(str),
        st.floats(0, 1e300, allow_nan=False).map(repr),
    )

    def extend(inner: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
        return st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**"]), inner).map(
                lambda p: f"{p[0]}{p[1]}{p[2]}"
            ),
            st.tuples(st.sampled_from(["sin", "cos", "tan", "exp", "log", "sqrt", "abs", ""]), inner).map(
                lambda p: f"{p[0]}({p[1]})"
            ),
            inner.map(lambda s: f"-{s}"),
        )

    return st.recursive(atoms, extend, max_leaves=40)


@HANG
@_hypothesis_settings
@given(_expressions())
def test_generated_expressions_never_misbehave(text: str) -> None:
    _parse_safely(text)


# -------------------------------------------------------------------- to_function

TIME_EXPRESSIONS = [
    "sin(t)*exp(-t) + t**2",
    "sqrt(abs(t)) - 3*t**-2",
    "2**t + t**0.5*0 + 1.25",
    "log(1 + t**2)/(1 + t)",
    "tan(t/3) - cos(2*pi*t)**3",
    "(1 + t)**(1/3) * exp(1)",
    "abs(t - 1)**2.5",
    "7",
    "-t",
    "t**t",
    "sin(" + "+".join(f"t**{k}/{k + 1}" for k in range(20)) + ")",  # long: built unevaluated
]


@pytest.mark.parametrize("text", TIME_EXPRESSIONS)
def test_to_function_matches_evalf(text: str) -> None:
    expr = parse(text, "f")
    f = to_function(expr)
    for v in (0.3, 1.7, 0.9):
        expected = float(expr.evalf(30, subs={T: sympy.Float(v, 30)}))
        assert f(v) == pytest.approx(expected, rel=1e-12, abs=1e-14)
        assert isinstance(f(v), float)


def test_to_function_other_variable_and_errors() -> None:
    g = to_function(parse("x**2 + 1", "f"), X)
    assert g(3.0) == 10.0
    with pytest.raises(ValueError, match="depends on x"):
        to_function(X * T)
    assert to_function(sympy.Integer(3))(123.0) == 3.0
    assert to_function(sympy.cot(T) + sympy.sec(T))(0.4) == pytest.approx(
        1 / math.tan(0.4) + 1 / math.cos(0.4)
    )


def test_to_function_is_fast() -> None:
    """A call of the compiled function is a tree of float closures: at most one Python call per node of the
    expression, each in `fsivsp.model.expressions.floats`, and C calls of math, operator and builtins only (no
    sympy)."""
    expr = parse("sin(t)*exp(-t) + t**2 - 3*sqrt(abs(t)) + 2**t + (1+t)**-2", "f")
    f = to_function(expr)
    python_calls, c_calls = [], []

    def profile(frame, event, arg):
        if event == "call":
            python_calls.append(frame.f_code.co_filename)
        elif event == "c_call" and arg is not sys.setprofile:
            c_calls.append(getattr(arg, "__module__", None) or type(arg.__self__).__module__)

    for v in (0.001, 0.7, 19.999):
        python_calls.clear()
        sys.setprofile(profile)
        try:
            f(v)
        finally:
            sys.setprofile(None)
        assert {Path(name).name for name in python_calls} == {"floats.py"}, python_calls
        assert len(python_calls) <= sum(1 for _ in sympy.preorder_traversal(expr)), python_calls
    assert set(c_calls) <= {"math", "_operator", "builtins"}, set(c_calls)


# ------------------------------------------------------------------ to_coefficient


@pytest.fixture(scope="module")
def mesh2d():
    ngsolve = pytest.importorskip("ngsolve")
    from netgen.geom2d import unit_square

    return ngsolve.Mesh(unit_square.GenerateMesh(maxh=0.3))


@pytest.fixture(scope="module")
def mesh3d():
    ngsolve = pytest.importorskip("ngsolve")
    from netgen.csg import unit_cube

    return ngsolve.Mesh(unit_cube.GenerateMesh(maxh=0.6))


def _value_at(expr: sympy.Expr, **point: float) -> float:
    subs = {X: point.get("x", 0.0), Y: point.get("y", 0.0), Z: point.get("z", 0.0), T: point["t"]}
    return float(expr.evalf(30, subs={k: sympy.Float(v, 30) for k, v in subs.items()}))


SPACE_TIME_EXPRESSIONS = [
    "2*x*y*exp(t)",
    "sin(pi*x)*cos(pi*y) + t**2",
    "sqrt(abs(x - y))*t",
    "x**3*y**-1 - 1/(1 + t)",
    "(1 + x)**2.5 + y**(1/3)",
    "2**(x*t) + x**y",
    "log(1 + x) + tan(y) - exp(-t)",
    "abs(x - 0.5) + abs(y - t)",
    "3",
    "t",
    "(x + t)**5",
    "sin(" + "+".join(f"x**{k}*y/{k + 1}" for k in range(12)) + ") + t",
]


@pytest.mark.parametrize("text", SPACE_TIME_EXPRESSIONS)
def test_to_coefficient_matches(text: str, mesh2d) -> None:
    import ngsolve

    expr = parse(text, "f", dim=2)
    t = ngsolve.Parameter(0.5)
    cf = to_coefficient(expr, t)
    mp = mesh2d(0.3, 0.4)
    assert cf(mp) == pytest.approx(_value_at(expr, x=0.3, y=0.4, t=0.5), rel=1e-12, abs=1e-13)
    t.Set(0.7)
    assert cf(mp) == pytest.approx(_value_at(expr, x=0.3, y=0.4, t=0.7), rel=1e-12, abs=1e-13)
    fixed = to_coefficient(expr, 0.7)
    assert fixed(mp) == pytest.approx(_value_at(expr, x=0.3, y=0.4, t=0.7), rel=1e-12, abs=1e-13)


def test_to_coefficient_parameter_changes_value(mesh2d) -> None:
    import ngsolve

    t = ngsolve.Parameter(0.5)
    cf = to_coefficient(parse("x*exp(t)", "f"), t)
    mp = mesh2d(0.3, 0.4)
    before = cf(mp)
    t.Set(0.7)
    after = cf(mp)
    assert before == pytest.approx(0.3 * math.exp(0.5))
    assert after == pytest.approx(0.3 * math.exp(0.7))


def test_to_coefficient_vector_and_matrix(mesh2d) -> None:
    import ngsolve

    t = ngsolve.Parameter(0.5)
    mp = mesh2d(0.3, 0.4)
    vec = to_coefficient(parse_vector(["x*t", "y**2", "1"], "u", 3), t)
    assert vec.dim == 3
    assert vec(mp) == pytest.approx((0.15, 0.16, 1.0))
    column = to_coefficient(sympy.Matrix([X, T]), t)
    assert column.dim == 2
    assert column(mp) == pytest.approx((0.3, 0.5))
    mat = to_coefficient(sympy.Matrix([[X, Y], [T, X * Y]]), t)
    assert tuple(mat.dims) == (2, 2)
    assert mat(mp) == pytest.approx((0.3, 0.4, 0.5, 0.12))
    nested = to_coefficient([[X, 1], [0, T]], t)
    assert tuple(nested.dims) == (2, 2)
    assert nested(mp) == pytest.approx((0.3, 1.0, 0.0, 0.5))


def test_to_coefficient_derived_expressions(mesh2d) -> None:
    """Derivatives bring sign(); float t folds time into constants."""
    import ngsolve

    expr = sympy.diff(parse("abs(x - 0.5)*t + sin(t)*x**2", "f"), X)
    assert expr.has(sympy.sign)
    mp = mesh2d(0.3, 0.4)
    expected = _value_at(expr, x=0.3, y=0.4, t=0.5)
    assert to_coefficient(expr, 0.5)(mp) == pytest.approx(expected)
    assert to_coefficient(expr, ngsolve.Parameter(0.5))(mp) == pytest.approx(expected)
    assert to_function(expr.subs(X, 0.3))(0.5) == pytest.approx(expected)


def test_to_coefficient_3d(mesh3d) -> None:
    import ngsolve

    expr = parse("x*y*z*exp(t) + sin(z)", "f")
    cf = to_coefficient(expr, ngsolve.Parameter(0.2))
    assert cf(mesh3d(0.3, 0.4, 0.5)) == pytest.approx(_value_at(expr, x=0.3, y=0.4, z=0.5, t=0.2))


# ------------------------------------------------------------------ separate_time


def _assert_separates(expr: sympy.Expr, terms) -> None:
    assert terms is not None
    for tk, sk in terms:
        assert not (tk.free_symbols & set(SPACE))
        assert T not in sk.free_symbols
    total = sympy.Add(*[tk * sk for tk, sk in terms])
    diff = sympy.expand(total - expr, trig=True, power_exp=True)
    assert diff == 0 or sympy.simplify(diff) == 0


@pytest.mark.parametrize(
    ("text", "n_terms"),
    [
        ("(x**2 + y**2)*exp(t)", 1),
        ("2*x*y*exp(t)", 1),
        ("exp(t)*x + exp(t)*y", 1),
        ("2*x*exp(t) + 3*y*exp(t)", 1),
        ("x*exp(t) + x*t", 1),
        ("sin(x - t)", 2),
        ("cos(2*x - 3*t)*exp(-t)", 2),
        ("t*x + y", 2),
        ("exp(x + t)", 1),
        ("2**(x + t)", 1),
        ("(x + t)**3", 4),
        ("(x + t)*(x - t)", 2),
        ("sin(pi*x)*sin(pi*y)*sin(2*pi*t) + t**2*x", 2),
        ("x*sin(3*t)", 1),
        ("(2*t + 2)*x + (t + 1)*y", 1),
        ("3", 1),
        ("x**2 + sin(y)", 1),
        ("t**2 + 1", 1),
        ("(x + y + z + t)**8", 9),
        ("x*t**2 + x*t + y*t**2 + y*t", 1),
    ],
)
def test_separate_time(text: str, n_terms: int) -> None:
    expr = parse(text, "f")
    terms = separate_time(expr)
    _assert_separates(expr, terms)
    assert len(terms) == n_terms


def test_separate_time_groups_equal_time_factors() -> None:
    assert separate_time(sympy.exp(T) * X + sympy.exp(T) * Y) == [(sympy.exp(T), X + Y)]
    assert separate_time(X**2 + Y) == [(1, X**2 + Y)]
    assert separate_time(sympy.Integer(5)) == [(1, 5)]
    assert separate_time(T**2) == [(T**2, 1)]
    assert separate_time(sympy.Integer(0)) == []
    assert separate_time(X * T - X * T) == []


@pytest.mark.parametrize("text", ["exp(x*t)", "1/(x + t)", "sqrt(x*t)", "abs(x - t)", "tan(x - t)", "x**t",
                                  "log(x + t)"])
def test_separate_time_refuses(text: str) -> None:
    assert separate_time(parse(text, "f")) is None


def test_separate_time_vector() -> None:
    comps = [sympy.sin(X - T), Y * sympy.cos(X - T), sympy.Integer(0)]
    terms = separate_time_vector(comps)
    assert terms is not None and len(terms) == 2
    for i, comp in enumerate(comps):
        _assert_separates(comp, [(tk, sk[i]) for tk, sk in terms])
    assert separate_time_vector([sympy.exp(T) * X, sympy.exp(T) * Y]) == [(sympy.exp(T), [X, Y])]
    assert separate_time_vector([X, Y]) == [(1, [X, Y])]
    assert separate_time_vector([sympy.Integer(0), sympy.Integer(0)]) == []
    assert separate_time_vector([X * T, sympy.exp(X * T)]) is None
    mixed = [T * X + 1, T**2 * Y, sympy.exp(-T) * (X + Y)]
    terms = separate_time_vector(mixed)
    assert terms is not None and len(terms) == 4
    for i, comp in enumerate(mixed):
        _assert_separates(comp, [(tk, sk[i]) for tk, sk in terms])


def test_separated_terms_compile(mesh2d) -> None:
    expr = parse("sin(pi*(x - t))*exp(-t) + t*y**2", "f", dim=2)
    terms = separate_time(expr)
    assert terms is not None
    mp = mesh2d(0.3, 0.4)
    pieces = [(to_function(tk), to_coefficient(sk, 0.0)) for tk, sk in terms]
    value = sum(f(0.6) * cf(mp) for f, cf in pieces)
    assert value == pytest.approx(_value_at(expr, x=0.3, y=0.4, t=0.6), rel=1e-12)
