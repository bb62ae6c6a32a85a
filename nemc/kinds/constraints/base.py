"""What every loop-closing constraint kind is and answers: the base class of this package.

A constraint adds equations Phi(q, t) = 0 between bodies or joints the tree has placed, written
against a LoadView (nemc/kinds/contract.py: the bodies' frames, the coordinates), so both
derivations ask it alike. Its multipliers lambda are the generalized force Phi_q^T lambda on the
tree, which the kind says how to apply (`act`: forces at points, couples, generalized forces on
joints' coordinates; the articulated-body algorithm's unit passes and the reaction outputs take
them from there) and reports as its reaction outputs (`reaction`). Each kind writes them so that
its multipliers are its reaction with no further conversion. The kinds between two points of two
bodies share PointPair.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..spatial import V2
from ..terms import Loc, PointRef, with_expressions_mapped

if TYPE_CHECKING:
    from ..contract import Frame, LoadSink, LoadView, Reader

Expr = sympy.Expr
Named = list[tuple[str, Expr]]


@dataclass(frozen=True)
class ConstraintDrawing:
    """What a picture shows of a constraint beyond its bodies' outlines (nemc/derive/
    geometry.py): discs (body, radius: a circle around the body's origin, with a spoke to show
    it turn), surfaces (body, point, axis: a line a disc rolls on, drawn over the range it
    travels, with the disc's body), segments (body, one end, the other: a contact's surface
    with ends) and blades (body, point, axis: a short edge)."""

    discs: tuple[tuple[str, Expr], ...] = ()
    surfaces: tuple[tuple[str, tuple[Expr, Expr], tuple[Expr, Expr], str], ...] = ()
    blades: tuple[tuple[str, tuple[Expr, Expr], tuple[Expr, Expr]], ...] = ()
    segments: tuple[tuple[str, tuple[Expr, Expr], tuple[Expr, Expr]], ...] = ()


@dataclass(frozen=True)
class Constraint:
    """A loop-closing constraint. Subclasses: one per kind, in this package."""

    type: ClassVar[str]  # the kind's name, as the YAML's `type:` gives it
    keys: ClassVar[tuple[str, ...]] = ()  # its YAML keys besides type
    required: ClassVar[tuple[str, ...]] = ()  # those of its keys it cannot do without
    equations_count: ClassVar[int]  # how many equations it adds
    slides: ClassVar[bool] = False  # it has a sliding direction friction can act along

    name: str
    loc: Loc

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        """The kind's own fields from its YAML entries (None: a problem was recorded)."""
        return {}

    def map_expressions(self, f: Callable[[Expr], Expr]) -> Constraint:
        """The constraint with f applied to every expression of its own fields."""
        return with_expressions_mapped(self, f)

    def equations(self, view: LoadView) -> list[Expr]:
        """Phi: the expressions that vanish when the constraint holds (those `on_velocities`
        names: linear in the rates, A(q, t) dq + a(q, t))."""
        raise NotImplementedError

    def held_as_at_start(self) -> tuple[int, ...]:
        """Which of its equations are g(q) = g(q at the run's start) (a gear pair's): the
        derivation subtracts an offset that each run sets at its start."""
        return ()

    def on_velocities(self) -> tuple[int, ...]:
        """Which of its equations are on the velocities, not the positions (nonholonomic:
        a knife edge's)."""
        return ()

    def act(self, view: LoadView, sink: LoadSink, multipliers: list[Expr]) -> None:
        """The generalized force Phi_q^T lambda of these multipliers, as loads into SINK."""
        raise NotImplementedError

    def reaction(self, view: LoadView, multipliers: list[Expr]) -> Named:
        """Its reaction outputs (NAME.<suffix>) under these multipliers."""
        raise NotImplementedError

    def drawing(self) -> ConstraintDrawing:
        """What a picture shows of it besides the bodies (nothing: its points are theirs)."""
        return ConstraintDrawing()

    def sliding(self, view: LoadView) -> tuple[V2, Expr] | None:
        """Coulomb friction along it (format v3 `friction: [{constraint: NAME}]`): its guide's
        direction (ground axes) and the sliding position along it, whose rate is the relative
        velocity friction opposes; None: it has no sliding direction (friction refused)."""
        return None

    def sliding_normal(self, multipliers: list[Expr]) -> Expr:
        """The normal force (signed) the guide's friction multiplies, from its multipliers."""
        raise NotImplementedError

    def sliding_act(self, view: LoadView, sink: LoadSink, force: Expr) -> None:
        """A friction FORCE along the guide: on the sliding body, the opposite on the guide's."""
        raise NotImplementedError


@dataclass(frozen=True)
class PointPair(Constraint):
    """A constraint between point a of one body and point b of another (written as a spring's
    ends are). Its multipliers are the force (ground axes) of body(b) on body(a) at point a and,
    for the kinds that hold an angle, the couple on body(a): their reaction outputs NAME.Fx,
    .Fy (ground axes), .Fn, .Ft (body(a)'s axes) and .M."""

    required: ClassVar[tuple[str, ...]] = ("a", "b")
    reaction_couple: ClassVar[bool] = False  # its reaction has a couple (output NAME.M)

    a: PointRef
    b: PointRef

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        a, b = read.point_ref("a"), read.point_ref("b")
        if a is not None and b is not None and a.body == b.body:
            read.problem("b", f"a constraint joins two bodies, but a and b are both on "
                              f"{a.body!r}")
            return None
        return read.fields(a=a, b=b, **(cls.read_own(read) or {}))

    @classmethod
    def read_own(cls, read: Reader) -> dict[str, Any] | None:
        """The kind's fields besides its points."""
        return {}

    def equations(self, view: LoadView) -> list[Expr]:
        return self.between(view.frame(self.a.body), view.frame(self.b.body))

    def between(self, a: Frame, b: Frame) -> list[Expr]:
        """Phi, given the two bodies' frames."""
        raise NotImplementedError

    def force(self, a: Frame, b: Frame, multipliers: list[Expr]) -> tuple[V2, Expr]:
        """The force (ground axes) of body(b) on body(a) at point a and the couple on body(a),
        from its multipliers."""
        raise NotImplementedError

    def act(self, view: LoadView, sink: LoadSink, multipliers: list[Expr]) -> None:
        """The force on body(a) at point a, its opposite on body(b) at the same place, the point
        of b under a; the couples likewise."""
        a, b = view.frame(self.a.body), view.frame(self.b.body)
        force, torque = self.force(a, b, multipliers)
        at = a.point(self.a.xy)
        sink.force(self.a.body, self.a.xy, force, at=at)
        sink.couple(self.a.body, torque)
        sink.force(self.b.body, self.contact_on_b(a, b), (-force[0], -force[1]), at=at)
        sink.couple(self.b.body, -torque)

    def contact_on_b(self, a: Frame, b: Frame) -> tuple[Expr, Expr]:
        """Where the reaction's opposite acts on body(b), in b's frame: the point of b at a."""
        return self.b.xy

    def reaction(self, view: LoadView, multipliers: list[Expr]) -> Named:
        a = view.frame(self.a.body)
        force, couple = self.force(a, view.frame(self.b.body), multipliers)
        c, s = sympy.cos(a.angle), sympy.sin(a.angle)
        named = [("Fx", force[0]), ("Fy", force[1]), ("Fn", c * force[0] + s * force[1]),
                 ("Ft", -s * force[0] + c * force[1])]
        return named + ([("M", couple)] if self.reaction_couple else [])
