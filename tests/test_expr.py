"""The expression grammar: whitelist parsing to sympy, never eval."""

from __future__ import annotations

import pytest
import sympy
from budgets import work_of

from nemc.front.expr import (
    FUNCTIONS,
    MAX_DEPTH,
    RESERVED,
    ExprError,
    Scope,
    parse_expression,
    suggest,
    tokenize,
)
from nemc.front.mechanism import TIME, rate_symbol, symbol

x, y, q = symbol("x"), symbol("y"), symbol("q")
PARAMS = Scope({"x": x, "y": y}, where="in parameters")
LOADS = Scope({"x": x, "y": y, "q": q}, frozenset({"q"}), time=True)


def parse(text: str, scope: Scope = LOADS) -> sympy.Expr:
    return parse_expression(text, scope)


@pytest.mark.parametrize("text, expected", [
    ("1", sympy.Integer(1)),
    ("0.5", sympy.Float(0.5)),
    ("2e-3", sympy.Float(0.002)),
    ("1.0e-6", sympy.Float(1e-6)),
    (".5", sympy.Float(0.5)),
    ("pi", sympy.pi),
    ("t", TIME),
    ("x + y*2", x + 2 * y),
    ("x - y - 1", x - y - 1),
    ("x / y / 2", x / y / 2),
    ("-x**2", -(x**2)),
    ("2**3**2", sympy.Integer(512)),
    ("x**-1", 1 / x),
    ("(x + y)*2", 2 * (x + y)),
    ("+x", x),
    ("--x", x),
    ("dot(q)", rate_symbol("q")),
    ("dot( q )", rate_symbol("q")),
    ("sin(x) + cos(y) + tan(x)", sympy.sin(x) + sympy.cos(y) + sympy.tan(x)),
    ("asin(x)+acos(x)+atan(x)", sympy.asin(x) + sympy.acos(x) + sympy.atan(x)),
    ("sinh(x)*cosh(x)*tanh(x)", sympy.sinh(x) * sympy.cosh(x) * sympy.tanh(x)),
    ("exp(x) + log(y) + sqrt(x)", sympy.exp(x) + sympy.log(y) + sympy.sqrt(x)),
    ("abs(x) + sign(y)", sympy.Abs(x) + sympy.sign(y)),
    ("atan2(y, x)", sympy.atan2(y, x)),
    ("min(x, y, 1)", sympy.Min(x, y, 1)),
    ("max(x, y)", sympy.Max(x, y)),
    ("  x\t+\n1 ", x + 1),
])
def test_valid(text: str, expected: sympy.Expr) -> None:
    assert parse(text) == expected


def test_integers_stay_exact() -> None:
    assert parse("1/3") == sympy.Rational(1, 3)
    assert isinstance(parse("12"), sympy.Integer)


@pytest.mark.parametrize("text, message", [
    ("x^2", "write '**'"),
    ("__import__('os')", "strings are not allowed"),
    ("'abc'", "strings are not allowed"),
    ('"abc"', "strings are not allowed"),
    ("x.real", "attribute access"),
    ("lambda: 1", "unexpected character ':'"),
    ("lambda", "unknown name 'lambda'"),
    ("foo(x)", "unknown function 'foo'"),
    ("sni(x)", "unknown function 'sni' (did you mean 'sin'?)"),
    ("xx", "unknown name 'xx' (did you mean 'x'?)"),
    ("sin(x, y)", "sin() takes 1 argument, got 2"),
    ("atan2(x)", "atan2() takes 2 arguments, got 1"),
    ("min(x)", "min() takes 2 or more arguments, got 1"),
    ("sin", "sin is a function"),
    ("dot(x)", "'x' is not one"),
    ("dot(q + 1)", "expected ')'"),
    ("dot(1)", "dot() takes a coordinate name"),
    ("ddot(q)", "unknown function 'ddot'"),
    ("x +", "got the end of the expression"),
    ("(x", "expected ')'"),
    ("x)", "expected an operator or the end"),
    ("x y", "expected an operator or the end, got 'y'"),
    ("", "empty"),
    ("   ", "empty"),
    ("[x]", "use parentheses"),
    ("x @ y", "unexpected character '@'"),
    ("1/0", "not finite"),
    ("2**100000", "too large"),
    ("1" * 2000, "more than 1000 digits"),
    ("x" * 100_001, "too long"),
    ("1.5/0.0", "divides by zero"),
    ("1e400", "out of range"),
    ("1e-400000", "out of range"),
    ("exp(1e308)", "out of range"),
    ("10.0**10**10", "out of range"),
    ("cosh(exp(1e5))", "out of range"),
    ("(10**999)**4", "too large"),
])
def test_invalid(text: str, message: str) -> None:
    with pytest.raises(ExprError) as info:
        parse(text)
    assert message in info.value.message


def test_numeric_blowups_are_refused_with_little_work() -> None:
    """Refused before sympy computes with them: a few hundred calls and kilobytes each (the
    numbers themselves are never built)."""
    for text in ("1e-400000", "log(1e-400000)", "cosh(exp(1e5))", "1e308**1e3080.0",
                 "2**100000", "(10**999)**4"):
        work = work_of(lambda text=text: parse(text))
        assert isinstance(work.error, ExprError), text
        assert work.calls < 5_000 and work.peak_bytes < 1_000_000, (text, work)


def test_error_offset() -> None:
    with pytest.raises(ExprError) as info:
        parse("x + y ^ 2")
    assert info.value.offset == 6


def test_scope_refuses_time_rates_and_named_names() -> None:
    with pytest.raises(ExprError, match="time 't' is not allowed in parameters"):
        parse("t", PARAMS)
    with pytest.raises(ExprError, match=r"dot\(\) is not allowed in parameters"):
        parse("dot(q)", PARAMS)
    scope = Scope({"x": x}, refused={"q": "'q' is a coordinate, not allowed here"})
    with pytest.raises(ExprError, match="'q' is a coordinate"):
        parse("x + q", scope)


def test_deep_nesting_is_a_clean_error_and_stops_at_the_limit() -> None:
    """10,000 levels refused at level 100: the parser's stack stays a few frames a level deep
    up to the limit (not 10,000 levels of them), and its work is linear in the text (the
    tokens, once)."""
    for text in ("(" * 10_000 + "1" + ")" * 10_000, "-" * 10_000 + "1", "x**" * 10_000 + "x"):
        work = work_of(lambda text=text: parse(text))
        assert isinstance(work.error, ExprError), work.error
        assert "nested too deeply" in work.error.message
        assert work.depth < 10 * MAX_DEPTH and work.calls < 2 * len(text), work


def test_moderate_nesting_is_fine() -> None:
    assert parse("(" * 50 + "x" + ")" * 50) == x


def test_tokens() -> None:
    assert [t.text for t in tokenize("a**-2.5e3,(b)")] == ["a", "**", "-", "2.5e3", ",", "(",
                                                          "b", ")", ""]


def test_reserved_words_cover_functions() -> None:
    assert set(FUNCTIONS) <= RESERVED and {"t", "pi", "ground", "dot", "ddot"} <= RESERVED


def test_suggest_prefers_same_word_in_other_case() -> None:
    assert suggest("rk45", ["RK23", "RK45"]) == " (did you mean 'RK45'?)"
    assert suggest("zzz", ["RK45"]) == ""
