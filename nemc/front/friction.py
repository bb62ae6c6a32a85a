"""The `friction` list (format v3): Coulomb friction on joints and along slot or prismatic
constraints, each item read by its kind (nemc/kinds/friction.py, guide_friction.py), then what
the implementation does not take refused by name.
"""

from __future__ import annotations

import sympy

from ..kinds.constraints import Constraint
from ..kinds.friction import KEYS, Friction
from ..kinds.guide_friction import KEYS as GUIDE_KEYS
from ..kinds.guide_friction import GuideFriction, guide_friction_symbol
from ..kinds.guide_friction import read_fields as read_guide
from ..kinds.loads.base import Load
from .context import Context, check_keys, described, entries_of, items_of, join_path
from .fields import default_value, has_defaults, read_string
from .parse import Node
from .reader import Reader


def read_friction(ctx: Context, node: Node, constraints: tuple[Constraint, ...] = ()
                  ) -> tuple[Load, ...]:
    """The friction items, one per joint or constraint (CONSTRAINTS: the file's)."""
    if not node.is_list or not items_of(node):
        ctx.problem(node.line, "friction", "expected a list of friction items "
                    f"{{joint, mu, mu_static, radius}} or {{joint, torque}}, {described(node)}")
        return ()
    found: list[Load] = []
    for i, item in enumerate(items_of(node)):
        path = join_path("friction", i)
        if item.is_map and "constraint" in entries_of(item):
            guide = _guide_friction(ctx, item, path, constraints, found)
            if guide is not None:
                found.append(guide)
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


def _guide_friction(ctx: Context, node: Node, path: str, constraints: tuple[Constraint, ...],
                    found: list[Load]) -> GuideFriction | None:
    """An item `{constraint: NAME, mu, mu_static}`: friction along a slot or prismatic
    constraint, refused at its line where that constraint has no sliding direction or already
    has an item, or mu_static < mu."""
    if not check_keys(ctx, node, path, GUIDE_KEYS, ("constraint",),
                      what="a friction mapping {constraint, mu, mu_static}"):
        return None
    read = Reader(ctx, node, path)
    name = read_string(ctx, entries_of(node)["constraint"], join_path(path, "constraint"),
                       "a constraint's name")
    named = {constraint.name: constraint for constraint in constraints}
    constraint = named.get(name) if name is not None else None
    key = join_path(path, "constraint")
    if name is not None and constraint is None:
        ctx.problem(node.line, key, f"no constraint named {name!r} (constraints: "
                    f"{', '.join(sorted(named)) or 'none'})")
    elif constraint is not None and not constraint.slides:
        ctx.problem(node.line, key, f"constraint {name!r} has no sliding direction: friction "
                    "on a constraint needs a slot or prismatic constraint (for pin friction "
                    "make the pin a revolute joint of the tree, with `radius`)")
        constraint = None
    elif any(getattr(other, "symbol", None) == guide_friction_symbol(name or "")
             for other in found):
        ctx.problem(node.line, key, f"constraint {name!r} already has a friction item")
        constraint = None
    count = len(ctx.problems)
    fields = read_guide(read, constraint)
    if fields is None or len(ctx.problems) > count:
        return None
    friction = GuideFriction(constraint=name or "", loc=ctx.loc(node, path), **fields)
    if _static_below_kinetic(ctx, friction):
        ctx.problem(node.line, join_path(path, "mu_static"), "mu_static must be >= mu (the "
                    "static coefficient limits the holding force)")
        return None
    return friction


def _usable(ctx: Context, friction: Friction, node: Node, path: str,
            found: list[Load]) -> bool:
    """Whether the item's joint can carry it (the kind and the joint say), one item a joint,
    mu_static >= mu at the defaults."""
    name = friction.on_joint
    joint = ctx.joints.get(name)
    if joint is None:
        return False
    zero = sympy.S.Zero
    refused = friction.refusal(joint.driven, joint.friction_normal(zero, (zero, zero))
                               is not None, joint.friction_lever)
    if any(getattr(other, "symbol", None) == friction.symbol for other in found):
        refused = ("joint", f"joint {name!r} already has a friction item")
    elif refused is None and _static_below_kinetic(ctx, friction):
        refused = ("mu_static", "mu_static must be >= mu (the static coefficient limits the "
                   "holding force)")
    if refused is not None:
        ctx.problem(node.line, join_path(path, refused[0]) if refused[0] else path, refused[1])
    return refused is None


def _static_below_kinetic(ctx: Context, friction: Friction | GuideFriction) -> bool:
    """Whether mu_static < mu at the default parameter values."""
    difference = friction.static_excess
    if not has_defaults(ctx, difference):
        return False
    value = default_value(ctx, difference)
    return value is not None and value < 0


def check_guides_without_contacts(ctx: Context, frictions: tuple[Load, ...],
                                  contacts: tuple[Load, ...]) -> None:
    """Refuse friction along a constraint together with contacts, at the friction item's line:
    an impact's impulses are solved with the joints' friction (Coulomb's law in the impulse),
    not yet with a guide's."""
    if not contacts:
        return
    for guide in (f for f in frictions if isinstance(f, GuideFriction)):
        ctx.problem(guide.loc.line, guide.loc.key, "friction along a constraint together with "
                    "`contacts` is not built yet (an impact's impulses take the joints' "
                    "friction, not a guide's): make the sliding pair a prismatic joint of the "
                    "tree with `friction`, closing the loop with a revolute constraint")

