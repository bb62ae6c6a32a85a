"""The load kinds, one module each, found through one table.

To add a kind: write its module (a subclass of loads.base.Load answering the questions its
docstring lists), add it to LOAD_KINDS, and test it; nothing else in nemc names a kind.
"""

from __future__ import annotations

from .base import Load, LoadDrawing
from .force import Force
from .joint_spring import JointSpring
from .spring import Spring
from .torque import Torque

LOAD_KINDS: dict[str, type[Load]] = {kind.kind: kind for kind in (Torque, Force, Spring,
                                                                  JointSpring)}

__all__ = ["LOAD_KINDS", "Force", "JointSpring", "Load", "LoadDrawing", "Spring", "Torque"]
