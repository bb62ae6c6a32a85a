"""The validated mechanism: the plain value the front end hands to every later stage.

Joints, loads and constraints are values of their kinds (nemc/kinds/), which know what their
kind means; this module holds what is common to every mechanism: its parameters, bodies,
outputs, scene and units. Its expressions and locations are in the terms of
nemc/kinds/terms.py (re-exported here: later stages write `m.symbol(q)`, `m.GROUND`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

from ..kinds.constraints import Constraint
from ..kinds.contact import Contact
from ..kinds.joints import Joint
from ..kinds.loads import Load
from ..kinds.terms import (
    GROUND,
    TIME,
    ZERO2,
    Expr,
    Loc,
    PointRef,
    Vec2,
    accel_symbol,
    rate_symbol,
    symbol,
    with_expressions_mapped,
)

__all__ = ["GROUND", "TIME", "ZERO2", "Body", "Event", "Expr", "Loc", "Mechanism", "Outputs",
           "Param", "PointRef", "Simulation", "Units", "Vec2", "accel_symbol", "rate_symbol",
           "symbol", "with_expressions_mapped"]


@dataclass(frozen=True)
class Param:
    """A parameter (settable at run time) or a constant (folded at compile time)."""

    name: str
    expr: Expr  # a number, or an expression of other parameters / constants
    loc: Loc


@dataclass(frozen=True)
class Body:
    name: str
    mass: Expr
    inertia: Expr  # about the mass center, z axis
    com: Vec2  # in the body frame
    points: Mapping[str, Vec2]  # named points in the body frame (not origin/com)
    loc: Loc


@dataclass(frozen=True)
class Outputs:
    reactions: tuple[str, ...] = ()  # joint and constraint names
    energy: bool = False
    points: tuple[PointRef, ...] = ()
    accelerations: bool = False
    expressions: tuple[tuple[str, Expr], ...] = ()
    drives: tuple[str, ...] = ()  # driven joints' names
    units: tuple[tuple[str, str], ...] = ()  # an expression's name -> its declared unit label

    @property
    def empty(self) -> bool:
        return not (self.reactions or self.energy or self.points or self.accelerations
                    or self.expressions or self.drives)


EventDirection = Literal["rising", "falling", "both"]
EventAction = Literal["record", "stop", "impact", "switch"]  # switch: friction's modes


@dataclass(frozen=True)
class Event:
    """An event of the scene: it fires where ``when`` crosses zero in ``direction``.

    ``action`` record: its times and states are reported; stop: the run ends there; impact: the
    state is replaced by ``law`` (state name "q" or "dot(q)" -> new value), every new value an
    expression evaluated on the state just before the event."""

    name: str
    when: Expr
    direction: EventDirection = "both"
    action: EventAction = "record"
    law: tuple[tuple[str, Expr], ...] = ()
    loc: Loc | None = None


@dataclass(frozen=True)
class Simulation:
    t_span: tuple[float, float] | None = None
    initial: Mapping[str, Expr] = field(default_factory=dict)  # "q" or "dot(q)" -> expression
    t_eval: tuple[float, ...] | None = None  # an explicit list of times, or
    t_eval_step: float | None = None  # {step: h}: t_span[0], t_span[0] + h, ... up to t_span[1]
    method: str | None = None
    rtol: float | None = None
    atol: float | None = None
    guess: Mapping[str, Expr] = field(default_factory=dict)  # closed loops: assembly start
    initial_loc: Loc | None = None  # where `initial` is, for messages about its values
    events: tuple[Event, ...] = ()
    max_step: float | None = None  # the largest step any method may take (solve_ivp's max_step)
    tstops: tuple[float, ...] = ()  # times every method's steps land on exactly
    max_steps: int | None = None  # the step budget (None: the runtime's default)
    inputs: Mapping[str, Expr] = field(default_factory=dict)  # input -> expression of p, t


AngleDisplay = Literal["rad", "deg"]


@dataclass(frozen=True)
class Units:
    """The optional `units:` mapping: labels only (nemc never converts). `angle` says how
    figures and animations show angles; the equations and tables always use radians."""

    length: str | None = None
    mass: str | None = None
    time: str | None = None
    angle: AngleDisplay = "rad"


@dataclass(frozen=True)
class Mechanism:
    name: str
    description: str
    source: str  # path of the YAML file as given
    source_hash: str  # sha256 hex of the file's bytes
    parameters: tuple[Param, ...]
    constants: tuple[Param, ...]
    gravity: Vec2
    bodies: tuple[Body, ...]
    joints: tuple[Joint, ...]  # in the order listed: this fixes the coordinate order
    # (each a kind of nemc/joints/, each load a kind of nemc/loads/)
    loads: tuple[Load, ...]
    outputs: Outputs
    simulation: Simulation
    constraints: tuple[Constraint, ...] = ()  # loop-closing joints (nemc/constraints/)
    units: Units = field(default_factory=Units)
    inputs: tuple[Param, ...] = ()  # values set from outside at run time, with their defaults
    load_names: tuple[tuple[str, int], ...] = ()  # a named load's name, its index in loads
    friction_count: int = 0  # the `friction` items (nemc/kinds/friction.py), the last loads
    contacts: tuple[Contact, ...] = ()  # but these: `contacts` (nemc/kinds/contact.py), loads too

    @property
    def frictions(self) -> tuple[Load, ...]:
        """The friction items (format v3), in file order: Coulomb friction on joints (the
        loads before the contacts, which are the last)."""
        end = len(self.loads) - len(self.contacts)
        return self.loads[end - self.friction_count:end] if self.friction_count else ()

    @property
    def coordinates(self) -> tuple[str, ...]:
        """The coordinates in the state: every joint's, but a driven joint's (prescribed)."""
        return tuple(q for joint in self.joints if not joint.driven for q in joint.coordinates)

    @property
    def driven(self) -> tuple[Joint, ...]:
        return tuple(joint for joint in self.joints if joint.driven)

    @property
    def state_names(self) -> tuple[str, ...]:
        return tuple(name for q in self.coordinates for name in (q, f"dot({q})"))

    def body(self, name: str) -> Body:
        return next(b for b in self.bodies if b.name == name)

    def joint(self, name: str) -> Joint:
        return next(j for j in self.joints if j.name == name)

    def constraint(self, name: str) -> Constraint:
        return next(c for c in self.constraints if c.name == name)
