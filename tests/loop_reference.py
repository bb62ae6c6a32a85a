"""An independent reference for closed loops and driven joints: Lagrange's equations with
multipliers.

Written from the format spec alone; it shares nothing with nemc's derivation but the validated
model (``nemc.front.validate.load_mechanism``). The tree's M(q) and f(t, q, u) come from the
Lagrangian derivation of tests/reference.py (``ReferenceModel``, over every tree coordinate: a
driven one is an ordinary coordinate there). On top of it, written here:

- the constraint equations Phi(q, t) = 0 from the positions the reference's own kinematics
  (``reference.body_frames``) gives the constraint points:
  revolute  p_a - p_b (ground axes, 2 equations);
  slot      n . (p_a - p_b), n the slot's axis turned +90 degrees, in body(b)'s frame (1);
  prismatic the slot's, and angle(a) - angle(b) - offset (2);
  coupling  q_a - ratio q_b (1; its multiplier the generalized force on q_a, -ratio times it
            on q_b, each across its joint as a drive's, left out of that joint's reaction);
            rolling and knife_edge as their functions below say, an
            equation on the velocities V(q, u, t) taking the row dV/du of Phi_q;
  a driven coordinate q_d - motion(t) (1: rheonomic);
- Phi_q and gamma = -d/dt(Phi_q u + Phi_t) + Phi_q qdd by sympy differentiation;
- the index-1 equations, solved numerically at a state:

      [[M, Phi_q^T], [Phi_q, 0]] [qdd; -lambda] = [f; gamma],  i.e.  M qdd = f + Phi_q^T lambda.

  With Phi written as above, lambda is the reaction the spec names: for a constraint, the force
  of body(b) on body(a) at point a (ground axes; a slot's lambda n; a prismatic's second
  multiplier the couple on body(a)); for a driven coordinate, the generalized force of its
  drive, i.e. the drive torque (revolute) or force along the axis (prismatic) on the child.

The state of ``LoopReference`` is the mechanism's (``Mechanism.state_names``: undriven tree
coordinates and their rates, the book's order); the driven ones are computed from their motion.
Tree-joint reactions are the Newton-Euler balance of the child's subtree (sum of m a_C minus
the loads on it and the constraint forces on it), as tests/test_outputs.py does for trees.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp
import yaml
from reference import Frame, ReferenceModel, body_frames, resolve_parameters

from nemc.front.mechanism import GROUND, TIME, Mechanism, PointRef, symbol
from nemc.kinds.constraints import Constraint
from nemc.kinds.joints import Joint
from nemc.kinds.loads import Force, JointSpring, Spring, Torque

Values = Mapping[str, object]  # name -> number, or an expression (text or sympy) of parameters

ASSEMBLY_TOL = 1e-10  # the spec's: given values must satisfy the constraints to 1e-10


class AssemblyError(ValueError):
    """The constraints cannot hold at the given values; the message names the constraint."""


# ---------------------------------------------------------------------------------------------
# Symbolic pieces


def tree_of(mech: Mechanism) -> Mechanism:
    """The mechanism's spanning tree: no constraints, every joint undriven (so every tree
    coordinate is a coordinate of the Lagrangian)."""
    joints = tuple(dataclasses.replace(j, motion=None) for j in mech.joints)
    return dataclasses.replace(mech, joints=joints, constraints=())


def _column(xy: Sequence[object]) -> sp.Matrix:
    return sp.Matrix([sp.sympify(xy[0]), sp.sympify(xy[1])])


def _rotation(angle: sp.Expr) -> sp.Matrix:
    return sp.Matrix([[sp.cos(angle), -sp.sin(angle)], [sp.sin(angle), sp.cos(angle)]])


def slot_normal(c: Constraint, frames: Mapping[str, Frame]) -> sp.Matrix:
    """The slot's normal in ground axes: its axis (body(b)'s frame) turned +90 degrees."""
    axis = _column(c.axis)
    axis = axis / sp.sqrt(axis[0] ** 2 + axis[1] ** 2)
    return _rotation(frames[c.b.body].angle) * sp.Matrix([-axis[1], axis[0]])


def point_of(ref: PointRef, frames: Mapping[str, Frame]) -> sp.Matrix:
    return frames[ref.body].point(ref.xy)


def time_rate(expr: sp.Matrix, q: Sequence[sp.Symbol], u: Sequence[sp.Symbol]) -> sp.Matrix:
    """d/dt of an expression of q and t."""
    return expr.jacobian(sp.Matrix(q)) * sp.Matrix(u) + sp.diff(expr, TIME)


def material_velocity(frame: Frame, at: sp.Matrix, q, u) -> sp.Matrix:
    """The velocity of the body's material point that is at ground point AT now."""
    omega = time_rate(sp.Matrix([frame.angle]), q, u)[0]
    arm = at - frame.origin
    return time_rate(frame.origin, q, u) + omega * sp.Matrix([-arm[1], arm[0]])


def unit_axis(axis: Sequence[object], angle: sp.Expr) -> sp.Matrix:
    column = _column(axis)
    return _rotation(angle) * column / sp.sqrt(column[0] ** 2 + column[1] ** 2)


def rolling_equations(c: Constraint, frames: Mapping[str, Frame], q, u) -> list[sp.Expr]:
    """A disc rolling (the spec's `rolling`): on a line, its center R from the line on its left
    and s + R (angle(disc) - angle(on)) constant (the distance rolled is the angle turned: the
    constant left out); on a disc, the centers' distance Rb + R (Rb - R inside), and the two
    bodies' material points at the contact moving alike along the tangent (on the velocities).
    Written so the multipliers are the spec's Fn (along the normal, from the surface to the
    disc) and Ft (along the normal turned -90 degrees)."""
    disc = frames[c.disc]
    if c.on is not None:
        other = frames[c.on.body]
        along = unit_axis(c.axis, other.angle)
        normal = sp.Matrix([-along[1], along[0]])
        d = disc.origin - other.point(c.on.xy)
        return [normal.dot(d) - c.radius, along.dot(d) + c.radius * (disc.angle - other.angle)]
    other = frames[c.on_body]
    d = disc.origin - other.origin
    distance = sp.sqrt(d.dot(d))
    e = d / distance
    gap = c.on_radius - c.radius - distance if c.inside else distance - c.on_radius - c.radius
    normal = -e if c.inside else e
    tangent = sp.Matrix([normal[1], -normal[0]])
    contact = other.origin + c.on_radius * e
    slip = material_velocity(disc, contact, q, u) - material_velocity(other, contact, q, u)
    return [gap, tangent.dot(slip)]


def knife_edge_equation(c: Constraint, frames: Mapping[str, Frame], q, u) -> sp.Expr:
    """The point's velocity across the blade (the axis turned +90 degrees, in its body)."""
    frame = frames[c.at.body]
    along = unit_axis(c.axis, frame.angle)
    return sp.Matrix([-along[1], along[0]]).dot(time_rate(frame.point(c.at.xy), q, u))


def on_velocities(c: Constraint) -> tuple[int, ...]:
    """Which of a constraint's equations are on the velocities (the spec: a knife edge's;
    rolling on a disc's second, written so here)."""
    if c.type == "knife_edge":
        return (0,)
    if c.type == "rolling" and c.on is None:
        return (1,)
    return ()


def constraint_equations(c: Constraint, frames: Mapping[str, Frame],
                         joints: Mapping[str, Joint] | None = None,
                         q: Sequence[sp.Symbol] = (), u: Sequence[sp.Symbol] = ()
                         ) -> list[sp.Expr]:
    """Phi of one constraint, written from the spec's table (a coupling's offset, its value
    at the start, left out: the accelerations and multipliers do not depend on it); an
    equation on the velocities (on_velocities) as its expression of q and u."""
    if c.type == "rolling":
        return rolling_equations(c, frames, q, u)
    if c.type == "knife_edge":
        return [knife_edge_equation(c, frames, q, u)]
    if c.type == "coupling":
        assert joints is not None
        q_a, q_b = (symbol(joints[name].coordinates[0]) for name in (c.a, c.b))
        return [q_a - c.ratio * q_b]
    d = point_of(c.a, frames) - point_of(c.b, frames)
    if c.type == "revolute":
        return [d[0], d[1]]
    if c.type not in ("slot", "prismatic"):
        raise ValueError(f"unknown constraint type {c.type!r}")
    n = slot_normal(c, frames)
    equations = [n[0] * d[0] + n[1] * d[1]]
    if c.type == "prismatic":
        equations.append(frames[c.a.body].angle - frames[c.b.body].angle - c.offset)
    return equations


def _subtree(mech: Mechanism, root: str) -> set[str]:
    inside = {root}
    for _ in mech.joints:
        inside |= {j.child for j in mech.joints if j.parent in inside}
    return inside


@dataclass(frozen=True)
class Loads:
    """Every load as point forces (body, point, force; ground frame) and couples (body, couple),
    symbolic in t, q, u and the parameters (gravity included; joint springs on prismatic joints
    as a force pair at the child's origin, as tests/test_outputs.py takes them)."""

    forces: list[tuple[str, sp.Matrix, sp.Matrix]]
    couples: list[tuple[str, sp.Expr]]


def applied_loads(mech: Mechanism, frames: Mapping[str, Frame], rate: Callable) -> Loads:
    gravity = _column(mech.gravity)
    forces = [(b.name, frames[b.name].point(b.com), b.mass * gravity) for b in mech.bodies]
    couples: list[tuple[str, sp.Expr]] = []
    for load in mech.loads:
        if isinstance(load, Torque):
            couples += [(load.body, load.expr), (load.reaction, -load.expr)]
        elif isinstance(load, Force):
            comps = _column(load.components)
            if load.frame == "body":
                comps = _rotation(frames[load.body].angle) * comps
            forces.append((load.body, frames[load.body].point(load.at), comps))
        elif isinstance(load, Spring):
            pa, pb = point_of(load.a, frames), point_of(load.b, frames)
            d = pb - pa
            length = sp.sqrt(d[0] ** 2 + d[1] ** 2)
            pull = load.k * (length - load.length) + load.damping * rate(length)
            forces += [(load.a.body, pa, pull * d / length), (load.b.body, pb, -pull * d / length)]
        elif isinstance(load, JointSpring):
            joint = mech.joint(load.joint)
            if joint.type == "revolute":
                rel = frames[joint.child].angle - frames[joint.parent].angle - joint.offset
                tau = -load.k * (rel - load.rest) - load.damping * rate(rel)
                couples += [(joint.child, tau), (joint.parent, -tau)]
            else:
                s = symbol(joint.coordinates[0])
                axis = _column(joint.axis)
                axis = _rotation(frames[joint.parent].angle) * axis / sp.sqrt(axis.dot(axis))
                tension = -load.k * (s - load.rest) - load.damping * rate(s)
                where = frames[joint.child].origin
                forces += [(joint.child, where, tension * axis),
                           (joint.parent, where, -tension * axis)]
        else:
            raise TypeError(f"unknown load {load!r}")
    return Loads([f for f in forces if f[0] != GROUND], [c for c in couples if c[0] != GROUND])


# ---------------------------------------------------------------------------------------------
# The reference


def _lambdify(args: Sequence[sp.Symbol], exprs: object) -> Callable:
    return sp.lambdify(args, exprs, modules="numpy", cse=True, dummify=True)


class LoopReference:
    """Numeric index-1 equations of a mechanism with constraints and driven joints."""

    def __init__(self, mech: Mechanism, params: Mapping[str, float] | None = None) -> None:
        self.mech = mech
        self.tree = tree_of(mech)
        self.ref = ReferenceModel(self.tree)
        self.params = dict(params or {})
        self.values = resolve_parameters(mech, self.params)
        self.p = self.ref.param_values(self.params)
        lag = self.ref.lagrangian
        self.q, self.u = lag.q, lag.u
        self.coordinates = tuple(self.tree.coordinates)  # every tree coordinate
        self.n = len(self.coordinates)
        self.state_names = mech.state_names
        self.free = np.array([self.coordinates.index(c) for c in mech.coordinates], dtype=int)
        self.driven_joints = mech.driven
        self.driven = np.array([self.coordinates.index(j.coordinates[0]) for j in mech.driven],
                               dtype=int)
        self.frames = body_frames(self.tree)
        self._points: dict[str, Callable] = {}
        self._build_constraints()
        self._build_functions()

    # -- construction -----------------------------------------------------------------------

    def _build_constraints(self) -> None:
        self.rows: dict[str, slice] = {}  # constraint name -> its rows of Phi
        closure: list[sp.Expr] = []
        self.on_velocities: list[int] = []  # rows of Phi on the velocities: V(q, u, t)
        lag = self.ref.lagrangian
        for c in self.mech.constraints:
            equations = constraint_equations(c, self.frames,
                                             {j.name: j for j in self.mech.joints},
                                             lag.q, lag.u)
            self.on_velocities += [len(closure) + k for k in on_velocities(c)]
            self.rows[c.name] = slice(len(closure), len(closure) + len(equations))
            closure += equations
        self.closure = sp.Matrix(closure) if closure else sp.zeros(0, 1)
        self.m_closure = len(closure)
        motions = [j.motion for j in self.driven_joints]
        drives = [symbol(j.coordinates[0]) - m for j, m in zip(self.driven_joints, motions)]
        self.Phi = sp.Matrix([*closure, *drives]) if closure or drives else sp.zeros(0, 1)
        args = (TIME, *self.p_symbols)
        self._motion = _lambdify(args, [[m, sp.diff(m, TIME), sp.diff(m, TIME, 2)]
                                        for m in motions])

    @property
    def p_symbols(self) -> tuple[sp.Symbol, ...]:
        return self.ref.param_symbols

    def _build_functions(self) -> None:
        q, u = sp.Matrix(self.q), sp.Matrix(self.u)
        args = (TIME, *self.q, *self.u, *self.p_symbols)
        self.args = args
        Phi_q = self.Phi.jacobian(q) if self.Phi.rows else sp.zeros(0, self.n)
        velocity = Phi_q * u + sp.diff(self.Phi, TIME)
        for k in self.on_velocities:  # V(q, u, t): its row of Phi_q is dV/du; V its velocity
            Phi_q[k, :] = sp.Matrix([self.Phi[k]]).jacobian(u)
            velocity[k] = self.Phi[k]
        gamma = -(velocity.jacobian(q) * u + sp.diff(velocity, TIME)) if self.Phi.rows \
            else sp.zeros(0, 1)
        self.Phi_q, self.gamma = Phi_q, gamma
        self._kkt = _lambdify(args, [self.ref.M, self.ref.f, Phi_q, gamma])
        closure_q = Phi_q[:self.m_closure, :] if self.m_closure else sp.zeros(0, self.n)
        closure = sp.Matrix([0 if k in self.on_velocities else v
                             for k, v in enumerate(self.closure)])
        self._closure = _lambdify(args, [closure, closure_q])
        lag = self.ref.lagrangian
        self._energy = _lambdify(args, [lag.T, lag.V, lag.Q])
        self._kinematics = _lambdify(args, self._kinematic_exprs())
        loads = applied_loads(self.tree, self.frames, lag.rate)
        self._loads = _lambdify(args, [[f[1], f[2]] for f in loads.forces]
                                + [[c[1]] for c in loads.couples])
        self.load_bodies = [f[0] for f in loads.forces] + [c[0] for c in loads.couples]
        self.n_forces = len(loads.forces)

    def _kinematic_exprs(self) -> list:
        """Per body: com position, its Jacobian and bias acceleration, angle, its Jacobian and
        bias; per constraint: its normal and body(a)'s angle (for the reaction's axes)."""
        q, u = sp.Matrix(self.q), sp.Matrix(self.u)
        out: list = []
        for body in self.mech.bodies:
            frame = self.frames[body.name]
            for value in (frame.point(body.com), sp.Matrix([frame.angle])):
                jac = value.jacobian(q)
                out += [value, jac, (jac * u).jacobian(q) * u]
        for c in self.mech.constraints:
            if c.type in ("coupling", "rolling", "knife_edge"):  # its reactions: multipliers
                out += [sp.Matrix([1, 0]), sp.S.Zero]
                continue
            normal = slot_normal(c, self.frames) if c.type != "revolute" else sp.Matrix([1, 0])
            out += [normal, self.frames[c.a.body].angle]
        for joint in self.mech.joints:
            out += [self.frames[joint.child].origin, self.frames[joint.child].angle,
                    self._joint_axis(joint)]
        return out

    def _joint_axis(self, joint) -> sp.Matrix:
        if joint.type != "prismatic":
            return sp.Matrix([0, 0])
        axis = _column(joint.axis)
        return _rotation(self.frames[joint.parent].angle) * axis / sp.sqrt(axis.dot(axis))

    # -- states -----------------------------------------------------------------------------

    def motion(self, t: float) -> np.ndarray:
        """(n_driven, 3): each driven coordinate's value, rate and acceleration at t."""
        return np.array(self._motion(t, *self.p), dtype=float).reshape(len(self.driven), 3)

    def full(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every tree coordinate and rate at (t, y): the state's, and the driven ones' motion."""
        y = np.asarray(y, dtype=float)
        q, u = np.zeros(self.n), np.zeros(self.n)
        q[self.free], u[self.free] = y[0::2], y[1::2]
        if len(self.driven):
            m = self.motion(t)
            q[self.driven], u[self.driven] = m[:, 0], m[:, 1]
        return q, u

    def _args(self, t: float, q: np.ndarray, u: np.ndarray) -> tuple:
        return (t, *q, *u, *self.p)

    # -- the index-1 equations ----------------------------------------------------------------

    def solve(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(qdd of every tree coordinate, lambda of every row of Phi) at (t, y)."""
        q, u = self.full(t, y)
        M, f, Phi_q, gamma = self._kkt(*self._args(t, q, u))
        M = np.asarray(M, dtype=float).reshape(self.n, self.n)
        f = np.asarray(f, dtype=float).reshape(self.n)
        m = self.Phi.rows
        A = np.zeros((self.n + m, self.n + m))
        A[:self.n, :self.n] = M
        if m:
            Phi_q = np.asarray(Phi_q, dtype=float).reshape(m, self.n)
            A[:self.n, self.n:] = Phi_q.T
            A[self.n:, :self.n] = Phi_q
        rhs = np.concatenate([f, np.asarray(gamma, dtype=float).reshape(m)])
        try:
            x = np.linalg.solve(A, rhs)
        except np.linalg.LinAlgError:  # redundant constraints: qdd still unique, lambda the
            x = np.linalg.lstsq(A, rhs, rcond=1e-12)[0]  # least-norm (0 on a zero row)
        return x[:self.n], -x[self.n:]

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        qdd, _ = self.solve(t, y)
        y = np.asarray(y, dtype=float)
        dy = np.empty(len(y))
        dy[0::2], dy[1::2] = y[1::2], qdd[self.free]
        return dy

    def multipliers(self, t: float, y: np.ndarray) -> dict[str, np.ndarray]:
        """Constraint name -> its multipliers (revolute: Fx, Fy; slot: the normal force;
        prismatic: the normal force and the couple on body(a))."""
        _, lam = self.solve(t, y)
        return {name: lam[rows] for name, rows in self.rows.items()}

    def drives(self, t: float, y: np.ndarray) -> dict[str, float]:
        """Driven joint name -> the torque or force of its drive on the child."""
        _, lam = self.solve(t, y)
        return {j.name: float(lam[self.m_closure + k]) for k, j in enumerate(self.driven_joints)}

    # -- constraints at a state ---------------------------------------------------------------

    def residual(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The loop constraints' position residual Phi and velocity residual Phi_q qdot."""
        q, u = self.full(t, y)
        Phi, Phi_q = self._closure(*self._args(t, q, u))
        Phi = np.asarray(Phi, dtype=float).reshape(self.m_closure)
        Phi_q = np.asarray(Phi_q, dtype=float).reshape(self.m_closure, self.n)
        return Phi, Phi_q @ u

    def _closure_at(self, t: float, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        Phi, Phi_q = self._closure(*self._args(t, q, np.zeros(self.n)))
        return (np.asarray(Phi, dtype=float).reshape(self.m_closure),
                np.asarray(Phi_q, dtype=float).reshape(self.m_closure, self.n))

    def degrees_of_freedom(self, t: float, y: np.ndarray) -> int:
        q, _ = self.full(t, y)
        _, Phi_q = self._closure_at(t, q)
        rank = np.linalg.matrix_rank(Phi_q[:, self.free]) if self.m_closure else 0
        return len(self.free) - int(rank)

    def _value(self, value: object) -> float:
        expr = sp.sympify(value)
        return float(expr.xreplace({symbol(k): sp.Float(v) for k, v in self.values.items()}))

    def assemble(self, t: float, initial: Values, guess: Values | None = None) -> np.ndarray:
        """The consistent state at t: given coordinates and rates kept, the others solved from
        the constraints (positions by Gauss-Newton from `guess`, default 0; rates by least
        squares). Raises AssemblyError naming the constraint that cannot hold."""
        guess = dict(guess or {})
        q, u = self.full(t, np.zeros(2 * len(self.free)))
        given_q, given_u = set(), set()
        for name, value in initial.items():
            if name.startswith("dot("):
                k = self.coordinates.index(name[4:-1])
                u[k] = self._value(value)
                given_u.add(k)
            else:
                k = self.coordinates.index(name)
                q[k] = self._value(value)
                given_q.add(k)
        for name, value in guess.items():
            k = self.coordinates.index(name)
            if k not in given_q:
                q[k] = self._value(value)
        unknown = [k for k in self.free if k not in given_q]
        q = self._solve_positions(t, q, unknown)
        unknown_u = [k for k in self.free if k not in given_u]
        u = self._solve_rates(t, q, u, unknown_u)
        y = np.empty(2 * len(self.free))
        y[0::2], y[1::2] = q[self.free], u[self.free]
        return y

    def _worst(self, Phi: np.ndarray) -> str:
        k = int(np.argmax(np.abs(Phi)))
        return next(name for name, rows in self.rows.items() if rows.start <= k < rows.stop)

    def _solve_positions(self, t: float, q: np.ndarray, unknown: list[int]) -> np.ndarray:
        if not self.m_closure:
            return q
        q = q.copy()
        for _ in range(100):
            Phi, Phi_q = self._closure_at(t, q)
            if not unknown:
                break
            step = np.linalg.lstsq(Phi_q[:, unknown], -Phi, rcond=None)[0]
            q[unknown] += step
            if np.max(np.abs(step)) <= 1e-15 * (1 + np.max(np.abs(q))):
                break
        Phi, _ = self._closure_at(t, q)
        if not np.all(np.isfinite(Phi)) or np.max(np.abs(Phi)) > ASSEMBLY_TOL:
            raise AssemblyError(f"constraint {self._worst(Phi)!r} cannot hold: residual "
                                f"{np.max(np.abs(Phi)):.3g}")
        return q

    def _solve_rates(self, t: float, q: np.ndarray, u: np.ndarray,
                     unknown: list[int]) -> np.ndarray:
        if not self.m_closure:
            return u
        u = u.copy()
        _, Phi_q = self._closure_at(t, q)
        if unknown:
            u[unknown] = np.linalg.lstsq(Phi_q[:, unknown], -(Phi_q @ u - Phi_q[:, unknown]
                                                               @ u[unknown]), rcond=None)[0]
        velocity = Phi_q @ u
        if np.max(np.abs(velocity)) > ASSEMBLY_TOL * (1 + np.max(np.abs(u))):
            raise AssemblyError(f"constraint {self._worst(velocity)!r} cannot hold: velocity "
                                f"residual {np.max(np.abs(velocity)):.3g}")
        return u

    def initial_state(self) -> np.ndarray:
        """The scene's initial state: `initial` kept, the rest assembled from `guess`."""
        scene = self.mech.simulation
        t0 = float(scene.t_span[0]) if scene.t_span else 0.0
        return self.assemble(t0, scene.initial, scene.guess)

    def project(self, t: float, y: np.ndarray) -> np.ndarray:
        """y moved onto the constraints: q by Gauss-Newton (minimum-norm steps), then qdot by
        the orthogonal projection onto Phi_q qdot = 0 (driven coordinates held)."""
        if not self.m_closure:
            return np.asarray(y, dtype=float)
        q, u = self.full(t, y)
        free = self.free
        for _ in range(6):
            Phi, Phi_q = self._closure_at(t, q)
            if np.max(np.abs(Phi)) <= 1e-15:
                break
            q[free] -= np.linalg.lstsq(Phi_q[:, free], Phi, rcond=None)[0]
        _, Phi_q = self._closure_at(t, q)
        u[free] -= np.linalg.lstsq(Phi_q[:, free], Phi_q @ u, rcond=None)[0]
        out = np.empty(len(y))
        out[0::2], out[1::2] = q[free], u[free]
        return out

    # -- energy and power ---------------------------------------------------------------------

    def energies(self, t: float, y: np.ndarray) -> tuple[float, float]:
        """(kinetic, potential: gravity and springs) of the whole tree, driven bodies included."""
        q, u = self.full(t, y)
        T, V, _ = self._energy(*self._args(t, q, u))
        return float(T), float(V)

    def energy(self, t: float, y: np.ndarray) -> float:
        return sum(self.energies(t, y))

    def power_in(self, t: float, y: np.ndarray) -> tuple[float, float]:
        """(power of the drives sum lambda_d qdot_d, power of the loads Q . qdot): along a
        motion, d(kinetic + potential)/dt is their sum (the loop constraints do no work)."""
        q, u = self.full(t, y)
        _, _, Q = self._energy(*self._args(t, q, u))
        Q = np.asarray(Q, dtype=float).reshape(self.n)
        drives = self.drives(t, y)
        drive = sum(drives[j.name] * u[k] for j, k in zip(self.driven_joints, self.driven))
        return float(drive), float(Q @ u)

    # -- outputs ------------------------------------------------------------------------------

    def outputs(self, t: float, y: np.ndarray) -> dict[str, float]:
        """The scene's outputs (driven coordinates, reactions, drives, energy, points; the spec's
        names), computed here: constraint reactions from the multipliers, tree-joint reactions
        from the Newton-Euler balance of the child's subtree."""
        qdd, lam = self.solve(t, y)
        q, u = self.full(t, y)
        args = self._args(t, q, u)
        kin = [np.asarray(v, dtype=float) for v in self._kinematics(*args)]
        bodies = self._body_motion(kin, qdd)
        constraint_forces = self._constraint_forces(kin, lam, bodies)
        wanted, out = self.mech.outputs, {}
        for k in self.driven:  # every run reports the driven coordinates and their rates
            name = self.coordinates[k]
            out.update({name: float(q[k]), f"dot({name})": float(u[k])})
        for name in wanted.reactions:
            if any(c.name == name for c in self.mech.constraints):
                out.update(self._constraint_reaction(name, constraint_forces))
            else:
                out.update(self._joint_reaction(name, args, kin, bodies, constraint_forces, lam))
        drives = {j.name: float(lam[self.m_closure + k]) for k, j in enumerate(self.driven_joints)}
        for name in wanted.drives:
            out[f"{name}.drive"] = drives[name]
        if wanted.energy:
            kinetic, potential = self.energies(t, y)
            out.update({"energy.kinetic": kinetic, "energy.potential": potential,
                        "energy.total": kinetic + potential})
        for point in wanted.points:
            r, v = self._point(point, args)
            out.update({f"{point.label}.x": float(r[0]), f"{point.label}.y": float(r[1]),
                        f"{point.label}.vx": float(v[0]), f"{point.label}.vy": float(v[1])})
        return out

    def _point(self, point: PointRef, args: tuple) -> tuple[np.ndarray, np.ndarray]:
        """Ground position and velocity of a point fixed in a body (lambdified on first use)."""
        if point.label not in self._points:
            value = point_of(point, self.frames)
            velocity = value.jacobian(sp.Matrix(self.q)) * sp.Matrix(self.u)
            self._points[point.label] = _lambdify(self.args, [value, velocity])
        r, v = self._points[point.label](*args)
        return np.ravel(np.asarray(r, dtype=float)), np.ravel(np.asarray(v, dtype=float))

    def _body_motion(self, kin: list[np.ndarray], qdd: np.ndarray) -> dict[str, tuple]:
        """Body -> (com position, com acceleration, angular acceleration)."""
        out = {}
        for i, body in enumerate(self.mech.bodies):
            r, jr, br, _, ja, ba = kin[6 * i:6 * i + 6]
            accel = jr.reshape(2, self.n) @ qdd + np.ravel(br)
            alpha = float(ja.reshape(self.n) @ qdd + np.ravel(ba)[0])
            out[body.name] = (np.ravel(r), accel, alpha)
        return out

    def _constraint_forces(self, kin, lam, bodies) -> dict[str, tuple]:
        """Constraint -> (force on body(a) at point a, couple on body(a), point a, its axes)."""
        base = 6 * len(self.mech.bodies)
        out = {}
        for i, c in enumerate(self.mech.constraints):
            normal, angle_a = np.ravel(kin[base + 2 * i]), float(kin[base + 2 * i + 1])
            mult = lam[self.rows[c.name]]
            if c.type in ("coupling", "rolling", "knife_edge"):  # the multipliers, as they are
                out[c.name] = (np.zeros(2), 0.0, 0.0, np.asarray(mult, dtype=float))
                continue
            force = mult[:2] if c.type == "revolute" else mult[0] * normal
            couple = float(mult[1]) if c.type == "prismatic" else 0.0
            out[c.name] = (np.asarray(force, dtype=float), couple, angle_a)
        return out

    def _constraint_reaction(self, name: str, forces: dict) -> dict[str, float]:
        kind = self.mech.constraint(name).type
        if kind in ("coupling", "rolling", "knife_edge"):
            suffixes = {"coupling": ("Q",), "rolling": ("Fn", "Ft"), "knife_edge": ("Fn",)}[kind]
            return {f"{name}.{suffix}": float(value)
                    for suffix, value in zip(suffixes, forces[name][3])}
        force, couple, angle = forces[name]
        out = self._named(name, force, angle)
        if self.mech.constraint(name).type == "prismatic":
            out[f"{name}.M"] = couple
        return out

    @staticmethod
    def _named(name: str, force: np.ndarray, angle: float) -> dict[str, float]:
        n = np.array([math.cos(angle), math.sin(angle)])
        tt = np.array([-math.sin(angle), math.cos(angle)])
        return {f"{name}.Fx": float(force[0]), f"{name}.Fy": float(force[1]),
                f"{name}.Fn": float(force @ n), f"{name}.Ft": float(force @ tt)}

    def _joint_reaction(self, name, args, kin, bodies, constraint_forces, lam) -> dict:
        """Force (and couple about the child's origin) of the parent on the child's subtree:
        sum(m a_C) - the loads on it - the constraint forces on it; a driven joint's drive
        left out."""
        joint = self.mech.joint(name)
        inside = _subtree(self.mech, joint.child)
        j = [jt.name for jt in self.mech.joints].index(name)
        base = 6 * len(self.mech.bodies) + 2 * len(self.mech.constraints) + 3 * j
        origin, angle = np.ravel(kin[base]), float(kin[base + 1])
        axis = np.ravel(kin[base + 2])
        force, moment = np.zeros(2), 0.0
        for body in self.mech.bodies:
            if body.name not in inside:
                continue
            mass, inertia = self._value(body.mass), self._value(body.inertia)
            r, a, alpha = bodies[body.name]
            force += mass * a
            moment += inertia * alpha + _cross(r - origin, mass * a)
        loads = self._loads(*args)
        for k, body in enumerate(self.load_bodies):
            if body not in inside:
                continue
            if k < self.n_forces:
                where, f = (np.ravel(np.asarray(v, dtype=float)) for v in loads[k])
                force -= f
                moment -= _cross(where - origin, f)
            else:
                moment -= float(np.ravel(np.asarray(loads[k], dtype=float))[0])
        for c in self.mech.constraints:
            if c.type == "coupling":  # generalized forces on its joints' coordinates, each
                # across its joint as a drive's: left out of that joint's reaction
                q_a = float(constraint_forces[c.name][3][0])
                shares = {c.a: q_a, c.b: -self._value(c.ratio) * q_a}
                if name in shares and joint.type == "prismatic":
                    force -= shares[name] * axis
                elif name in shares:
                    moment -= shares[name]
                continue
            if c.type in ("rolling", "knife_edge"):
                raise NotImplementedError("this oracle has no tree-joint reactions beside a "
                                          f"{c.type} constraint")
            f, couple, _ = constraint_forces[c.name]
            where = self._point(c.a, args)[0]  # where its force acts on both bodies
            for body, sign in ((c.a.body, 1.0), (c.b.body, -1.0)):
                if body in inside:
                    force -= sign * f
                    moment -= sign * (_cross(where - origin, f) + couple)
        if joint.driven:
            drive = float(lam[self.m_closure + list(self.driven_joints).index(joint)])
            if joint.type == "prismatic":
                force -= drive * axis
            else:
                moment -= drive
        out = self._named(name, force, angle)
        if joint.type in ("prismatic", "weld"):
            out[f"{name}.M"] = moment
        return out


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


# ---------------------------------------------------------------------------------------------
# Seeded random four-bars and closed chains


def _r(value: float) -> float:
    return round(float(value), 4)


def _wrap(angle: float) -> float:
    return float((angle + math.pi) % (2 * math.pi) - math.pi)


@dataclass(frozen=True)
class RandomFourbar:
    """A random Grashof crank-rocker: its YAML and its two assemblies at the scene's q1."""

    text: str
    q1: float
    branches: dict[str, tuple[float, float]]  # "open" / "crossed" -> (q2, q3), wrapped
    constraint_a: str  # the body of the constraint's point a ("rocker" or "coupler")


class _FourbarBuilder:
    """Links: ground AD (tilted, anywhere), crank AB (the shortest), coupler BC, rocker DC.
    Joint offsets, relative or absolute coupler angle, mass-centre offsets and the order of
    the constraint's points are random; loads (a damped torque on the crank, a spring, a force
    on the rocker) when asked."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng
        while True:
            L0, L1, L2, L3 = (_r(rng.uniform(lo, hi)) for lo, hi in
                              ((0.8, 1.2), (0.15, 0.3), (0.8, 1.3), (0.6, 1.0)))
            s, *_, long = sorted((L0, L1, L2, L3))
            if s == L1 and s + long <= L0 + L1 + L2 + L3 - s - long - 0.1:  # Grashof, margin
                break
        self.L = (L0, L1, L2, L3)
        self.A = np.array([_r(rng.uniform(-0.3, 0.3)), _r(rng.uniform(-0.3, 0.3))])
        self.tilt = _r(rng.uniform(-0.5, 0.5))
        self.D = self.A + L0 * np.array([math.cos(self.tilt), math.sin(self.tilt)])
        self.D = np.round(self.D, 4)
        self.offsets = [_r(rng.uniform(-1, 1)) if rng.random() < 0.5 else 0.0 for _ in range(3)]
        self.absolute = bool(rng.random() < 0.5)

    def angles(self, q1: float) -> dict[str, tuple[float, float]]:
        """The two assemblies (q2, q3) at crank coordinate q1, by circle intersection."""
        L0, L1, L2, L3 = self.L
        o1, o2, o3 = self.offsets
        th1 = q1 + o1
        B = self.A + L1 * np.array([math.cos(th1), math.sin(th1)])
        d = float(np.hypot(*(self.D - B)))
        a = (L2**2 - L3**2 + d**2) / (2 * d)
        h = math.sqrt(L2**2 - a**2)
        e = (self.D - B) / d
        out = {}
        for sign in (1.0, -1.0):
            C = B + a * e + sign * h * np.array([-e[1], e[0]])
            th2 = math.atan2(*(C - B)[::-1])
            th3 = math.atan2(*(C - self.D)[::-1])
            q2 = th2 - o2 - (0.0 if self.absolute else th1)
            opposite = _cross(self.D - B, self.A - B) * _cross(self.D - B, C - B) < 0
            out["open" if opposite else "crossed"] = (_wrap(q2), _wrap(th3 - o3))
        return out

    def data(self, name: str, loads: bool, q1: float, w1: float, guess: tuple) -> dict:
        rng = self.rng
        L0, L1, L2, L3 = self.L
        params: dict[str, object] = {"L0": L0, "L1": L1, "L2": L2, "L3": L3, "g": 9.81}
        bodies = {}
        for i, (body, length) in enumerate((("crank", L1), ("coupler", L2), ("rocker", L3)), 1):
            params[f"m{i}"] = _r(rng.uniform(0.5, 2.0))
            point = "B" if body == "crank" else "C"
            bodies[body] = {"mass": f"m{i}",
                            "inertia": f"m{i}*L{i}**2/12*{_r(rng.uniform(0.8, 1.5))}",
                            "com": [f"L{i}/2", _r(rng.uniform(-0.1, 0.1))],
                            "points": {point: [f"L{i}", 0], "P": [_r(rng.uniform(0, length)),
                                                                  _r(rng.uniform(-0.2, 0.2))]}}
        o1, o2, o3 = self.offsets
        joints = {
            "A": {"type": "revolute", "parent": GROUND, "child": "crank",
                  "at": [float(self.A[0]), float(self.A[1])], "coordinate": "q1", "offset": o1},
            "B": {"type": "revolute", "parent": "crank", "child": "coupler", "at": "B",
                  "coordinate": "q2", "offset": o2,
                  "angle": "absolute" if self.absolute else "relative"},
            "D": {"type": "revolute", "parent": GROUND, "child": "rocker",
                  "at": [float(self.D[0]), float(self.D[1])], "coordinate": "q3", "offset": o3},
        }
        ends = ["rocker.C", "coupler.C"]
        if rng.random() < 0.5:
            ends.reverse()
        data: dict[str, object] = {
            "name": name, "description": "seeded random Grashof crank-rocker four-bar",
            "parameters": params, "gravity": [_r(rng.uniform(-0.3, 0.3)), "-g"],
            "bodies": bodies, "joints": joints,
            "constraints": {"C": {"type": "revolute", "a": ends[0], "b": ends[1]}},
            "outputs": {"reactions": ["A", "B", "D", "C"], "energy": True,
                        "points": ["coupler.P"]},
            "simulation": {"t_span": [0, 2], "initial": {"q1": _r(q1), "dot(q1)": _r(w1)},
                           "guess": {"q2": _r(guess[0]), "q3": _r(guess[1])},
                           "method": "DOP853", "rtol": 1e-10, "atol": 1e-12}}
        if loads:
            data["loads"] = [
                {"torque": f"{_r(rng.uniform(-2, 2))} - {_r(rng.uniform(0.05, 0.3))}*dot(q1)",
                 "body": "crank"},
                {"spring": {"a": "coupler.P", "b": {"body": GROUND, "at": [0.5, 1.2]},
                            "k": _r(rng.uniform(5, 30)), "length": _r(rng.uniform(0.3, 0.8)),
                            "damping": _r(rng.uniform(0, 0.5))}},
                {"force": [f"{_r(rng.uniform(-1, 1))}*sin(3*t)", _r(rng.uniform(-1, 1))],
                 "body": "rocker", "at": "P", "frame": "body"},
            ]
        return data


def random_fourbar(rng: np.random.Generator, name: str = "random_fourbar", loads: bool = True,
                   branch: str = "open") -> RandomFourbar:
    """A seeded random crank-rocker whose scene assembles on `branch` (its guess is the branch's
    angles moved by up to 0.15 rad)."""
    builder = _FourbarBuilder(rng)
    q1 = float(rng.uniform(-math.pi, math.pi))
    branches = builder.angles(q1)
    guess = tuple(v + float(rng.uniform(-0.15, 0.15)) for v in branches[branch])
    data = builder.data(name, loads, q1, float(rng.uniform(-3, 3)), guess)
    q1 = data["simulation"]["initial"]["q1"]
    text = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    a_body = data["constraints"]["C"]["a"].split(".")[0]
    return RandomFourbar(text, q1, builder.angles(q1), a_body)


SLIDER_PIN = ("  S: {type: revolute, parent: rod, child: slider, at: end, coordinate: q3, "
              "angle: absolute}")
SLIDER_GUIDE = ("guide: {type: prismatic, a: slider.origin, b: {body: ground, at: [0, 0]}, "
                "axis: [1, 0]}")


def slider_crank_variants(text: str) -> dict[str, str]:
    """The slider_crank example with its slider held otherwise: "prismatic_joint", a prismatic
    joint to the ground (coordinate x) with a revolute constraint `pin` at the rod's end;
    "slot", a slot instead of the prismatic constraint (the slider's tilt q3 then free and,
    its mass centre on the pin, decoupled: it spins at its initial rate 3 rad/s)."""
    for needed in (SLIDER_PIN, SLIDER_GUIDE, "reactions: [O, guide]", "guess: {q2: 0, q3: 0}",
                   "name: slider_crank", "initial: {q1: pi/4, dot(q1): 0}"):
        if needed not in text:
            raise ValueError(f"slider_crank.yaml changed: {needed!r} not found")
    joint = (text.replace(SLIDER_PIN, "  S: {type: prismatic, parent: ground, child: slider, "
                                      "coordinate: x}")
             .replace(SLIDER_GUIDE, "pin: {type: revolute, a: rod.end, b: slider.origin}")
             .replace("reactions: [O, guide]", "reactions: [O, S, pin]")
             .replace("guess: {q2: 0, q3: 0}", "guess: {q2: 0, x: 0.4}")
             .replace("name: slider_crank", "name: slider_crank_joint"))
    slot = (text.replace(SLIDER_GUIDE, SLIDER_GUIDE.replace("type: prismatic", "type: slot"))
            .replace("initial: {q1: pi/4, dot(q1): 0}",
                     "initial: {q1: pi/4, dot(q1): 0, dot(q3): 3}")
            .replace("name: slider_crank", "name: slider_crank_slot"))
    return {"prismatic_joint": joint, "slot": slot}


def closed_chain_yaml(n_links: int, closed: bool = True, name: str | None = None) -> str:
    """n uniform links (m = 1, L = 1, relative angles) from a ground pivot at O, under gravity;
    closed: the last link's tip pinned to the ground (a revolute constraint) where the scene's
    initial configuration puts it, so the file's initial values assemble exactly. An
    (n + 1)-bar linkage with n - 2 degrees of freedom; open: the same bodies as a plain chain."""
    angles = [-0.3] + [2 * 0.3 / (n_links - 1)] * (n_links - 1)  # an arch from O
    absolute = np.cumsum(angles)
    tip = np.sum([np.cos(absolute), np.sin(absolute)], axis=1)
    lines = [f"name: {name or ('closed' if closed else 'open') + str(n_links)}",
             f"description: {n_links} links, {'closed to the ground' if closed else 'open'}",
             "parameters: {m: 1, L: 1, g: 9.81}", "gravity: [0, -g]", "bodies:"]
    for i in range(1, n_links + 1):
        lines.append(f"  link{i}: {{mass: m, inertia: m*L**2/12, com: [L/2, 0], "
                     "points: {tip: [L, 0]}}")
    lines.append("joints:")
    for i in range(1, n_links + 1):
        parent, at = ("ground", "[0, 0]") if i == 1 else (f"link{i - 1}", "tip")
        lines.append(f"  J{i}: {{type: revolute, parent: {parent}, child: link{i}, at: {at}, "
                     f"coordinate: q{i}}}")
    if closed:
        lines += ["constraints:", f"  E: {{type: revolute, a: link{n_links}.tip, b: {{body: "
                  f"ground, at: [{float(tip[0])!r}, {float(tip[1])!r}]}}}}"]
    initial = ", ".join(f"q{i}: {angles[i - 1]!r}" for i in range(1, n_links + 1))
    lines += ["simulation:", "  t_span: [0, 10]", f"  initial: {{{initial}}}",
              "  method: DOP853", "  rtol: 1.0e-9", "  atol: 1.0e-11"]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------
# Integration with projection (the index-1 form plus projection after every step)


@dataclass
class ProjectedRun:
    t: np.ndarray
    y: np.ndarray  # (n_state, n_t)
    nfev: int
    steps: int


def projected_run(rhs: Callable, project: Callable, t_span: Sequence[float], y0: np.ndarray,
                  rtol: float, atol: float, t_eval: Sequence[float] | None = None
                  ) -> ProjectedRun:
    """scipy's DOP853, step by step; after every step the state is projected onto the
    constraints (``project(t, y)``) and the solver restarts its step from there (its stored
    derivative recomputed: one more evaluation per step). States at t_eval are the step's dense
    output, projected. Without t_eval: the projected state after each step."""
    from scipy.integrate import DOP853

    t0, t1 = (float(v) for v in t_span)
    solver = DOP853(rhs, t0, np.asarray(y0, dtype=float), t1, rtol=rtol, atol=atol)
    times = None if t_eval is None else np.asarray(t_eval, dtype=float)
    out_t: list[float] = [t0] if times is None or times[0] == t0 else []
    out_y: list[np.ndarray] = [solver.y.copy()] if out_t else []
    k = len(out_t)
    steps = 0
    while solver.status == "running":
        message = solver.step()
        if solver.status == "failed":
            raise RuntimeError(f"DOP853 failed at t = {solver.t}: {message}")
        steps += 1
        if times is not None:
            dense = solver.dense_output()
            while k < len(times) and times[k] <= solver.t:
                out_t.append(float(times[k]))
                out_y.append(project(times[k], dense(times[k])))
                k += 1
        solver.y = project(solver.t, solver.y)
        solver.f = rhs(solver.t, solver.y)
        solver.nfev += 1
        if times is None:
            out_t.append(solver.t)
            out_y.append(solver.y.copy())
    return ProjectedRun(np.array(out_t), np.array(out_y).T, solver.nfev, steps)


def extended_precision_run(ref: LoopReference, t_span: Sequence[float], y0: np.ndarray,
                           steps: int) -> np.ndarray:
    """The state at t_span[1] by DOP853's 8th-order formula at a fixed step, in numpy's extended
    precision (np.longdouble: 64-bit mantissa on x86), the index-1 equations solved in double and
    refined twice in extended precision: an independent reference whose rounding lies far below
    a double-precision run's (check its convergence by halving the step). No driven joints."""
    from scipy.integrate._ivp import dop853_coefficients as dop

    if len(ref.driven):
        raise ValueError("extended_precision_run takes mechanisms without driven joints")
    ld = np.longdouble
    stages = dop.N_STAGES
    a, b, c = (np.asarray(x, dtype=ld) for x in (dop.A[:stages, :stages], dop.B, dop.C[:stages]))
    p = np.array(ref.p, dtype=ld)
    n, m = ref.n, ref.Phi.rows

    def rhs(t: np.longdouble, y: np.ndarray) -> np.ndarray:
        M, f, Phi_q, gamma = ref._kkt(t, *y[0::2], *y[1::2], *p)
        K = np.zeros((n + m, n + m), dtype=ld)
        K[:n, :n] = np.asarray(M, dtype=ld).reshape(n, n)
        if m:
            G = np.asarray(Phi_q, dtype=ld).reshape(m, n)
            K[:n, n:], K[n:, :n] = G.T, G
        r = np.concatenate([np.asarray(f, dtype=ld).reshape(n),
                            np.asarray(gamma, dtype=ld).reshape(m)])
        K64 = K.astype(float)
        x = np.linalg.solve(K64, r.astype(float)).astype(ld)
        for _ in range(2):
            x += np.linalg.solve(K64, (r - K @ x).astype(float)).astype(ld)
        dy = np.empty(2 * n, dtype=ld)
        dy[0::2], dy[1::2] = y[1::2], x[:n]
        return dy

    t0, t1 = ld(t_span[0]), ld(t_span[1])
    h = (t1 - t0) / steps
    y = np.asarray(y0, dtype=ld).copy()
    k = np.empty((stages, len(y)), dtype=ld)
    for i in range(steps):
        t = t0 + i * h
        for s in range(stages):
            k[s] = rhs(t + c[s] * h, y + h * (a[s, :s] @ k[:s]))
        y = y + h * (b @ k)
    return y


def double_fourbar_crank(t_end: float, rtol: float = 1e-13) -> tuple[float, float]:
    """The crank angle and rate at T_END of the IFToMM benchmark A02, the double four-bar of
    examples/double_fourbar.yaml, from its one minimal coordinate, not from constraints: on its
    parallelogram branch the three cranks stay parallel at the angle theta and the two couplers
    translate with the cranks' tips, so (m = 1 kg, L = 1 m uniform rods, g = 9.81)
    T = 3 * (1/2) (m L^2 / 3) dtheta^2 + 2 * (1/2) m L^2 dtheta^2 = (3/2) m L^2 dtheta^2,
    V = 3 m g (L/2) sin(theta) + 2 m g L sin(theta) = (7/2) m g L sin(theta), and Lagrange's
    equation is ddtheta = -(7/6) (g / L) cos(theta), from theta = pi/2, dtheta = -1 (the tip B0
    moving right at 1 m/s). Solved by scipy's DOP853 at RTOL (atol 1e-15)."""
    from scipy.integrate import solve_ivp

    g, length = 9.81, 1.0

    def pendulum(_t: float, y: np.ndarray) -> list[float]:
        return [y[1], -7.0 / 6.0 * g / length * math.cos(y[0])]

    run = solve_ivp(pendulum, (0.0, t_end), [math.pi / 2, -1.0], method="DOP853", rtol=rtol,
                    atol=1e-15)
    return float(run.y[0, -1]), float(run.y[1, -1])
