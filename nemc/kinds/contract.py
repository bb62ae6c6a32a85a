"""What the kinds are handed: the interfaces through which a joint, load or constraint kind reads
its YAML, places bodies and applies loads, without knowing which stage asks.

- Reader: one YAML mapping, as the front end offers it to a kind's `read` (nemc/front/reader.py
  builds it: typed values, each checked and located; a wrong one records a problem and reads as
  None).
- Frame: a body's pose, as a derivation sees it (the articulated-body algorithm's frames name
  every value in its program; the kinematics' frames build plain expressions).
- LoadView: what a derivation shows a load or a constraint: the bodies' frames and rates, the
  coordinates, the joints. Both derivations offer it (nemc/derive/articulated.py and
  nemc/derive/kinematics.py), so a kind writes its force law once for all of them.
- LoadSink: what a load or a constraint says it does: forces at points of bodies, couples,
  tensions across joints. The articulated-body algorithm turns them into spatial forces; the
  Newton-Euler balances (mass matrix form, reactions) project them.
- SpatialSink: the articulated-body algorithm's own sink of spatial forces, where a joint puts
  what a tension across it or a generalized force on its coordinates does.
- KinematicsView: whole expressions of places and angles (potential energy).
- JointView: what a load acting on a joint may ask of it (nemc/kinds/joints/base.py's Joint
  answers it).

Protocols only: the stages implement them, the kinds call them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

import sympy

from .spatial import V2, V3, Vec
from .terms import Loc, PointRef, Vec2

Expr = sympy.Expr


class Reader(Protocol):
    """One YAML mapping of a joint, load or constraint, as its kind reads it."""

    @property
    def location(self) -> Loc: ...

    def fields(self, **values: Any) -> dict[str, Any] | None:
        """The values read, or None when one is None or a problem was recorded meanwhile."""

    def problem(self, key: str, message: str) -> None: ...

    def has(self, key: str) -> bool:
        """Whether the mapping gives this key."""

    def flag(self, key: str, default: bool) -> bool:
        """true or false."""

    def expr(self, key: str, default: Expr | None = None) -> Expr | None:
        """An expression of t, coordinates, rates, parameters and constants (as loads take)."""

    def fixed(self, key: str, default: Expr, positive: bool = False,
              nonnegative: bool = False) -> Expr | None:
        """An expression of parameters and constants, finite (and > 0, or >= 0) at their
        defaults."""

    def vec2(self, key: str) -> Vec2 | None:
        """[x, y], each as `expr` reads it."""

    def axis(self, key: str) -> Vec2 | None:
        """A fixed direction [x, y], not zero; default [1, 0]."""

    def choice(self, key: str, choices: tuple[str, ...], default: str) -> str | None: ...

    def parent_point(self, key: str) -> Vec2 | None:
        """A point of the joint's parent: a point name or [x, y]; default its origin."""

    def body_point(self, key: str, body: str | None, moving: bool = False) -> Vec2 | None:
        """A point of `body`: a point name or [x, y]; default its mass center. `moving`: [x, y]
        may be expressions of the coordinates, inputs and t (no rates)."""

    def body(self, key: str, ground: bool, default: str | None = None) -> str | None: ...

    def point_ref(self, key: str) -> PointRef | None:
        """BODY.POINT or {body: BODY, at: [x, y]} (ground allowed)."""

    def joint(self, key: str, accepts: Callable[[type], bool], needs: str) -> str | None:
        """A joint's name; `needs` says what a joint of a kind (a class of nemc/kinds/joints/)
        that `accepts` refuses lacks."""

    def mapping(self, key: str, allowed: tuple[str, ...], required: tuple[str, ...]
                ) -> Reader | None:
        """The mapping under `key`, to read in turn (None: not a mapping of these keys)."""


class Frame(Protocol):
    """A body's pose, as a derivation sees it."""

    @property
    def angle(self) -> Expr: ...

    @property
    def origin(self) -> V2: ...

    def rotate(self, xy: Sequence[Expr]) -> V2:
        """A vector given in this body's frame, in ground axes."""

    def point(self, xy: Sequence[Expr]) -> V2:
        """The ground position of the point fixed in this body at xy (body frame)."""

    def velocity(self, xy: Sequence[Expr]) -> V2:
        """The ground velocity of the point fixed in this body at xy (kinematics only)."""

    def name(self, expr: Expr) -> Expr:
        """expr, named in the derivation's program (or as it is)."""

    def names(self, exprs: Sequence[Expr]) -> tuple[Expr, ...]: ...


class SpatialSink(Protocol):
    """Spatial forces on bodies (the articulated-body algorithm's, about the ground origin)."""

    def apply(self, body: str, force: V3) -> None:
        """A spatial force (couple about O, force) on a body."""

    def apply_at(self, body: str, at: Sequence[Expr], force: Sequence[Expr]) -> None:
        """A force (ground axes) on a body, at ground point `at`."""


class LoadSink(Protocol):
    """What a load or a constraint does to the bodies, in the terms of the mechanism."""

    def force(self, body: str, xy: Sequence[Expr], force: Sequence[Expr],
              at: Sequence[Expr] | None = None) -> None:
        """A force (ground axes) on the point of `body` at xy (its frame); `at`: that point's
        ground position, when the load has it at hand."""

    def couple(self, body: str, torque: Expr) -> None: ...

    def tension(self, joint: JointView, displacement: Expr, tension: Expr) -> None:
        """Equal and opposite loads on the joint's two bodies doing power tension * d/dt of its
        relative displacement (the joint says how: JointView.joint_load)."""

    def generalized(self, joint: JointView, forces: Sequence[Expr]) -> None:
        """Generalized forces on the joint's coordinates, one per coordinate (the joint says
        how: Joint.generalized_load)."""


class LoadView(Protocol):
    """The mechanism's bodies, coordinates and joints as a derivation shows them to a load."""

    def frame(self, body: str) -> Frame: ...

    def angular_velocity(self, body: str) -> Expr: ...

    def coordinate(self, name: str) -> Expr:
        """A coordinate's value: its symbol, or a driven coordinate's motion (of t)."""

    def speed(self, name: str) -> Expr: ...

    def joint(self, name: str) -> JointView: ...


class KinematicsView(Protocol):
    """Whole expressions of a point's place and a body's angle (nemc/derive/kinematics.py)."""

    def angle(self, body: str) -> Expr: ...

    def position(self, body: str, xy: Vec2) -> Vec: ...

    def coordinate(self, name: str) -> Expr: ...

    def joint(self, name: str) -> JointView: ...


class JointView(Protocol):
    """A joint, as a load acting on it sees it."""

    name: str
    parent: str
    child: str
    coordinates: tuple[str, ...]

    def displacement(self, child_angle: Expr, parent_angle: Expr, q: Sequence[Expr]) -> Expr:
        """The relative displacement a joint_spring acts on."""

    def displacement_rate(self, child_rate: Expr, parent_rate: Expr,
                          u: Sequence[Expr]) -> Expr: ...

    def joint_load(self, sink: SpatialSink, parent: Frame, child_origin: V2,
                   tension: Expr) -> None:
        """Equal and opposite loads on its two bodies doing power tension * displacement rate."""

    def spring_force_on_child(self, parent_angle: Expr, tension: Expr) -> V2 | None: ...
