"""The loop-closing constraints: each read by its kind (nemc/kinds/constraints/); with them, no
more equations on the positions than free coordinates.
"""

from __future__ import annotations

from ..kinds.constraints import CONSTRAINT_KINDS, Constraint
from .context import Context, check_keys, described, entries_of, join_path, nonempty_mapping
from .fields import read_choice
from .parse import Node
from .reader import Reader, constraint_keys, every_key


def read_constraints(ctx: Context, node: Node) -> tuple[Constraint, ...]:
    """The loop-closing constraints; with them, no more equations on the positions than free
    coordinates."""
    if not nonempty_mapping(ctx, node, "constraints", "constraint"):
        return ()
    found = []
    for name, item in entries_of(node).items():
        path = join_path("constraints", name)
        if ctx.names.get(name) != ("constraint", path):
            continue  # a bad or colliding name, already reported
        constraint = _constraint(ctx, name, item, path)
        if constraint is not None:
            found.append(constraint)
    # on the positions (one on the velocities, as a planet's rolling held by its carrier,
    # may repeat what the positions' already say: the runtime drops a redundant equation)
    equations = sum(c.equations_count - len(c.on_velocities()) for c in found)
    free = len([q for joint in ctx.joints.values() if not joint.driven
                for q in joint.coordinates])
    if found and equations > free:
        ctx.problem(node.line, "constraints", f"the constraints add {equations} equations but "
                    f"the joints leave only {free} free coordinates: the mechanism is "
                    "over-constrained (remove a constraint, or free a joint)")
    return tuple(found)


def _constraint(ctx: Context, name: str, node: Node, path: str) -> Constraint | None:
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a constraint mapping {{type, ...}}, "
                                     f"{described(node)}")
        return None
    entries = entries_of(node)
    type_node = entries.get("type")
    type_name = None if type_node is None else read_choice(
        ctx, type_node, join_path(path, "type"), tuple(CONSTRAINT_KINDS), "constraint type")
    kind = CONSTRAINT_KINDS.get(type_name) if type_name is not None else None
    all_keys = every_key(constraint_keys(k) for k in CONSTRAINT_KINDS.values())
    allowed = constraint_keys(kind) if kind is not None else all_keys
    owner = (f"a {kind.type} constraint" if kind is not None else "", all_keys)
    count = len(ctx.problems)
    check_keys(ctx, node, path, allowed, ("type", *(kind.required if kind else ())),
               owner=owner)
    fields = kind.read(Reader(ctx, node, path)) if kind is not None else None
    if kind is None or fields is None or len(ctx.problems) > count:
        return None
    return kind(name=name, loc=ctx.loc(node, path), **fields)
