"""One YAML value read where it stands: a number, an expression of the names a scope allows,
a fixed expression (finite at the parameters' default values), a vector [x, y], a string, one
of a few choices, a flag. A wrong value records a problem at its FILE:LINE: key.path and reads
as None.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import sympy

from ..errors import InputError
from .context import Context, described, items_of, join_path, suggestion
from .expr import MAX_DEPTH, ExprError, Scope, parse_expression, tree_depth
from .mechanism import Vec2
from .parse import Node

ZERO2: Vec2 = (sympy.S.Zero, sympy.S.Zero)


def read_expr(ctx: Context, node: Node, path: str, scope: Scope) -> sympy.Expr | None:
    """A number or expression string; ``None`` (and a problem) if it is not one."""
    value = node.value
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        ctx.problem(node.line, path, f"expected a number or an expression, {described(node)}")
        return None
    if isinstance(value, int):
        return sympy.Integer(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            ctx.problem(node.line, path, f"expected a finite number, got {value}")
            return None
        return sympy.Float(value)
    try:
        expr = parse_expression(value, scope)
    except ExprError as exc:
        shown = value if len(value) <= 60 else value[:57] + "..."
        ctx.problem(node.line, path, f"{exc.message} (in expression {shown!r}, "
                                     f"at character {exc.offset + 1})")
        if ctx.budget.exhausted:  # stop: every later expression would say the same
            raise InputError(sorted(ctx.problems, key=lambda p: p.line)) from None
        return None
    return _shallow_enough(ctx, node, path, expr)


def _shallow_enough(ctx: Context, node: Node, path: str, expr: sympy.Expr) -> sympy.Expr | None:
    """EXPR, unless it is deeper than MAX_DEPTH with the definitions it uses written out (as
    derive substitutes them): every later stage must handle what validation accepts."""
    depth = tree_depth(expr, ctx.depths)
    if depth <= MAX_DEPTH:
        return expr
    ctx.problem(node.line, path, too_deep(expr, depth))
    return None


def too_deep(expr: sympy.Expr, depth: int) -> str:
    """The message for an expression DEPTH levels deep with its definitions written out."""
    if tree_depth(expr) == depth:
        return (f"expression is nested too deeply: {depth} levels, at most {MAX_DEPTH} (each "
                "operation and function call is a level)")
    return (f"expression is nested too deeply: {depth} levels once the parameters and constants "
            f"it uses are written out, at most {MAX_DEPTH}")


def default_value(ctx: Context, expr: sympy.Expr) -> float | None:
    """The value of ``expr`` at the default parameter values; nan if not a finite real."""
    try:
        value = float(expr.xreplace(ctx.defaults))
    except (TypeError, ValueError, ArithmeticError):
        return math.nan
    return value if math.isfinite(value) else math.nan


def has_defaults(ctx: Context, expr: sympy.Expr) -> bool:
    """Whether every symbol of a fixed expression has a default value (else skip checks)."""
    return expr.free_symbols <= ctx.defaults.keys()


def read_fixed(ctx: Context, node: Node, path: str, positive: bool = False,
               nonnegative: bool = False) -> sympy.Expr | None:
    """An expression of parameters and constants, finite (and > 0, or >= 0) at the default
    values."""
    expr = read_expr(ctx, node, path, ctx.scope("fixed"))
    if expr is None or not has_defaults(ctx, expr):
        return expr
    value = default_value(ctx, expr)
    if math.isnan(value):
        ctx.problem(node.line, path, "does not evaluate to a finite real number at the "
                                     f"default parameter values (got {expr})")
        return None
    if positive and value <= 0:
        ctx.problem(node.line, path, f"must be > 0, got {value:g} at the default parameter values")
        return None
    if nonnegative and value < 0:
        ctx.problem(node.line, path, f"must be >= 0, got {value:g} at the default parameter "
                                     "values")
        return None
    return expr


def read_vec2(ctx: Context, node: Node, path: str, scope: Scope | None = None) -> Vec2 | None:
    """``[x, y]``: fixed expressions, or ``scope`` expressions when given."""
    items = items_of(node)
    if not node.is_list or len(items) != 2:
        ctx.problem(node.line, path, f"expected a vector [x, y] of 2 entries, {described(node)}")
        return None
    if scope is None:
        parts = [read_fixed(ctx, item, join_path(path, i)) for i, item in enumerate(items)]
    else:
        parts = [read_expr(ctx, item, join_path(path, i), scope) for i, item in enumerate(items)]
    if parts[0] is None or parts[1] is None:
        return None
    return (parts[0], parts[1])


def read_number(ctx: Context, node: Node, path: str) -> float | None:
    """A finite number: YAML number or an expression without names (``2*pi``)."""
    expr = read_expr(ctx, node, path, Scope(where="here (a plain number is expected)",
                                            budget=ctx.budget))
    if expr is None:
        return None
    value = default_value(ctx, expr)
    if math.isnan(value):
        ctx.problem(node.line, path, f"expected a finite number, got {expr}")
        return None
    return value


def read_string(ctx: Context, node: Node, path: str, what: str) -> str | None:
    if isinstance(node.value, str):
        return node.value
    ctx.problem(node.line, path, f"expected {what}, {described(node)}")
    return None


def read_choice(ctx: Context, node: Node, path: str, choices: Iterable[str], what: str
                ) -> str | None:
    """One of ``choices``, with a suggestion for a misspelling."""
    choices = tuple(choices)
    value = read_string(ctx, node, path, what)
    if value is None:
        return None
    if value not in choices:
        ctx.problem(node.line, path, f"unknown {what} {value!r}{suggestion(value, choices)}; "
                                     f"expected one of: {', '.join(choices)}")
        return None
    return value


def read_flag(ctx: Context, node: Node, path: str) -> bool:
    if isinstance(node.value, bool):
        return node.value
    ctx.problem(node.line, path, f"expected true or false, {described(node)}")
    return False
