"""Coulomb friction on a joint that sticks and slips (format v3, the top-level `friction` list).

    friction:
      - {joint: slide, mu: 0.3, mu_static: 0.4}              # normal force: the joint's reaction
      - {joint: A, mu: 0.1, mu_static: 0.15, radius: r_pin}  # pin friction: mu*radius*|reaction|
      - {joint: B, torque: T_c}                              # a given Coulomb torque (or force)

An item acts as a load: a tension across its joint (a force along a prismatic joint's axis, a
couple across a revolute joint), whose value is the friction force F, a runtime unknown
(`friction_symbol`) that the generated C solves at every state together with the
accelerations (templates/friction.c.tmpl; decision 0039). What the solver needs of the item
is `terms`: mu, mu_static and the normal force's components, whose magnitude sets the limit:

    slipping (dot(q) != 0):  F = -sign(dot(q)) * mu * |N|
    stuck    (dot(q) == 0):  F holds the joint (its acceleration 0) while |F| <= mu_static * |N|

N is the reaction's component across a prismatic joint's axis; radius times the reaction
force for pin friction on a revolute joint; the given Coulomb force or torque itself (with
mu = mu_static = 1) for `torque:` / `force:`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from .loads.base import Load
from .terms import Loc, symbol

if TYPE_CHECKING:
    from .contract import KinematicsView, LoadSink, LoadView, Reader

Expr = sympy.Expr
KEYS = ("joint", "mu", "mu_static", "radius", "torque", "force")


def friction_symbol(joint: str) -> sympy.Symbol:
    """The friction force (or torque) across JOINT: solved in C at every state."""
    return symbol(f"friction({joint})")


@dataclass(frozen=True)
class Friction(Load):
    """Coulomb friction across one joint (a load: nemc/kinds/loads/base.py's questions)."""

    kind: ClassVar[str] = "friction"
    keys: ClassVar[tuple[str, ...]] = KEYS

    joint: str
    mu: Expr  # kinetic coefficient (1 with a given Coulomb force)
    mu_static: Expr  # static coefficient (default mu)
    radius: Expr | None  # pin friction's radius (revolute joints)
    given: Expr | None  # a given Coulomb force or torque (`torque:` or `force:`)
    loc: Loc

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        joint = read.joint("joint", lambda kind: kind.relative,
                           "friction needs a joint with a relative coordinate (revolute or "
                           "prismatic)")
        given_keys = [key for key in ("torque", "force") if read.has(key)]
        if len(given_keys) > 1:
            read.problem("force", "a friction item has `torque` or `force`, not both")
            return None
        if given_keys:
            for key in ("mu", "mu_static", "radius"):
                if read.has(key):
                    read.problem(key, f"a given Coulomb {given_keys[0]} has no `{key}`")
            fields = read.fields(joint=joint, mu=sympy.S.One, mu_static=sympy.S.One,
                                 given=read.fixed(given_keys[0], sympy.S.One, positive=True))
            return None if fields is None else {**fields, "radius": None}
        if not read.has("mu"):
            read.problem("mu", "a friction item needs `mu` (or a given `torque` or `force`)")
            return None
        mu = read.fixed("mu", sympy.S.One, positive=True)
        mu_static = read.fixed("mu_static", mu if mu is not None else sympy.S.One,
                               positive=True)
        radius = read.fixed("radius", sympy.S.One, positive=True) if read.has("radius") \
            else None
        fields = read.fields(joint=joint, mu=mu, mu_static=mu_static)
        if fields is None or (read.has("radius") and radius is None):
            return None
        return {**fields, "radius": radius, "given": None}

    @property
    def on_joint(self) -> str:
        """The name of the joint it acts across."""
        return self.joint

    @property
    def symbol(self) -> sympy.Symbol:
        return friction_symbol(self.joint)

    def expressions(self) -> list[tuple[str, Expr]]:
        found = [("mu", self.mu), ("mu_static", self.mu_static)]
        found += [(key, value) for key, value in (("radius", self.radius),
                                                  ("torque", self.given)) if value is not None]
        return found

    def act(self, view: LoadView, sink: LoadSink) -> None:
        """The friction force F across the joint: on the child, the opposite on the parent."""
        joint = view.joint(self.joint)
        parent, child = view.frame(joint.parent), view.frame(joint.child)
        displacement = joint.displacement(child.angle, parent.angle,
                                          [view.coordinate(c) for c in joint.coordinates])
        sink.tension(joint, displacement, self.symbol)

    def checks(self) -> list[tuple[str, Expr, bool]]:
        """(key, expression, strict) of what must hold at every run's parameters: mu > 0 and
        mu_static >= mu."""
        if self.given is not None:
            return [("torque", self.given, True)]
        found = [("mu", self.mu, True), ("mu_static - mu", self.mu_static - self.mu, False)]
        if self.radius is not None:
            found.append(("radius", self.radius, True))
        return found

    def terms(self, normal: Sequence[Expr], lever: bool) -> tuple[Expr, Expr, Expr, Expr]:
        """mu, mu_static and the normal force's two components (its magnitude is what mu
        multiplies): NORMAL, what the joint says its friction takes from its reaction
        (Joint.friction_normal), times the radius where LEVER (pin friction's couple)."""
        if self.given is not None:
            return (sympy.S.One, sympy.S.One, self.given, sympy.S.Zero)
        scale = self.radius if lever and self.radius is not None else sympy.S.One
        return (self.mu, self.mu_static, scale * normal[0], scale * normal[1])

    def refusal(self, driven: bool, takes_friction: bool, lever: bool) -> tuple[str, str] | None:
        """(key, why) the joint cannot carry this item: DRIVEN (its motion prescribed),
        not TAKES_FRICTION (Joint.friction_normal gives none), a LEVER without a radius."""
        if driven:
            return ("joint", f"joint {self.joint!r} is driven (motion:): its drive already "
                    "holds it, friction would only add to the drive's torque")
        if not takes_friction:
            return ("joint", f"joint {self.joint!r} has an absolute angle: friction needs the "
                    "joint's own rate (angle: relative)")
        if lever and self.given is None and self.radius is None:
            return ("", "pin friction on a revolute joint needs `radius` (the torque is "
                    "mu * radius * |reaction|), or give the Coulomb torque as `torque:`")
        return None

    @property
    def static_excess(self) -> Expr:
        """mu_static - mu, which must not be negative."""
        return self.mu_static - self.mu

    def reported(self, kin: KinematicsView, rate: Callable[[Expr], Expr]
                 ) -> list[tuple[str, Expr]]:
        """NAME.friction: the friction force or torque on the child."""
        return [(".friction", self.symbol)]

    def reported_kinds(self, coordinate_kind: Callable[[str], str]) -> list[tuple[str, str]]:
        return [(".friction", "couple" if coordinate_kind(self.joint) == "angle"
                 else "joint force")]
