"""Planar spatial vector algebra (Featherstone, Rigid Body Dynamics Algorithms, 2008, ch. 2 in
the plane), with every quantity in ground axes about the ground origin O:

    motion vector  v = (omega, vx, vy)   vx, vy: velocity of the body point passing through O
    force vector   f = (n, fx, fy)       n: moment about O

so moving a quantity from a body to its parent needs no coordinate transform. Plain tuples of
sympy expressions; the articulated-body algorithm (nemc/articulated.py) and the joint and load
kinds (nemc/joints/, nemc/loads/) build on these.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import sympy

Expr = sympy.Expr
V2 = tuple[Expr, Expr]  # a planar vector
V3 = tuple[Expr, Expr, Expr]  # a planar spatial motion or force vector
M3 = tuple[V3, V3, V3]  # a 3 x 3 matrix (spatial inertias are symmetric)
ZERO3: V3 = (sympy.S.Zero,) * 3


def add(a: Sequence[Expr], b: Sequence[Expr]) -> tuple[Expr, ...]:
    return tuple(x + y for x, y in zip(a, b))


def scale(a: Sequence[Expr], k: Expr) -> tuple[Expr, ...]:
    return tuple(x * k for x in a)


def dot(a: Sequence[Expr], b: Sequence[Expr]) -> Expr:
    return sum((x * y for x, y in zip(a, b)), sympy.S.Zero)


def mat_vec(a: M3, v: V3) -> V3:
    return tuple(dot(row, v) for row in a)  # type: ignore[return-value]


def cross_motion(v: V3, w: V3) -> V3:
    """v x w for motion vectors (the derivative of w moving with velocity v)."""
    return (sympy.S.Zero, v[2] * w[0] - v[0] * w[2], v[0] * w[1] - v[1] * w[0])


def cross_force(v: V3, f: V3) -> V3:
    """v x* f for a force f (v x* I v is the velocity-product force of a body)."""
    return (v[1] * f[2] - v[2] * f[1], -v[0] * f[2], v[0] * f[1])


def point_force(at: Sequence[Expr], force: Sequence[Expr]) -> V3:
    """A force applied at ground point `at`, as a spatial force about O."""
    return (at[0] * force[1] - at[1] * force[0], force[0], force[1])


def couple(torque: Expr) -> V3:
    return (torque, sympy.S.Zero, sympy.S.Zero)


def point_velocity(v: V3, at: Sequence[Expr]) -> V2:
    """Velocity of the body point at ground point `at`, for body spatial velocity v."""
    return (v[1] - v[0] * at[1], v[2] + v[0] * at[0])


def rigid_inertia(mass: Expr, inertia: Expr, com: Sequence[Expr]) -> M3:
    """Spatial inertia about O of a body with this mass, central inertia and mass center."""
    cx, cy = com
    return (
        (inertia + mass * (cx * cx + cy * cy), -mass * cy, mass * cx),
        (-mass * cy, mass, sympy.S.Zero),
        (mass * cx, sympy.S.Zero, mass),
    )


def unit(vector: Sequence[Expr]) -> V2:
    """The planar vector divided by its length."""
    x, y = vector
    norm = sympy.sqrt(x * x + y * y)
    return x / norm, y / norm


# -- plain planar vectors as sympy column matrices (the kinematics' whole expressions) --------

Vec = sympy.Matrix  # 2 x 1


def rotation(angle: Expr) -> sympy.Matrix:
    c, s = sympy.cos(angle), sympy.sin(angle)
    return sympy.Matrix([[c, -s], [s, c]])


def vec(xy: Iterable[Expr]) -> Vec:
    return sympy.Matrix(list(xy))


def cross_z(a: Vec, b: Vec) -> Expr:
    """z component of a x b for planar vectors."""
    return a[0] * b[1] - a[1] * b[0]
