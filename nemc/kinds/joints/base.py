"""What every joint kind is and answers: the base class of the kinds in this package.

A joint kind is a frozen dataclass (its fields are what its YAML keys hold) whose methods answer
every question the pipeline asks about a joint of that kind: which YAML keys it takes and how
they are read (validate), where it places its child (every derivation: the articulated-body
algorithm, the kinematics of the outputs and of the mass-matrix form, hence Taylor too), its
motion axes and how its coordinates' accelerations follow (articulated body), how a load on the
joint acts (joint springs, generalized forces), its reaction output, and how it is drawn.
Nothing outside nemc/kinds/joints/ tests a joint's kind by its name; it asks the joint.

Derivations hand a joint a Frame (nemc/kinds/contract.py): the pose of its parent, with the
operations a placement needs. The articulated-body algorithm's frames name every value in its
straight-line program; the kinematics' frames build plain expressions. Each kind writes its
placement once, for both.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..contract import Frame, SpatialSink
from ..spatial import V2, V3, cross_motion
from ..terms import ZERO2, Loc, Vec2, with_expressions_mapped

if TYPE_CHECKING:
    from ..contract import Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class JointDrawing:
    """How a picture shows a joint: a pin, a slider on a rail (its axis, in the parent's frame),
    a fixed (welded) connection, or nothing (a free body)."""

    symbol: str = "pin"
    axis: Vec2 | None = None


@dataclass(frozen=True)
class Joint:
    """A joint of the mechanism's tree. Subclasses: one per kind, in this package."""

    type: ClassVar[str]  # the kind's name, as the YAML's `type:` gives it
    keys: ClassVar[tuple[str, ...]]  # its YAML keys besides type, parent and child
    coordinate_key: ClassVar[str | None] = None  # the key naming its coordinate(s)
    coordinate_kinds: ClassVar[tuple[str, ...]] = ()  # "angle" or "length", per coordinate
    merged: ClassVar[bool] = False  # no degree of freedom: its child moves with its parent
    floating: ClassVar[bool] = False  # its child is a root of the articulated-body algorithm
    reaction_couple: ClassVar[bool] = False  # its reaction has a couple (output NAME.M)
    relative: ClassVar[bool] = False  # it has a relative displacement (a joint_spring acts on)
    drivable: ClassVar[bool] = False  # it may carry `motion:` (one coordinate, prescribed)
    friction_lever: ClassVar[bool] = False  # its friction is a couple: mu * radius * |normal|

    name: str
    parent: str  # a body name or "ground"
    child: str
    coordinates: tuple[str, ...]
    loc: Loc | None = None
    at: Vec2 = ZERO2  # where the joint attaches the child, in the parent's frame
    motion: Expr | None = None  # a driven joint's prescribed coordinate, an expression of t

    @property
    def driven(self) -> bool:
        return self.motion is not None

    @property
    def n_coordinates(self) -> int:
        return len(self.coordinate_kinds)

    # -- the YAML ---------------------------------------------------------------------------

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        """The kind's own fields from its YAML entries (None: a problem was recorded)."""
        return {}

    @classmethod
    def parent_problem(cls, parent: str) -> str | None:
        """Why this kind cannot have this parent, or None."""
        return None

    def drive_problem(self) -> str | None:
        """Why this joint cannot be driven as it is, or None."""
        return None if self.drivable else f"a {self.type} joint cannot be driven"

    # -- expressions --------------------------------------------------------------------------

    def map_expressions(self, f: Callable[[Expr], Expr]) -> Joint:
        """The joint with f applied to every expression it holds (e.g. constants folded)."""
        return with_expressions_mapped(self, f)

    # -- placement: every derivation ---------------------------------------------------------

    def place(self, parent: Frame, q: Sequence[Expr]) -> tuple[Expr, V2]:
        """The child's angle and the ground position of its origin, given the parent's pose
        and this joint's coordinates q."""
        raise NotImplementedError

    def origin_velocity(self, parent: Frame, q: Sequence[Expr], u: Sequence[Expr]) -> V2:
        """The ground velocity of the child's origin (q, u: coordinates and rates)."""
        raise NotImplementedError

    # -- the articulated-body algorithm ------------------------------------------------------

    def motion_subspace(self, parent: Frame, child_origin: V2, parent_velocity: V3,
               u: Sequence[Expr]) -> tuple[list[V3], list[Expr]]:
        """Its motion subspace S (axes, about O, ground axes) and the rates along them: the
        child's spatial velocity is the parent's plus sum(axis * rate)."""
        raise NotImplementedError

    def bias_acceleration(self, velocity: V3, relative: V3, axes: Sequence[V3],
                          rates: Sequence[Expr]) -> V3:
        """dS/dt rates: the child's acceleration when the joint's rates are constant (relative:
        S rates, the child's velocity less the parent's). S moves with the child (revolute) or
        the parent (prismatic): v x (S rates), the same for both; a kind whose axes move
        otherwise (some with the parent, some with the child) says so."""
        return cross_motion(velocity, relative)

    def coordinate_accelerations(self, joint_accelerations: Sequence[Expr],
                                 acceleration: V3) -> list[Expr]:
        """Its coordinates' accelerations from the accelerations along its axes and the child's
        spatial acceleration (the same unless its coordinates are not its joint rates)."""
        return list(joint_accelerations)

    def root_accelerations(self, acceleration: V3, bias: V3, child_origin: V2,
                           name: Callable[[Expr], Expr]) -> list[Expr]:
        """A floating kind's coordinates' accelerations from its child's spatial acceleration
        (solved directly: the child is a root)."""
        raise NotImplementedError(f"a {self.type} joint is not floating")

    # -- loads on the joint --------------------------------------------------------------------

    def displacement(self, child_angle: Expr, parent_angle: Expr, q: Sequence[Expr]) -> Expr:
        """The relative displacement a joint_spring acts on (kinds with `relative`)."""
        raise NotImplementedError(f"a {self.type} joint has no relative displacement")

    def displacement_rate(self, child_rate: Expr, parent_rate: Expr,
                          u: Sequence[Expr]) -> Expr:
        """d/dt of displacement, from the bodies' angular rates or the joint's rates."""
        raise NotImplementedError(f"a {self.type} joint has no relative displacement")

    def joint_load(self, sink: SpatialSink, parent: Frame, child_origin: V2,
                   tension: Expr) -> None:
        """Equal and opposite loads on its two bodies doing power tension * displacement rate."""
        raise NotImplementedError(f"a {self.type} joint has no relative displacement")

    def generalized_load(self, sink: SpatialSink, parent: Frame, child_origin: V2,
                         forces: Sequence[Expr]) -> None:
        """Loads equivalent to generalized forces on its coordinates (for M^-1)."""
        if forces:
            self.joint_load(sink, parent, child_origin, forces[0])

    def spring_force_on_child(self, parent_angle: Expr, tension: Expr) -> V2 | None:
        """The force (ground axes) a joint_spring of this tension puts on the child, when it
        acts by a force (not a couple): the reaction output leaves it out."""
        return None

    def friction_normal(self, parent_angle: Expr, force: Sequence[Expr]
                        ) -> tuple[Expr, Expr] | None:
        """The normal force Coulomb friction on this joint multiplies (`friction`: its two
        components, whose norm is its magnitude), from the joint's reaction FORCE on the child
        (ground axes); None: this joint takes no friction."""
        return None

    # -- the picture -----------------------------------------------------------------------------

    def drawing(self) -> JointDrawing:
        """How a picture of the mechanism shows it (default: a pin)."""
        return JointDrawing()
