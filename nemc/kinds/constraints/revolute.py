"""The revolute constraint: point a of one body and point b of another coincide.

    NAME: {type: revolute, a: BODY.POINT, b: {body: BODY, at: [x, y]}}

Two equations, p_a - p_b = 0 (ground axes); its multipliers are the force of body(b) on body(a)
at the common point, ground axes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import sympy

from ..contract import Frame
from ..spatial import V2
from .base import PointPair


@dataclass(frozen=True)
class RevoluteConstraint(PointPair):
    type: ClassVar[str] = "revolute"
    keys: ClassVar[tuple[str, ...]] = ("a", "b")
    equations_count: ClassVar[int] = 2

    def between(self, a: Frame, b: Frame) -> list[sympy.Expr]:
        pa, pb = a.point(self.a.xy), b.point(self.b.xy)
        return [pa[0] - pb[0], pa[1] - pb[1]]

    def force(self, a: Frame, b: Frame, multipliers: list[sympy.Expr]
              ) -> tuple[V2, sympy.Expr]:
        return (multipliers[0], multipliers[1]), sympy.S.Zero
