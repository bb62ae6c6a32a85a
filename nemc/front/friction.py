"""The `friction` list (format v3): Coulomb friction on joints, each item read by the kind
(nemc/kinds/friction.py), then what the first implementation does not take refused by name.
"""

from __future__ import annotations

import sympy

from ..kinds.friction import KEYS, Friction
from .context import Context, check_keys, described, entries_of, items_of, join_path
from .fields import default_value, has_defaults
from .parse import Node
from .reader import Reader


def read_friction(ctx: Context, node: Node) -> tuple[Friction, ...]:
    """The friction items, one per joint."""
    if not node.is_list or not items_of(node):
        ctx.problem(node.line, "friction", "expected a list of friction items "
                    f"{{joint, mu, mu_static, radius}} or {{joint, torque}}, {described(node)}")
        return ()
    found: list[Friction] = []
    for i, item in enumerate(items_of(node)):
        path = join_path("friction", i)
        if item.is_map and "constraint" in entries_of(item):
            ctx.problem(item.line, join_path(path, "constraint"), "friction on a constraint (a "
                        "loop's slot or prismatic pair) is not supported yet: make the sliding "
                        "pair a prismatic joint of the tree and close the loop with a revolute "
                        "constraint (as examples/slider_crank_friction.yaml does)")
            continue
        if not check_keys(ctx, item, path, KEYS, ("joint",),
                          what="a friction mapping {joint, mu, mu_static, radius}"):
            continue
        count = len(ctx.problems)
        fields = Friction.read(Reader(ctx, item, path))
        if fields is None or len(ctx.problems) > count:
            continue
        friction = Friction(loc=ctx.loc(item, path), **fields)
        if _usable(ctx, friction, item, path, found):
            found.append(friction)
    return tuple(found)


def _usable(ctx: Context, friction: Friction, node: Node, path: str,
            found: list[Friction]) -> bool:
    """Whether the item's joint can carry it (the kind and the joint say), one item a joint,
    mu_static >= mu at the defaults."""
    name = friction.on_joint
    joint = ctx.joints.get(name)
    if joint is None:
        return False
    zero = sympy.S.Zero
    refused = friction.refusal(joint.driven, joint.friction_normal(zero, (zero, zero))
                               is not None, joint.friction_lever)
    if any(other.symbol == friction.symbol for other in found):
        refused = ("joint", f"joint {name!r} already has a friction item")
    elif refused is None and _static_below_kinetic(ctx, friction):
        refused = ("mu_static", "mu_static must be >= mu (the static coefficient limits the "
                   "holding force)")
    if refused is not None:
        ctx.problem(node.line, join_path(path, refused[0]) if refused[0] else path, refused[1])
    return refused is None


def _static_below_kinetic(ctx: Context, friction: Friction) -> bool:
    """Whether mu_static < mu at the default parameter values."""
    difference = friction.static_excess
    if not has_defaults(ctx, difference):
        return False
    value = default_value(ctx, difference)
    return value is not None and value < 0
