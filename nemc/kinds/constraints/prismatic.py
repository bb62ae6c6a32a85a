"""The prismatic constraint: a slot that also holds the bodies' relative angle.

    NAME: {type: prismatic, a: BODY.POINT, b: {body: BODY, at: [x, y]}, axis: [ax, ay],
           offset: EXPR}

Two equations: the slot's n . (p_a - p_b) = 0, and angle(a) - angle(b) - offset = 0. Its
multipliers: the normal force lambda_1 n and the couple lambda_2 of body(b) on body(a).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..contract import Frame
from ..spatial import V2
from .slot import Slot

if TYPE_CHECKING:
    from ..contract import Reader


@dataclass(frozen=True)
class PrismaticConstraint(Slot):
    type: ClassVar[str] = "prismatic"
    keys: ClassVar[tuple[str, ...]] = ("a", "b", "axis", "offset")
    equations_count: ClassVar[int] = 2
    reaction_couple: ClassVar[bool] = True

    offset: sympy.Expr = sympy.S.Zero

    @classmethod
    def read_own(cls, read: Reader) -> dict[str, Any] | None:
        return {"axis": read.axis("axis"), "offset": read.fixed("offset", sympy.S.Zero)}

    def between(self, a: Frame, b: Frame) -> list[sympy.Expr]:
        return [*super().between(a, b), a.angle - b.angle - self.offset]

    def force(self, a: Frame, b: Frame, multipliers: list[sympy.Expr]
              ) -> tuple[V2, sympy.Expr]:
        force, _ = super().force(a, b, multipliers[:1])
        return force, multipliers[1]
