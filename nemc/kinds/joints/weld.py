"""The weld joint: the child is fixed to the parent.

    {type: weld, parent: P, child: C, at: POINT, offset: EXPR}

Child origin at `at`, child angle = parent angle + offset. No coordinate: the articulated-body
algorithm merges the child into its parent's body. Its reaction has a couple (NAME.M).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..contract import Frame
from ..spatial import V2
from .base import Joint, JointDrawing

if TYPE_CHECKING:
    from ..contract import Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class Weld(Joint):
    type: ClassVar[str] = "weld"
    keys: ClassVar[tuple[str, ...]] = ("at", "offset")
    merged: ClassVar[bool] = True
    reaction_couple: ClassVar[bool] = True

    offset: Expr = sympy.S.Zero

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        return read.fields(at=read.parent_point("at"), offset=read.fixed("offset", sympy.S.Zero))

    def place(self, parent: Frame, q: Sequence[Expr]) -> tuple[Expr, V2]:
        return parent.angle + self.offset, parent.point(self.at)

    def origin_velocity(self, parent: Frame, q: Sequence[Expr], u: Sequence[Expr]) -> V2:
        return parent.velocity(self.at)

    def drawing(self) -> JointDrawing:
        return JointDrawing("fixed")
