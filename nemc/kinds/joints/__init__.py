"""The joint kinds, one module each, found through one table.

To add a kind: write its module (a subclass of joints.base.Joint answering the questions its
docstring lists), add it to JOINT_KINDS, and test it; nothing else in nemc names a kind.
"""

from __future__ import annotations

from .base import Joint, JointDrawing
from .free import Free
from .prismatic import Prismatic
from .revolute import Revolute
from .weld import Weld

JOINT_KINDS: dict[str, type[Joint]] = {kind.type: kind for kind in (Revolute, Prismatic, Free,
                                                                     Weld)}


def joint_kind(name: str) -> type[Joint]:
    """The kind of this name; an unknown name is a programming error (validate refuses it)."""
    try:
        return JOINT_KINDS[name]
    except KeyError:
        raise ValueError(f"unknown joint kind {name!r}; known: {', '.join(JOINT_KINDS)}") from None


__all__ = ["JOINT_KINDS", "Free", "Joint", "JointDrawing", "Prismatic", "Revolute", "Weld",
           "joint_kind"]
