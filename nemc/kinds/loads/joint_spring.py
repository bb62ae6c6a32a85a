"""A spring and damper on a joint's relative displacement (the kinds with one: revolute angle,
prismatic slide).

    - joint_spring: {joint: JOINT, k: EXPR, rest: EXPR, damping: EXPR}

Torque or force tension = -k (displacement - rest) - damping d(displacement)/dt on the child,
the opposite on the parent; its elastic part has potential energy k (displacement - rest)^2 / 2.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..joints import JOINT_KINDS
from ..terms import Loc
from .base import Load, LoadDrawing

if TYPE_CHECKING:
    from ..contract import KinematicsView, LoadSink, LoadView, Reader

Expr = sympy.Expr


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

    def act(self, view: LoadView, sink: LoadSink) -> None:
        joint = view.joint(self.joint)
        parent, child = view.frame(joint.parent), view.frame(joint.child)
        displacement = joint.displacement(child.angle, parent.angle,
                                          [view.coordinate(c) for c in joint.coordinates])
        rate = joint.displacement_rate(view.angular_velocity(joint.child),
                                       view.angular_velocity(joint.parent),
                                       [view.speed(c) for c in joint.coordinates])
        tension = -self.k * (displacement - self.rest)
        sink.tension(joint, displacement, parent.name(tension - self.damping * rate))

    def potential(self, kin: KinematicsView) -> sympy.Expr:
        joint = kin.joint(self.joint)
        displacement = joint.displacement(kin.angle(joint.child), kin.angle(joint.parent),
                                          [kin.coordinate(c) for c in joint.coordinates])
        return self.k * (displacement - self.rest) ** 2 / 2

    def reported(self, kin: KinematicsView, rate: Callable[[Expr], Expr]
                 ) -> list[tuple[str, Expr]]:
        """Its torque or force on the child, NAME.tension: -k (displacement - rest) - damping
        d(displacement)/dt."""
        joint = kin.joint(self.joint)
        displacement = joint.displacement(kin.angle(joint.child), kin.angle(joint.parent),
                                          [kin.coordinate(c) for c in joint.coordinates])
        return [(".tension", -self.k * (displacement - self.rest)
                 - self.damping * rate(displacement))]

    def reported_kinds(self, coordinate_kind: Callable[[str], str]) -> list[tuple[str, str]]:
        return [(".tension", "couple" if coordinate_kind(self.joint) == "angle"
                 else "joint force")]

    def drawing(self) -> LoadDrawing:
        return LoadDrawing(on_joint=self.joint)
