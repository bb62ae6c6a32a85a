"""What every loop-closing constraint kind is and answers: the base class of this package.

A constraint joins two points a and b of two bodies already placed by the joint tree (written
as a spring's ends are). A kind says which equations Phi(q, t) = 0 it adds (in ground axes,
from the two bodies' frames), and what its multipliers mean as a reaction: the force of body(b)
on body(a) at point a (and a couple, for the kinds that hold an angle). Written so that the
generalized force Phi_q^T lambda is exactly that reaction acting on a, and its opposite on b:
the multipliers of the index-1 equations are the reactions, with no further conversion.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..spatial import V2
from ..terms import Loc, PointRef, with_expressions_mapped

if TYPE_CHECKING:
    from ..contract import Frame, LoadSink, Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class Constraint:
    """A loop-closing constraint. Subclasses: one per kind, in this package."""

    type: ClassVar[str]  # the kind's name, as the YAML's `type:` gives it
    keys: ClassVar[tuple[str, ...]] = ()  # its YAML keys besides type, a and b
    equations_count: ClassVar[int]  # how many equations it adds
    reaction_couple: ClassVar[bool] = False  # its reaction has a couple (output NAME.M)

    name: str
    a: PointRef
    b: PointRef
    loc: Loc

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        """The kind's own fields from its YAML entries (None: a problem was recorded)."""
        return {}

    def map_expressions(self, f: Callable[[Expr], Expr]) -> Constraint:
        """The constraint with f applied to every expression of its own fields."""
        return with_expressions_mapped(self, f)

    def equations(self, a: Frame, b: Frame) -> list[Expr]:
        """Phi: the expressions that vanish when the constraint holds, given the two bodies'
        frames."""
        raise NotImplementedError

    def reaction(self, a: Frame, b: Frame, multipliers: list[Expr]) -> tuple[V2, Expr]:
        """The force (ground axes) of body(b) on body(a) at point a and the couple on body(a),
        from its multipliers."""
        raise NotImplementedError

    def act(self, sink: LoadSink, a: Frame, b: Frame, multipliers: list[Expr]) -> None:
        """The reaction of these multipliers as loads: on body(a) at point a, its opposite on
        body(b) at the same place, the point of b under a (generalized force Phi_q^T lambda,
        driven coordinates' included). Every derivation takes a constraint's loads from here:
        the articulated-body algorithm's unit passes and the reaction outputs."""
        force, torque = self.reaction(a, b, multipliers)
        at = a.point(self.a.xy)
        sink.force(self.a.body, self.a.xy, force, at=at)
        sink.couple(self.a.body, torque)
        sink.force(self.b.body, self.contact_on_b(a, b), (-force[0], -force[1]), at=at)
        sink.couple(self.b.body, -torque)

    def contact_on_b(self, a: Frame, b: Frame) -> tuple[Expr, Expr]:
        """Where the reaction's opposite acts on body(b), in b's frame: the point of b at a."""
        return self.b.xy
