"""The validated mechanism: the plain value the loader hands to every later stage.

Every expression is a sympy expression over the symbols made by the helpers below, so all
stages agree on names: a parameter, constant or coordinate ``q`` is ``Symbol("q")``, its rate
``dot(q)`` is ``Symbol("dot(q)")`` and time is ``Symbol("t")``. Every item keeps the location
of the YAML node it came from, so later stages can still point at the line that caused a
problem.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal, Union

import sympy

Expr = sympy.Expr
Vec2 = tuple[sympy.Expr, sympy.Expr]

TIME = sympy.Symbol("t", real=True)
GROUND = "ground"


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


JointType = Literal["revolute", "prismatic", "free", "weld"]


@dataclass(frozen=True)
class Joint:
    name: str
    type: JointType
    parent: str  # a body name or "ground"
    child: str
    at: Vec2  # attachment point in the parent's frame (resolved from a point name if given so)
    coordinates: tuple[str, ...]  # revolute/prismatic: 1, free: 3 (x, y, th), weld: 0
    angle: Literal["relative", "absolute"] = "relative"  # revolute only
    offset: Expr = sympy.S.Zero
    axis: Vec2 = (sympy.S.One, sympy.S.Zero)  # prismatic only, in the parent frame
    loc: Loc | None = None


@dataclass(frozen=True)
class Torque:
    """A couple ``expr`` on ``body`` and ``-expr`` on ``reaction``."""

    expr: Expr
    body: str
    reaction: str
    loc: Loc


@dataclass(frozen=True)
class Force:
    components: Vec2
    body: str
    at: Vec2  # point of application in the body frame (default: com)
    frame: Literal["ground", "body"]
    loc: Loc


@dataclass(frozen=True)
class Spring:
    a: PointRef
    b: PointRef
    k: Expr
    length: Expr
    damping: Expr
    loc: Loc


@dataclass(frozen=True)
class JointSpring:
    joint: str
    k: Expr
    rest: Expr
    damping: Expr
    loc: Loc


Load = Union[Torque, Force, Spring, JointSpring]  # noqa: UP007 (a runtime alias)


@dataclass(frozen=True)
class Outputs:
    reactions: tuple[str, ...] = ()  # joint names
    energy: bool = False
    points: tuple[PointRef, ...] = ()
    accelerations: bool = False
    expressions: tuple[tuple[str, Expr], ...] = ()

    @property
    def empty(self) -> bool:
        return not (
            self.reactions or self.energy or self.points or self.accelerations or self.expressions
        )


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
    events: tuple[Event, ...] = ()
    max_step: float | None = None  # the largest step any method may take (solve_ivp's max_step)
    tstops: tuple[float, ...] = ()  # times every method's steps land on exactly
    max_steps: int | None = None  # the step budget (None: the runtime's default)


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
    loads: tuple[Load, ...]
    outputs: Outputs
    simulation: Simulation

    @property
    def coordinates(self) -> tuple[str, ...]:
        return tuple(q for joint in self.joints for q in joint.coordinates)

    @property
    def state_names(self) -> tuple[str, ...]:
        return tuple(name for q in self.coordinates for name in (q, f"dot({q})"))

    def body(self, name: str) -> Body:
        return next(b for b in self.bodies if b.name == name)

    def joint(self, name: str) -> Joint:
        return next(j for j in self.joints if j.name == name)
