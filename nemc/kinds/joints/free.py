"""The free joint: the child moves freely in the plane; its parent is the ground.

    {type: free, parent: ground, child: C, coordinates: [x, y, th]}

Child origin at (x, y), child angle th: absolute coordinates, so the child is a root of the
articulated-body algorithm whatever the file lists, its acceleration solved directly from its
articulated inertia.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import ClassVar

import sympy

from ..contract import Frame, SpatialSink
from ..spatial import V2, V3, add, couple, scale
from ..terms import GROUND
from .base import Joint, JointDrawing

Expr = sympy.Expr


@dataclass(frozen=True)
class Free(Joint):
    type: ClassVar[str] = "free"
    keys: ClassVar[tuple[str, ...]] = ("coordinates",)
    coordinate_key: ClassVar[str | None] = "coordinates"
    coordinate_kinds: ClassVar[tuple[str, ...]] = ("length", "length", "angle")
    floating: ClassVar[bool] = True

    @classmethod
    def parent_problem(cls, parent: str) -> str | None:
        return None if parent == GROUND else f"a free joint's parent must be ground, got {parent!r}"

    def place(self, parent: Frame, q: Sequence[Expr]) -> tuple[Expr, V2]:
        return q[2], (q[0], q[1])

    def origin_velocity(self, parent: Frame, q: Sequence[Expr], u: Sequence[Expr]) -> V2:
        return u[0], u[1]

    def motion_subspace(self, parent: Frame, child_origin: V2, parent_velocity: V3,
               u: Sequence[Expr]) -> tuple[list[V3], list[Expr]]:
        x, y = child_origin
        one, zero = sympy.S.One, sympy.S.Zero
        return [(zero, one, zero), (zero, zero, one), (one, y, -x)], list(u)

    def bias_acceleration(self, velocity: V3, relative: V3, axes: Sequence[V3],
                          rates: Sequence[Expr]) -> V3:
        """S depends on the origin (x, y), which moves: dS/dt u = uth * (0, uy, -ux)."""
        ux, uy, uth = rates
        return (sympy.S.Zero, uth * uy, -uth * ux)

    def root_accelerations(self, acceleration: V3, bias: V3, child_origin: V2,
                           name: Callable[[Expr], Expr]) -> list[Expr]:
        """The coordinates' accelerations from the child's spatial acceleration a:
        S qdd = a - bias, S = [(0, 1, 0), (0, 0, 1), (1, y, -x)]."""
        x, y = child_origin
        w = add(acceleration, scale(bias, -1))
        return [name(w[1] - y * w[0]), name(w[2] + x * w[0]), w[0]]

    def generalized_load(self, sink: SpatialSink, parent: Frame, child_origin: V2,
                         forces: Sequence[Expr]) -> None:
        sink.apply_at(self.child, child_origin, forces[:2])
        sink.apply(self.child, couple(forces[2]))

    def drawing(self) -> JointDrawing:
        return JointDrawing("none")
