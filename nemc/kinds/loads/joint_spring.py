"""A spring and damper on a joint's relative displacement (the kinds with one: revolute angle,
prismatic slide).

    - joint_spring: {joint: JOINT, k: EXPR, rest: EXPR, damping: EXPR}

Torque or force tension = -k (displacement - rest) - damping d(displacement)/dt on the child,
the opposite on the parent; its elastic part has potential energy k (displacement - rest)^2 / 2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..contract import ArticulatedLoads
from ..joints import JOINT_KINDS
from ..spatial import V2
from ..terms import Loc
from .base import Applied, Load

if TYPE_CHECKING:
    from ..contract import KinematicsView, Reader
    from ..joints import Joint


@dataclass(frozen=True)
class JointSpring(Load):
    kind: ClassVar[str] = "joint_spring"
    keys: ClassVar[tuple[str, ...]] = ("joint_spring",)

    joint: str
    k: sympy.Expr
    rest: sympy.Expr
    damping: sympy.Expr
    loc: Loc

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        inner = read.mapping("joint_spring", ("joint", "k", "rest", "damping"), ("joint", "k"))
        if inner is None:
            return None
        springy = " or ".join(kind.type for kind in JOINT_KINDS.values() if kind.relative)
        joint = inner.joint("joint", lambda kind: kind.relative,
                            f"a joint_spring needs a {springy} joint")
        return inner.fields(joint=joint, k=inner.expr("k"),
                            rest=inner.expr("rest", sympy.S.Zero),
                            damping=inner.expr("damping", sympy.S.Zero), loc=inner.location)

    def expressions(self) -> list[tuple[str, sympy.Expr]]:
        return [(key, getattr(self, key)) for key in ("k", "rest", "damping")]

    def tension(self, displacement: sympy.Expr, rate: sympy.Expr) -> sympy.Expr:
        return -self.k * (displacement - self.rest) - self.damping * rate

    def act(self, aba: ArticulatedLoads) -> None:
        joint = aba.joint(self.joint)
        parent, child = aba.frame(joint.parent), aba.frame(joint.child)
        q = [aba.coordinate(c) for c in joint.coordinates]
        u = [aba.speed(c) for c in joint.coordinates]
        displacement = joint.displacement(child.angle, parent.angle, q)
        rate = joint.displacement_rate(aba.velocity(joint.child)[0],
                                       aba.velocity(joint.parent)[0], u)
        tension = -self.k * (displacement - self.rest)
        tension = parent.name(tension - self.damping * rate)
        joint.joint_load(aba, parent, child.origin, tension)

    def displacement(self, kin: KinematicsView, joint: Joint) -> sympy.Expr:
        return joint.displacement(kin.angle(joint.child), kin.angle(joint.parent),
                                  [kin.coordinate(c) for c in joint.coordinates])

    def applied(self, kin: KinematicsView) -> Applied:
        rel = self.displacement(kin, kin.joint(self.joint))
        return Applied(generalized=[(rel, self.tension(rel, kin.rate(rel)))])

    def force_through_joint(self, kin: KinematicsView, joint: Joint) -> V2 | None:
        if joint.name != self.joint:
            return None
        rel = self.displacement(kin, joint)
        return joint.spring_force_on_child(kin.angle(joint.parent),
                                           self.tension(rel, kin.rate(rel)))

    def potential(self, kin: KinematicsView) -> sympy.Expr:
        rel = self.displacement(kin, kin.joint(self.joint))
        return self.k * (rel - self.rest) ** 2 / 2
