"""What the file's items name: a body (or ground), a joint, a point of a body (`BODY.POINT`, a
point name or [x, y]), a fixed direction; each checked against what the file defines, with a
suggestion for a misspelling.
"""

from __future__ import annotations

from .context import Context, check_keys, described, entries_of, join_path, suggestion
from .fields import ZERO2, default_value, has_defaults, read_string, read_vec2
from .mechanism import GROUND, PointRef, Vec2
from .parse import Node

IMPLICIT_POINTS = ("origin", "com")


def body_name(ctx: Context, node: Node, path: str, ground: bool) -> str | None:
    """A body name (or ``ground`` where allowed), with a suggestion for misspellings."""
    name = read_string(ctx, node, path, "a body name")
    if name is None:
        return None
    if name == GROUND and not ground:
        ctx.problem(node.line, path, "expected a body, got 'ground' (ground is not allowed here)")
        return None
    if name == GROUND or name in ctx.body_keys:
        return name
    candidates = [*ctx.body_keys, GROUND] if ground else ctx.body_keys
    ctx.problem(node.line, path, f"unknown body {name!r}{suggestion(name, candidates)}")
    return None


def joint_name(ctx: Context, node: Node, path: str) -> str | None:
    name = read_string(ctx, node, path, "a joint name")
    if name is None:
        return None
    if name not in ctx.joint_keys:
        ctx.problem(node.line, path, f"unknown joint {name!r}{suggestion(name, ctx.joint_keys)}")
        return None
    return name


def point_of(ctx: Context, node: Node, path: str, body: str | None, moving: bool = False
             ) -> Vec2 | None:
    """A point of ``body``: a point name (``origin``, ``com``, named) or ``[x, y]``, fixed or
    (``moving``) expressions of the coordinates, inputs and t."""
    if node.is_list:
        return read_vec2(ctx, node, path, ctx.scope("point") if moving else None)
    name = read_string(ctx, node, path, "a point name or [x, y]")
    if name is None or body is None:
        return None
    return named_point(ctx, body, name, node.line, path)


def named_point(ctx: Context, body: str, name: str, line: int, path: str) -> Vec2 | None:
    if body == GROUND:
        if name == "origin":
            return ZERO2
        ctx.problem(line, path, f"ground has no point {name!r}: its only named point is origin; "
                                "give a position as [x, y]")
        return None
    if body not in ctx.bodies:
        return None  # the body itself is wrong, and already reported
    found = ctx.bodies[body]
    if name == "origin":
        return ZERO2
    if name == "com":
        return found.com
    if name in found.points:
        return found.points[name]
    candidates = [*found.points, *IMPLICIT_POINTS]
    ctx.problem(line, path, f"body {body!r} has no point {name!r}{suggestion(name, candidates)}; "
                            f"its points: {', '.join(candidates)}")
    return None


def point_ref(ctx: Context, node: Node, path: str, ground: bool) -> PointRef | None:
    """``BODY.POINT``, or (where ``ground`` is true, for springs) ``{body: BODY, at: [x, y]}``."""
    if node.is_map and ground:
        if not check_keys(ctx, node, path, ("body", "at"), ("body", "at")):
            return None
        entries = entries_of(node)
        body = None
        if "body" in entries:
            body = body_name(ctx, entries["body"], join_path(path, "body"), ground=True)
        xy = read_vec2(ctx, entries["at"], join_path(path, "at")) if "at" in entries else None
        if body is None or xy is None:
            return None
        return PointRef(body, xy, f"{body}.[{xy[0]}, {xy[1]}]")
    text = node.value if isinstance(node.value, str) else None
    parts = text.split(".") if text is not None else []
    if len(parts) != 2:
        other = " or {body: BODY, at: [x, y]}" if ground else ""
        ctx.problem(node.line, path, f"expected BODY.POINT (e.g. link1.com){other}, "
                                     f"{described(node)}")
        return None
    body = body_name(ctx, Node(parts[0], node.line, node.column), path, ground)
    if body is None:
        return None
    xy = named_point(ctx, body, parts[1], node.line, path)
    return PointRef(body, xy, f"{body}.{parts[1]}") if xy is not None else None


def read_axis(ctx: Context, node: Node, path: str) -> Vec2 | None:
    axis = read_vec2(ctx, node, path)
    if axis is None or not all(has_defaults(ctx, part) for part in axis):
        return axis
    if all(default_value(ctx, part) == 0 for part in axis):
        ctx.problem(node.line, path, "axis must not be [0, 0] at the default parameter values")
        return None
    return axis
