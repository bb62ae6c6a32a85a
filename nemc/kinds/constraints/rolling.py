"""Rolling without slipping: a disc on a line of a body, or on another disc.

    NAME: {type: rolling, disc: BODY, radius: R, on: {body: BODY, at: [x, y]}, axis: [ax, ay]}
    NAME: {type: rolling, disc: BODY, radius: R, on_disc: {body: BODY, radius: R_b, inside: no}}

The disc is body `disc`, its center the body's origin. Two equations, both written so that their
multipliers are the force of the surface on the disc at the contact point, along the surface's
normal (NAME.Fn, pushing the disc off the surface) and its tangent (NAME.Ft, the friction the
rolling needs):

- on a line (through point `at` of body `on`, along `axis` in that body's frame, the disc on its
  left side; u the axis and n its left normal in ground axes, c the center, p the line's point):
  (c - p) . n - R = 0, and (c - p) . u + R (angle(disc) - angle(on)) = its value at the start
  (holonomic: the distance rolled is the angle turned);
- on a disc (body `on_disc.body`, centered at its origin, radius R_b; the disc outside it, or
  inside it, a ring, with `inside: yes`; d the vector from its center to the disc's, e = d/|d|,
  t = e turned +90 degrees): |d| - (R_b + R) = 0 outside, (R_b - R) - |d| = 0 inside, and the
  contact points of the two bodies have the same velocity along t. That second equation is on
  the velocities: its integral involves the angle of d, whose branch cut would jump, so the
  relation between the angles is kept by the integration, not by projection.

The force acts on the disc at its contact point and, opposite, on the other body at the same
place: the virtual work of these forces is exactly Phi_q^T lambda.
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
ONE_SURFACE = "a rolling disc rolls on a line (`on`) or on a disc (`on_disc`): give one of them"


@dataclass(frozen=True)
class Rolling(Constraint):
    type: ClassVar[str] = "rolling"
    keys: ClassVar[tuple[str, ...]] = ("disc", "radius", "on", "axis", "on_disc")
    required: ClassVar[tuple[str, ...]] = ("disc", "radius")
    equations_count: ClassVar[int] = 2

    disc: str
    radius: Expr
    on: PointRef | None = None  # the line's body and point
    axis: tuple[Expr, Expr] = (sympy.S.One, sympy.S.Zero)  # in on.body's frame
    on_body: str | None = None  # rolling on a disc: its body,
    on_radius: Expr = sympy.S.Zero  # its radius
    inside: bool = False  # and whether the disc rolls inside it (a ring)

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        disc = read.body("disc", ground=False)
        radius = read.fixed("radius", sympy.S.One, positive=True)
        has = {key: read.has(key) for key in ("on", "on_disc")}
        if has["on"] == has["on_disc"]:
            read.problem("on", ONE_SURFACE)
            return None
        if has["on"]:
            on = read.point_ref("on")
            if on is not None and on.body == disc:
                read.problem("on", f"a disc cannot roll on itself ({disc!r})")
                return None
            return read.fields(disc=disc, radius=radius, on=on, axis=read.axis("axis"))
        if read.has("axis"):
            read.problem("axis", "a disc rolling on a disc has no axis (the line's, with `on`)")
            return None
        other = read.mapping("on_disc", ("body", "radius", "inside"), ("body", "radius"))
        if other is None:
            return None
        body = other.body("body", ground=True)
        if body is not None and body == disc:
            other.problem("body", f"a disc cannot roll on itself ({disc!r})")
            return None
        return read.fields(disc=disc, radius=radius, on_body=body,
                           on_radius=other.fixed("radius", sympy.S.One, positive=True),
                           inside=other.flag("inside", False))

    @property
    def other(self) -> str:
        """The body the disc rolls on."""
        return self.on.body if self.on is not None else self.on_body  # type: ignore[return-value]

    def held_as_at_start(self) -> tuple[int, ...]:
        return (1,) if self.on is not None else ()

    def on_velocities(self) -> tuple[int, ...]:
        return () if self.on is not None else (1,)

    # -- the geometry: the contact point and the surface's normal and tangent (ground axes) ----

    def contact(self, disc: Frame, other: Frame) -> tuple[V2, V2, V2]:
        """The contact point (the disc's center less R along the normal), the normal (from the
        surface toward the disc) and the tangent (the normal turned -90 degrees)."""
        c = disc.origin
        if self.on is not None:
            u = other.rotate(unit(self.axis))
            n = (-u[1], u[0])
        else:
            o = other.origin
            d = (c[0] - o[0], c[1] - o[1])
            length = sympy.sqrt(d[0] ** 2 + d[1] ** 2)
            e = (d[0] / length, d[1] / length)
            n = (-e[0], -e[1]) if self.inside else e
        point = (c[0] - self.radius * n[0], c[1] - self.radius * n[1])
        return point, n, (n[1], -n[0])

    def equations(self, view: LoadView) -> list[Expr]:
        disc, other = view.frame(self.disc), view.frame(self.other)
        c = disc.origin
        if self.on is not None:
            p = other.point(self.on.xy)
            u = other.rotate(unit(self.axis))
            d = (c[0] - p[0], c[1] - p[1])
            return [-u[1] * d[0] + u[0] * d[1] - self.radius,
                    u[0] * d[0] + u[1] * d[1] + self.radius * (disc.angle - other.angle)]
        o = other.origin
        length = sympy.sqrt((c[0] - o[0]) ** 2 + (c[1] - o[1]) ** 2)
        gap = (self.on_radius - self.radius - length if self.inside
               else length - self.on_radius - self.radius)
        point, _, tangent = self.contact(disc, other)
        on_disc, on_other = (disc.velocity(local(disc, point)),
                             other.velocity(local(other, point)))
        slip = [on_disc[i] - on_other[i] for i in range(2)]
        return [gap, tangent[0] * slip[0] + tangent[1] * slip[1]]

    def force(self, disc: Frame, other: Frame, multipliers: list[Expr]) -> tuple[V2, V2]:
        """The contact point and the force of the surface on the disc there (ground axes)."""
        point, n, tangent = self.contact(disc, other)
        normal, friction = multipliers
        return point, (normal * n[0] + friction * tangent[0],
                       normal * n[1] + friction * tangent[1])

    def act(self, view: LoadView, sink: LoadSink, multipliers: list[Expr]) -> None:
        disc, other = view.frame(self.disc), view.frame(self.other)
        point, force = self.force(disc, other, multipliers)
        sink.force(self.disc, local(disc, point), force, at=point)
        sink.force(self.other, local(other, point), (-force[0], -force[1]), at=point)

    def drawing(self) -> ConstraintDrawing:
        if self.on is not None:
            return ConstraintDrawing(discs=((self.disc, self.radius),),
                                     surfaces=((self.on.body, self.on.xy, self.axis, self.disc),))
        return ConstraintDrawing(discs=((self.disc, self.radius),
                                        (self.other, self.on_radius)))

    def reaction(self, view: LoadView, multipliers: list[Expr]) -> Named:
        point, force = self.force(view.frame(self.disc), view.frame(self.other), multipliers)
        return [("Fx", force[0]), ("Fy", force[1]), ("Fn", multipliers[0]),
                ("Ft", multipliers[1])]


def local(frame: Frame, point: V2) -> V2:
    """A ground point in a body's frame."""
    origin, angle = frame.origin, frame.angle
    dx, dy = point[0] - origin[0], point[1] - origin[1]
    c, s = sympy.cos(angle), sympy.sin(angle)
    return c * dx + s * dy, -s * dx + c * dy
