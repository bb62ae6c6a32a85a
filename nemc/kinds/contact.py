"""A contact that lasts (format v3, the top-level `contacts` mapping; issue 50, decision 0041).

    contacts:
      floor: {point: ball.origin, radius: R, surface: {body: ground, at: [0, 0], axis: [1, 0]},
              restitution: e, mu: 0.5}

A point of a body (or a disc of `radius` around it) kept on the left side of a line of another
body (or the ground): the line passes through `surface.at` along `surface.axis`, both in the
surface body's frame. With u the axis and n its left normal in ground axes, p the point, a the
line's point, the contact point c = p - radius n, and:

    gap            g(q)     = n . (p - a) - radius         (>= 0: open; 0: touching)
    normal speed   n . v_rel = dg/dt                        (v_rel: the point's body's material
    tangent speed  u . v_rel                                 point at c less the surface's there)

With `surface.length` the surface is a segment from a along u, its ends corners (decision
0042): where the point projects beyond an end (s = u . (p - a) <= 0 or >= length), the gap is
|p - corner| - radius and n is along p - corner (`regions`); every expression below is then
one Piecewise over the three regions, each computed within its own.

The contact's force, n Fn + u Ft on the point's body at c and the opposite on the surface
body (Fn >= 0 while the contact lasts, |Ft| <= mu Fn; decision 0041), does the virtual work
Fn (n . v_rel) + Ft (u . v_rel): the rows of the Jacobian of the two speeds in the rates are
the generalized forces of a unit Fn and a unit Ft. This module answers every question about one
contact: its keys and how they are read, its expressions, the bounds its parameters must keep,
its geometry and speeds in a derivation's view, its unknown forces (`symbols`), what the solver
needs of it (`terms`), the loads those forces are (`act`), and how a picture shows it
(`shape`: its line, and a disc around a body's origin, as a rolling constraint's).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from .constraints.base import ConstraintDrawing
from .loads.base import Load
from .spatial import V2, unit
from .terms import Loc, PointRef, Vec2, symbol

if TYPE_CHECKING:
    from .contract import Frame, LoadSink, LoadView, Reader

Expr = sympy.Expr
KEYS = ("point", "radius", "surface", "restitution", "mu")
SURFACE_KEYS = ("body", "at", "axis", "length")
GROUND = "ground"


@dataclass(frozen=True)
class Bound:
    """What one of a contact's expressions must keep at every run's parameters: EXPRESSION
    >= 0 (> 0 where STRICT), told as RULE, at the contact's key KEY; a run's check names it
    PREFIX + KEY (the contact's key path, or "1 - " before it)."""

    key: str
    expression: Expr
    strict: bool
    rule: str
    prefix: str = ""


def contact_symbol(name: str, tangent: bool = False) -> sympy.Symbol:
    """The normal force (TANGENT: the friction force) of contact NAME: solved in C at every
    state (0 while open)."""
    return symbol(f"contact_{'tangent' if tangent else 'normal'}({name})")


@dataclass(frozen=True)
class Contact(Load):
    """One contact of the `contacts` mapping: a point or disc on a line of a body; a load
    whose normal force the generated C solves (nemc/kinds/loads/base.py's questions)."""

    kind: ClassVar[str] = "contact"
    keys: ClassVar[tuple[str, ...]] = KEYS
    required: ClassVar[tuple[str, ...]] = ("point", "surface")

    name: str
    point: PointRef  # the point (a disc's center) and its body
    radius: Expr  # 0: a point
    surface: str  # the line's body (ground allowed)
    at: Vec2  # a point of the line, in the surface body's frame
    axis: Vec2  # the line's direction there (the contact stays on its left)
    restitution: Expr  # Newton's coefficient e of the normal speed in an impact
    mu: Expr | None  # Coulomb's coefficient (None: frictionless)
    loc: Loc
    length: Expr | None = None  # the segment's length from `at` along `axis` (None: a line)

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        """The contact's fields (but its name and location) from its YAML mapping; None
        where a problem was recorded."""
        point = read.point_ref("point")
        if point is not None and point.body == GROUND:
            read.problem("point", f"the contact's point {point.label} is a point of the ground: "
                         "the point must be on a moving body (the ground goes in `surface`)")
            return None
        surface = read.mapping("surface", SURFACE_KEYS, ("body",))
        if surface is None:
            return None
        body = surface.body("body", ground=True)
        if point is not None and body is not None and body == point.body:
            surface.problem("body", f"a body cannot touch itself: the point {point.label} and "
                            f"the surface are both on {body!r}")
            return None
        at = surface.body_point("at", body) if surface.has("at") else (sympy.S.Zero, sympy.S.Zero)
        length = surface.fixed("length", sympy.S.One, positive=True)
        fields = read.fields(
            point=point, surface=body, at=at, axis=surface.axis("axis"), length=length,
            radius=read.fixed("radius", sympy.S.Zero, nonnegative=True),
            restitution=read.fixed("restitution", sympy.S.Zero, nonnegative=True))
        if fields is None:
            return None
        mu = read.fixed("mu", sympy.S.Zero, nonnegative=True) if read.has("mu") else None
        if read.has("mu") and mu is None:
            return None
        return {**fields, "mu": mu, "length": length if surface.has("length") else None}

    @property
    def bodies(self) -> tuple[str, str]:
        """The point's body, then the surface's."""
        return (self.point.body, self.surface)

    @property
    def symbol(self) -> sympy.Symbol:
        """Its normal force's symbol (CONTACT: a runtime unknown, like a friction force)."""
        return contact_symbol(self.name)

    @property
    def symbols(self) -> tuple[sympy.Symbol, ...]:
        """Its unknown forces: the normal force, then with `mu` the friction force along u."""
        return (self.symbol,) + ((contact_symbol(self.name, True),) if self.mu is not None
                                 else ())

    @property
    def has_friction(self) -> bool:
        """Whether the contact has Coulomb friction (`mu`), its tangent force an unknown."""
        return self.mu is not None

    def expressions(self) -> list[tuple[str, Expr]]:
        """(key, expression) of every expression it holds (all of them fixed: parameters)."""
        found = [("radius", self.radius), ("restitution", self.restitution),
                 ("surface.at.0", self.at[0]), ("surface.at.1", self.at[1]),
                 ("surface.axis.0", self.axis[0]), ("surface.axis.1", self.axis[1])]
        found += [("surface.length", self.length)] if self.length is not None else []
        return found + ([("mu", self.mu)] if self.mu is not None else [])

    def bounds(self) -> list[Bound]:
        """What its parameters must keep (the front end checks them at the defaults, a run at
        its own): radius >= 0, 0 <= restitution <= 1, mu >= 0."""
        found = [Bound("radius", self.radius, False, "radius must be >= 0 (0: a point)"),
                 Bound("restitution", self.restitution, False,
                       "restitution must be >= 0 (0: a plastic impact)"),
                 Bound("restitution", 1 - self.restitution, False,
                       "restitution must be <= 1 (1: an elastic impact; more would create "
                       "energy)", "1 - ")]
        if self.mu is not None:
            found.append(Bound("mu", self.mu, False, "mu must be >= 0 (Coulomb's coefficient)"))
        if self.length is not None:
            found.append(Bound("surface.length", self.length, True,
                               "the surface's length must be > 0 (a segment from `at` along "
                               "`axis`; without `length`, a line)"))
        return found

    def shape(self) -> ConstraintDrawing:
        """How a picture shows it (nemc/derive/geometry.py, as a rolling constraint): its line,
        drawn over the range the point's body's origin travels (a segment: between its ends),
        and where the point is that origin and has a radius, the disc."""
        at_origin = all(sympy.sympify(v) == 0 for v in self.point.xy)
        discs = ((self.point.body, self.radius),) if at_origin and self.radius != 0 else ()
        if self.length is not None:  # a segment: drawn between its ends
            return ConstraintDrawing(discs=discs, segments=((self.surface, self.at, self.end),))
        return ConstraintDrawing(discs=discs,
                                 surfaces=((self.surface, self.at, self.axis, self.point.body),))

    # -- the geometry, in any derivation's view (ground axes) ------------------------------------

    def frame_vectors(self, surface: Frame) -> tuple[V2, V2]:
        """The line's unit direction u and its left normal n (pointing into the open side)."""
        u = surface.rotate(unit(self.axis))
        return u, (-u[1], u[0])

    @property
    def end(self) -> Vec2:
        """The segment's far end in the surface body's frame: at + length along the axis."""
        assert self.length is not None
        u = unit(self.axis)
        return (self.at[0] + self.length * u[0], self.at[1] + self.length * u[1])

    def regions(self, view: LoadView) -> list[Region]:
        """The parts of the surface the point may be nearest to, each (where, anchor, normal)
        in ground axes: a line, one part (everywhere, its point a, its left normal n); a
        segment (decision 0042), its corner at `at` where s = u . (p - a) <= 0, its far end's
        where s >= length (each with its normal along p - corner: g = |p - corner| - radius),
        and the line's between and where a point (radius 0) is on a corner (no normal there)."""
        surface = view.frame(self.surface)
        u, n = self.frame_vectors(surface)
        a = surface.point(self.at)
        line = Region(sympy.true, a, n)
        if self.length is None:
            return [line]
        p = view.frame(self.point.body).point(self.point.xy)
        s = u[0] * (p[0] - a[0]) + u[1] * (p[1] - a[1])
        found = []
        for beyond, corner in ((s <= 0, a), (s >= self.length, surface.point(self.end))):
            d = (p[0] - corner[0], p[1] - corner[1])
            norm = sympy.sqrt(d[0] ** 2 + d[1] ** 2)  # 0: a point on the corner, the line's
            found.append(Region(sympy.And(beyond, norm > 0), corner, (d[0] / norm, d[1] / norm)))
        return found + [line]

    def contact_point(self, view: LoadView, region: Region) -> V2:
        """c = p - radius n: where the point (the disc) touches REGION when g = 0."""
        p = view.frame(self.point.body).point(self.point.xy)
        n = region.normal
        return (p[0] - self.radius * n[0], p[1] - self.radius * n[1])

    def gap(self, view: LoadView) -> Expr:
        """g = n . (p - a) - radius (at a corner: |p - corner| - radius): the distance from
        the disc to the surface, negative when it has passed through it."""
        p = view.frame(self.point.body).point(self.point.xy)
        regions = self.regions(view)
        return pieces(regions, [r.normal[0] * (p[0] - r.anchor[0])
                                + r.normal[1] * (p[1] - r.anchor[1]) - self.radius
                                for r in regions])

    def region_speeds(self, view: LoadView, region: Region) -> tuple[Expr, Expr]:
        """(n . v_rel, t . v_rel) on REGION (t = (n_y, -n_x), the line's u): the normal and
        tangent speeds at the contact point c of the point's body's material point there
        relative to the surface body's (kinematics' view: its frames give velocities). The
        normal speed is dg/dt; the tangent speed, the slip."""
        body, surface = view.frame(self.point.body), view.frame(self.surface)
        n = region.normal
        c = self.contact_point(view, region)
        moving = _material_velocity(body, self.point.xy, view.angular_velocity(self.point.body),
                                    body.point(self.point.xy), c)
        held = _material_velocity(surface, self.at, view.angular_velocity(self.surface),
                                  surface.point(self.at), c)
        relative = (moving[0] - held[0], moving[1] - held[1])
        return (n[0] * relative[0] + n[1] * relative[1], n[1] * relative[0] - n[0] * relative[1])

    def speeds(self, view: LoadView) -> tuple[Expr, Expr]:
        """(normal speed, tangent speed) where the point is (region_speeds, piecewise)."""
        regions = self.regions(view)
        found = [self.region_speeds(view, region) for region in regions]
        return (pieces(regions, [v[0] for v in found]), pieces(regions, [v[1] for v in found]))

    def jacobian_rows(self, view: LoadView, rates: Sequence[Expr]) -> tuple[list[Expr], ...]:
        """The rows of d(normal speed, tangent speed)/d(RATES): the speeds are linear in the
        rates, and the rows are the generalized forces of a unit normal and tangent force."""
        return tuple([sympy.diff(speed, rate) for rate in rates] for speed in self.speeds(view))

    def terms(self, view: LoadView, rate: Callable[[Expr], Expr]) -> tuple[Expr, ...]:
        """What the solver needs of it, 4 per unknown force (kinematics' view; RATE: d/dt, the
        accelerations as symbols): restitution, gap, normal speed and normal acceleration;
        with `mu`, then mu, 0, the tangent speed (the slip) and its rate (the accelerations
        affine in the contact's forces). On a segment each is its region's (the rates taken
        within the region: a corner's normal acceleration has its centripetal part)."""
        regions = self.regions(view)
        speeds = [self.region_speeds(view, region) for region in regions]

        def each(k: int, of: Callable[[Expr], Expr]) -> Expr:
            return pieces(regions, [of(v[k]) for v in speeds])

        found = (self.restitution, self.gap(view), each(0, lambda v: v), each(0, rate))
        if self.mu is not None:
            found += (self.mu, sympy.S.Zero, each(1, lambda v: v), each(1, rate))
        return found

    def act(self, view: LoadView, sink: LoadSink) -> None:
        """n Fn + t Ft on the point's body at the contact point c (at its point, with the
        couple of the offset c - p), and the opposite on the surface body (at its line's point
        a, with the couple of c - a; the ground takes nothing); on a segment, n, t and c are
        the region's."""
        regions = self.regions(view)
        forces = self.symbols
        along = forces[1] if len(forces) > 1 else sympy.S.Zero
        body = view.frame(self.point.body)
        p = body.point(self.point.xy)
        a = view.frame(self.surface).point(self.at)

        def force(r: Region) -> V2:
            n = r.normal
            return (forces[0] * n[0] + along * n[1], forces[0] * n[1] - along * n[0])

        def lever(r: Region, origin: V2) -> Expr:
            c, f = self.contact_point(view, r), force(r)
            return (c[0] - origin[0]) * f[1] - (c[1] - origin[1]) * f[0]

        total = (pieces(regions, [force(r)[0] for r in regions]),
                 pieces(regions, [force(r)[1] for r in regions]))
        sink.force(self.point.body, self.point.xy, total, at=p)
        if self.mu is not None:
            sink.couple(self.point.body, pieces(regions, [lever(r, p) for r in regions]))
        if self.surface == GROUND:
            return
        sink.force(self.surface, self.at, (-total[0], -total[1]), at=a)
        sink.couple(self.surface, -pieces(regions, [lever(r, a) for r in regions]))


@dataclass(frozen=True)
class Region:
    """A part of a contact's surface (Contact.regions): WHERE the point is nearest to it, a
    point of it (ANCHOR) and its unit normal into the open side, in ground axes."""

    where: Any
    anchor: V2
    normal: V2


def pieces(regions: Sequence[Region], values: Sequence[Expr]) -> Expr:
    """VALUES, one per region, as one Piecewise where there are several (the last region's
    everywhere else); a line's single region gives its value itself."""
    if len(regions) == 1:
        return values[0]
    return sympy.Piecewise(*[(v, r.where) for v, r in zip(values[:-1], regions[:-1])],
                           (values[-1], True))


def _material_velocity(frame: Frame, xy: Vec2, omega: Expr, known: V2, at: V2) -> V2:
    """The ground velocity of the body's material point at ground position AT, from that of
    its point XY (at ground position KNOWN) and its angular velocity OMEGA."""
    v = frame.velocity(xy)
    r = (at[0] - known[0], at[1] - known[1])
    return (v[0] - omega * r[1], v[1] + omega * r[0])

