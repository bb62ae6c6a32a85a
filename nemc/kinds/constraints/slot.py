"""The slot: point a stays on the line through point b along `axis`, fixed in body(b).

    NAME: {type: slot, a: BODY.POINT, b: BODY.POINT, axis: [ax, ay]}

One equation, n . (p_a - p_b) = 0, n the line's normal (axis turned by +90 degrees) in ground
axes; rotation is free. Its multiplier is the normal force of body(b) on body(a): lambda n,
acting on b (opposite) at the point of b under a.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..contract import Frame
from ..spatial import V2, scale, unit
from .base import PointPair

if TYPE_CHECKING:
    from ..contract import LoadSink, LoadView, Reader


@dataclass(frozen=True)
class Slot(PointPair):
    type: ClassVar[str] = "slot"
    keys: ClassVar[tuple[str, ...]] = ("a", "b", "axis")
    equations_count: ClassVar[int] = 1
    slides: ClassVar[bool] = True

    axis: tuple[sympy.Expr, sympy.Expr] = (sympy.S.One, sympy.S.Zero)  # in body(b)'s frame

    @classmethod
    def read_own(cls, read: Reader) -> dict[str, Any] | None:
        return {"axis": read.axis("axis")}

    def normal(self, b: Frame) -> V2:
        ux, uy = unit(self.axis)
        return b.rotate((-uy, ux))

    def separation(self, a: Frame, b: Frame) -> V2:
        pa, pb = a.point(self.a.xy), b.point(self.b.xy)
        return pa[0] - pb[0], pa[1] - pb[1]

    def between(self, a: Frame, b: Frame) -> list[sympy.Expr]:
        n, d = self.normal(b), self.separation(a, b)
        return [n[0] * d[0] + n[1] * d[1]]

    def force(self, a: Frame, b: Frame, multipliers: list[sympy.Expr]
              ) -> tuple[V2, sympy.Expr]:
        return scale(self.normal(b), multipliers[0]), sympy.S.Zero  # type: ignore[return-value]

    def sliding(self, view: LoadView) -> tuple[V2, sympy.Expr]:
        """The line's direction u (ground axes) and the sliding position u . (p_a - p_b), whose
        rate is a's velocity relative to the point of b under it, along u."""
        a, b = view.frame(self.a.body), view.frame(self.b.body)
        ux, uy = unit(self.axis)
        u, d = b.rotate((ux, uy)), self.separation(a, b)
        return u, u[0] * d[0] + u[1] * d[1]

    def sliding_normal(self, multipliers: list[sympy.Expr]) -> sympy.Expr:
        """The normal force: the first multiplier (lambda n, n a unit vector)."""
        return multipliers[0]

    def sliding_act(self, view: LoadView, sink: LoadSink, force: sympy.Expr) -> None:
        """FORCE u on body(a) at point a, -FORCE u on body(b) at the point of b under a."""
        a, b = view.frame(self.a.body), view.frame(self.b.body)
        u, _ = self.sliding(view)
        along = (force * u[0], force * u[1])
        at = a.point(self.a.xy)
        sink.force(self.a.body, self.a.xy, along, at=at)
        sink.force(self.b.body, self.contact_on_b(a, b), (-along[0], -along[1]), at=at)

    def contact_on_b(self, a: Frame, b: Frame) -> tuple[sympy.Expr, sympy.Expr]:
        """The point of body(b) under a, in b's frame: b's point plus the separation."""
        d = self.separation(a, b)
        c, s = sympy.cos(b.angle), sympy.sin(b.angle)
        return (self.b.xy[0] + c * d[0] + s * d[1], self.b.xy[1] - s * d[0] + c * d[1])
