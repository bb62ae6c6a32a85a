"""The inputs: values set from outside at run time (a control engineer's u), each with a
default, an expression of parameters and constants finite at their defaults. The scene may set
them (`simulation.inputs`, scene.py); loads, outputs and events use them as they use the state.
"""

from __future__ import annotations

import math

from .context import Context, described, entries_of, join_path
from .fields import default_value, has_defaults, read_expr
from .mechanism import Param
from .parse import Node


def read_inputs(ctx: Context, node: Node) -> tuple[Param, ...]:
    """The inputs in file order: name -> default value."""
    if not node.is_map:
        ctx.problem(node.line, "inputs", "expected a mapping input name -> default value, "
                                         f"{described(node)}")
        return ()
    found = []
    scope = ctx.scope("inputs")
    for name, value in entries_of(node).items():
        path = join_path("inputs", name)
        if ctx.names.get(name) != ("input", path):
            continue  # a bad or colliding name, already reported
        expr = read_expr(ctx, value, path, scope)
        if expr is None:
            continue
        if has_defaults(ctx, expr) and math.isnan(default_value(ctx, expr)):
            ctx.problem(value.line, path, "default value does not evaluate to a finite real "
                                          f"number (got {expr})")
            continue
        found.append(Param(name, expr, ctx.loc(value, path)))
    return tuple(found)
