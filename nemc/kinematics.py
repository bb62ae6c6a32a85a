"""Planar kinematics of a mechanism's bodies, and its applied loads as forces and couples.

Each body's angle and origin are built joint by joint from the ground; velocities and
accelerations are time derivatives, with the symbols ddot(q) standing for the unknown
accelerations. The loads of the YAML (and gravity) become point forces, body couples and
generalized forces of joint springs.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import sympy

from . import model as m

Vec = sympy.Matrix  # 2x1 column


@dataclass(frozen=True)
class BodyKinematics:
    """Where a body is: its angle and the ground-frame position of its origin."""

    angle: sympy.Expr
    origin: Vec


def rotation(angle: sympy.Expr) -> sympy.Matrix:
    c, s = sympy.cos(angle), sympy.sin(angle)
    return sympy.Matrix([[c, -s], [s, c]])


def vec(xy: Iterable[sympy.Expr]) -> Vec:
    return sympy.Matrix(list(xy))


def cross_z(a: Vec, b: Vec) -> sympy.Expr:
    """z component of a x b for planar vectors."""
    return a[0] * b[1] - a[1] * b[0]


class Kinematics:
    """Positions, velocities and accelerations of points fixed in the bodies."""

    def __init__(self, mech: m.Mechanism):
        self.mech = mech
        self.q = tuple(m.symbol(c) for c in mech.coordinates)
        self.u = tuple(m.rate_symbol(c) for c in mech.coordinates)
        self.qdd = tuple(m.accel_symbol(c) for c in mech.coordinates)
        self.bodies: dict[str, BodyKinematics] = {
            m.GROUND: BodyKinematics(sympy.S.Zero, vec([0, 0]))
        }
        self._joint_of = {joint.child: joint for joint in mech.joints}
        for joint in joints_parent_first(mech.joints):
            self.bodies[joint.child] = self._place_child(joint)

    def _place_child(self, joint: m.Joint) -> BodyKinematics:
        parent = self.bodies[joint.parent]
        at = parent.origin + rotation(parent.angle) * vec(joint.at)
        coords = [m.symbol(c) for c in joint.coordinates]
        if joint.type == "revolute":
            base = sympy.S.Zero if joint.angle == "absolute" else parent.angle
            return BodyKinematics(base + coords[0] + joint.offset, at)
        if joint.type == "prismatic":
            axis = vec(joint.axis)
            unit = axis / sympy.sqrt(axis.dot(axis))
            return BodyKinematics(
                parent.angle + joint.offset, at + rotation(parent.angle) * unit * coords[0]
            )
        if joint.type == "free":
            return BodyKinematics(coords[2], vec(coords[:2]))
        return BodyKinematics(parent.angle + joint.offset, at)  # weld

    def angle(self, body: str) -> sympy.Expr:
        return self.bodies[body].angle

    def position(self, body: str, xy: m.Vec2) -> Vec:
        kin = self.bodies[body]
        return kin.origin + rotation(kin.angle) * vec(xy)

    def velocity(self, body: str, xy: m.Vec2) -> Vec:
        """Ground velocity of a point fixed in `body`, built joint by joint from the ground
        (no differentiation: linear in the depth of the tree, where `rate` is quadratic)."""
        if body == m.GROUND:
            return vec([0, 0])
        kin, omega = self.bodies[body], self.rate(self.angle(body))
        arm = rotation(kin.angle) * vec(xy)
        return self.origin_velocity(body) + omega * vec([-arm[1], arm[0]])

    def origin_velocity(self, body: str) -> Vec:
        joint = self._joint_of[body]
        if joint.type == "free":
            return vec([m.rate_symbol(c) for c in joint.coordinates[:2]])
        if joint.type != "prismatic":
            return self.velocity(joint.parent, joint.at)
        axis = vec(joint.axis)
        unit = axis / sympy.sqrt(axis.dot(axis))
        q, u = m.symbol(joint.coordinates[0]), m.rate_symbol(joint.coordinates[0])
        slide_point = [joint.at[0] + unit[0] * q, joint.at[1] + unit[1] * q]
        along = rotation(self.angle(joint.parent)) * unit * u
        return self.velocity(joint.parent, slide_point) + along

    def rate(self, expr: sympy.Matrix | sympy.Expr) -> sympy.Matrix | sympy.Expr:
        """d/dt of an expression of q, dq and t, with qdd as the symbols of the accelerations."""
        total = sympy.diff(expr, m.TIME)
        for q, u, a in zip(self.q, self.u, self.qdd):
            total += sympy.diff(expr, q) * u + sympy.diff(expr, u) * a
        return total

    def partials(self, expr: sympy.Matrix | sympy.Expr) -> list:
        """Partial velocities: d expr / d dq_k for every rate, expr being a velocity."""
        return [sympy.diff(expr, u) for u in self.u]


def joints_parent_first(joints: Iterable[m.Joint]) -> list[m.Joint]:
    placed, pending, ordered = {m.GROUND}, list(joints), []
    while pending:
        ready = [j for j in pending if j.parent in placed]
        if not ready:
            raise ValueError("joints do not form a tree rooted at ground (validate first)")
        for joint in ready:
            ordered.append(joint)
            placed.add(joint.child)
            pending.remove(joint)
    return ordered


def joint_relative(kin: Kinematics, joint: m.Joint) -> sympy.Expr:
    """A joint's relative angle (child - parent - offset) or prismatic displacement."""
    if joint.type == "prismatic":
        return m.symbol(joint.coordinates[0])
    return kin.angle(joint.child) - kin.angle(joint.parent) - joint.offset


@dataclass(frozen=True)
class PointForce:
    """A force (ground frame) applied at a point fixed in a body."""

    body: str
    xy: m.Vec2
    force: Vec


def applied_loads(mech: m.Mechanism, kin: Kinematics) -> tuple[list[PointForce], list, list]:
    """Gravity and the YAML's loads as point forces, body couples and generalized forces.

    Returns (point forces, couples as (body, torque), generalized forces as (coordinate
    gradient vector, scalar) pairs whose contribution is scalar * d(relative)/dq)."""
    g = vec(mech.gravity)
    forces = [PointForce(b.name, b.com, b.mass * g) for b in mech.bodies]
    couples: list[tuple[str, sympy.Expr]] = []
    generalized: list[tuple[sympy.Expr, sympy.Expr]] = []
    for load in mech.loads:
        if isinstance(load, m.Torque):
            couples += [(load.body, load.expr), (load.reaction, -load.expr)]
        elif isinstance(load, m.Force):
            f = vec(load.components)
            if load.frame == "body":
                f = rotation(kin.angle(load.body)) * f
            forces.append(PointForce(load.body, load.at, f))
        elif isinstance(load, m.Spring):
            forces += spring_forces(load, kin)
        elif isinstance(load, m.JointSpring):
            rel = joint_relative(kin, mech.joint(load.joint))
            tension = -load.k * (rel - load.rest) - load.damping * kin.rate(rel)
            generalized.append((rel, tension))
    return [f for f in forces if f.body != m.GROUND], couples, generalized


def spring_forces(spring: m.Spring, kin: Kinematics) -> list[PointForce]:
    """The spring-damper's forces on its two end points (ground frame)."""
    d = kin.position(spring.b.body, spring.b.xy) - kin.position(spring.a.body, spring.a.xy)
    length = sympy.sqrt(d.dot(d))
    stretch_rate = d.dot(kin.rate(d)) / length
    pull = spring.k * (length - spring.length) + spring.damping * stretch_rate
    on_a = d / length * pull
    return [
        PointForce(spring.a.body, spring.a.xy, on_a),
        PointForce(spring.b.body, spring.b.xy, -on_a),
    ]
