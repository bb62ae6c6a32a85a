"""A couple on a body, and the opposite couple on another (default: the ground).

    - torque: EXPR       # of t, coordinates, rates, parameters
      body: BODY
      reaction: BODY     # default ground
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..terms import GROUND, Loc
from .base import Load

if TYPE_CHECKING:
    from ..contract import KinematicsView, LoadSink, LoadView, Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class Torque(Load):
    kind: ClassVar[str] = "torque"
    keys: ClassVar[tuple[str, ...]] = ("torque", "body", "reaction")
    required: ClassVar[tuple[str, ...]] = ("body",)

    expr: sympy.Expr
    body: str
    reaction: str
    loc: Loc

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        body = read.body("body", ground=False)
        reaction = read.body("reaction", ground=True, default=GROUND)
        if reaction is not None and reaction == body:
            read.problem("reaction", f"reaction must differ from body, got {body!r} for both")
            reaction = None
        return read.fields(expr=read.expr("torque"), body=body, reaction=reaction)

    def expressions(self) -> list[tuple[str, sympy.Expr]]:
        return [("torque", self.expr)]

    def reported(self, kin: KinematicsView, rate: Callable[[Expr], Expr]
                 ) -> list[tuple[str, Expr]]:
        """The torque on the body, NAME."""
        return [("", self.expr)]

    def reported_kinds(self, coordinate_kind: Callable[[str], str]) -> list[tuple[str, str]]:
        return [("", "couple")]

    def act(self, view: LoadView, sink: LoadSink) -> None:
        torque = view.frame(self.body).name(self.expr)
        sink.couple(self.body, torque)
        sink.couple(self.reaction, -torque)
