"""The bodies: mass and inertia (>= 0 at the default values: a particle has no inertia, a
massless link neither), mass center and named points.
"""

from __future__ import annotations

from .context import Context, check_keys, described, entries_of, join_path, nonempty_mapping
from .expr import RESERVED
from .fields import ZERO2, read_fixed, read_vec2
from .mechanism import Body, Vec2
from .names import IDENTIFIER
from .parse import Node
from .references import IMPLICIT_POINTS


def read_bodies(ctx: Context, node: Node | None) -> tuple[Body, ...]:
    if not nonempty_mapping(ctx, node, "bodies", "body"):
        return ()
    for name, body_node in entries_of(node).items():
        path = join_path("bodies", name)
        if ctx.names.get(name) == ("body", path):
            body = _body(ctx, name, body_node, path)
            if body is not None:
                ctx.bodies[name] = body
    return tuple(ctx.bodies.values())


def _body(ctx: Context, name: str, node: Node, path: str) -> Body | None:
    if not check_keys(ctx, node, path, ("mass", "inertia", "com", "points"), ("mass", "inertia")):
        return None
    entries = entries_of(node)
    mass = None
    if "mass" in entries:
        mass = read_fixed(ctx, entries["mass"], join_path(path, "mass"), nonnegative=True)
    inertia = None
    if "inertia" in entries:
        inertia = read_fixed(ctx, entries["inertia"], join_path(path, "inertia"),
                             nonnegative=True)
    com = read_vec2(ctx, entries["com"], join_path(path, "com")) if "com" in entries else ZERO2
    points: dict[str, Vec2] | None = {}
    if "points" in entries:
        points = _points(ctx, entries["points"], join_path(path, "points"))
    if mass is None or inertia is None or com is None or points is None:
        return None
    return Body(name, mass, inertia, com, points, ctx.loc(node, path))


def _points(ctx: Context, node: Node, path: str) -> dict[str, Vec2] | None:
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a mapping point name -> [x, y], {described(node)}")
        return None
    points: dict[str, Vec2] = {}
    ok = True
    for name, value in entries_of(node).items():
        item_path = join_path(path, name)
        line = node.key_lines[name]
        if name in IMPLICIT_POINTS:
            ctx.problem(line, item_path, f"{name!r} is an implicit point of every body and "
                                         "cannot be redefined")
        elif not IDENTIFIER.fullmatch(name) or name in RESERVED:
            ctx.problem(line, item_path, "point name must be an identifier [A-Za-z_][A-Za-z0-9_]*"
                                         f" and not a reserved word, got {name!r}")
        else:
            xy = read_vec2(ctx, value, item_path)
            if xy is not None:
                points[name] = xy
                continue
        ok = False
    return points if ok else None
