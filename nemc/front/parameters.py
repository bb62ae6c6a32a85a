"""The parameters and constants: each parsed in its scope, the definitions free of cycles,
their default values finite, each definition with those it uses written out at most MAX_DEPTH
deep.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import sympy

from .context import Context, described, entries_of, join_path
from .expr import MAX_DEPTH, tree_depth
from .fields import default_value, has_defaults, read_expr, too_deep
from .mechanism import Param, symbol
from .parse import Node
from .values import dependency_order


def read_parameters(ctx: Context, root: Mapping[str, Node]) -> tuple[tuple[Param, ...], ...]:
    """Parameters and constants: parsed, free of cycles, with finite default values."""
    parsed: dict[str, tuple[Node, str, sympy.Expr]] = {}
    for section, kind in (("constants", "constant"), ("parameters", "parameter")):
        node = root.get(section)
        if node is None:
            continue
        if not node.is_map:
            ctx.problem(node.line, section, f"expected a mapping name -> number or expression, "
                                            f"{described(node)}")
            continue
        scope = ctx.scope(section)
        for name, value in entries_of(node).items():
            path = join_path(section, name)
            if ctx.names.get(name) != (kind, path):
                continue  # a bad or colliding name, already reported
            expr = read_expr(ctx, value, path, scope)
            if expr is not None:
                parsed[name] = (value, path, expr)
    cyclic = _check_cycles(ctx, parsed)
    _compute_defaults(ctx, parsed, cyclic)
    made = {name: Param(name, expr, ctx.loc(node, path))
            for name, (node, path, expr) in parsed.items()}
    return (tuple(made[n] for n in ctx.parameters if n in made),
            tuple(made[n] for n in ctx.constants if n in made))


def _dependencies(expr: sympy.Expr) -> list[str]:
    return sorted(s.name for s in expr.free_symbols if isinstance(s, sympy.Symbol))


def _check_cycles(ctx: Context, parsed: Mapping[str, tuple[Node, str, sympy.Expr]]) -> set[str]:
    """Report each cycle among parameter definitions once; return the names on cycles.
    A depth-first search with its own stack: a chain of thousands of definitions is fine."""
    cyclic: set[str] = set()
    done: set[str] = set()
    for start in parsed:
        if start in done:
            continue
        path = [start]
        pending = [iter(_dependencies(parsed[start][2]))]
        while path:
            dep = next(pending[-1], None)
            if dep is None:
                done.add(path.pop())
                pending.pop()
            elif dep in path:
                cycle = path[path.index(dep):]
                if not cyclic & set(cycle):
                    node, key, _ = parsed[cycle[0]]
                    chain = " -> ".join([*cycle, cycle[0]])
                    ctx.problem(node.line, key, f"definitions form a cycle: {chain}")
                cyclic.update(cycle)
            elif dep in parsed and dep not in done:
                path.append(dep)
                pending.append(iter(_dependencies(parsed[dep][2])))
    return cyclic


def _compute_defaults(ctx: Context, parsed: Mapping[str, tuple[Node, str, sympy.Expr]],
                      cyclic: set[str]) -> None:
    """Evaluate default values in dependency order; each must be a finite real number, and
    each definition, with the definitions it uses written out, at most MAX_DEPTH deep."""
    names = [name for name in parsed if name not in cyclic]
    for name in dependency_order(names, lambda n: _dependencies(parsed[n][2])):
        node, path, expr = parsed[name]
        if not has_defaults(ctx, expr):
            continue
        depth = tree_depth(expr, ctx.depths)
        if depth > MAX_DEPTH:
            ctx.problem(node.line, path, too_deep(expr, depth))
            continue
        ctx.depths[symbol(name)] = depth
        value = default_value(ctx, expr)
        if math.isnan(value):
            ctx.problem(node.line, path, "default value does not evaluate to a finite real "
                                         f"number (got {expr})")
        else:
            ctx.defaults[symbol(name)] = sympy.Float(value)
