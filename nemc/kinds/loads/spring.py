"""A linear spring, with a damper in parallel, between two points.

    - spring: {a: BODY.POINT, b: {body: BODY, at: [x, y]}, k: EXPR, length: EXPR,
               damping: EXPR}

It pulls the points together with k (distance - length) + damping d(distance)/dt along the line
between them; its elastic part has potential energy k (distance - length)^2 / 2.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..spatial import dot, scale
from ..terms import Loc, PointRef
from .base import Load, LoadDrawing

if TYPE_CHECKING:
    from ..contract import KinematicsView, LoadSink, LoadView, Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class Spring(Load):
    kind: ClassVar[str] = "spring"
    keys: ClassVar[tuple[str, ...]] = ("spring",)

    a: PointRef
    b: PointRef
    k: sympy.Expr
    length: sympy.Expr
    damping: sympy.Expr
    loc: Loc

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        inner = read.mapping("spring", ("a", "b", "k", "length", "damping"),
                             ("a", "b", "k", "length"))
        if inner is None:
            return None
        return inner.fields(a=inner.point_ref("a"), b=inner.point_ref("b"), k=inner.expr("k"),
                            length=inner.expr("length"),
                            damping=inner.expr("damping", sympy.S.Zero), loc=inner.location)

    def expressions(self) -> list[tuple[str, sympy.Expr]]:
        return [(key, getattr(self, key)) for key in ("k", "length", "damping")]

    def act(self, view: LoadView, sink: LoadSink) -> None:
        frame_a, frame_b = view.frame(self.a.body), view.frame(self.b.body)
        pa, pb = frame_a.point(self.a.xy), frame_b.point(self.b.xy)
        va, vb = frame_a.velocity(self.a.xy), frame_b.velocity(self.b.xy)
        d = frame_a.names((pb[0] - pa[0], pb[1] - pa[1]))
        length = frame_a.name(sympy.sqrt(dot(d, d)))
        stretch_rate = dot(d, (vb[0] - va[0], vb[1] - va[1])) / length
        pull = self.k * (length - self.length)
        pull = frame_a.name((pull + self.damping * stretch_rate) / length)
        on_a = frame_a.names(scale(d, pull))
        sink.force(self.a.body, self.a.xy, on_a, at=pa)
        sink.force(self.b.body, self.b.xy, scale(on_a, -1), at=pb)

    def potential(self, kin: KinematicsView) -> sympy.Expr:
        d = kin.position(self.b.body, self.b.xy) - kin.position(self.a.body, self.a.xy)
        return self.k * (sympy.sqrt(d.dot(d)) - self.length) ** 2 / 2

    def reported(self, kin: KinematicsView, rate: Callable[[Expr], Expr]
                 ) -> list[tuple[str, Expr]]:
        """Its tension, NAME.tension: k (distance - length) + damping d(distance)/dt, positive
        when it pulls the points together."""
        d = kin.position(self.b.body, self.b.xy) - kin.position(self.a.body, self.a.xy)
        distance = sympy.sqrt(d.dot(d))
        return [(".tension", self.k * (distance - self.length) + self.damping * rate(distance))]

    def reported_kinds(self, coordinate_kind: Callable[[str], str]) -> list[tuple[str, str]]:
        return [(".tension", "joint force")]

    def drawing(self) -> LoadDrawing:
        return LoadDrawing(between=(self.a, self.b))
