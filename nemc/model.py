"""The validated mechanism: the plain value the loader hands to every later stage.

Joints and loads are values of their kinds (nemc/joints/, nemc/loads/), which know what their
kind means; this module holds what is common to every mechanism.

Every expression is a sympy expression over the symbols made by the helpers below, so all
stages agree on names: a parameter, constant or coordinate ``q`` is ``Symbol("q")``, its rate
``dot(q)`` is ``Symbol("dot(q)")`` and time is ``Symbol("t")``. Every item keeps the location
of the YAML node it came from, so later stages can still point at the line that caused a
problem.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, TypeVar

import sympy

if TYPE_CHECKING:  # the kinds build on this module's values
    from .constraints import Constraint
    from .joints import Joint
    from .loads import Load

Expr = sympy.Expr
Vec2 = tuple[sympy.Expr, sympy.Expr]

TIME = sympy.Symbol("t", real=True)
GROUND = "ground"
ZERO2: Vec2 = (sympy.S.Zero, sympy.S.Zero)


Record = TypeVar("Record")


def with_expressions_mapped(record: Record, f: Callable[[sympy.Expr], sympy.Expr]) -> Record:
    """A joint, load or constraint (a dataclass) with f applied to every expression of its own
    fields: sympy values and tuples of them (e.g. constants folded)."""
    changes = {}
    for item in dataclasses.fields(record):  # type: ignore[arg-type]
        value = getattr(record, item.name)
        if isinstance(value, sympy.Basic):
            changes[item.name] = f(value)
        elif isinstance(value, tuple) and value and all(
                isinstance(v, sympy.Basic) for v in value):
            changes[item.name] = tuple(f(v) for v in value)
    return dataclasses.replace(record, **changes)  # type: ignore[type-var]


def symbol(name: str) -> sympy.Symbol:
    """The symbol of a parameter, constant or coordinate."""
    return sympy.Symbol(name, real=True)


def rate_symbol(coordinate: str) -> sympy.Symbol:
    """The symbol of ``dot(coordinate)``."""
    return sympy.Symbol(f"dot({coordinate})", real=True)


def accel_symbol(coordinate: str) -> sympy.Symbol:
    """The symbol of ``ddot(coordinate)`` (never written by users; used by outputs)."""
    return sympy.Symbol(f"ddot({coordinate})", real=True)


@dataclass(frozen=True)
class Loc:
    """Where an item came from: file, 1-based line and column, and its key path."""

    file: str
    line: int
    column: int
    key: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}: {self.key}"


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
class PointRef:
    """A point fixed in a body (``ground`` allowed), by its coordinates in that body's frame."""

    body: str
    xy: Vec2
    label: str  # how the user wrote it: "link1.B", "link1.com", "ground.[2, 0]"


@dataclass(frozen=True)
class Outputs:
    reactions: tuple[str, ...] = ()  # joint and constraint names
    energy: bool = False
    points: tuple[PointRef, ...] = ()
    accelerations: bool = False
    expressions: tuple[tuple[str, Expr], ...] = ()
    drives: tuple[str, ...] = ()  # driven joints' names

    @property
    def empty(self) -> bool:
        return not (self.reactions or self.energy or self.points or self.accelerations
                    or self.expressions or self.drives)


EventDirection = Literal["rising", "falling", "both"]
EventAction = Literal["record", "stop", "impact"]


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
