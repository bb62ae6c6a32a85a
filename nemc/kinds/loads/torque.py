"""A couple on a body, and the opposite couple on another (default: the ground).

    - torque: EXPR       # of t, coordinates, rates, parameters
      body: BODY
      reaction: BODY     # default ground
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..contract import ArticulatedLoads
from ..spatial import couple
from ..terms import GROUND, Loc
from .base import Applied, Load

if TYPE_CHECKING:
    from ..contract import KinematicsView, Reader


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

    def act(self, aba: ArticulatedLoads) -> None:
        torque = aba.frame(self.body).name(self.expr)
        aba.apply(self.body, couple(torque))
        aba.apply(self.reaction, couple(-torque))

    def applied(self, kin: KinematicsView) -> Applied:
        return Applied(couples=[(self.body, self.expr), (self.reaction, -self.expr)])
