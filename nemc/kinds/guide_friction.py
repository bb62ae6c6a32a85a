"""Coulomb friction along a loop-closing guide (format v3 `friction`, an item `constraint:`).

    friction:
      - {constraint: guide, mu: 0.2, mu_static: 0.3}   # a slot or prismatic constraint

An item acts as a load: a force F along the guide on its sliding body, the opposite on the
guide's body (Constraint.sliding_act), F a runtime unknown (`guide_friction_symbol`) that the
generated C solves at every state with the accelerations (templates/friction.c.tmpl's
GUIDE_LAW; decision 0039, amended). Its sliding speed is the rate of the constraint's sliding
position (Constraint.sliding), not a coordinate's, so its terms for the solver are:

    mu N, mu_static N, the sliding speed v, its rate dv/dt (all affine in the forces)

    slipping (v != 0):  F = -sign(v) * mu * |N|
    stuck    (v == 0):  F holds it (dv/dt = 0, a constraint on the loop) while |F| <= mu_static |N|

N is the constraint's normal force, a multiplier of the loop (Constraint.sliding_normal).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from .constraints.base import Constraint
from .loads.base import Load
from .terms import Loc, symbol

if TYPE_CHECKING:
    from .contract import KinematicsView, LoadSink, LoadView

Expr = sympy.Expr
KEYS = ("constraint", "mu", "mu_static")


def guide_friction_symbol(constraint: str) -> sympy.Symbol:
    """The friction force along CONSTRAINT's guide: solved in C at every state."""
    return symbol(f"friction({constraint})")


@dataclass(frozen=True)
class GuideFriction(Load):
    """Coulomb friction along one slot or prismatic constraint (a load)."""

    kind: ClassVar[str] = "guide friction"
    keys: ClassVar[tuple[str, ...]] = KEYS

    constraint: str  # the constraint's name: the item's NAME in outputs and events
    guide: Constraint  # that constraint, which answers its sliding questions
    mu: Expr  # kinetic coefficient
    mu_static: Expr  # static coefficient (default mu)
    loc: Loc

    @property
    def on_constraint(self) -> str:
        """The name of the constraint it acts along."""
        return self.constraint

    @property
    def symbol(self) -> sympy.Symbol:
        return guide_friction_symbol(self.constraint)

    def map_expressions(self, f: Callable[[Expr], Expr]) -> GuideFriction:
        """f on its coefficients and on its constraint's expressions (the guide's axis)."""
        mapped = super().map_expressions(f)
        return dataclasses.replace(mapped, guide=self.guide.map_expressions(f))  # type: ignore

    def expressions(self) -> list[tuple[str, Expr]]:
        return [("mu", self.mu), ("mu_static", self.mu_static)]

    def act(self, view: LoadView, sink: LoadSink) -> None:
        """The friction force along the guide (the constraint puts it on its bodies)."""
        self.guide.sliding_act(view, sink, self.symbol)

    def checks(self) -> list[tuple[str, Expr, bool]]:
        """(key, expression, strict) of what must hold at every run's parameters: mu > 0 and
        mu_static >= mu."""
        return [("mu", self.mu, True), ("mu_static - mu", self.mu_static - self.mu, False)]

    @property
    def static_excess(self) -> Expr:
        """mu_static - mu, which must not be negative."""
        return self.mu_static - self.mu

    def sliding_speed(self, view: LoadView, rate: Callable[[Expr], Expr]) -> Expr:
        """The guide's sliding speed: the rate of its sliding position."""
        sliding = self.guide.sliding(view)
        assert sliding is not None  # the front end refused the others
        return rate(sliding[1])

    def terms(self, view: LoadView, rate: Callable[[Expr], Expr],
              multipliers: Sequence[Expr]) -> tuple[Expr, Expr, Expr, Expr]:
        """mu N, mu_static N (N signed, so that they stay affine in the friction forces: the
        solver takes their magnitudes), the sliding speed and its rate (RATE: d/dt, the
        accelerations as symbols; MULTIPLIERS: the constraint's, whose normal force is N)."""
        normal = self.guide.sliding_normal(list(multipliers))  # signed: affine in the forces
        speed = self.sliding_speed(view, rate)
        return (self.mu * normal, self.mu_static * normal, speed, rate(speed))

    def reported(self, kin: KinematicsView, rate: Callable[[Expr], Expr]
                 ) -> list[tuple[str, Expr]]:
        """NAME.friction: the friction force on the sliding body, along the guide."""
        return [(".friction", self.symbol)]

    def reported_kinds(self, coordinate_kind: Callable[[str], str]) -> list[tuple[str, str]]:
        return [(".friction", "joint force")]


def read_fields(read: Any, constraint: Constraint | None) -> dict[str, Any] | None:
    """The item's fields through READ (the front end's Reader), its constraint found by name
    (None: not a constraint of the file, already reported)."""
    if not read.has("mu"):
        read.problem("mu", "friction on a constraint needs `mu`")
        return None
    mu = read.fixed("mu", sympy.S.One, positive=True)
    mu_static = read.fixed("mu_static", mu if mu is not None else sympy.S.One, positive=True)
    if constraint is None or mu is None or mu_static is None:
        return None
    return {"guide": constraint, "mu": mu, "mu_static": mu_static}
