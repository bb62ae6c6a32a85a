"""A force on a point of a body, its components in the ground's or the body's frame.

    - force: [EXPR, EXPR]
      body: BODY
      at: POINT          # a point of the body; default com
      frame: ground      # or body
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal

from ..terms import Loc, Vec2
from .base import Load

if TYPE_CHECKING:
    from ..contract import LoadSink, LoadView, Reader


@dataclass(frozen=True)
class Force(Load):
    kind: ClassVar[str] = "force"
    keys: ClassVar[tuple[str, ...]] = ("force", "body", "at", "frame")
    required: ClassVar[tuple[str, ...]] = ("body",)

    components: Vec2
    body: str
    at: Vec2  # point of application in the body frame (default: com)
    frame: Literal["ground", "body"]
    loc: Loc

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        body = read.body("body", ground=False)
        return read.fields(components=read.vec2("force"), body=body,
                           at=read.body_point("at", body), frame=read.choice(
                               "frame", ("ground", "body"), "ground"))

    def expressions(self) -> list[tuple[str, object]]:
        return [(f"force[{i}]", c) for i, c in enumerate(self.components)]

    def act(self, view: LoadView, sink: LoadSink) -> None:
        frame = view.frame(self.body)
        force = frame.rotate(self.components) if self.frame == "body" else self.components
        sink.force(self.body, self.at, frame.names(force))
