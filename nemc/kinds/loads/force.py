"""A force on a point of a body, its components in the ground's or the body's frame.

    - force: [EXPR, EXPR]
      body: BODY
      at: POINT          # a point of the body; default com; [x, y] may move on the body
      frame: ground      # or body

A moving point's body-frame place [x(q, t), y(q, t)] (a sliding contact, a cam's follower)
says where the force acts now: it acts on the body's material point there, so it does virtual
work through that material point's displacement, never through the point's sliding along the
body (every derivation takes the point's velocity as the body's at xy, xy held).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import sympy

from ..spatial import rotation, vec
from ..terms import Loc, Vec2
from .base import Load

if TYPE_CHECKING:
    from ..contract import KinematicsView, LoadSink, LoadView, Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class Force(Load):
    kind: ClassVar[str] = "force"
    keys: ClassVar[tuple[str, ...]] = ("force", "body", "at", "frame")
    required: ClassVar[tuple[str, ...]] = ("body",)

    components: Vec2
    body: str
    at: Vec2  # point of application in the body frame (default: com), maybe of q and t
    frame: Literal["ground", "body"]
    loc: Loc

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        body = read.body("body", ground=False)
        return read.fields(components=read.vec2("force"), body=body,
                           at=read.body_point("at", body, moving=True), frame=read.choice(
                               "frame", ("ground", "body"), "ground"))

    def expressions(self) -> list[tuple[str, object]]:
        return [*((f"force[{i}]", c) for i, c in enumerate(self.components)),
                *((f"at[{i}]", c) for i, c in enumerate(self.at))]

    def reported(self, kin: KinematicsView, rate: Callable[[Expr], Expr]
                 ) -> list[tuple[str, Expr]]:
        """The force on the body in ground axes, NAME.Fx and NAME.Fy (a body-frame force
        turned with its body)."""
        force = (rotation(kin.angle(self.body)) * vec(self.components) if self.frame == "body"
                 else vec(self.components))
        return [(".Fx", force[0]), (".Fy", force[1])]

    def reported_kinds(self, coordinate_kind: Callable[[str], str]) -> list[tuple[str, str]]:
        return [(".Fx", "joint force"), (".Fy", "joint force")]

    def act(self, view: LoadView, sink: LoadSink) -> None:
        frame = view.frame(self.body)
        force = frame.rotate(self.components) if self.frame == "body" else self.components
        sink.force(self.body, self.at, frame.names(force))
