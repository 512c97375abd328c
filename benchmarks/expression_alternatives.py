"""Issue 23: ``ast.parse(mode="eval")`` with a whitelisting visitor against the hand-written parser, and
``sympy.lambdify`` against the two hand-written compilers (`to_function`, `to_coefficient`).

Measures parse time on 2 000 generated expressions (and whether both give the same result or message), the
hostile inputs of tests/test_expressions.py (rejected; compile()/exec of user text), compile and call time
of both compilers, and the tests of tests/test_expressions.py that pass with each alternative swapped in.

    PYTHONPATH=src python benchmarks/expression_alternatives.py --json benchmarks/expression_alternatives.json
"""
from __future__ import annotations

import argparse
import ast
import json
import math
import os
import random
import re
import subprocess
import sys
import time
from pathlib import Path

import sympy
from sympy.core.cache import clear_cache

from fsivsp.model.expressions import ExpressionError, T, X, Y, Z, parse, to_coefficient, to_function
from fsivsp.model.expressions.functions import CALLABLE
from fsivsp.model.expressions.nodes import MAX_EXPONENT, Builder
from fsivsp.model.expressions.parser import MAX_DEPTH, MAX_LENGTH, SIMPLE_TOKENS, _expected, _Parser, _Token

ROOT = Path(__file__).resolve().parent.parent
OPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}


class AstParser(Builder):
    """The grammar of `fsivsp.model.expressions.parser` as a whitelist of Python ast nodes; nodes are built and
    checked by the same `Builder`."""

    def __init__(self, text: str, field: str, dim: int) -> None:
        super().__init__(text, field)
        self.dim = dim

    def parse(self) -> sympy.Expr:
        if not self.text.strip():
            raise self.error("empty expression")
        try:
            tree = ast.parse(self.text, mode="eval")
        except SyntaxError as error:
            raise self.error(f"syntax error at position {(error.offset or 1) - 1}",
                             "; " + _expected(self.dim)) from None
        except (ValueError, RecursionError, MemoryError) as error:
            raise self.error(f"cannot read ({type(error).__name__})") from None
        expr, _ = self.visit(tree.body, 0)
        if expr.has(sympy.zoo, sympy.nan, sympy.oo, -sympy.oo):
            raise self.error("expression is not finite (division by zero?)")
        if expr.has(sympy.I):
            raise self.error("expression is not real-valued")
        for node in sympy.preorder_traversal(expr):
            if isinstance(node, sympy.Pow) and node.exp.is_Number and abs(node.exp) > MAX_EXPONENT:
                raise self.error(f"exponent {node.exp} too large after combining powers")
        return expr

    def visit(self, node: ast.AST, depth: int):
        if depth > MAX_DEPTH:
            raise self.error(f"expression nested too deeply (more than {MAX_DEPTH} levels)")
        simple = sum(1 for _ in ast.walk(node)) <= SIMPLE_TOKENS
        if isinstance(node, ast.BinOp) and type(node.op) in OPS:
            return self.binary(OPS[type(node.op)], self.visit(node.left, depth + 1),
                               self.visit(node.right, depth + 1), simple)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
            a, value = self.visit(node.operand, depth + 1)
            return (a, value) if isinstance(node.op, ast.UAdd) else self.finish(-a, None if value is None else -value)
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in CALLABLE
                and len(node.args) == 1 and not node.keywords and not isinstance(node.args[0], ast.Starred)):
            return self.apply(node.func.id, self.visit(node.args[0], depth + 1), simple)
        if isinstance(node, ast.Name):
            if node.id in ("x", "y", "t") or (node.id == "z" and self.dim == 3):
                return {"x": X, "y": Y, "z": Z, "t": T}[node.id], None
            if node.id == "pi":
                return sympy.pi, math.pi
            raise self.error(f"unknown name {node.id!r}", "; " + _expected(self.dim))
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return _Parser.number(self, _Token("number", ast.get_source_segment(self.text, node), node.col_offset))
        raise self.error(f"unexpected {type(node).__name__} at position {getattr(node, 'col_offset', 0)}",
                         "; " + _expected(self.dim))


def ast_parse(text, field: str, dim: int = 3) -> sympy.Expr:
    """`fsivsp.model.expressions.parse` with the ast grammar."""
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise ExpressionError(f"{field}: expected an expression string, got {type(text).__name__}")
    text = str(text)
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"{field}: expression too long ({len(text)} characters, at most {MAX_LENGTH})")
    try:
        return AstParser(text, field, dim).parse()
    except ExpressionError:
        raise
    except Exception as error:  # noqa: BLE001 - as parse
        raise ExpressionError(f"{field}: cannot process {text[:80]!r} ({type(error).__name__})") from error


def lambdify_function(expr, var=T):
    """`to_function` by sympy.lambdify (math module)."""
    return sympy.lambdify(var, expr, modules="math")


def lambdify_coefficient(expr, t):
    """`to_coefficient` by sympy.lambdify with NGSolve's functions (scalars only)."""
    import ngsolve

    names = {name: getattr(ngsolve, name) for name in
             ("sin", "cos", "tan", "exp", "log", "sqrt", "atan", "asin", "acos", "sinh", "cosh")}
    names.update(Abs=lambda a: ngsolve.IfPos(a, a, -a), pi=math.pi, E=math.e)
    value = sympy.lambdify((X, Y, Z, T), expr, modules=[names])(ngsolve.x, ngsolve.y, ngsolve.z, t)
    return value if isinstance(value, ngsolve.CoefficientFunction) else ngsolve.CoefficientFunction(float(value))


#: the swaps of the tests run (the module is loaded as a pytest plugin, FSIVSP_SWAP says which)
SWAPS = {"ast.parse": ("parse", ast_parse), "lambdify": ("to_function", lambdify_function),
         "lambdify (coefficients)": ("to_coefficient", lambdify_coefficient)}


def pytest_configure(config) -> None:
    import fsivsp.model.expressions
    import fsivsp.model.expressions.parser

    name, function = SWAPS[os.environ["FSIVSP_SWAP"]]
    setattr(fsivsp.expressions, name, function)
    if name == "parse":
        fsivsp.model.expressions.parser.parse = function  # parse_vector's


def generated(n: int, seed: int = 23) -> list[str]:
    rng = random.Random(seed)
    atoms, functions = ["x", "y", "z", "t", "pi", "2", "0.5", "3.25", "1e-3", "7"], list(CALLABLE)

    def expression(depth: int) -> str:
        r = rng.random()
        if depth == 0 or r < 0.25:
            return rng.choice(atoms)
        if r < 0.45:
            return f"{rng.choice(functions)}({expression(depth - 1)})"
        if r < 0.55:
            return f"-{expression(depth - 1)}"
        if r < 0.65:
            return f"({expression(depth - 1)})**{rng.choice(['2', '3', '-1', '0.5'])}"
        return f"({expression(depth - 1)} {rng.choice('+-*/')} {expression(depth - 1)})"

    return [expression(4) for _ in range(n)]


def outcome(parser, text: str):
    try:
        return "ok", parser(text, "f")
    except ExpressionError as error:
        return "error", str(error)


def best_time(function, items, repeats: int = 3) -> float:
    best = math.inf
    for _ in range(repeats):
        clear_cache()
        start = time.perf_counter()
        for item in items:
            function(item)
        best = min(best, time.perf_counter() - start)
    return best


def parsers(corpus: list[str], tests) -> dict:
    outcome(parse, "sin(x)"), outcome(ast_parse, "sin(x)")
    agree = sum(outcome(parse, s) == outcome(ast_parse, s) for s in corpus)
    hostile = {}
    for name, parser in (("hand-written", parse), ("ast.parse", ast_parse)):
        rejected = compiled = 0
        for text in tests.HOSTILE:
            calls: list[str] = []
            with tests._no_code_execution(calls):
                rejected += outcome(parser, text)[0] == "error"
            compiled += bool(calls)
        hostile[name] = {"rejected": rejected, "compile_or_exec_of_user_text": compiled}
    return {"expressions": len(corpus), "same_result_or_message": agree, "hostile_inputs": len(tests.HOSTILE),
            "hostile": hostile,
            "seconds": {"hand-written": best_time(lambda s: outcome(parse, s), corpus),
                        "ast.parse": best_time(lambda s: outcome(ast_parse, s), corpus)}}


def compilers(tests) -> dict:
    import ngsolve
    from netgen.geom2d import unit_square

    times = [parse(s, "f") for s in tests.TIME_EXPRESSIONS]
    values = [0.013 * i for i in range(1, 2001)]
    result = {}
    for name, compiler in (("to_function", to_function), ("lambdify", lambdify_function)):
        functions = [compiler(e) for e in times]
        result[name] = {"compile_us": best_time(compiler, times) / len(times) * 1e6,
                        "call_us": best_time(lambda f: [f(v) for v in values], functions) / len(times)
                        / len(values) * 1e6}
    mesh = ngsolve.Mesh(unit_square.GenerateMesh(maxh=0.3))
    spaces, t = [parse(s, "f", 2) for s in tests.SPACE_TIME_EXPRESSIONS], ngsolve.Parameter(0.37)
    points = [mesh(0.1 + 0.08 * i, 0.2 + 0.07 * i) for i in range(10)]
    largest = max(abs(to_coefficient(e, t)(p) - lambdify_coefficient(e, t)(p)) for e in spaces for p in points)
    for name, compiler in (("to_coefficient", to_coefficient), ("lambdify (coefficients)", lambdify_coefficient)):
        result[name] = {"compile_us": best_time(lambda e, compiler=compiler: compiler(e, t), spaces)
                        / len(spaces) * 1e6}
    result["coefficients_largest_difference"] = largest
    return result


def tests_with(swap: str) -> str:
    env = dict(os.environ, FSIVSP_SWAP=swap,
               PYTHONPATH=os.pathsep.join([str(ROOT / "benchmarks"), os.environ.get("PYTHONPATH", "")]))
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p",
                          "expression_alternatives", "tests/test_expressions.py"],
                         cwd=ROOT, env=env, capture_output=True, text=True)
    return re.findall(r"^.*(?:passed|failed).*$", run.stdout, re.M)[-1].strip("= ")


def main() -> None:
    arguments = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    arguments.add_argument("--json", type=Path, help="write the figures here")
    options = arguments.parse_args()
    sys.path.insert(0, str(ROOT / "tests"))
    import test_expressions as tests

    figures = {"parsers": parsers(generated(2000), tests), "compilers": compilers(tests),
               "tests": {swap: tests_with(swap) for swap in SWAPS}}
    print(json.dumps(figures, indent=2))
    if options.json:
        options.json.write_text(json.dumps(figures, indent=2) + "\n")


if __name__ == "__main__":
    main()
