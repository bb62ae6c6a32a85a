"""Planar kinematics of a mechanism's bodies, and its applied loads as forces and couples.

Each body's angle and origin are built joint by joint from the ground, each joint placing its
child (Joint.place, the same placement the articulated-body algorithm uses); velocities and
accelerations are time derivatives, with the symbols ddot(q) standing for the unknown
accelerations. Kinematics is the LoadView of whole expressions (nemc/kinds/contract.py):
gravity and the loads of the YAML (each Load.act) become point forces, body couples and
tensions across joints in a BalanceLoads, as the Newton-Euler balances take them.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import sympy

from ..front import mechanism as m
from ..kinds.spatial import Vec, rotation, vec

if TYPE_CHECKING:
    from ..kinds.joints import Joint


@dataclass(frozen=True)
class BodyKinematics:
    """Where a body is: its angle and the ground-frame position of its origin."""

    angle: sympy.Expr
    origin: Vec


class Kinematics:
    """Positions, velocities and accelerations of points fixed in the bodies."""

    def __init__(self, mech: m.Mechanism):
        self.mech = mech
        self.q = tuple(m.symbol(c) for c in mech.coordinates)
        self.u = tuple(m.rate_symbol(c) for c in mech.coordinates)
        self.qdd = tuple(m.accel_symbol(c) for c in mech.coordinates)
        self._placed: dict[str, BodyKinematics] = {
            m.GROUND: BodyKinematics(sympy.S.Zero, vec([0, 0]))
        }
        self._joint_of = {joint.child: joint for joint in mech.joints}
        self.motions = {joint.coordinates[0]: prescribed_motion(joint) for joint in mech.driven}

    def body(self, name: str) -> BodyKinematics:
        """A body's angle and origin, placed (with its ancestors) on first use: a body's whole
        expressions grow with its depth in the tree, so placing every body of a long chain
        costs the square of its length, which the derivation spends only when it asks."""
        pending = []
        while name not in self._placed:
            pending.append(self._joint_of[name])
            name = pending[-1].parent
        for joint in reversed(pending):
            angle, origin = joint.place(self.frame(joint.parent),
                                        [self.coordinate(c) for c in joint.coordinates])
            self._placed[joint.child] = BodyKinematics(angle, vec(origin))
        return self._placed[pending[0].child] if pending else self._placed[name]

    def coordinate(self, name: str) -> sympy.Expr:
        """A coordinate's value: its symbol, or a driven coordinate's motion (of t)."""
        return self.motions[name][0] if name in self.motions else m.symbol(name)

    def speed(self, name: str) -> sympy.Expr:
        return self.motions[name][1] if name in self.motions else m.rate_symbol(name)

    def frame(self, body: str) -> SymbolicFrame:
        return SymbolicFrame(self, body)

    def angular_velocity(self, body: str) -> sympy.Expr:
        return self.rate(self.angle(body))

    def joint(self, name: str) -> Joint:
        return self.mech.joint(name)

    def angle(self, body: str) -> sympy.Expr:
        return self.body(body).angle

    def position(self, body: str, xy: m.Vec2) -> Vec:
        kin = self.body(body)
        return kin.origin + rotation(kin.angle) * vec(xy)

    def velocity(self, body: str, xy: m.Vec2) -> Vec:
        """Ground velocity of a point fixed in `body`, built joint by joint from the ground
        (no differentiation: linear in the depth of the tree, where `rate` is quadratic)."""
        if body == m.GROUND:
            return vec([0, 0])
        kin, omega = self.body(body), self.rate(self.angle(body))
        arm = rotation(kin.angle) * vec(xy)
        return self.origin_velocity(body) + omega * vec([-arm[1], arm[0]])

    def origin_velocity(self, body: str) -> Vec:
        joint = self._joint_of[body]
        return vec(joint.origin_velocity(self.frame(joint.parent),
                                         [self.coordinate(c) for c in joint.coordinates],
                                         [self.speed(c) for c in joint.coordinates]))

    def rate(self, expr: sympy.Matrix | sympy.Expr) -> sympy.Matrix | sympy.Expr:
        """d/dt of an expression of q, dq and t, with qdd as the symbols of the accelerations."""
        total = sympy.diff(expr, m.TIME)
        for q, u, a in zip(self.q, self.u, self.qdd):
            total += sympy.diff(expr, q) * u + sympy.diff(expr, u) * a
        return where_it_exists(total)

    def partials(self, expr: sympy.Matrix | sympy.Expr) -> list:
        """Partial velocities: d expr / d dq_k for every rate, expr being a velocity."""
        return [sympy.diff(expr, u) for u in self.u]


class SymbolicFrame:
    """A body's pose for a joint placing its child (joints.base.Frame): plain expressions."""

    def __init__(self, kin: Kinematics, body: str):
        self.kin, self.body = kin, body

    @property
    def angle(self) -> sympy.Expr:
        return self.kin.angle(self.body)

    @property
    def origin(self) -> tuple[sympy.Expr, sympy.Expr]:
        origin = self.kin.body(self.body).origin
        return origin[0], origin[1]

    def rotate(self, xy: Sequence[sympy.Expr]) -> tuple[sympy.Expr, sympy.Expr]:
        rotated = rotation(self.angle) * vec(xy)
        return rotated[0], rotated[1]

    def point(self, xy: Sequence[sympy.Expr]) -> tuple[sympy.Expr, sympy.Expr]:
        position = self.kin.position(self.body, tuple(xy))  # type: ignore[arg-type]
        return position[0], position[1]

    def velocity(self, xy: Sequence[sympy.Expr]) -> tuple[sympy.Expr, sympy.Expr]:
        velocity = self.kin.velocity(self.body, tuple(xy))  # type: ignore[arg-type]
        return velocity[0], velocity[1]

    def name(self, expr: sympy.Expr) -> sympy.Expr:
        return expr

    def names(self, exprs: Sequence[sympy.Expr]) -> tuple[sympy.Expr, ...]:
        return tuple(exprs)


def where_it_exists(derivative: sympy.Expr | sympy.Matrix) -> sympy.Expr | sympy.Matrix:
    """A derivative taken where it exists: sympy's DiracDelta terms (from the kinks and steps
    of abs, sign, min and max: the derivative of sign or of a Heaviside step) are 0 everywhere
    else, and C cannot print them (issue 51: such motion laws crashed the compile). The
    impulse at the kink itself is not in the equations."""
    if not derivative.has(sympy.DiracDelta):
        return derivative
    return derivative.replace(lambda e: isinstance(e, sympy.DiracDelta), lambda e: sympy.S.Zero)


def time_derivative(expr: sympy.Expr) -> sympy.Expr:
    """d expr / dt where it exists (where_it_exists)."""
    return where_it_exists(sympy.diff(expr, m.TIME))


def prescribed_motion(joint: Joint) -> tuple[sympy.Expr, sympy.Expr, sympy.Expr]:
    """A driven joint's coordinate, rate and acceleration: its motion and their derivatives
    (where they exist: a motion with a kink, abs(sin(t)), has a step in its rate)."""
    motion = sympy.sympify(joint.motion)
    rate = time_derivative(motion)
    return motion, rate, time_derivative(rate)


def motion_substitutions(mech: m.Mechanism) -> dict[sympy.Symbol, sympy.Expr]:
    """Each driven coordinate's symbol, rate and acceleration -> its prescribed value (where
    loads and outputs name them)."""
    found: dict[sympy.Symbol, sympy.Expr] = {}
    for joint in mech.driven:
        name = joint.coordinates[0]
        values = prescribed_motion(joint)
        for symbol, value in zip((m.symbol(name), m.rate_symbol(name), m.accel_symbol(name)),
                                 values):
            found[symbol] = value
    return found


def joints_parent_first(joints: Iterable[Joint]) -> list[Joint]:
    """The joints by their depth in the tree (those on ground first), in file order at each
    depth: every joint after the one placing its parent. Linear in the number of joints."""
    joints = list(joints)
    of_child = {joint.child: joint for joint in joints}
    depth = {m.GROUND: -1}
    for joint in joints:
        path, body = [], joint.child
        while body not in depth:
            if body not in of_child or len(path) > len(joints):
                raise ValueError("joints do not form a tree rooted at ground (validate first)")
            path.append(body)
            body = of_child[body].parent
        for body in reversed(path):
            depth[body] = depth[of_child[body].parent] + 1
    return sorted(joints, key=lambda joint: depth[joint.child])


@dataclass(frozen=True)
class PointForce:
    """A force (ground axes) applied at a point fixed in a body (xy: in its frame)."""

    body: str
    xy: m.Vec2
    force: Vec  # 2 x 1


@dataclass(frozen=True)
class Tension:
    """A tension across a joint: equal and opposite loads on its bodies doing power
    tension * d(displacement)/dt (a generalized force tension * d(displacement)/dq)."""

    joint: Joint
    displacement: sympy.Expr
    tension: sympy.Expr


@dataclass
class BalanceLoads:
    """Loads as the Newton-Euler balances take them (a LoadSink, nemc/kinds/contract.py):
    point forces, couples (body, torque) and tensions across joints."""

    forces: list[PointForce] = field(default_factory=list)
    couples: list[tuple[str, sympy.Expr]] = field(default_factory=list)
    tensions: list[Tension] = field(default_factory=list)

    def force(self, body: str, xy: Sequence[sympy.Expr], force: Sequence[sympy.Expr],
              at: Sequence[sympy.Expr] | None = None) -> None:
        if body != m.GROUND:
            self.forces.append(PointForce(body, tuple(xy), vec(force)))  # type: ignore[arg-type]

    def couple(self, body: str, torque: sympy.Expr) -> None:
        self.couples.append((body, torque))

    def tension(self, joint: Joint, displacement: sympy.Expr, tension: sympy.Expr) -> None:
        self.tensions.append(Tension(joint, displacement, tension))

    def generalized(self, joint: Joint, forces: Sequence[sympy.Expr]) -> None:
        """Generalized forces on the joint's coordinates: each a tension along its coordinate
        (its power: force * the coordinate's rate)."""
        for name, force in zip(joint.coordinates, forces):
            self.tensions.append(Tension(joint, m.symbol(name), force))


def generalized_forces(kin: Kinematics, applied: BalanceLoads) -> list[sympy.Expr]:
    """The generalized forces of APPLIED along kin's coordinates, by their virtual power: a
    point force through its material point's velocity (xy may move on the body), a couple
    through its body's rate, a tension through its displacement."""
    n = len(kin.q)
    forces = [sympy.S.Zero] * n
    for load in applied.forces:
        jv = kin.partials(kin.velocity(load.body, load.xy))
        for k in range(n):
            forces[k] += jv[k].dot(load.force)
    for body, torque in applied.couples:
        if body != m.GROUND:
            jw = kin.partials(kin.rate(kin.angle(body)))
            for k in range(n):
                forces[k] += jw[k] * torque
    for across in applied.tensions:
        for k in range(n):
            forces[k] += sympy.diff(across.displacement, kin.q[k]) * across.tension
    return forces


def applied_loads(mech: m.Mechanism, kin: Kinematics) -> BalanceLoads:
    """Gravity and the YAML's loads (each kind's Load.act) as point forces, body couples and
    tensions across joints."""
    applied = BalanceLoads()
    g = vec(mech.gravity)
    for body in mech.bodies:
        applied.force(body.name, body.com, body.mass * g)
    for load in mech.loads:
        load.act(kin, applied)
    return applied
