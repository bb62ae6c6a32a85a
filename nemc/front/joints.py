"""The joints: each read by its kind (nemc/kinds/joints/), and the tree they form (every body
the child of exactly one joint, every chain reaching ground).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from ..kinds.joints import JOINT_KINDS, Joint
from .context import (
    Context,
    check_keys,
    described,
    entries_of,
    items_of,
    join_path,
    nonempty_mapping,
)
from .fields import read_choice, read_expr
from .parse import Node
from .reader import Reader, every_key, joint_keys
from .references import body_name


@dataclass(frozen=True)
class _Edge:
    joint: str
    parent: str
    child: str
    parent_line: int
    child_line: int


def read_joints(ctx: Context, node: Node | None) -> tuple[Joint, ...]:
    if not nonempty_mapping(ctx, node, "joints", "joint"):
        return ()
    edges: list[_Edge] = []
    for name, joint_node in entries_of(node).items():
        path = join_path("joints", name)
        if ctx.names.get(name) == ("joint", path) and joint_node.is_map:
            edge = _edge(ctx, name, joint_node, path)
            if edge is not None:
                edges.append(edge)
            joint = _joint(ctx, name, joint_node, path, edge)
            if joint is not None:
                ctx.joints[name] = joint
        elif not joint_node.is_map:
            ctx.problem(joint_node.line, path, f"expected a joint mapping, {described(joint_node)}")
    _check_tree(ctx, edges, _named_children(node))
    return tuple(ctx.joints.values())


def _edge(ctx: Context, name: str, node: Node, path: str) -> _Edge | None:
    """The joint's parent and child, if both name real bodies (or ground for the parent)."""
    entries = entries_of(node)
    parent = child = None
    if "parent" in entries:
        parent = body_name(ctx, entries["parent"], join_path(path, "parent"), ground=True)
    if "child" in entries:
        child = body_name(ctx, entries["child"], join_path(path, "child"), ground=False)
    if parent is None or child is None:
        return None
    return _Edge(name, parent, child, entries["parent"].line, entries["child"].line)


def _joint(ctx: Context, name: str, node: Node, path: str, edge: _Edge | None) -> Joint | None:
    entries = entries_of(node)
    kind = None
    if "type" in entries:
        type_name = read_choice(ctx, entries["type"], join_path(path, "type"), tuple(JOINT_KINDS),
                                "joint type")
        kind = JOINT_KINDS.get(type_name) if type_name is not None else None
    all_keys = every_key(joint_keys(k) for k in JOINT_KINDS.values())
    if kind is None:
        check_keys(ctx, node, path, all_keys, ("type", "parent", "child"))
        return None
    required = ["type", "parent", "child", *([kind.coordinate_key] if kind.coordinate_key else [])]
    check_keys(ctx, node, path, joint_keys(kind), required,
               owner=(f"a {kind.type} joint", all_keys))
    count = len(ctx.problems)
    coordinates = _joint_coordinates(ctx, kind, name, entries, path)
    if edge is not None and (why := kind.parent_problem(edge.parent)) is not None:
        ctx.problem(edge.parent_line, join_path(path, "parent"), why)
    fields = kind.read(Reader(ctx, node, path, parent=edge.parent if edge else None))
    motion = None
    if "motion" in entries and kind.drivable:
        motion = read_expr(ctx, entries["motion"], join_path(path, "motion"), ctx.scope("motion"))
    if len(ctx.problems) > count or edge is None or fields is None or coordinates is None:
        return None
    joint = kind(name=name, parent=edge.parent, child=edge.child, coordinates=coordinates,
                 loc=ctx.loc(node, path), motion=motion, **fields)
    if joint.driven and (why := joint.drive_problem()) is not None:
        ctx.problem(entries["motion"].line, join_path(path, "motion"), why)
        return None
    return joint


def _joint_coordinates(ctx: Context, kind: type[Joint], name: str, entries: Mapping[str, Node],
                       path: str) -> tuple[str, ...] | None:
    """The joint's coordinates; their names were checked when they were collected."""
    count = len(kind.coordinate_kinds)
    if count == 0 or kind.coordinate_key is None:
        return ()
    node = entries.get(kind.coordinate_key)
    if node is None:
        return None
    if count > 1 and (not node.is_list or len(items_of(node)) != count):
        ctx.problem(node.line, join_path(path, kind.coordinate_key),
                    f"expected a list of {count} coordinate names, {described(node)}")
        return None
    found = ctx.joint_coordinates.get(name, ())
    return found if len(found) == count else None


def _named_children(node: Node) -> set[object]:
    """Every child any joint names, valid or not: a body a broken joint names is reported
    with that joint, not as unattached too."""
    children = [entries_of(joint).get("child") for joint in entries_of(node).values()]
    return {child.value for child in children if child is not None and child.is_scalar}


def _check_tree(ctx: Context, edges: list[_Edge], named_children: set[object]) -> None:
    """Every body is the child of exactly one joint, and every chain reaches ground."""
    parent_of: dict[str, _Edge] = {}
    for edge in edges:
        if edge.child in parent_of:
            first = parent_of[edge.child].joint
            ctx.problem(edge.child_line, join_path(join_path("joints", edge.joint), "child"),
                        f"body {edge.child!r} is already the child of joint {first!r}; every "
                        "body is the child of exactly one joint")
        else:
            parent_of[edge.child] = edge
    for body in ctx.body_names:
        if body not in parent_of and body not in named_children:
            ctx.problem(ctx.lines[body], ctx.names[body][1], f"body {body!r} is not attached: "
                        f"no joint has child: {body} (every body is the child of exactly one "
                        "joint)")
    _check_cycles_in_tree(ctx, parent_of)


def _check_cycles_in_tree(ctx: Context, parent_of: Mapping[str, _Edge]) -> None:
    """Each cycle once; every body's way up is walked once (linear in the bodies)."""
    reported: set[str] = set()
    settled: set[str] = set()  # bodies whose way up an earlier walk took: nothing new there
    for start in parent_of:
        chain: list[str] = []
        on_chain: set[str] = set()
        body = start
        while body in parent_of and body not in on_chain and body not in settled:
            chain.append(body)
            on_chain.add(body)
            body = parent_of[body].parent
        settled.update(chain)
        if body not in on_chain or body in reported:
            continue
        cycle = chain[chain.index(body):]
        reported.update(cycle)
        edge = parent_of[cycle[0]]
        bodies = " -> ".join([*cycle, cycle[0]])
        joints = ", ".join(parent_of[b].joint for b in cycle)
        ctx.problem(edge.parent_line, join_path(join_path("joints", edge.joint), "parent"),
                    f"joints {joints} form a cycle (child -> parent: {bodies}) that never "
                    "reaches ground; the joints must form a tree rooted at ground")
