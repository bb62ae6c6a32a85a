"""What each joint carries: the masses and inertias its coordinates move, which must not all be
zero (format v3: a body's mass and inertia may be 0, a particle or a massless link, as long as
the mass matrix stays positive definite).

Each undriven joint moves the bodies of its subtree. A length coordinate needs mass there; an
angle coordinate needs mass or inertia there (about a pivot: mass away from it, which a run
checks where it matters: the articulated-body algorithm's and the mass matrix's pivots); a free
joint's angle, about the subtree's own center, needs inertia or a second body with mass. A
massless body at the end of a chain carries nothing: the file is refused naming it, and a run
whose parameters make it so is refused the same way (the derived checks, "joints.J").
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import sympy

from ..kinds.joints import Joint
from .context import Context
from .fields import default_value
from .mechanism import Body


@dataclass(frozen=True)
class Carried:
    """One thing a joint needs of its subtree: an expression of parameters that must be > 0."""

    joint: str
    body: str  # the joint's child: the subtree's root
    what: str  # "mass" or "mass or inertia" or "inertia"
    value: sympy.Expr

    @property
    def key(self) -> str:
        return f"joints.{self.joint} ({self.what} of body {self.body!r} and what it carries)"

    def message(self, shown: str) -> str:
        return (f"body {self.body!r} and what it carries have no {self.what} ({shown}): "
                f"joint {self.joint!r} would move nothing (its coordinates have no inertia: the "
                "mass matrix is singular); give the body a mass or an inertia, or weld it to "
                "one that has")


def carried(bodies: Mapping[str, Body], joints: Sequence[Joint]) -> Iterator[Carried]:
    """What every undriven joint with coordinates needs of the bodies it moves."""
    children: dict[str, list[str]] = {}
    for joint in joints:
        children.setdefault(joint.parent, []).append(joint.child)
    for joint in joints:
        if joint.driven or not joint.coordinate_kinds or joint.child not in bodies:
            continue
        moved = [bodies[name] for name in subtree(joint.child, children) if name in bodies]
        mass = sympy.Add(*(body.mass for body in moved))
        inertia = sympy.Add(*(body.inertia for body in moved))
        if "length" in joint.coordinate_kinds:
            yield Carried(joint.name, joint.child, "mass", mass)
            if "angle" in joint.coordinate_kinds and len(moved) == 1:  # a free joint's angle
                yield Carried(joint.name, joint.child, "inertia", inertia)
        else:
            yield Carried(joint.name, joint.child, "mass or inertia", mass + inertia)


def subtree(root: str, children: Mapping[str, list[str]]) -> list[str]:
    """ROOT and the bodies below it, each once (a cycle of joints, refused elsewhere with its
    line, is walked once round: it looped here, its memory growing without end)."""
    found, pending, seen = [], [root], {root}
    while pending:
        body = pending.pop()
        found.append(body)
        below = [child for child in children.get(body, ()) if child not in seen]
        seen.update(below)
        pending.extend(below)
    return found


def check_carried(ctx: Context) -> None:
    """Refuse a joint whose bodies have nothing for its coordinates to move, at the defaults,
    naming its child body."""
    for need in carried(ctx.bodies, tuple(ctx.joints.values())):
        if not need.value.free_symbols <= ctx.defaults.keys():
            continue  # a value without a default, reported already
        value = default_value(ctx, need.value)
        if value is not None and value <= 0:
            body = ctx.bodies[need.body]
            ctx.problem(body.loc.line, body.loc.key,
                        need.message(f"{value:g} at the default parameter values"))
