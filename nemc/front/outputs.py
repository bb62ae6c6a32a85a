"""The outputs a scene asks for: reactions, drives, points, energy, accelerations and named
expressions.
"""

from __future__ import annotations

import sympy

from .context import Context, check_keys, described, entries_of, join_path, list_of, suggestion
from .fields import read_expr, read_flag, read_string
from .mechanism import Outputs, PointRef
from .parse import Node
from .references import joint_name, point_ref


def read_outputs(ctx: Context, node: Node) -> Outputs:
    keys = ("reactions", "energy", "points", "accelerations", "expressions", "drives")
    if not check_keys(ctx, node, "outputs", keys):
        return Outputs()
    entries = entries_of(node)
    reactions: list[str] = []
    for i, item in enumerate(list_of(ctx, entries.get("reactions"), "outputs.reactions")):
        name = _reaction_name(ctx, item, f"outputs.reactions[{i}]")
        if name in reactions:
            ctx.problem(item.line, f"outputs.reactions[{i}]", f"{name!r} is listed twice")
        elif name is not None:
            reactions.append(name)
    drives: list[str] = []
    for i, item in enumerate(list_of(ctx, entries.get("drives"), "outputs.drives")):
        name = _driven_joint(ctx, item, f"outputs.drives[{i}]")
        if name in drives:
            ctx.problem(item.line, f"outputs.drives[{i}]", f"{name!r} is listed twice")
        elif name is not None:
            drives.append(name)
    points: list[PointRef] = []
    for i, item in enumerate(list_of(ctx, entries.get("points"), "outputs.points")):
        point = point_ref(ctx, item, f"outputs.points[{i}]", ground=False)
        if point is not None and point.label in [p.label for p in points]:
            ctx.problem(item.line, f"outputs.points[{i}]", f"{point.label} is listed twice")
        elif point is not None:
            points.append(point)
    flags = {key: read_flag(ctx, entries[key], join_path("outputs", key)) if key in entries
             else False for key in ("energy", "accelerations")}
    expressions, units = _output_expressions(ctx, entries.get("expressions"))
    return Outputs(tuple(reactions), flags["energy"], tuple(points), flags["accelerations"],
                   expressions, tuple(drives), units)


def _reaction_name(ctx: Context, node: Node, path: str) -> str | None:
    """A joint's or a constraint's name."""
    name = read_string(ctx, node, path, "a joint or constraint name")
    if name is None:
        return None
    if name not in ctx.joint_keys and name not in ctx.constraint_keys:
        known = [*ctx.joint_keys, *ctx.constraint_keys]
        ctx.problem(node.line, path, f"unknown joint or constraint {name!r}"
                                     f"{suggestion(name, known)}")
        return None
    return name


def _driven_joint(ctx: Context, node: Node, path: str) -> str | None:
    """A driven joint's name (one with `motion:`)."""
    name = joint_name(ctx, node, path)
    joint = ctx.joints.get(name) if name is not None else None
    if joint is not None and not joint.driven:
        driven = [j.name for j in ctx.joints.values() if j.driven]
        ctx.problem(node.line, path, f"joint {name!r} is not driven (it has no motion:); "
                                     f"driven joints: {', '.join(driven) or 'none'}")
        return None
    return name


def _output_expressions(ctx: Context, node: Node | None
                        ) -> tuple[tuple[tuple[str, sympy.Expr], ...], tuple[tuple[str, str], ...]]:
    """The named expressions, and the units of those given as {value: EXPR, unit: LABEL}."""
    if node is None:
        return (), ()
    if not node.is_map:
        ctx.problem(node.line, "outputs.expressions", "expected a mapping name -> expression, "
                                                      f"{described(node)}")
        return (), ()
    result, units = [], []
    for name, value in entries_of(node).items():
        path = join_path("outputs.expressions", name)
        if ctx.names.get(name) != ("output expression", path):
            continue  # a bad or colliding name, already reported
        if value.is_map:
            value, unit = _expression_with_unit(ctx, value, path)
            if unit:
                units.append((name, unit))
            if value is None:
                continue
        expr = read_expr(ctx, value, path, ctx.scope("load"))
        if expr is not None:
            result.append((name, expr))
    return tuple(result), tuple(units)


def _expression_with_unit(ctx: Context, node: Node, path: str) -> tuple[Node | None, str]:
    """{value: EXPR, unit: LABEL}'s value node and unit label ("" when bad)."""
    if not check_keys(ctx, node, path, ("value", "unit"), required=("value",),
                      what="an expression or {value: EXPR, unit: LABEL}"):
        return None, ""
    entries = entries_of(node)
    if "value" not in entries:  # reported
        return None, ""
    if "unit" not in entries:
        return entries["value"], ""
    unit = read_string(ctx, entries["unit"], join_path(path, "unit"), "a unit label (N*m)")
    if unit is not None and not unit.strip():
        ctx.problem(entries["unit"].line, join_path(path, "unit"), "the unit label is empty")
        unit = None
    return entries["value"], (unit or "").strip()
