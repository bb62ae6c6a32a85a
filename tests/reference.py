"""An independent reference for the dynamics tests: Lagrange's equations with sympy.

Written from the format spec alone; it shares nothing with nemc's derivation but the validated
model (``nemc.front.mechanism``). Each body's angle and origin come from walking the joint tree; the
kinetic energy T, the potential energy V (gravity, springs, joint springs) and the generalized
forces Q (torques, forces, dampers, by virtual power) give

    M = d2T/du2,   f = Q + dL/dq - (d2L/du dq) u - d2L/du dt,   M qdd = f,

with L = T - V and u the coordinate rates. ``random_mechanism_yaml`` writes seeded random valid
mechanisms (chains and trees of mixed joints and loads) for the comparison tests.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sp
import yaml

from nemc.front.mechanism import (
    GROUND,
    TIME,
    Mechanism,
    PointRef,
    Vec2,
    rate_symbol,
    symbol,
)
from nemc.kinds.joints import Joint
from nemc.kinds.loads import Force, JointSpring, Spring, Torque

# The spec says a joint spring acts on "the relative angle" of a revolute joint without saying
# whether the joint's `offset` is part of it. nemc (kinematics.joint_relative) measures it from
# the offset: child angle - parent angle - offset, i.e. q for `angle: relative` and
# q - parent angle for `angle: absolute`. Set True for child angle - parent angle instead.
JOINT_SPRING_ANGLE_INCLUDES_OFFSET = False

Params = Mapping[str, float] | None


def _rot(angle: sp.Expr) -> sp.Matrix:
    return sp.Matrix([[sp.cos(angle), -sp.sin(angle)], [sp.sin(angle), sp.cos(angle)]])


def _col(xy: Vec2) -> sp.Matrix:
    return sp.Matrix([sp.sympify(xy[0]), sp.sympify(xy[1])])


@dataclass(frozen=True)
class Frame:
    """A body frame in the ground frame: its angle and its origin (2x1)."""

    angle: sp.Expr
    origin: sp.Matrix

    def point(self, xy: Vec2) -> sp.Matrix:
        return self.origin + _rot(self.angle) * _col(xy)


def _child_frame(joint: Joint, parent: Frame) -> Frame:
    at = parent.point(joint.at)
    if joint.type == "revolute":
        q = symbol(joint.coordinates[0])
        base = parent.angle if joint.angle == "relative" else sp.S.Zero
        return Frame(base + q + joint.offset, at)
    if joint.type == "prismatic":
        s = symbol(joint.coordinates[0])
        axis = _col(joint.axis)
        unit = axis / sp.sqrt(axis[0] ** 2 + axis[1] ** 2)
        return Frame(parent.angle + joint.offset, at + _rot(parent.angle) * unit * s)
    if joint.type == "free":
        if joint.parent != GROUND or sp.sympify(getattr(joint, "offset", 0)) != 0:
            raise ValueError(f"free joint {joint.name}: ground parent and no offset expected")
        x, y, th = (symbol(c) for c in joint.coordinates)
        return Frame(th, sp.Matrix([x, y]))
    if joint.type == "weld":
        return Frame(parent.angle + joint.offset, at)
    raise ValueError(f"unknown joint type {joint.type!r}")


def body_frames(mech: Mechanism) -> dict[str, Frame]:
    """Every body's frame (and the ground's) as expressions of the coordinate symbols."""
    by_child = {j.child: j for j in mech.joints}
    frames: dict[str, Frame] = {GROUND: Frame(sp.S.Zero, sp.zeros(2, 1))}

    def frame(name: str) -> Frame:
        if name not in frames:
            joint = by_child[name]
            frames[name] = _child_frame(joint, frame(joint.parent))
        return frames[name]

    for body in mech.bodies:
        frame(body.name)
    return frames


@dataclass(frozen=True)
class Lagrangian:
    """The symbolic pieces: coordinates q, rates u, T, V and generalized forces Q."""

    q: tuple[sp.Symbol, ...]
    u: tuple[sp.Symbol, ...]
    T: sp.Expr
    V: sp.Expr
    Q: sp.Matrix

    def rate(self, expr: sp.Expr) -> sp.Expr:
        """d expr / dt along the motion (expr of t and q only)."""
        return sp.diff(expr, TIME) + sum(
            (sp.diff(expr, qi) * ui for qi, ui in zip(self.q, self.u)), sp.S.Zero
        )

    def partials(self, expr: sp.Expr) -> sp.Matrix:
        """d expr / dq_i as a column: the virtual-power coefficients of a position or angle."""
        return sp.Matrix([sp.diff(expr, qi) for qi in self.q])


def _kinetic(mech: Mechanism, frames: dict[str, Frame], lag: Lagrangian) -> sp.Expr:
    total = sp.S.Zero
    for body in mech.bodies:
        frame = frames[body.name]
        vc = frame.point(body.com).applyfunc(lag.rate)
        w = lag.rate(frame.angle)
        total += body.mass * (vc[0] ** 2 + vc[1] ** 2) / 2 + body.inertia * w**2 / 2
    return total


def _point(frames: dict[str, Frame], ref: PointRef) -> sp.Matrix:
    return frames[ref.body].point(ref.xy)


def _joint_relative(mech: Mechanism, frames: dict[str, Frame], name: str) -> sp.Expr:
    joint = mech.joint(name)
    if joint.type == "prismatic":
        return symbol(joint.coordinates[0])
    if joint.type != "revolute":
        raise ValueError(f"joint spring on {joint.type} joint {name}")
    rel = frames[joint.child].angle - frames[joint.parent].angle
    return rel if JOINT_SPRING_ANGLE_INCLUDES_OFFSET else rel - joint.offset


def _potential_and_forces(
    mech: Mechanism, frames: dict[str, Frame], lag: Lagrangian
) -> tuple[sp.Expr, sp.Matrix]:
    gravity = _col(mech.gravity)
    V = sp.S.Zero
    for body in mech.bodies:
        rc = frames[body.name].point(body.com)
        V -= body.mass * (gravity.T * rc)[0]
    Q = sp.zeros(len(lag.q), 1)
    for load in mech.loads:
        if isinstance(load, Torque):
            arm = frames[load.body].angle - frames[load.reaction].angle
            Q += load.expr * lag.partials(arm)
        elif isinstance(load, Force):
            frame = frames[load.body]
            comps = _col(load.components)
            if load.frame == "body":
                comps = _rot(frame.angle) * comps
            # virtual work through the body's material point at `at` (a moving point: held)
            held = sp.symbols("held_x held_y", real=True)
            rp = frame.point(held)
            at = dict(zip(held, load.at))
            Q += sp.Matrix([(comps.T * rp.diff(qi))[0].xreplace(at) for qi in lag.q])
        elif isinstance(load, Spring):
            d = _point(frames, load.a) - _point(frames, load.b)
            length = sp.sqrt(d[0] ** 2 + d[1] ** 2)
            V += load.k * (length - load.length) ** 2 / 2
            Q -= load.damping * lag.rate(length) * lag.partials(length)
        elif isinstance(load, JointSpring):
            rel = _joint_relative(mech, frames, load.joint)
            V += load.k * (rel - load.rest) ** 2 / 2
            Q -= load.damping * lag.rate(rel) * lag.partials(rel)
        else:
            raise TypeError(f"unknown load {load!r}")
    return V, Q


def lagrangian(mech: Mechanism) -> Lagrangian:
    q = tuple(symbol(c) for c in mech.coordinates)
    u = tuple(rate_symbol(c) for c in mech.coordinates)
    frames = body_frames(mech)
    lag = Lagrangian(q, u, sp.S.Zero, sp.S.Zero, sp.zeros(len(q), 1))
    T = _kinetic(mech, frames, lag)
    V, Q = _potential_and_forces(mech, frames, lag)
    return Lagrangian(q, u, T, V, Q)


def equations(lag: Lagrangian) -> tuple[sp.Matrix, sp.Matrix]:
    """Mass matrix M and forcing f with M qdd = f."""
    L = lag.T - lag.V
    p = sp.Matrix([sp.diff(L, ui) for ui in lag.u])
    M = p.jacobian(lag.u)
    dLdq = sp.Matrix([sp.diff(L, qi) for qi in lag.q])
    f = lag.Q + dLdq - p.jacobian(lag.q) * sp.Matrix(lag.u) - sp.diff(p, TIME)
    return M, f


def _definitions(mech: Mechanism) -> dict[sp.Symbol, sp.Expr]:
    return {symbol(p.name): sp.sympify(p.expr) for p in (*mech.constants, *mech.parameters)}


def resolve_parameters(mech: Mechanism, overrides: Params = None) -> dict[str, float]:
    """Every parameter and constant as a number; a derived one follows its inputs.

    An override replaces a parameter's definition (a number for a derived one too).
    """
    overrides = dict(overrides or {})
    known = {p.name for p in mech.parameters}
    unknown = set(overrides) - known
    if unknown:
        raise KeyError(f"not parameters of {mech.name}: {sorted(unknown)}")
    values: dict[sp.Symbol, float] = {symbol(k): float(v) for k, v in overrides.items()}
    pending = {s: e for s, e in _definitions(mech).items() if s not in values}
    while pending:
        ready = {s: e for s, e in pending.items() if e.free_symbols <= values.keys()}
        if not ready:
            raise ValueError(f"cyclic or unresolved definitions: {sorted(map(str, pending))}")
        for s, e in ready.items():
            values[s] = float(e.xreplace({k: sp.Float(v) for k, v in values.items()}))
            del pending[s]
    return {s.name: v for s, v in values.items()}


class ReferenceModel:
    """Numeric M, f, T, V of a mechanism (lambdified once)."""

    def __init__(self, mech: Mechanism) -> None:
        self.mech = mech
        lag = lagrangian(mech)
        M, f = equations(lag)
        self.lagrangian, self.M, self.f = lag, M, f  # symbolic, for references built on this one
        self.param_symbols = tuple(_definitions(mech))
        args = (TIME, *lag.q, *lag.u, *self.param_symbols)
        self._M = sp.lambdify(args, M, modules="numpy", cse=True, dummify=True)
        self._f = sp.lambdify(args, f, modules="numpy", cse=True, dummify=True)
        self._TV = sp.lambdify(args, [lag.T, lag.V], modules="numpy", cse=True, dummify=True)
        self.n = len(lag.q)
        self._cache: dict[tuple, tuple[float, ...]] = {}

    def param_values(self, params: Params = None) -> tuple[float, ...]:
        key = tuple(sorted((params or {}).items()))
        if key not in self._cache:
            values = resolve_parameters(self.mech, params)
            self._cache[key] = tuple(values[s.name] for s in self.param_symbols)
        return self._cache[key]

    def _args(self, t: float, y: np.ndarray, params: Params) -> tuple[float, ...]:
        y = np.asarray(y, dtype=float)
        return (t, *y[0::2], *y[1::2], *self.param_values(params))

    def mass_forcing(self, t: float, y: np.ndarray, params: Params = None):
        args = self._args(t, y, params)
        M = np.array(self._M(*args), dtype=float).reshape(self.n, self.n)
        f = np.array(self._f(*args), dtype=float).reshape(self.n)
        return M, f

    def rhs(self, t: float, y: np.ndarray, params: Params = None) -> np.ndarray:
        M, f = self.mass_forcing(t, y, params)
        dy = np.empty(2 * self.n)
        dy[0::2] = np.asarray(y, dtype=float)[1::2]
        dy[1::2] = np.linalg.solve(M, f)
        return dy

    def energy(self, t: float, y: np.ndarray, params: Params = None) -> tuple[float, float]:
        T, V = self._TV(*self._args(t, y, params))
        return float(T), float(V)

    def initial_state(self, params: Params = None) -> np.ndarray:
        """The scene's initial state (unlisted values 0)."""
        values = {symbol(k): sp.Float(v) for k, v in resolve_parameters(self.mech, params).items()}
        y = np.zeros(2 * self.n)
        for name, expr in self.mech.simulation.initial.items():
            index = self.mech.state_names.index(name)
            y[index] = float(sp.sympify(expr).xreplace(values))
        return y


def tree_example_names(folder: Path) -> list[str]:
    """The example files this reference covers: trees without driven joints or inputs. Closed
    loops (`constraints`) and driven joints (`motion`) are tests/loop_reference.py's; a tree
    with `inputs:` (cart_pole) is checked through complex_step_linearization below
    (tests/test_examples_plant.py, tests/test_plant.py), which takes the inputs' values; a
    mechanism with Coulomb friction (`friction`) is tests/test_friction.py's, one with contacts
    (`contacts`) tests/test_contacts*.py's."""
    names = []
    for path in sorted(folder.glob("*.yaml")):
        data = yaml.safe_load(path.read_text())
        driven = any("motion" in joint for joint in data["joints"].values())
        if not {"constraints", "inputs", "friction", "contacts"} & set(data) and not driven:
            names.append(path.stem)
    return names


def reference_rhs(mech: Mechanism) -> Callable[..., np.ndarray]:
    """``rhs(t, y, params=None) -> dy`` in the state order [q1, dot(q1), q2, dot(q2), ...]."""
    return ReferenceModel(mech).rhs


def reference_energy(mech: Mechanism) -> Callable[..., tuple[float, float]]:
    """``energy(t, y, params=None) -> (T, V)``: kinetic and potential (gravity and springs)."""
    return ReferenceModel(mech).energy


# ---------------------------------------------------------------------------------------------
# The book's own equations


def book_two_link_rhs(t: float, y: np.ndarray) -> np.ndarray:
    """The book's 5.4 Newton-Euler equations EqA and Eq2, solved for the accelerations."""
    L1 = L2 = m1 = m2 = 1.0
    g = 9.81
    q1, u1, q2, u2 = y
    T01 = (
        -450 * u1
        - 300 * (q1 - math.pi / 6)
        + 0.5 * g * L1 * m1 * math.cos(q1)
        + g * L1 * m2 * math.cos(q1)
    )
    T12 = -200 * u2 - 300 * (q2 - math.pi / 3) + 0.5 * g * L2 * m2 * math.cos(q2)
    IA, IC2 = m1 * L1**2 / 3, m2 * L2**2 / 12
    rB = L1 * np.array([math.cos(q1), math.sin(q1)])
    rC1, rC2 = rB / 2, rB + L2 / 2 * np.array([math.cos(q2), math.sin(q2)])

    def cross(a, b):
        return a[0] * b[1] - a[1] * b[0]

    def residual(a1: float, a2: float) -> np.ndarray:
        aB = L1 * (
            a1 * np.array([-math.sin(q1), math.cos(q1)])
            - u1**2 * np.array([math.cos(q1), math.sin(q1)])
        )
        aC2 = aB + L2 / 2 * (
            a2 * np.array([-math.sin(q2), math.cos(q2)])
            - u2**2 * np.array([math.cos(q2), math.sin(q2)])
        )
        F21 = -m2 * aC2 + np.array([0, -m2 * g])
        eqA = -IA * a1 + cross(rB, F21) + cross(rC1, [0, -m1 * g]) + T01 - T12
        eq2 = -IC2 * a2 + cross(rB - rC2, -F21) + T12
        return np.array([eqA, eq2])

    r0 = residual(0, 0)
    A = np.column_stack([residual(1, 0) - r0, residual(0, 1) - r0])
    a = np.linalg.solve(A, -r0)
    return np.array([u1, a[0], u2, a[1]])


# ---------------------------------------------------------------------------------------------
# Seeded random mechanisms


def _num(rng: np.random.Generator, lo: float, hi: float) -> float:
    return round(float(rng.uniform(lo, hi)), 4)


def _xy(rng: np.random.Generator, scale: float = 1.0) -> list[float]:
    return [_num(rng, -scale, scale), _num(rng, -scale, scale)]


def _signed(value: float) -> str:
    return f"+ {value}" if value >= 0 else f"- {-value}"


class _RandomBuilder:
    """Builds one random mechanism as plain data, then YAML text."""

    def __init__(self, rng: np.random.Generator, n_bodies: int, tree: bool) -> None:
        self.rng = rng
        self.n = n_bodies
        self.tree = tree
        self.params: dict[str, object] = {"g": 9.81}
        self.constants: dict[str, object] = {"c0": _num(rng, 0.5, 1.5)}
        self.bodies: dict[str, dict] = {}
        self.joints: dict[str, dict] = {}
        self.loads: list[dict] = []
        self.coords: list[str] = []
        self.movable: list[str] = []  # joints with one coordinate (for joint springs)

    def body(self, i: int) -> None:
        rng = self.rng
        self.params[f"m{i}"] = _num(rng, 0.5, 2.0)
        self.params[f"L{i}"] = _num(rng, 0.5, 1.5)
        inertia = f"m{i}*L{i}**2/12" if rng.random() < 0.5 else f"{_num(rng, 0.05, 0.3)}*c0"
        points = {f"P{i}": [f"L{i}", _num(rng, -0.2, 0.2)], f"R{i}": _xy(rng, 0.8)}
        self.bodies[f"b{i}"] = {
            "mass": f"m{i}",
            "inertia": inertia,
            "com": [f"L{i}/2", _num(rng, -0.2, 0.2)],
            "points": points,
        }

    def _at(self, parent: str) -> object:
        if parent != GROUND and self.rng.random() < 0.7:
            i = parent[1:]
            return f"P{i}" if self.rng.random() < 0.6 else f"R{i}"
        return _xy(self.rng, 0.5)

    def joint(self, i: int) -> None:
        rng = self.rng
        child = f"b{i}"
        if i == 1 or not self.tree:
            parent = GROUND if i == 1 else f"b{i - 1}"
        else:
            parent = [GROUND, *self.bodies][int(rng.integers(0, i))]  # b1 .. b(i-1) or ground
        kind = str(rng.choice(["revolute", "prismatic", "weld"], p=[0.55, 0.3, 0.15]))
        if i == 1 and rng.random() < 0.3:
            kind = "free"
        if kind == "weld" and not self.coords:
            kind = "revolute"
        spec: dict[str, object] = {"type": kind, "parent": parent, "child": child}
        if kind == "free":
            names = ["x1", "y1", "th1"]
            spec["coordinates"] = names
            self.coords += names
        elif kind == "weld":
            spec["at"] = self._at(parent)
            spec["offset"] = _num(rng, -1.5, 1.5)
        else:
            spec["at"] = self._at(parent)
            spec["coordinate"] = f"q{i}"
            self.coords.append(f"q{i}")
            self.movable.append(f"J{i}")
            if rng.random() < 0.6:
                spec["offset"] = _num(rng, -1.5, 1.5) if rng.random() < 0.7 else "pi/4"
            if kind == "revolute" and rng.random() < 0.4:
                spec["angle"] = "absolute"
            if kind == "prismatic":
                spec["axis"] = _xy(rng, 1.0)
        self.joints[f"J{i}"] = spec

    def _rate_term(self) -> str:
        q = self.coords[int(self.rng.integers(0, len(self.coords)))]
        return f"{_num(self.rng, 0.1, 0.5)}*dot({q})"

    def _random_point(self, exclude: str | None = None) -> object:
        rng = self.rng
        bodies = [b for b in self.bodies if b != exclude]
        if rng.random() < 0.3 or not bodies:
            return {"body": GROUND, "at": [_num(rng, 1.0, 2.0), _num(rng, 1.0, 2.0)]}
        body = bodies[int(rng.integers(0, len(bodies)))]
        if rng.random() < 0.5:
            return {"body": body, "at": _xy(rng, 0.8)}
        return f"{body}.{'P' if rng.random() < 0.5 else 'R'}{body[1:]}"

    def loads_for(self, i: int) -> None:
        rng = self.rng
        body = f"b{i}"
        if rng.random() < 0.5:
            reaction = self.joints[f"J{i}"]["parent"] if rng.random() < 0.5 else GROUND
            expr = f"{_num(rng, -1, 1)}*sin({_num(rng, 0.5, 3)}*t) - {self._rate_term()}"
            self.loads.append({"torque": expr, "body": body, "reaction": reaction})
        if rng.random() < 0.5:
            fx = f"{_num(rng, -1, 1)}*cos(t) - {self._rate_term()}"
            fy = f"{_num(rng, -1, 1)} {_signed(_num(rng, -0.5, 0.5))}*sin(2*t)"
            load = {"force": [fx, fy], "body": body, "frame": str(rng.choice(["ground", "body"]))}
            if rng.random() < 0.7:
                load["at"] = f"P{i}" if rng.random() < 0.5 else f"R{i}"
            self.loads.append(load)
        if rng.random() < 0.4:
            a = f"{body}.{'P' if rng.random() < 0.5 else 'R'}{i}"
            spring = {"a": a, "b": self._random_point(exclude=body), "k": _num(rng, 1, 20)}
            spring["length"] = _num(rng, 0.1, 1.0)
            if rng.random() < 0.6:
                spring["damping"] = _num(rng, 0.05, 0.5)
            self.loads.append({"spring": spring})

    def joint_springs(self) -> None:
        for name in self.movable:
            if self.rng.random() < 0.4:
                spring: dict[str, object] = {"joint": name, "k": _num(self.rng, 1, 10)}
                spring["rest"] = _num(self.rng, -0.5, 0.5)
                if self.rng.random() < 0.5:
                    spring["damping"] = _num(self.rng, 0.05, 0.5)
                self.loads.append({"joint_spring": spring})

    def text(self, name: str) -> str:
        gravity = [_num(self.rng, -0.3, 0.3), "-g"]
        data = {
            "name": name,
            "description": "seeded random mechanism for the reference comparison",
            "parameters": self.params,
            "constants": self.constants,
            "gravity": gravity,
            "bodies": self.bodies,
            "joints": self.joints,
            "loads": self.loads,
        }
        if not self.loads:
            del data["loads"]
        return yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)


def random_mechanism_yaml(
    rng: np.random.Generator, n_bodies: int, tree: bool, name: str = "random_mech"
) -> str:
    """Valid YAML text of a random chain (``tree=False``) or tree of ``n_bodies`` bodies.

    Mixed joints: revolute (relative or absolute, with offsets), prismatic (random axes, offsets),
    weld (never before the first coordinate), at most one free joint, at the root. Random masses,
    inertias, mass centers and points; torques and forces depending on t and dot(q); springs
    with and without damping; joint springs.
    """
    builder = _RandomBuilder(rng, n_bodies, tree)
    for i in range(1, n_bodies + 1):
        builder.body(i)
        builder.joint(i)
    for i in range(1, n_bodies + 1):
        builder.loads_for(i)
    builder.joint_springs()
    return builder.text(name)


def relative_chain_yaml(n: int, name: str, mass: float, length: float) -> str:
    """An n-link chain of uniform rods under gravity, revolute joints in relative angles."""
    links = "".join(f"  link{i}: {{mass: m, inertia: m*L**2/12, com: [L/2, 0], "
                    f"points: {{tip: [L, 0]}}}}\n" for i in range(1, n + 1))
    joints = "".join(f"  J{i}: {{parent: {'ground' if i == 1 else f'link{i - 1}'}, "
                     f"child: link{i}, at: {'[0, 0]' if i == 1 else 'tip'}, type: revolute, "
                     f"coordinate: q{i}, angle: relative}}\n" for i in range(1, n + 1))
    initial = ", ".join(f"q{i}: {(-0.7, 0.3, -0.2, 0.5)[(i - 1) % 4]}" for i in range(1, n + 1))
    return (f"name: {name}\nparameters: {{m: {mass}, L: {length}, g: 9.81}}\n"
            f"gravity: [0, -g]\nbodies:\n{links}joints:\n{joints}"
            f"simulation: {{t_span: [0, 2], initial: {{{initial}}}}}\n")


def program_results(program, values: Mapping) -> list[float]:
    """A straight-line program's results at VALUES of its inputs, its steps computed in order
    at 30 digits."""
    env = dict(values)
    for name, expr in program.assignments():
        env[name] = expr.xreplace(env).evalf(30)
    return [float(sp.sympify(result).xreplace(env).evalf(30)) for result in program.results]


def complex_step_linearization(mech: Mechanism, t: float, y: np.ndarray,
                               inputs: Mapping[str, float], params: Params = None,
                               step: float = 1e-200) -> tuple[np.ndarray, np.ndarray]:
    """A = d(dy/dt)/dy and B = d(dy/dt)/du of the Lagrange derivation above, by complex steps:
    Im f(x + i h e_k) / h is the derivative to rounding, with no cancellation (Squire and
    Trapp 1998); the mechanism's loads may name its inputs (here held as numbers)."""
    lag = lagrangian(mech)
    M, f = equations(lag)
    params_symbols = tuple(_definitions(mech))
    input_symbols = tuple(symbol(item.name) for item in mech.inputs)
    args = (TIME, *lag.q, *lag.u, *params_symbols, *input_symbols)
    mass = sp.lambdify(args, M, modules="numpy")
    force = sp.lambdify(args, f, modules="numpy")
    values = resolve_parameters(mech, params)
    p = [values[s.name] for s in params_symbols]
    n = len(lag.q)

    def rhs(state: np.ndarray, u: np.ndarray) -> np.ndarray:
        call = (t, *state[0::2], *state[1::2], *p, *u)
        qdd = np.linalg.solve(np.array(mass(*call), dtype=complex).reshape(n, n),
                              np.array(force(*call), dtype=complex).reshape(n))
        out = np.empty(2 * n, dtype=complex)
        out[0::2], out[1::2] = state[1::2], qdd
        return out

    u0 = np.array([float(inputs[item.name]) for item in mech.inputs], dtype=complex)
    y0 = np.asarray(y, dtype=complex)
    a = np.column_stack([rhs(y0 + 1j * step * e, u0).imag / step
                         for e in np.eye(2 * n)])
    b = np.column_stack([rhs(y0, u0 + 1j * step * e).imag / step
                         for e in np.eye(len(u0))]) if len(u0) else np.zeros((2 * n, 0))
    return a, b
