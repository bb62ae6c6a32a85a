"""The prismatic joint: the child slides along an axis fixed in the parent.

    {type: prismatic, parent: P, child: C, at: POINT, coordinate: s, axis: [ax, ay],
     offset: EXPR}

Child origin at `at` + s * unit(axis), the axis in the parent's frame (default [1, 0]); child
angle = parent angle + offset. Its reaction has a couple (NAME.M); a joint_spring on it acts
by a force along the axis, which its reaction output leaves out.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..contract import Frame, SpatialSink
from ..spatial import V2, V3, add, rotation, scale, unit, vec
from .base import Joint, JointDrawing

if TYPE_CHECKING:
    from ..contract import Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class Prismatic(Joint):
    type: ClassVar[str] = "prismatic"
    keys: ClassVar[tuple[str, ...]] = ("at", "coordinate", "axis", "offset")
    coordinate_key: ClassVar[str | None] = "coordinate"
    coordinate_kinds: ClassVar[tuple[str, ...]] = ("length",)
    reaction_couple: ClassVar[bool] = True
    relative: ClassVar[bool] = True
    drivable: ClassVar[bool] = True

    axis: tuple[Expr, Expr] = (sympy.S.One, sympy.S.Zero)
    offset: Expr = sympy.S.Zero

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        return read.fields(at=read.parent_point("at"), axis=read.axis("axis"),
                           offset=read.fixed("offset", sympy.S.Zero))

    def place(self, parent: Frame, q: Sequence[Expr]) -> tuple[Expr, V2]:
        slide = scale(parent.rotate(unit(self.axis)), q[0])
        return parent.angle + self.offset, add(parent.point(self.at), slide)  # type: ignore

    def origin_velocity(self, parent: Frame, q: Sequence[Expr], u: Sequence[Expr]) -> V2:
        ux, uy = unit(self.axis)
        slide_point = (self.at[0] + ux * q[0], self.at[1] + uy * q[0])
        return add(parent.velocity(slide_point), scale(parent.rotate((ux, uy)), u[0]))  # type: ignore

    def motion_subspace(self, parent: Frame, child_origin: V2, parent_velocity: V3,
               u: Sequence[Expr]) -> tuple[list[V3], list[Expr]]:
        ax, ay = parent.names(parent.rotate(unit(self.axis)))
        return [(sympy.S.Zero, ax, ay)], [u[0]]

    def displacement(self, child_angle: Expr, parent_angle: Expr, q: Sequence[Expr]) -> Expr:
        return q[0]

    def displacement_rate(self, child_rate: Expr, parent_rate: Expr,
                          u: Sequence[Expr]) -> Expr:
        return u[0]

    def joint_load(self, sink: SpatialSink, parent: Frame, child_origin: V2,
                   tension: Expr) -> None:
        along = parent.names(parent.rotate(unit(self.axis)))
        sink.apply_at(self.child, child_origin, scale(along, tension))
        sink.apply_at(self.parent, child_origin, scale(along, -tension))

    def spring_force_on_child(self, parent_angle: Expr, tension: Expr) -> V2 | None:
        axis = rotation(parent_angle) * vec(self.axis)
        force = axis / sympy.sqrt(axis.dot(axis)) * tension
        return force[0], force[1]

    def friction_normal(self, parent_angle: Expr, force: Sequence[Expr]
                        ) -> tuple[Expr, Expr] | None:
        """The reaction's component across the axis (the guide's push on the slider)."""
        along = rotation(parent_angle) * vec(self.axis)
        across = sympy.Matrix([-along[1], along[0]]) / sympy.sqrt(along.dot(along))
        return vec(force).dot(across), sympy.S.Zero

    def drawing(self) -> JointDrawing:
        return JointDrawing("slider", self.axis)
