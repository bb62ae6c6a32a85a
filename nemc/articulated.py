"""The accelerations by the articulated-body algorithm, as a straight-line program.

Featherstone's articulated-body algorithm (Rigid Body Dynamics Algorithms, 2008, ch. 7) in
planar form, with every spatial quantity expressed in ground axes about the ground origin O:

    motion vector  v = (omega, vx, vy)   vx, vy: velocity of the body point passing through O
    force vector   f = (n, fx, fy)       n: moment about O

so moving a quantity from a body to its parent needs no coordinate transform. Per body, in
three passes over the joint tree: velocities and bias accelerations (root to leaves),
articulated inertias and bias forces (leaves to root), accelerations (root to leaves). The cost
is linear in the number of bodies; each quantity is a named intermediate (nemc/program.py), so
the generated code is too.

Welded bodies move with their parent and are merged into it. A free joint's coordinates are
absolute (x, y of the body origin and its angle), so its body is a root whatever its parent in
the file. An absolute-angle revolute joint moves like a relative one with the joint rate
dot(q) - omega_parent; its coordinate's acceleration is the body's angular acceleration.

Loads (gravity, torques, forces, springs, joint springs) all enter as spatial forces on bodies;
a joint spring acts as equal and opposite couples (or, on a prismatic joint, forces along its
axis) on the two bodies it joins. `inverse_mass_program` runs the same algorithm at rest with
only unit generalized forces applied, which gives the columns of M^-1 for diagnostics.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import sympy

from . import model as m
from .kinematics import joints_parent_first
from .program import Program, ProgramBuilder

Expr = sympy.Expr
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


def point_velocity(v: V3, at: Sequence[Expr]) -> tuple[Expr, Expr]:
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


class Geometry:
    """Angles, their cosines and sines, and origins of all bodies, as program names."""

    def __init__(self, mech: m.Mechanism, prog: ProgramBuilder, value: Callable):
        self.prog, self.value = prog, value
        zero, one = sympy.S.Zero, sympy.S.One
        self.angle = {m.GROUND: zero}
        self.trig = {m.GROUND: (one, zero)}
        self.origin = {m.GROUND: (zero, zero)}
        for joint in joints_parent_first(mech.joints):
            self._place(joint)

    def _place(self, joint: m.Joint) -> None:
        parent, coords = joint.parent, [m.symbol(c) for c in joint.coordinates]
        offset = self.value(joint.offset)
        if joint.type == "free":
            angle, origin = coords[2], (coords[0], coords[1])
        elif joint.type == "revolute":
            base = sympy.S.Zero if joint.angle == "absolute" else self.angle[parent]
            angle, origin = base + coords[0] + offset, self.point(parent, joint.at)
        elif joint.type == "prismatic":
            slide = scale(self.rotate(parent, self.unit_axis(joint)), coords[0])
            angle = self.angle[parent] + offset
            origin = self.prog.lets(add(self.point(parent, joint.at), slide))
        else:  # weld
            angle, origin = self.angle[parent] + offset, self.point(parent, joint.at)
        angle = self.prog.let(angle)
        self.angle[joint.child] = angle
        self.trig[joint.child] = (self.prog.let(sympy.cos(angle)), self.prog.let(sympy.sin(angle)))
        self.origin[joint.child] = origin

    def unit_axis(self, joint: m.Joint) -> tuple[Expr, Expr]:
        ax, ay = (self.value(a) for a in joint.axis)
        norm = sympy.sqrt(ax * ax + ay * ay)
        return ax / norm, ay / norm

    def rotate(self, body: str, xy: Sequence[Expr]) -> tuple[Expr, Expr]:
        """A body-frame vector in ground axes."""
        c, s = self.trig[body]
        x, y = (self.value(v) for v in xy)
        return c * x - s * y, s * x + c * y

    def point(self, body: str, xy: Sequence[Expr]) -> tuple[Expr, Expr]:
        """Ground position of the point fixed in `body` at body coordinates xy."""
        return self.prog.lets(add(self.origin[body], self.rotate(body, xy)))  # type: ignore


@dataclass
class Node:
    """A body with its own degrees of freedom, and the bodies welded to it."""

    joint: m.Joint
    parent: str  # the parent node's body, or ground
    members: list[str]
    axes: list[V3] = field(default_factory=list)  # the joint's motion subspace S
    rates: list[Expr] = field(default_factory=list)  # the joint's rates
    velocity: V3 = ZERO3
    bias_acceleration: V3 = ZERO3  # c = dS/dt rate
    inertia: M3 | None = None  # articulated inertia, accumulated from the children
    bias_force: V3 = ZERO3  # p^A, accumulated from the children
    loads: list[V3] = field(default_factory=list)
    u_vector: V3 = ZERO3  # U = I^A S
    d_inverse: Expr = sympy.S.Zero  # 1 / (S^T I^A S)
    u_force: Expr = sympy.S.Zero  # u = -S^T p^A


class ArticulatedBody:
    """The three passes over the nodes of one mechanism, writing into one program."""

    def __init__(self, mech: m.Mechanism, value: Callable, *, at_rest: bool = False):
        self.mech, self.value, self.at_rest = mech, value, at_rest
        self.prog = ProgramBuilder()
        self.geo = Geometry(mech, self.prog, value)
        self.node_of: dict[str, str] = {m.GROUND: m.GROUND}
        self.nodes: dict[str, Node] = {}
        for joint in joints_parent_first(mech.joints):
            self._add_body(joint)

    def _add_body(self, joint: m.Joint) -> None:
        if joint.type == "weld":
            node = self.node_of[joint.parent]
            self.node_of[joint.child] = node
            if node != m.GROUND:
                self.nodes[node].members.append(joint.child)
            return
        parent = m.GROUND if joint.type == "free" else self.node_of[joint.parent]
        self.node_of[joint.child] = joint.child
        self.nodes[joint.child] = Node(joint, parent, [joint.child])

    # -- pass 1: velocities ---------------------------------------------------------------

    def speed(self, coordinate: str) -> Expr:
        return sympy.S.Zero if self.at_rest else m.rate_symbol(coordinate)

    def velocity(self, body: str) -> V3:
        node = self.node_of[body]
        return ZERO3 if node == m.GROUND else self.nodes[node].velocity

    def _motion(self, node: Node) -> None:
        joint, geo, parent_v = node.joint, self.geo, self.velocity(node.parent)
        speeds = [self.speed(c) for c in joint.coordinates]
        if joint.type == "free":
            x, y = geo.origin[joint.child]
            one, zero = sympy.S.One, sympy.S.Zero
            node.axes = [(zero, one, zero), (zero, zero, one), (one, y, -x)]
            node.rates = speeds
        elif joint.type == "revolute":
            px, py = geo.origin[joint.child]
            node.axes = [(sympy.S.One, py, -px)]
            absolute = joint.angle == "absolute"
            node.rates = [self.prog.let(speeds[0] - parent_v[0]) if absolute else speeds[0]]
        else:  # prismatic
            ax, ay = self.prog.lets(geo.rotate(joint.parent, geo.unit_axis(joint)))
            node.axes, node.rates = [(sympy.S.Zero, ax, ay)], speeds
        relative = ZERO3
        for axis, rate in zip(node.axes, node.rates):
            relative = add(relative, scale(axis, rate))
        node.velocity = self.prog.lets(add(parent_v, relative))
        if joint.type == "free":
            ux, uy, uth = node.rates
            node.bias_acceleration = self.prog.lets((sympy.S.Zero, uth * uy, -uth * ux))
        else:
            node.bias_acceleration = self.prog.lets(cross_motion(node.velocity, relative))

    # -- loads ----------------------------------------------------------------------------

    def apply(self, body: str, force: V3) -> None:
        node = self.node_of[body]
        if node != m.GROUND:
            self.nodes[node].loads.append(force)

    def apply_at(self, body: str, at: Sequence[Expr], force: Sequence[Expr]) -> None:
        self.apply(body, point_force(at, force))

    def _loads(self) -> None:
        gx, gy = (self.value(g) for g in self.mech.gravity)
        for body in self.mech.bodies:
            mass = self.value(body.mass)
            self.apply_at(body.name, self.geo.point(body.name, body.com), (mass * gx, mass * gy))
        for load in self.mech.loads:
            if isinstance(load, m.Torque):
                torque = self.prog.let(self.value(load.expr))
                self.apply(load.body, couple(torque))
                self.apply(load.reaction, couple(-torque))
            elif isinstance(load, m.Force):
                force = [self.value(c) for c in load.components]
                if load.frame == "body":
                    force = self.geo.rotate(load.body, force)
                at = self.geo.point(load.body, load.at)
                self.apply_at(load.body, at, self.prog.lets(force))
            elif isinstance(load, m.Spring):
                self._spring(load)
            elif isinstance(load, m.JointSpring):
                self._joint_spring(self.mech.joint(load.joint), load)

    def _spring(self, spring: m.Spring) -> None:
        pa = self.geo.point(spring.a.body, spring.a.xy)
        pb = self.geo.point(spring.b.body, spring.b.xy)
        va = point_velocity(self.velocity(spring.a.body), pa)
        vb = point_velocity(self.velocity(spring.b.body), pb)
        d = self.prog.lets((pb[0] - pa[0], pb[1] - pa[1]))
        length = self.prog.let(sympy.sqrt(dot(d, d)))
        stretch_rate = dot(d, (vb[0] - va[0], vb[1] - va[1])) / length
        value = self.value
        pull = value(spring.k) * (length - value(spring.length))
        pull = self.prog.let((pull + value(spring.damping) * stretch_rate) / length)
        on_a = self.prog.lets(scale(d, pull))
        self.apply_at(spring.a.body, pa, on_a)
        self.apply_at(spring.b.body, pb, scale(on_a, -1))

    def _joint_spring(self, joint: m.Joint, spring: m.JointSpring) -> None:
        value = self.value
        if joint.type == "prismatic":
            q = m.symbol(joint.coordinates[0])
            relative, rate = q, self.speed(joint.coordinates[0])
        else:
            relative = self.geo.angle[joint.child] - self.geo.angle[joint.parent]
            relative -= value(joint.offset)
            rate = self.velocity(joint.child)[0] - self.velocity(joint.parent)[0]
        tension = -value(spring.k) * (relative - value(spring.rest))
        tension = self.prog.let(tension - value(spring.damping) * rate)
        self._joint_load(joint, tension)

    def _joint_load(self, joint: m.Joint, tension: Expr) -> None:
        """Equal and opposite loads on a joint's bodies doing power tension * (joint rate)."""
        if joint.type == "prismatic":
            along = self.prog.lets(self.geo.rotate(joint.parent, self.geo.unit_axis(joint)))
            at = self.geo.origin[joint.child]
            self.apply_at(joint.child, at, scale(along, tension))
            self.apply_at(joint.parent, at, scale(along, -tension))
        else:
            self.apply(joint.child, couple(tension))
            self.apply(joint.parent, couple(-tension))

    def generalized_forces(self, forces: Sequence[Expr]) -> None:
        """Loads equivalent to generalized forces Q on the coordinates (in file order)."""
        remaining = list(forces)
        for joint in self.mech.joints:
            mine = [remaining.pop(0) for _ in joint.coordinates]
            if joint.type == "free":
                self.apply_at(joint.child, self.geo.origin[joint.child], mine[:2])
                self.apply(joint.child, couple(mine[2]))
            elif joint.type == "revolute" and joint.angle == "absolute":
                self.apply(joint.child, couple(mine[0]))
            elif mine:
                self._joint_load(joint, mine[0])

    # -- pass 2: articulated inertias and bias forces -------------------------------------

    def _own_terms(self, node: Node) -> None:
        inertia = ((sympy.S.Zero,) * 3,) * 3
        for body in node.members:
            spec = self.mech.body(body)
            com = self.geo.point(body, spec.com)
            rigid = rigid_inertia(self.value(spec.mass), self.value(spec.inertia), com)
            inertia = tuple(add(a, b) for a, b in zip(inertia, rigid))
        node.inertia = self._symmetric(inertia)  # type: ignore[arg-type]
        external = ZERO3
        for load in node.loads:
            external = add(external, load)
        momentum = mat_vec(node.inertia, node.velocity)
        node.bias_force = add(cross_force(node.velocity, momentum), scale(external, -1))

    def _symmetric(self, a: M3) -> M3:
        upper = {(i, j): self.prog.let(a[i][j]) for i in range(3) for j in range(i, 3)}
        return tuple(tuple(upper[min(i, j), max(i, j)] for j in range(3)) for i in range(3))

    def _articulate(self, node: Node, status: int) -> None:
        """Project the node's articulated inertia through its joint (1 degree of freedom)."""
        axis = node.axes[0]
        node.inertia = self._symmetric(node.inertia)
        node.bias_force = self.prog.lets(node.bias_force)
        node.u_vector = self.prog.lets(mat_vec(node.inertia, axis))
        d = self.prog.let(dot(axis, node.u_vector))
        self.prog.require_positive(d, status)
        node.d_inverse = self.prog.let(1 / d)
        node.u_force = self.prog.let(-dot(axis, node.bias_force))
        if node.parent == m.GROUND:
            return
        u_vec, d_inv = node.u_vector, node.d_inverse
        passed = tuple(
            tuple(node.inertia[i][j] - u_vec[i] * u_vec[j] * d_inv for j in range(3))
            for i in range(3)
        )
        passed = self._symmetric(passed)  # type: ignore[arg-type]
        force = add(node.bias_force, mat_vec(passed, node.bias_acceleration))
        force = add(force, scale(u_vec, node.u_force * d_inv))
        parent = self.nodes[node.parent]
        parent.inertia = tuple(add(a, b) for a, b in zip(parent.inertia, passed))
        parent.bias_force = add(parent.bias_force, force)

    # -- pass 3: accelerations ------------------------------------------------------------

    def _accelerate(self, node: Node, accel: dict[str, V3]) -> list[Expr]:
        """The node's spatial acceleration (into accel) and its coordinates' accelerations."""
        parent_a = ZERO3 if node.parent == m.GROUND else accel[node.parent]
        base = add(parent_a, node.bias_acceleration)
        if node.joint.type == "free":
            return self._free_accelerations(node, accel)
        axis = node.axes[0]
        joint_acc = self.prog.let((node.u_force - dot(node.u_vector, base)) * node.d_inverse)
        accel[node.joint.child] = self.prog.lets(add(base, scale(axis, joint_acc)))
        if node.joint.type == "revolute" and node.joint.angle == "absolute":
            return [accel[node.joint.child][0]]
        return [joint_acc]

    def _free_accelerations(self, node: Node, accel: dict[str, V3]) -> list[Expr]:
        """A free body is a root: I^A a = -p^A gives its spatial acceleration a directly."""
        node.inertia = self._symmetric(node.inertia)
        status = self.mech.joints.index(node.joint) + 1
        a = solve_symmetric(self.prog, node.inertia, scale(node.bias_force, -1), status)
        accel[node.joint.child] = a
        x, y = self.geo.origin[node.joint.child]
        w = add(a, scale(node.bias_acceleration, -1))  # = S qdd
        return [self.prog.let(w[1] - y * w[0]), self.prog.let(w[2] + x * w[0]), w[0]]

    # -- the whole algorithm --------------------------------------------------------------

    def run(self, extra_forces: Sequence[Expr] = ()) -> Program:
        order = list(self.nodes.values())
        for node in order:
            self._motion(node)
        if extra_forces:
            self.generalized_forces(extra_forces)
        else:
            self._loads()
        for node in order:
            self._own_terms(node)
        for node in reversed(order):
            if node.joint.type != "free":
                self._articulate(node, self.mech.joints.index(node.joint) + 1)
        accel: dict[str, V3] = {}
        qdd: dict[str, Expr] = {}
        for node in order:
            values = self._accelerate(node, accel)
            qdd.update(zip(node.joint.coordinates, values))
        return self.prog.finish(qdd[c] for c in self.mech.coordinates)


def solve_symmetric(prog: ProgramBuilder, a: M3, b: V3, status: int) -> V3:
    """x with a x = b for a symmetric positive definite 3 x 3 a, by LDL^T with guarded pivots."""
    n = 3
    low = [[sympy.S.Zero] * n for _ in range(n)]
    diag = [sympy.S.Zero] * n
    for j in range(n):
        d = prog.let(a[j][j] - sum((low[j][k] ** 2 * diag[k] for k in range(j)), sympy.S.Zero))
        prog.require_positive(d, status)
        diag[j] = d
        for i in range(j + 1, n):
            s = a[i][j] - sum((low[i][k] * low[j][k] * diag[k] for k in range(j)), sympy.S.Zero)
            low[i][j] = prog.let(s / d)
    z = list(b)
    for i in range(n):
        z[i] = prog.let(z[i] - sum((low[i][k] * z[k] for k in range(i)), sympy.S.Zero))
    x = [prog.let(z[i] / diag[i]) for i in range(n)]
    for i in reversed(range(n)):
        x[i] = prog.let(x[i] - sum((low[k][i] * x[k] for k in range(i + 1, n)), sympy.S.Zero))
    return tuple(x)  # type: ignore[return-value]


def dynamics_program(mech: m.Mechanism, value: Callable) -> Program:
    """qdd(t, q, dq) for the mechanism's loads: the right-hand side's accelerations."""
    return ArticulatedBody(mech, value).run()


def generalized_force_symbols(n: int) -> tuple[sympy.Symbol, ...]:
    """Q_k as new symbols no name from the file can equal (the emitter prints them as Q[k])."""
    return tuple(sympy.Dummy(f"generalized_force_{k}", real=True) for k in range(n))


def inverse_mass_program(mech: m.Mechanism, value: Callable,
                         forces: Sequence[sympy.Symbol]) -> Program:
    """M^-1 Q at rest with only the generalized forces Q (symbols, one per coordinate)."""
    return ArticulatedBody(mech, value, at_rest=True).run(forces)
