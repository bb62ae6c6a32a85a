"""The knife edge: a point of a body cannot move across a direction fixed in that body (a skate,
a sleigh's runner, a wheel that cannot skid sideways).

    NAME: {type: knife_edge, at: BODY.POINT, axis: [ax, ay]}

One equation, on the velocities: n . v_at = 0, n the axis turned +90 degrees (ground axes), v_at
the velocity of point `at` (written like a spring's end: BODY.POINT or {body: BODY, at: [x, y]}).
Nonholonomic: it removes a degree of freedom of motion, not of position (the state keeps every
coordinate). Its multiplier is the force across the blade, lambda n at the point (NAME.Fn; in
ground axes NAME.Fx, NAME.Fy), which does no work.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..spatial import V2, unit
from ..terms import PointRef
from .base import Constraint, ConstraintDrawing, Named

if TYPE_CHECKING:
    from ..contract import Frame, LoadSink, LoadView, Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class KnifeEdge(Constraint):
    type: ClassVar[str] = "knife_edge"
    keys: ClassVar[tuple[str, ...]] = ("at", "axis")
    required: ClassVar[tuple[str, ...]] = ("at",)
    equations_count: ClassVar[int] = 1

    at: PointRef
    axis: tuple[Expr, Expr] = (sympy.S.One, sympy.S.Zero)  # in the body's frame

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        at = read.point_ref("at")
        if at is not None and at.body == "ground":
            read.problem("at", "a knife edge is a point of a moving body, not of the ground")
            return None
        return read.fields(at=at, axis=read.axis("axis"))

    def on_velocities(self) -> tuple[int, ...]:
        return (0,)

    def across(self, frame: Frame) -> V2:
        """The direction the point cannot move in: the axis turned +90 degrees, ground axes."""
        ux, uy = unit(self.axis)
        return frame.rotate((-uy, ux))

    def equations(self, view: LoadView) -> list[Expr]:
        frame = view.frame(self.at.body)
        n, v = self.across(frame), frame.velocity(self.at.xy)
        return [n[0] * v[0] + n[1] * v[1]]

    def act(self, view: LoadView, sink: LoadSink, multipliers: list[Expr]) -> None:
        frame = view.frame(self.at.body)
        n = self.across(frame)
        sink.force(self.at.body, self.at.xy, (multipliers[0] * n[0], multipliers[0] * n[1]))

    def drawing(self) -> ConstraintDrawing:
        return ConstraintDrawing(blades=((self.at.body, self.at.xy, self.axis),))

    def reaction(self, view: LoadView, multipliers: list[Expr]) -> Named:
        n = self.across(view.frame(self.at.body))
        return [("Fx", multipliers[0] * n[0]), ("Fy", multipliers[0] * n[1]),
                ("Fn", multipliers[0])]
