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

What depends on a joint's kind (its placement, motion axes, how its coordinates' accelerations
follow, how a load on it acts) the joint answers itself (nemc/joints/); gravity and the loads of
the YAML (nemc/loads/, Load.act) all enter as spatial forces on bodies. `inverse_mass_program`
runs the same algorithm at rest with only unit generalized forces applied, which gives the
columns of M^-1 for diagnostics.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import sympy

from ..front import mechanism as m
from ..kinds.constraints import Constraint
from ..kinds.joints import Joint
from ..kinds.spatial import (
    M3,
    V2,
    V3,
    ZERO3,
    add,
    couple,
    cross_force,
    dot,
    mat_vec,
    point_force,
    point_velocity,
    rigid_inertia,
    scale,
)
from .kinematics import joints_parent_first, prescribed_motion
from .program import Program, ProgramBuilder

Expr = sympy.Expr


class Geometry:
    """Angles, their cosines and sines, and origins of all bodies, as program names; each
    joint places its child (Joint.place, the placement every derivation uses)."""

    def __init__(self, joints: Sequence[Joint], prog: ProgramBuilder, value: Callable,
                 coordinate: Callable[[str], Expr]):
        self.prog, self.value, self.coordinate = prog, value, coordinate
        zero, one = sympy.S.Zero, sympy.S.One
        self.angle = {m.GROUND: zero}
        self.trig = {m.GROUND: (one, zero)}
        self.origin = {m.GROUND: (zero, zero)}
        for joint in joints_parent_first(joints):
            self._place(joint)

    def _place(self, joint: Joint) -> None:
        coordinates = [self.coordinate(c) for c in joint.coordinates]
        angle, origin = joint.place(ProgramFrame(self, joint.parent), coordinates)
        self.origin[joint.child] = self.prog.lets(origin)  # type: ignore[assignment]
        angle = self.prog.let(angle)
        self.angle[joint.child] = angle
        self.trig[joint.child] = (self.prog.let(sympy.cos(angle)), self.prog.let(sympy.sin(angle)))

    def rotate(self, body: str, xy: Sequence[Expr]) -> V2:
        """A body-frame vector in ground axes."""
        c, s = self.trig[body]
        x, y = (self.value(v) for v in xy)
        return c * x - s * y, s * x + c * y

    def point(self, body: str, xy: Sequence[Expr]) -> V2:
        """Ground position of the point fixed in `body` at body coordinates xy."""
        return self.prog.lets(add(self.origin[body], self.rotate(body, xy)))  # type: ignore


class ProgramFrame:
    """A body's pose for the joints and loads acting in the articulated-body algorithm
    (nemc/kinds/contract.py Frame): every value it makes is named in the program. motion: the
    body's spatial velocity, where the algorithm has computed it."""

    def __init__(self, geo: Geometry, body: str, motion: V3 | None = None):
        self.geo, self.body, self.motion = geo, body, motion

    @property
    def angle(self) -> Expr:
        return self.geo.angle[self.body]

    @property
    def origin(self) -> V2:
        return self.geo.origin[self.body]

    def rotate(self, xy: Sequence[Expr]) -> V2:
        return self.geo.rotate(self.body, xy)

    def point(self, xy: Sequence[Expr]) -> V2:
        return self.geo.point(self.body, xy)

    def velocity(self, xy: Sequence[Expr]) -> V2:
        if self.motion is None:
            raise NotImplementedError("no velocities here: the positions' program")
        return point_velocity(self.motion, self.point(xy))

    def name(self, expr: Expr) -> Expr:
        return self.geo.prog.let(expr)

    def names(self, exprs: Sequence[Expr]) -> tuple[Expr, ...]:
        return self.geo.prog.lets(exprs)


class PointPositions:
    """Ground positions of points fixed in the bodies as names of one straight-line program
    (the drawing's, nemc/emit/positions_c.py): each body placed once from its parent, so the
    program grows linearly with the bodies where whole position expressions grow
    quadratically."""

    def __init__(self, mech: m.Mechanism, value: Callable):
        joints = [joint.map_expressions(value) for joint in mech.joints]
        motions = {joint.coordinates[0]: prescribed_motion(joint)[0]
                   for joint in joints if joint.driven}
        self.prog = ProgramBuilder("g")
        self.geo = Geometry(joints, self.prog, value,
                            lambda name: motions[name] if name in motions else m.symbol(name))

    def position(self, body: str, xy: Sequence[Expr]) -> V2:
        return self.geo.point(body, xy)


@dataclass
class Node:
    """A body with its own degrees of freedom, and the bodies welded to it."""

    joint: Joint
    parent: str  # the parent node's body, or ground
    members: list[str]
    status: int  # what the generated code returns when this node's inertia is singular
    prescribed: Expr | None = None  # a driven joint's acceleration (its coordinate's qdd)
    axes: list[V3] = field(default_factory=list)  # the joint's motion subspace S
    rates: list[Expr] = field(default_factory=list)  # the joint's rates
    velocity: V3 = ZERO3
    bias_acceleration: V3 = ZERO3  # c = dS/dt rate
    inertia: M3 | None = None  # articulated inertia, accumulated from the children
    bias_force: V3 = ZERO3  # p^A, accumulated from the children
    loads: list[V3] = field(default_factory=list)
    u_vectors: list[V3] = field(default_factory=list)  # U = I^A S, a column per axis
    d_inverse: list[list[Expr]] = field(default_factory=list)  # D^-1 = (S^T I^A S)^-1
    u_forces: list[Expr] = field(default_factory=list)  # u = -S^T p^A
    acceleration: V3 = ZERO3  # its body's spatial acceleration (pass 3)


class ArticulatedBody:
    """The three passes over the nodes of one mechanism, writing into one program. Its joints
    and loads have their expressions in runtime symbols (value: constants folded).

    A driven joint's coordinate, rate and acceleration are its motion's (Featherstone's hybrid
    dynamics): its node does not articulate, it hands its whole inertia to its parent with the
    bias of its prescribed acceleration, and its drive is S^T (I^A a + p^A). at_rest: velocities
    and prescribed accelerations zero (the passes of M^-1 times generalized forces)."""

    def __init__(self, mech: m.Mechanism, value: Callable, *, at_rest: bool = False):
        self.mech, self.value, self.at_rest = mech, value, at_rest
        self.joints = {joint.name: joint.map_expressions(value) for joint in mech.joints}
        self.motions = {joint.coordinates[0]: prescribed_motion(joint)
                        for joint in self.joints.values() if joint.driven}
        self.prog = ProgramBuilder()
        self.geo = Geometry(list(self.joints.values()), self.prog, value, self.coordinate)
        self.node_of: dict[str, str] = {m.GROUND: m.GROUND}
        self.nodes: dict[str, Node] = {}
        status = {name: k for k, name in enumerate(self.joints, start=1)}  # file order
        for joint in joints_parent_first(self.joints.values()):
            self._add_body(joint, status[joint.name])

    def _add_body(self, joint: Joint, status: int) -> None:
        if joint.merged:
            node = self.node_of[joint.parent]
            self.node_of[joint.child] = node
            if node != m.GROUND:
                self.nodes[node].members.append(joint.child)
            return
        parent = m.GROUND if joint.floating else self.node_of[joint.parent]
        self.node_of[joint.child] = joint.child
        prescribed = None
        if joint.driven:
            prescribed = sympy.S.Zero if self.at_rest else self.motions[joint.coordinates[0]][2]
        self.nodes[joint.child] = Node(joint, parent, [joint.child], status, prescribed)

    # -- what joints and loads acting here use (nemc/kinds/contract.py: LoadView, LoadSink,
    #    SpatialSink) ------------------------------------------------------------------------

    def frame(self, body: str) -> ProgramFrame:
        """Its pose; its velocities once pass 1 has computed them (loads act after it)."""
        return ProgramFrame(self.geo, body, self.velocity(body))

    def angular_velocity(self, body: str) -> Expr:
        return self.velocity(body)[0]

    def joint(self, name: str) -> Joint:
        return self.joints[name]

    def coordinate(self, name: str) -> Expr:
        """A coordinate's value: its symbol, or a driven coordinate's motion."""
        return self.motions[name][0] if name in self.motions else m.symbol(name)

    def speed(self, coordinate: str) -> Expr:
        if self.at_rest:
            return sympy.S.Zero
        if coordinate in self.motions:
            return self.motions[coordinate][1]
        return m.rate_symbol(coordinate)

    def velocity(self, body: str) -> V3:
        node = self.node_of[body]
        return ZERO3 if node == m.GROUND else self.nodes[node].velocity

    def apply(self, body: str, force: V3) -> None:
        node = self.node_of[body]
        if node != m.GROUND:
            self.nodes[node].loads.append(force)

    def apply_at(self, body: str, at: Sequence[Expr], force: Sequence[Expr]) -> None:
        self.apply(body, point_force(at, force))

    def force(self, body: str, xy: Sequence[Expr], force: Sequence[Expr],
              at: Sequence[Expr] | None = None) -> None:
        self.apply_at(body, self.geo.point(body, xy) if at is None else at, force)

    def couple(self, body: str, torque: Expr) -> None:
        self.apply(body, couple(torque))

    def tension(self, joint: Joint, displacement: Expr, tension: Expr) -> None:
        joint.joint_load(self, self.frame(joint.parent), self.geo.origin[joint.child], tension)

    def generalized(self, joint: Joint, forces: Sequence[Expr]) -> None:
        joint.generalized_load(self, self.frame(joint.parent), self.geo.origin[joint.child],
                               forces)

    # -- pass 1: velocities ---------------------------------------------------------------

    def _motion(self, node: Node) -> None:
        joint, parent_v = node.joint, self.velocity(node.parent)
        speeds = [self.speed(c) for c in joint.coordinates]
        node.axes, node.rates = joint.motion_subspace(self.frame(joint.parent),
                                             self.geo.origin[joint.child], parent_v, speeds)
        relative = ZERO3
        for axis, rate in zip(node.axes, node.rates):
            relative = add(relative, scale(axis, rate))
        node.velocity = self.prog.lets(add(parent_v, relative))  # type: ignore[assignment]
        node.bias_acceleration = self.prog.lets(  # type: ignore[assignment]
            joint.bias_acceleration(node.velocity, relative, node.axes, node.rates))  # type: ignore

    # -- loads ----------------------------------------------------------------------------

    def _loads(self) -> None:
        gx, gy = (self.value(g) for g in self.mech.gravity)
        for body in self.mech.bodies:
            mass = self.value(body.mass)
            self.apply_at(body.name, self.geo.point(body.name, body.com), (mass * gx, mass * gy))
        for load in self.mech.loads:
            load.map_expressions(self.value).act(self, self)

    def generalized_forces(self, forces: Sequence[Expr]) -> None:
        """Loads equivalent to generalized forces Q on the coordinates (in file order)."""
        remaining = list(forces)
        for joint in self.joints.values():
            if joint.driven:  # prescribed: not a coordinate of M
                continue
            mine = [remaining.pop(0) for _ in joint.coordinates]
            joint.generalized_load(self, self.frame(joint.parent), self.geo.origin[joint.child],
                                   mine)

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
            external = add(external, load)  # type: ignore[assignment]
        momentum = mat_vec(node.inertia, node.velocity)
        node.bias_force = add(cross_force(node.velocity, momentum), scale(external, -1))  # type: ignore

    def _symmetric(self, a: M3) -> M3:
        upper = {(i, j): self.prog.let(a[i][j]) for i in range(3) for j in range(i, 3)}
        return tuple(tuple(upper[min(i, j), max(i, j)] for j in range(3)) for i in range(3))  # type: ignore

    def _articulate(self, node: Node) -> None:
        """Project the node's articulated inertia through its joint's motion subspace S (k
        axes): U = I^A S, D = S^T U, u = -S^T p^A, and pass I^A - U D^-1 U^T and
        p^A + I^a c + U D^-1 u to the parent; for a driven joint hand the inertia whole to the
        parent with its prescribed motion's bias."""
        node.inertia = self._symmetric(node.inertia)  # type: ignore[arg-type]
        node.bias_force = self.prog.lets(node.bias_force)  # type: ignore[assignment]
        if node.prescribed is not None:
            if node.parent != m.GROUND:
                moving = add(node.bias_acceleration, scale(node.axes[0], node.prescribed))
                self._pass_to_parent(node, node.inertia,
                                     add(node.bias_force, mat_vec(node.inertia, moving)))
            return
        node.u_vectors = [self.prog.lets(mat_vec(node.inertia, axis))  # type: ignore[misc]
                          for axis in node.axes]
        size = len(node.axes)
        d = {(i, j): self.prog.let(dot(node.axes[i], node.u_vectors[j]))
             for i in range(size) for j in range(i, size)}
        node.d_inverse = inverse_symmetric(self.prog, d, size, node.status)
        node.u_forces = [self.prog.let(-dot(axis, node.bias_force)) for axis in node.axes]
        if node.parent == m.GROUND:
            return
        passed = tuple(
            tuple(node.inertia[i][j] - projected(node.u_vectors, node.d_inverse, i, j)
                  for j in range(3))
            for i in range(3)
        )
        passed = self._symmetric(passed)  # type: ignore[arg-type]
        force = add(node.bias_force, mat_vec(passed, node.bias_acceleration))  # type: ignore
        self._pass_to_parent(node, passed, with_articulated_force(node, node.u_forces, force))

    def _pass_to_parent(self, node: Node, inertia: M3, force: Sequence[Expr]) -> None:
        parent = self.nodes[node.parent]
        parent.inertia = tuple(add(a, b) for a, b in zip(parent.inertia, inertia))  # type: ignore
        parent.bias_force = add(parent.bias_force, force)  # type: ignore[assignment]

    # -- pass 3: accelerations ------------------------------------------------------------

    def _accelerate(self, node: Node, accel: dict[str, V3]) -> list[Expr]:
        """The node's spatial acceleration (into accel) and its coordinates' accelerations (a
        driven joint's: none, they are prescribed)."""
        if node.joint.floating:
            return self._root_accelerations(node, accel)
        parent_a = ZERO3 if node.parent == m.GROUND else accel[node.parent]
        base = add(parent_a, node.bias_acceleration)
        if node.prescribed is not None:
            moving = add(base, scale(node.axes[0], node.prescribed))
            accel[node.joint.child] = self.prog.lets(moving)  # type: ignore[assignment]
            return []
        return self._joint_accelerations(node, node.u_forces, base, accel)

    def _joint_accelerations(self, node: Node, u_forces: Sequence[Expr], base: V3,
                             accel: dict[str, V3]) -> list[Expr]:
        """qdd_S = D^-1 (u - U^T a'), the child's acceleration a' + S qdd_S (into accel), and
        the joint's coordinates' accelerations from them (a' = the parent's plus the bias)."""
        rest = [u - dot(u_vector, base) for u, u_vector in zip(u_forces, node.u_vectors)]
        joint_acc = [self.prog.let(sum((row[b] * rest[b] for b in range(len(rest))),
                                       sympy.S.Zero))
                     for row in node.d_inverse]
        moving = base
        for axis, acc in zip(node.axes, joint_acc):
            moving = add(moving, scale(axis, acc))  # type: ignore[assignment]
        accel[node.joint.child] = self.prog.lets(moving)  # type: ignore[assignment]
        return node.joint.coordinate_accelerations(joint_acc, accel[node.joint.child])

    def _root_accelerations(self, node: Node, accel: dict[str, V3]) -> list[Expr]:
        """A root node: I^A a = -p^A gives its spatial acceleration a directly."""
        node.inertia = self._symmetric(node.inertia)  # type: ignore[arg-type]
        a = solve_symmetric(self.prog, node.inertia, scale(node.bias_force, -1), node.status)  # type: ignore
        accel[node.joint.child] = a
        return node.joint.root_accelerations(a, node.bias_acceleration,
                                             self.geo.origin[node.joint.child], self.prog.let)

    def _drive(self, node: Node, acceleration: V3, bias: V3) -> Expr:
        """The drive of a driven joint: S^T (I^A a + p^A), what its joint transmits along S."""
        return self.prog.let(dot(node.axes[0], add(mat_vec(node.inertia, acceleration), bias)))  # type: ignore

    # -- M^-1 times generalized forces, with this configuration's articulated inertias ------

    def unit_pass(self, constraint: Constraint, equation: int) -> tuple[list[Expr], list[Expr]]:
        """The undriven coordinates' accelerations and the drives under the reaction of a unit
        multiplier of the constraint's equation alone, at rest: M^-1 Phi_q^T e_k for the tree
        with its driven joints held (and what their drives must add). Reuses the articulated
        inertias of the main passes (run first)."""
        sink = PassLoads(self)
        unit = [sympy.S.One if j == equation else sympy.S.Zero
                for j in range(constraint.equations_count)]
        constraint.map_expressions(self.value).act(self, sink, unit)
        order = list(self.nodes.values())
        bias = {node.joint.child: scale(sink.total(node.joint.child), -1) for node in order}
        u_forces: dict[str, list[Expr]] = {}
        for node in reversed(order):
            child = node.joint.child
            bias[child] = self.prog.lets(bias[child])
            if node.joint.floating or node.parent == m.GROUND and node.prescribed is not None:
                continue
            passed = bias[child]
            if node.prescribed is None:
                u_forces[child] = [self.prog.let(-dot(axis, bias[child])) for axis in node.axes]
                if node.parent == m.GROUND:
                    continue
                passed = with_articulated_force(node, u_forces[child], passed)
            bias[node.parent] = add(bias[node.parent], passed)
        qdd: dict[str, Expr] = {}
        drives: dict[str, Expr] = {}
        accel: dict[str, V3] = {}
        for node in order:
            child = node.joint.child
            base = ZERO3 if node.parent == m.GROUND else accel[node.parent]
            if node.joint.floating:
                a = solve_symmetric(self.prog, node.inertia, scale(bias[child], -1), node.status)  # type: ignore
                accel[child] = a
                qdd.update(zip(node.joint.coordinates, node.joint.root_accelerations(
                    a, ZERO3, self.geo.origin[child], self.prog.let)))
            elif node.prescribed is not None:
                accel[child] = base
                drives[node.joint.name] = self._drive(node, base, bias[child])
            else:
                qdd.update(zip(node.joint.coordinates,
                               self._joint_accelerations(node, u_forces[child], base, accel)))
        return ([qdd[c] for c in self.mech.coordinates],
                [drives[joint.name] for joint in self.mech.driven])

    # -- the whole algorithm --------------------------------------------------------------

    def run(self, extra_forces: Sequence[Expr] = (), extra_results: Sequence[Expr] = ()
            ) -> Program:
        """The program of the accelerations of the undriven coordinates (file order), then the
        drives of the driven joints, then for each loop constraint equation its unit pass:
        accelerations and drives, then extra_results (expressions of the state, computed with
        the names the program has). extra_forces: generalized forces applied instead of the
        loads (M^-1 Q, with at_rest)."""
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
            if not node.joint.floating:
                self._articulate(node)
        accel: dict[str, V3] = {}
        qdd: dict[str, Expr] = {}
        drives: dict[str, Expr] = {}
        for node in order:
            values = self._accelerate(node, accel)
            qdd.update(zip(node.joint.coordinates, values))
            if node.prescribed is not None:
                drives[node.joint.name] = self._drive(node, accel[node.joint.child],
                                                      node.bias_force)
        results = [qdd[c] for c in self.mech.coordinates]
        if not extra_forces:
            results += [drives[joint.name] for joint in self.mech.driven]
        for constraint in () if extra_forces else self.mech.constraints:
            for equation in range(constraint.equations_count):
                unit_qdd, unit_drives = self.unit_pass(constraint, equation)
                results += unit_qdd + unit_drives
        return self.prog.finish([*results, *self.prog.reduce(extra_results)])


class PassLoads:
    """The loads of one unit pass of ABA's algorithm, by node: a constraint's reaction
    (LoadSink) or generalized forces (SpatialSink, Joint.generalized_load)."""

    def __init__(self, aba: ArticulatedBody):
        self.aba, self.node_of, self.point = aba, aba.node_of, aba.geo.point
        self.loads: dict[str, list[V3]] = {}

    def apply(self, body: str, force: V3) -> None:
        node = self.node_of[body]
        if node != m.GROUND:
            self.loads.setdefault(node, []).append(force)

    def apply_at(self, body: str, at: Sequence[Expr], force: Sequence[Expr]) -> None:
        self.apply(body, point_force(at, force))

    def force(self, body: str, xy: Sequence[Expr], force: Sequence[Expr],
              at: Sequence[Expr] | None = None) -> None:
        self.apply_at(body, self.point(body, xy) if at is None else at, force)

    def couple(self, body: str, torque: Expr) -> None:
        self.apply(body, couple(torque))

    def tension(self, joint: Joint, displacement: Expr, tension: Expr) -> None:
        raise NotImplementedError("a unit pass carries a constraint's reaction, no tension")

    def generalized(self, joint: Joint, forces: Sequence[Expr]) -> None:
        joint.generalized_load(self, self.aba.frame(joint.parent),
                               self.aba.geo.origin[joint.child], forces)

    def total(self, node: str) -> V3:
        total = ZERO3
        for force in self.loads.get(node, []):
            total = add(total, force)  # type: ignore[assignment]
        return total


def projected(u_vectors: Sequence[V3], d_inverse: Sequence[Sequence[Expr]], i: int, j: int
              ) -> Expr:
    """(U D^-1 U^T)[i][j]."""
    size = len(u_vectors)
    return sum((u_vectors[a][i] * d_inverse[a][b] * u_vectors[b][j]
                for a in range(size) for b in range(size)), sympy.S.Zero)


def with_articulated_force(node: Node, u_forces: Sequence[Expr], force: Sequence[Expr]
                           ) -> tuple[Expr, ...]:
    """force + U D^-1 u: what the joint's own forces u add to what its node passes on."""
    for a, u_vector in enumerate(node.u_vectors):
        weight = sum((node.d_inverse[a][b] * u for b, u in enumerate(u_forces)), sympy.S.Zero)
        force = add(force, scale(u_vector, weight))
    return tuple(force)


def inverse_symmetric(prog: ProgramBuilder, d: dict[tuple[int, int], Expr], size: int,
                      status: int) -> list[list[Expr]]:
    """D^-1 of a symmetric positive definite SIZE x SIZE matrix D (its upper triangle d), by
    LDL^T with guarded pivots (a joint's projected inertia: 1 x 1 for one degree of freedom,
    where it is 1 / d, k x k for a joint of k)."""
    low = [[sympy.S.Zero] * size for _ in range(size)]
    pivots = [sympy.S.Zero] * size
    for j in range(size):
        pivot = prog.let(d[j, j] - sum((low[j][k] ** 2 * pivots[k] for k in range(j)),
                                       sympy.S.Zero))
        prog.require_positive(pivot, status)
        pivots[j] = pivot
        for i in range(j + 1, size):
            entry = d[j, i] - sum((low[i][k] * low[j][k] * pivots[k] for k in range(j)),
                                  sympy.S.Zero)
            low[i][j] = prog.let(entry / pivot)
    columns = []
    for column in range(size):
        z = [sympy.S.One if i == column else sympy.S.Zero for i in range(size)]
        for i in range(size):
            z[i] = prog.let(z[i] - sum((low[i][k] * z[k] for k in range(i)), sympy.S.Zero))
        x = [prog.let(z[i] / pivots[i]) for i in range(size)]
        for i in reversed(range(size)):
            x[i] = prog.let(x[i] - sum((low[k][i] * x[k] for k in range(i + 1, size)),
                                       sympy.S.Zero))
        columns.append(x)
    return [[columns[b][a] for b in range(size)] for a in range(size)]


def solve_symmetric(prog: ProgramBuilder, a: M3, b: V3, status: int) -> V3:
    """x with a x = b for a symmetric positive definite 3 x 3 a, by LDL^T with guarded pivots."""
    n = len(b)
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


def dynamics_program(mech: m.Mechanism, value: Callable,
                     extra_results: Sequence[Expr] = ()) -> Program:
    """qdd(t, q, dq) for the mechanism's loads (the right-hand side's accelerations), then the
    drives of its driven joints, then the unit passes of its loop constraints, then
    extra_results (ArticulatedBody.run)."""
    return ArticulatedBody(mech, value).run(extra_results=extra_results)


def generalized_force_symbols(n: int) -> tuple[sympy.Symbol, ...]:
    """Q_k as new symbols no name from the file can equal (the emitter prints them as Q[k])."""
    return tuple(sympy.Dummy(f"generalized_force_{k}", real=True) for k in range(n))


def inverse_mass_program(mech: m.Mechanism, value: Callable,
                         forces: Sequence[sympy.Symbol]) -> Program:
    """M^-1 Q at rest with only the generalized forces Q (symbols, one per coordinate)."""
    return ArticulatedBody(mech, value, at_rest=True).run(forces)
