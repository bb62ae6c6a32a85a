"""The loop-closing constraint kinds, one module each, found through one table.

To add a kind: write its module (a subclass of constraints.base.Constraint: its equations and
the meaning of its multipliers), add it to CONSTRAINT_KINDS, and test it.
"""

from __future__ import annotations

from .base import Constraint, PointPair
from .coupling import Coupling
from .knife_edge import KnifeEdge
from .prismatic import PrismaticConstraint
from .revolute import RevoluteConstraint
from .rolling import Rolling
from .slot import Slot

CONSTRAINT_KINDS: dict[str, type[Constraint]] = {
    kind.type: kind for kind in (RevoluteConstraint, Slot, PrismaticConstraint, Coupling,
                                 Rolling, KnifeEdge)}

__all__ = ["CONSTRAINT_KINDS", "Constraint", "Coupling", "KnifeEdge", "PointPair",
           "PrismaticConstraint", "RevoluteConstraint", "Rolling", "Slot"]
