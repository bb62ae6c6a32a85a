"""What every load kind is and answers: the base class of the kinds in this package.

A load kind is a frozen dataclass (what its YAML mapping holds, ending with its location) whose
methods answer every question the pipeline asks about a load of that kind: its YAML keys and
how they are read (validate), the expressions it holds, how it acts in the articulated-body
algorithm (spatial forces on bodies) and in the Newton-Euler balances of the kinematics (point
forces, couples and generalized forces: the mass-matrix form and the reaction outputs), and its
potential energy. Nothing outside nemc/loads/ tests a load's kind; it asks the load.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..spatial import V2
from ..terms import Loc, Vec2, with_expressions_mapped

if TYPE_CHECKING:
    from ..contract import ArticulatedLoads, KinematicsView, Reader
    from ..joints import Joint

Expr = sympy.Expr


@dataclass(frozen=True)
class PointForce:
    """A force (ground frame) applied at a point fixed in a body."""

    body: str
    xy: Vec2
    force: sympy.Matrix  # 2 x 1


@dataclass
class Applied:
    """Loads as the Newton-Euler balances take them: point forces, couples (body, torque), and
    generalized forces (relative displacement, tension) doing tension * d(displacement)/dq."""

    forces: list[PointForce] = field(default_factory=list)
    couples: list[tuple[str, Expr]] = field(default_factory=list)
    generalized: list[tuple[Expr, Expr]] = field(default_factory=list)

    def add(self, other: Applied) -> None:
        self.forces += other.forces
        self.couples += other.couples
        self.generalized += other.generalized


@dataclass(frozen=True)
class Load:
    """A load of the mechanism. Subclasses: one per kind, in this package."""

    kind: ClassVar[str]  # the key that marks a load of this kind in the YAML's `loads` list
    keys: ClassVar[tuple[str, ...]]  # every key of its mapping (the kind's key first)
    required: ClassVar[tuple[str, ...]] = ()  # keys besides the kind's own that must be there

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        """The load's fields from its YAML entries (None: a problem was recorded)."""
        raise NotImplementedError

    @property
    def location(self) -> Loc:
        return self.loc  # type: ignore[attr-defined]  (every kind's last field)

    def expressions(self) -> list[tuple[str, Expr]]:
        """(key path under its location, expression) of every expression of t, q, dq it
        holds."""
        return []

    def map_expressions(self, f: Callable[[Expr], Expr]) -> Load:
        """The load with f applied to every expression it holds (e.g. constants folded)."""
        return with_expressions_mapped(self, f)

    def act(self, aba: ArticulatedLoads) -> None:
        """Apply the load in the articulated-body algorithm (its expressions already in
        runtime symbols)."""
        raise NotImplementedError

    def applied(self, kin: KinematicsView) -> Applied:
        """The load as point forces, couples and generalized forces."""
        raise NotImplementedError

    def potential(self, kin: KinematicsView) -> Expr | None:
        """Its potential energy, for the kinds that have one."""
        return None

    def force_through_joint(self, kin: KinematicsView, joint: Joint) -> V2 | None:
        """The force this load puts on the joint's child through the joint itself (the joint's
        reaction output leaves it out); None when it puts none."""
        return None
