"""The revolute joint: the child turns about a point of the parent.

    {type: revolute, parent: P, child: C, at: POINT, coordinate: q,
     angle: relative | absolute, offset: EXPR}

Child origin at `at`. `angle: relative` (default): child angle = parent angle + q + offset;
`angle: absolute`: child angle = q + offset (the book's q2 in 5.2 and 5.4), which moves like a
relative joint with the joint rate dot(q) - omega_parent, and whose coordinate's acceleration is
the child's angular acceleration.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import sympy

from ..contract import Frame, SpatialSink
from ..spatial import V2, V3, couple
from ..terms import GROUND
from .base import Joint

if TYPE_CHECKING:
    from ..contract import Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class Revolute(Joint):
    type: ClassVar[str] = "revolute"
    keys: ClassVar[tuple[str, ...]] = ("at", "coordinate", "angle", "offset")
    coordinate_key: ClassVar[str | None] = "coordinate"
    coordinate_kinds: ClassVar[tuple[str, ...]] = ("angle",)
    relative: ClassVar[bool] = True
    drivable: ClassVar[bool] = True
    friction_lever: ClassVar[bool] = True

    angle: Literal["relative", "absolute"] = "relative"
    offset: Expr = sympy.S.Zero

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        return read.fields(at=read.parent_point("at"),
                           angle=read.choice("angle", ("relative", "absolute"), "relative"),
                           offset=read.fixed("offset", sympy.S.Zero))

    @property
    def absolute(self) -> bool:
        return self.angle == "absolute"

    def drive_problem(self) -> str | None:
        if self.absolute and self.parent != GROUND:
            return ("a driven revolute joint with angle: absolute needs the ground as its "
                    "parent (its joint rate would follow the parent's motion); drive its "
                    "relative angle (angle: relative) instead")
        return None

    def place(self, parent: Frame, q: Sequence[Expr]) -> tuple[Expr, V2]:
        base = sympy.S.Zero if self.absolute else parent.angle
        return base + q[0] + self.offset, parent.point(self.at)

    def origin_velocity(self, parent: Frame, q: Sequence[Expr], u: Sequence[Expr]) -> V2:
        return parent.velocity(self.at)

    def motion_subspace(self, parent: Frame, child_origin: V2, parent_velocity: V3,
               u: Sequence[Expr]) -> tuple[list[V3], list[Expr]]:
        px, py = child_origin
        rate = parent.name(u[0] - parent_velocity[0]) if self.absolute else u[0]
        return [(sympy.S.One, py, -px)], [rate]

    def coordinate_accelerations(self, joint_accelerations: Sequence[Expr],
                                 acceleration: V3) -> list[Expr]:
        return [acceleration[0]] if self.absolute else list(joint_accelerations)

    def displacement(self, child_angle: Expr, parent_angle: Expr, q: Sequence[Expr]) -> Expr:
        return child_angle - parent_angle - self.offset

    def displacement_rate(self, child_rate: Expr, parent_rate: Expr,
                          u: Sequence[Expr]) -> Expr:
        return child_rate - parent_rate

    def joint_load(self, sink: SpatialSink, parent: Frame, child_origin: V2,
                   tension: Expr) -> None:
        sink.apply(self.child, couple(tension))
        sink.apply(self.parent, couple(-tension))

    def generalized_load(self, sink: SpatialSink, parent: Frame, child_origin: V2,
                         forces: Sequence[Expr]) -> None:
        if self.absolute:  # the coordinate is the child's angle: a couple on it alone
            sink.apply(self.child, couple(forces[0]))
        else:
            self.joint_load(sink, parent, child_origin, forces[0])

    def friction_normal(self, parent_angle: Expr, force: Sequence[Expr]
                        ) -> tuple[Expr, Expr] | None:
        """The whole reaction force (pin friction: mu * radius * its magnitude); none on an
        absolute angle, whose rate is not the joint's own."""
        return None if self.absolute else (force[0], force[1])
