"""A coupling: two joints' coordinates in a fixed ratio (gear pairs, belts and chains, a rack on
a pinion).

    NAME: {type: coupling, a: JOINT, b: JOINT, ratio: EXPR}

One equation, q_a - ratio q_b = its value at the start (relative coordinates: a gear pair has
ratio -r_b/r_a, a belt or chain r_b/r_a, a rack of coordinate s on a pinion of angle q ratio r).
Its multiplier is the generalized force on joint a's coordinate (a torque for a revolute joint,
a force along a prismatic one), and -ratio times it on joint b's: its reaction output NAME.Q.
It acts on the coordinates, not at a point of contact: the coupled joints' reactions hold no
tooth force (a rolling disc on a disc, `rolling`, has the geometry for that).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from .base import Constraint, Named

if TYPE_CHECKING:
    from ..contract import LoadSink, LoadView, Reader

ONE_COORDINATE = "a coupling joins two joints of one coordinate each (revolute or prismatic)"


@dataclass(frozen=True)
class Coupling(Constraint):
    type: ClassVar[str] = "coupling"
    keys: ClassVar[tuple[str, ...]] = ("a", "b", "ratio")
    required: ClassVar[tuple[str, ...]] = ("a", "b", "ratio")
    equations_count: ClassVar[int] = 1

    a: str
    b: str
    ratio: sympy.Expr

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        def one(kind: type) -> bool:
            return len(getattr(kind, "coordinate_kinds", ())) == 1

        a = read.joint("a", one, ONE_COORDINATE)
        b = read.joint("b", one, ONE_COORDINATE)
        if a is not None and a == b:
            read.problem("b", f"a coupling joins two joints, but a and b are both {a!r}")
            return None
        return read.fields(a=a, b=b, ratio=read.fixed("ratio", sympy.S.One))

    def held_as_at_start(self) -> tuple[int, ...]:
        return (0,)

    def coordinates(self, view: LoadView) -> tuple[sympy.Expr, sympy.Expr]:
        return tuple(view.coordinate(view.joint(name).coordinates[0])  # type: ignore[return-value]
                     for name in (self.a, self.b))

    def equations(self, view: LoadView) -> list[sympy.Expr]:
        q_a, q_b = self.coordinates(view)
        return [q_a - self.ratio * q_b]

    def act(self, view: LoadView, sink: LoadSink, multipliers: list[sympy.Expr]) -> None:
        sink.generalized(view.joint(self.a), [multipliers[0]])
        sink.generalized(view.joint(self.b), [-self.ratio * multipliers[0]])

    def reaction(self, view: LoadView, multipliers: list[sympy.Expr]) -> Named:
        return [("Q", multipliers[0])]
