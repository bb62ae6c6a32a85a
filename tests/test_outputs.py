"""The scene's outputs (``model.outputs``, ``res.outputs``) against independent computations.

- The book's 5.1 (eqs. 5.15-5.19) and 5.2 (its MATLAB ``F21 = -m2*aC2 + G2``) written out here.
- Every example that lists outputs, and copies of every example (and of seeded random trees and
  chains) asking for every group: reactions of all joints, energy, points, accelerations and
  expressions. Reactions are the child subtree's Newton-Euler balance, sum(m a_C) minus the
  external forces on it (and, for ``.M``, the same balance of moments about the joint point),
  computed here in numpy from numeric kinematics lambdified from ``reference.body_frames`` with
  the accelerations of the reference's Lagrangian ``rhs``; energy against ``reference.energy``;
  points against the same kinematics; expressions against hand-written numpy.
- Energy conservation along a tight double pendulum run; the spec's names and order; "skip what
  a scene doesn't need"; floats for one state, arrays for many.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
import yaml
from reference import (
    ReferenceModel,
    body_frames,
    random_mechanism_yaml,
    resolve_parameters,
    tree_example_names,
)

import nemc
from nemc.front.mechanism import (
    GROUND,
    TIME,
    Mechanism,
    rate_symbol,
    symbol,
)
from nemc.front.validate import load_mechanism
from nemc.kinds.loads import Force, JointSpring, Spring, Torque
from nemc.pipeline import compile_mechanism

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
EXAMPLE_NAMES = tree_example_names(EXAMPLES)  # loops and drives: test_loops.py
WITH_OUTPUTS = sorted(
    n for n in EXAMPLE_NAMES if "outputs" in yaml.safe_load((EXAMPLES / f"{n}.yaml").read_text())
)
WITHOUT_OUTPUTS = sorted(set(EXAMPLE_NAMES) - set(WITH_OUTPUTS))
RANDOM_CASES = [(0, 4, True), (3, 4, False), (6, 3, False), (29, 4, True)]  # seed, bodies, tree
RTOL = 1e-9

# numpy of the examples' own output expressions: f(t, state by name, parameters by name)
Numpy = Callable[[float, dict, dict], float]
EXPRESSIONS: dict[str, dict[str, Numpy]] = {
    "body_frame_thruster": {
        "tip_height": lambda t, s, p: p["L"] * np.sin(s["q"]),
        "thrust": lambda t, s, p: p["F0"] * np.sin(p["w"] * t),
    },
    "damped_spring_pendulum": {
        "spring_length": lambda t, s, p: np.hypot(
            p["L"] * np.cos(s["theta"]) - 1.2, p["L"] * np.sin(s["theta"]) + 0.4
        ),
    },
}


@pytest.fixture(scope="module")
def scratch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("output-mechanisms")


# ---------------------------------------------------------------------------------------------
# Independent numeric kinematics and Newton-Euler balances


def cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def rot(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def subtree(mech: Mechanism, root: str) -> set[str]:
    inside = {root}
    for _ in mech.joints:
        inside |= {j.child for j in mech.joints if j.parent in inside}
    return inside


@dataclass
class At:
    """One evaluation point: time, state, parameter values and the reference's accelerations."""

    t: float
    y: np.ndarray
    args: tuple
    qdd: np.ndarray
    values: dict[str, float]


@dataclass
class Balance:
    force: np.ndarray
    moment: float
    scale: float  # size of the largest terms, for the tolerance


@dataclass
class Case:
    """A compiled model with its reference and the test's own kinematics."""

    path: str
    model: nemc.runtime.model.Model
    ref: ReferenceModel
    mech: Mechanism
    frames: dict = field(default_factory=dict)
    _fns: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.frames = body_frames(self.mech)
        self.q = tuple(symbol(c) for c in self.mech.coordinates)
        self.u = tuple(rate_symbol(c) for c in self.mech.coordinates)
        self.symbols = (TIME, *self.q, *self.u, *self.ref.param_symbols)

    def _lambdify(self, key: object, build: Callable[[], object]) -> Callable:
        if key not in self._fns:
            self._fns[key] = sp.lambdify(self.symbols, build(), modules="numpy", dummify=True)
        return self._fns[key]

    def scalar(self, expr: sp.Expr, at: At) -> float:
        return float(self._lambdify(("scalar", expr), lambda: sp.sympify(expr))(*at.args))

    def _track(self, key: object, column: Callable[[], sp.Matrix], at: At):
        """Value, velocity and acceleration of a column of functions of q (no t dependence)."""

        def build() -> list:
            value = column()
            jac = value.jacobian(self.q)
            velocity = jac * sp.Matrix(self.u)
            bias = velocity.jacobian(self.q) * sp.Matrix(self.u)
            return [value, velocity, bias, jac]

        value, velocity, bias, jac = self._lambdify(key, build)(*at.args)
        value, velocity = np.ravel(value).astype(float), np.ravel(velocity).astype(float)
        jac = np.asarray(jac, dtype=float).reshape(len(value), len(self.q))
        return value, velocity, np.ravel(bias).astype(float) + jac @ at.qdd

    def point(self, body: str, xy, at: At):
        """Ground-frame position, velocity, acceleration of a point fixed in a body."""
        key = ("point", body, tuple(map(str, xy)))
        return self._track(key, lambda: self.frames[body].point(xy), at)

    def angle(self, body: str, at: At) -> tuple[float, float, float]:
        value, rate, accel = self._track(
            ("angle", body), lambda: sp.Matrix([self.frames[body].angle]), at
        )
        return float(value[0]), float(rate[0]), float(accel[0])

    def at(self, t: float, y: np.ndarray, params: dict | None = None) -> At:
        y = np.asarray(y, dtype=float)
        pvals = self.ref.param_values(params)
        qdd = self.ref.rhs(t, y, params)[1::2]
        return At(t, y, (t, *y[0::2], *y[1::2], *pvals), qdd, resolve_parameters(self.mech, params))

    # -- loads: (body, point of application (ground frame), force (ground frame)) and couples

    def external_forces(self, at: At) -> list[tuple[str, np.ndarray, np.ndarray]]:
        mech = self.mech
        g = np.array([self.scalar(mech.gravity[0], at), self.scalar(mech.gravity[1], at)])
        forces = []
        for body in mech.bodies:
            rc = self.point(body.name, body.com, at)[0]
            forces.append((body.name, rc, self.scalar(body.mass, at) * g))
        for load in mech.loads:
            if isinstance(load, Force):
                f = np.array([self.scalar(c, at) for c in load.components])
                if load.frame == "body":
                    f = rot(self.angle(load.body, at)[0]) @ f
                forces.append((load.body, self.point(load.body, load.at, at)[0], f))
            elif isinstance(load, Spring):
                ra, va, _ = self.point(load.a.body, load.a.xy, at)
                rb, vb, _ = self.point(load.b.body, load.b.xy, at)
                d = rb - ra
                length = float(np.hypot(*d))
                stretch_rate = float(d @ (vb - va)) / length
                pull = self.scalar(load.k, at) * (length - self.scalar(load.length, at))
                pull += self.scalar(load.damping, at) * stretch_rate
                forces += [
                    (load.a.body, ra, pull * d / length),
                    (load.b.body, rb, -pull * d / length),
                ]
            elif isinstance(load, JointSpring) and mech.joint(load.joint).type == "prismatic":
                joint = mech.joint(load.joint)
                k = mech.coordinates.index(joint.coordinates[0])
                s, ds = at.y[2 * k], at.y[2 * k + 1]
                tension = -self.scalar(load.k, at) * (s - self.scalar(load.rest, at))
                tension -= self.scalar(load.damping, at) * ds
                axis = np.array([self.scalar(c, at) for c in joint.axis])
                axis = rot(self.angle(joint.parent, at)[0]) @ axis / np.hypot(*axis)
                where = self.point(joint.child, (0, 0), at)[0]  # collinear pair at the slider
                forces += [
                    (joint.child, where, tension * axis),
                    (joint.parent, where, -tension * axis),
                ]
        return [f for f in forces if f[0] != GROUND]

    def couples(self, at: At) -> list[tuple[str, float]]:
        mech, couples = self.mech, []
        for load in mech.loads:
            if isinstance(load, Torque):
                tau = self.scalar(load.expr, at)
                couples += [(load.body, tau), (load.reaction, -tau)]
            elif isinstance(load, JointSpring) and mech.joint(load.joint).type == "revolute":
                joint = mech.joint(load.joint)
                child, parent = self.angle(joint.child, at), self.angle(joint.parent, at)
                rel = child[0] - parent[0] - self.scalar(joint.offset, at)
                rate = child[1] - parent[1]
                tau = -self.scalar(load.k, at) * (rel - self.scalar(load.rest, at))
                tau -= self.scalar(load.damping, at) * rate
                couples += [(joint.child, tau), (joint.parent, -tau)]
        return couples

    def reaction(self, joint_name: str, at: At) -> Balance:
        """Force of the parent on the child's subtree, and the couple about the joint point."""
        joint = self.mech.joint(joint_name)
        inside = subtree(self.mech, joint.child)
        origin = self.point(joint.child, (0, 0), at)[0]
        force, moment, scale = np.zeros(2), 0.0, 0.0
        for body in (b for b in self.mech.bodies if b.name in inside):
            mass, inertia = self.scalar(body.mass, at), self.scalar(body.inertia, at)
            rc, _, ac = self.point(body.name, body.com, at)
            alpha = self.angle(body.name, at)[2]
            force += mass * ac
            moment += inertia * alpha + cross(rc - origin, mass * ac)
            scale += mass * float(np.hypot(*ac)) * (1 + float(np.hypot(*(rc - origin))))
            scale += abs(inertia * alpha)
        for body, where, f in self.external_forces(at):
            if body in inside:
                force -= f
                moment -= cross(where - origin, f)
                scale += float(np.hypot(*f)) * (1 + float(np.hypot(*(where - origin))))
        for body, tau in self.couples(at):
            if body in inside:
                moment -= tau
                scale += abs(tau)
        return Balance(force, moment, scale)

    def expected(self, t: float, y: np.ndarray, params: dict | None = None) -> dict:
        """Every output the file asks for, with the size of its terms: name -> (value, scale)."""
        at, wanted, out = self.at(t, y, params), self.mech.outputs, {}
        for name in wanted.reactions:
            bal = self.reaction(name, at)
            th = self.angle(self.mech.joint(name).child, at)[0]
            n, tt = np.array([math.cos(th), math.sin(th)]), np.array([-math.sin(th), math.cos(th)])
            for key, value in (
                ("Fx", bal.force[0]),
                ("Fy", bal.force[1]),
                ("Fn", bal.force @ n),
                ("Ft", bal.force @ tt),
            ):
                out[f"{name}.{key}"] = (float(value), bal.scale)
            if self.mech.joint(name).type in ("prismatic", "weld"):
                out[f"{name}.M"] = (bal.moment, bal.scale)
        if wanted.energy:
            kinetic, potential = self.ref.energy(t, y, params)
            scale = abs(kinetic) + abs(potential)
            out["energy.kinetic"] = (kinetic, scale)
            out["energy.potential"] = (potential, scale)
            out["energy.total"] = (kinetic + potential, scale)
        for point in wanted.points:
            r, v, _ = self.point(point.body, point.xy, at)
            for key, value in zip(("x", "y", "vx", "vy"), (*r, *v)):
                out[f"{point.label}.{key}"] = (float(value), 1.0)
        if wanted.accelerations:
            for q, value in zip(self.mech.coordinates, at.qdd):
                out[f"ddot({q})"] = (float(value), 1.0)
        state = dict(zip(self.mech.state_names, at.y))
        for name, _ in wanted.expressions:
            value = EXPRESSIONS[self.mech.name][name](t, state, at.values)
            out[name] = (float(value), 1.0)
        return out


@functools.cache
def _build(path: str) -> Case:
    mech = load_mechanism(path)
    return Case(path, nemc.compile(path), ReferenceModel(mech), mech)


def example(name: str) -> Case:
    return _build(str(EXAMPLES / f"{name}.yaml"))


def assert_outputs_match(case: Case, t: float, y: np.ndarray, params: dict | None = None):
    got = case.model.outputs(t, y, params)
    want = case.expected(t, y, params)
    assert set(got) == set(want), f"names: nemc {sorted(got)}, expected {sorted(want)}"
    bad = []
    for name, (value, scale) in want.items():
        if not abs(got[name] - value) <= RTOL * max(1.0, abs(value), scale):
            bad.append(f"{name}: nemc {got[name]!r}, independent {value!r}")
    state = dict(zip(case.mech.state_names, np.round(y, 6)))
    assert not bad, f"{case.mech.name} at t={t}, {state}, params={params}:\n" + "\n".join(bad)


def random_states(rng: np.random.Generator, n_state: int, count: int = 4) -> Iterator[tuple]:
    for _ in range(count):
        yield float(rng.uniform(0, 3)), rng.uniform(-1.5, 1.5, n_state)


def scaled_parameters(case: Case, rng: np.random.Generator) -> dict[str, float]:
    """The file's numeric parameters (not derived ones), each scaled by 0.7 .. 1.3."""
    plain = [p.name for p in case.mech.parameters if not sp.sympify(p.expr).free_symbols]
    return {name: case.model.parameters[name] * float(rng.uniform(0.7, 1.3)) for name in plain}


# ---------------------------------------------------------------------------------------------
# Mechanisms that ask for every group


def ask_for_everything(data: dict, name: str) -> tuple[dict, dict[str, Numpy]]:
    """A copy of a mechanism's data with every output group, and numpy for its expressions."""
    data = dict(data, name=name)
    joints = data["joints"]
    q0 = next(
        j.get("coordinate") or j["coordinates"][2] for j in joints.values() if j["type"] != "weld"
    )
    p0 = next(iter(data["parameters"]))
    points = [f"{b}.{p}" for b, spec in data["bodies"].items() for p in spec.get("points", {})]
    points += [f"{b}.com" for b in data["bodies"]] + [f"{next(iter(data['bodies']))}.origin"]
    data["outputs"] = {
        "reactions": list(joints),
        "energy": True,
        "points": points,
        "accelerations": True,
        "expressions": {
            "zeta_mix": f"sin({q0})*dot({q0}) + t**2",
            "alpha_par": f"{p0}*cos({q0}) - sqrt(abs({q0}) + 1) + atan2({q0}, 2)",
        },
    }
    numpy_exprs: dict[str, Numpy] = {
        "zeta_mix": lambda t, s, p: np.sin(s[q0]) * s[f"dot({q0})"] + t**2,
        "alpha_par": lambda t, s, p: (
            p[p0] * np.cos(s[q0]) - np.sqrt(abs(s[q0]) + 1) + np.arctan2(s[q0], 2)
        ),
    }
    return data, numpy_exprs


def everything_case(name: str, data: dict, folder: Path) -> Case:
    data, numpy_exprs = ask_for_everything(data, f"{name}_all")
    EXPRESSIONS[data["name"]] = numpy_exprs
    path = folder / f"{data['name']}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100))
    return _build(str(path))


def everything_example(name: str, folder: Path) -> Case:
    return everything_case(name, yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text()), folder)


# ---------------------------------------------------------------------------------------------
# Book 5.1: compound pendulum (ft, lb, s)

W51, L51, G51 = 12.0, 3.0, 32.2
M51 = W51 / G51


def test_compound_pendulum_released_from_rest_at_zero() -> None:
    """Book (5.18), (5.19): alpha(0) = -16.1 rad/s^2, F_Ox = 0, F_Oy = 3 lb."""
    case = example("compound_pendulum")
    y0 = np.array([0.0, 0.0])
    assert case.model.rhs(0.0, y0)[1] == pytest.approx(-16.1, rel=1e-12)
    out = case.model.outputs(0.0, y0)
    assert out["O.Fx"] == pytest.approx(0.0, abs=1e-12)
    assert out["O.Fy"] == pytest.approx(3.0, rel=1e-12)
    # body axes at theta = 0: n = x, t = y; F_t = m L alpha / 2 + m g = -9 + 12
    assert out["O.Fn"] == pytest.approx(0.0, abs=1e-12)
    assert out["O.Ft"] == pytest.approx(3.0, rel=1e-12)
    assert out["energy.kinetic"] == pytest.approx(0.0, abs=1e-14)
    assert out["energy.potential"] == pytest.approx(0.0, abs=1e-14)


def test_compound_pendulum_acceleration_output_at_zero(scratch: Path) -> None:
    out = everything_example("compound_pendulum", scratch).model.outputs(0.0, np.zeros(2))
    assert out["ddot(theta)"] == pytest.approx(-16.1, rel=1e-12)
    assert out["rod.com.x"] == pytest.approx(1.5, rel=1e-14)


def test_compound_pendulum_book_reactions_and_energy() -> None:
    """Eq. (5.16) in ground axes, (5.17) in the rod's n, t axes (signs from m a_C = F_O1 + G)."""
    model = example("compound_pendulum").model
    rng = np.random.default_rng(510)
    for _ in range(20):
        t, th, w = float(rng.uniform(0, 10)), float(rng.uniform(-4, 4)), float(rng.uniform(-6, 6))
        alpha = -3 * G51 * math.cos(th) / (2 * L51)  # (5.15)
        fx = -M51 * L51 / 2 * (alpha * math.sin(th) + w**2 * math.cos(th))  # (5.16)
        fy = M51 * L51 / 2 * (alpha * math.cos(th) - w**2 * math.sin(th)) + M51 * G51
        fn = -M51 * L51 * w**2 / 2 + M51 * G51 * math.sin(th)  # (5.17)
        ft = M51 * L51 * alpha / 2 + M51 * G51 * math.cos(th)
        out = model.outputs(t, np.array([th, w]))
        assert isinstance(out["O.Fx"], float)
        scale = M51 * (G51 + L51 * w**2)
        for name, value in (("O.Fx", fx), ("O.Fy", fy), ("O.Fn", fn), ("O.Ft", ft)):
            assert out[name] == pytest.approx(value, rel=1e-10, abs=1e-12 * scale), name
        # the n, t components are the projections of the ground components
        n, tt = (math.cos(th), math.sin(th)), (-math.sin(th), math.cos(th))
        assert fn == pytest.approx(fx * n[0] + fy * n[1], rel=1e-10, abs=1e-12 * scale)
        assert ft == pytest.approx(fx * tt[0] + fy * tt[1], rel=1e-10, abs=1e-12 * scale)
        kinetic = 0.5 * (M51 * L51**2 / 3) * w**2
        potential = M51 * G51 * L51 / 2 * math.sin(th)
        assert out["energy.kinetic"] == pytest.approx(kinetic, rel=1e-12)
        assert out["energy.potential"] == pytest.approx(potential, rel=1e-12, abs=1e-13)
        assert out["energy.total"] == pytest.approx(kinetic + potential, rel=1e-12, abs=1e-12)


# ---------------------------------------------------------------------------------------------
# Book 5.2: double pendulum, the book's MATLAB in numpy


def book_double_pendulum_reactions(y, qdd, m1=1.0, m2=1.0, L1=1.0, L2=0.5, g=10.0) -> dict:
    q1, u1, q2, u2 = y
    a1, a2 = qdd
    e1, n1 = np.array([math.cos(q1), math.sin(q1)]), np.array([-math.sin(q1), math.cos(q1)])
    e2, n2 = np.array([math.cos(q2), math.sin(q2)]), np.array([-math.sin(q2), math.cos(q2)])
    aC1 = L1 / 2 * (a1 * n1 - u1**2 * e1)  # the book's (xC1'', yC1'')
    aC2 = L1 * (a1 * n1 - u1**2 * e1) + L2 / 2 * (a2 * n2 - u2**2 * e2)  # (xC2'', yC2'')
    G1, G2 = np.array([0.0, -m1 * g]), np.array([0.0, -m2 * g])
    F21 = -m2 * aC2 + G2  # the book's: force of link 2 on link 1
    F12 = -F21  # link 1 on link 2: nemc's B
    F01 = m1 * aC1 - F21 - G1  # (5.20)'s force balance: ground on link 1
    out = {}
    for joint, force, n, t in (("A", F01, e1, n1), ("B", F12, e2, n2)):
        out[f"{joint}.Fx"], out[f"{joint}.Fy"] = force
        out[f"{joint}.Fn"], out[f"{joint}.Ft"] = force @ n, force @ t
    return out


@pytest.mark.parametrize("params", [None, {"m1": 1.7, "m2": 0.6, "L1": 0.8, "L2": 1.3, "g": 9.8}])
def test_double_pendulum_book_reactions(params: dict | None) -> None:
    case = example("double_pendulum")
    rng = np.random.default_rng(520)
    for _ in range(12):
        t, y = float(rng.uniform(0, 5)), rng.uniform(-3, 3, 4)
        qdd = case.ref.rhs(t, y, params)[1::2]
        np.testing.assert_allclose(case.model.rhs(t, y, params)[1::2], qdd, rtol=1e-10)
        expected = book_double_pendulum_reactions(y, qdd, **(params or {}))
        out = case.model.outputs(t, y, params)
        scale = 10.0 * (1 + np.abs(y[1::2]).max() ** 2 + np.abs(qdd).max())
        for name, value in expected.items():
            assert out[name] == pytest.approx(value, rel=1e-10, abs=1e-12 * scale), name


def test_double_pendulum_total_energy_is_constant() -> None:
    case = example("double_pendulum")
    res = case.model.simulate(
        t_span=(0.0, 10.0), t_eval=np.linspace(0, 10, 201), method="DOP853", rtol=1e-10, atol=1e-12
    )
    assert res.success, res.message
    total = res.outputs["energy.total"]
    assert total.shape == (201,)
    scale = np.max(np.abs(res.outputs["energy.kinetic"]) + np.abs(res.outputs["energy.potential"]))
    spread = (total.max() - total.min()) / scale
    assert spread < 1e-8, f"relative spread of energy.total {spread:.2e}"
    np.testing.assert_allclose(
        res.outputs["energy.kinetic"] + res.outputs["energy.potential"], total, rtol=1e-13
    )
    # the run's outputs are model.outputs at the returned states
    again = case.model.outputs(res.t, res.y)
    for name in case.model.output_names:
        np.testing.assert_array_equal(res.outputs[name], again[name], err_msg=name)


# ---------------------------------------------------------------------------------------------
# Every example, and every output group of every example and of random mechanisms


@pytest.mark.parametrize("name", WITH_OUTPUTS)
def test_example_outputs_match_independent(name: str) -> None:
    case = example(name)
    rng = np.random.default_rng(600 + EXAMPLE_NAMES.index(name))
    for t, y in random_states(rng, case.model.n_state):
        assert_outputs_match(case, t, y)
        assert_outputs_match(case, t, y, scaled_parameters(case, rng))


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_every_group_of_every_example(name: str, scratch: Path) -> None:
    case = everything_example(name, scratch)
    rng = np.random.default_rng(700 + EXAMPLE_NAMES.index(name))
    for t, y in random_states(rng, case.model.n_state):
        assert_outputs_match(case, t, y)
        assert_outputs_match(case, t, y, scaled_parameters(case, rng))


@pytest.mark.parametrize(("seed", "n_bodies", "tree"), RANDOM_CASES)
def test_every_group_of_random_mechanisms(
    seed: int, n_bodies: int, tree: bool, scratch: Path
) -> None:
    text = random_mechanism_yaml(np.random.default_rng(seed), n_bodies, tree, f"rand{seed}")
    case = everything_case(f"rand{seed}", yaml.safe_load(text), scratch)
    rng = np.random.default_rng(800 + seed)
    for t, y in random_states(rng, case.model.n_state, count=3):
        assert_outputs_match(case, t, y)
        assert_outputs_match(case, t, y, scaled_parameters(case, rng))


def test_free_joint_reaction_is_zero(scratch: Path) -> None:
    """A free joint constrains nothing: the 'reaction' of the ground on a free body is 0."""
    case = everything_example("free_body_on_spring", scratch)
    for t, y in random_states(np.random.default_rng(901), case.model.n_state):
        out = case.model.outputs(t, y)
        for key in ("Fx", "Fy", "Fn", "Ft"):
            assert out[f"float.{key}"] == pytest.approx(0.0, abs=1e-9), key


# ---------------------------------------------------------------------------------------------
# Names, order, what is generated, shapes

EVERYTHING_YAML = """\
name: every_group
parameters: {M: 2, m: 0.5, L: 0.8, mb: 0.3, Lb: 0.4, mp: 0.7, k: 20, g: 9.81}
gravity: [0, -g]
bodies:
  cart: {mass: M, inertia: M*0.05, points: {hinge: [0, -0.1]}}
  pendulum: {mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {tip: [L, 0]}}
  bar: {mass: mb, inertia: mb*Lb**2/12, com: [Lb/2, 0]}
  puck: {mass: mp, inertia: mp*0.01, points: {rim: [0.1, 0]}}
joints:
  rail: {type: prismatic, parent: ground, child: cart, axis: [4, 3], coordinate: s}
  hinge: {type: revolute, parent: cart, child: pendulum, at: hinge, coordinate: phi}
  W: {type: weld, parent: pendulum, child: bar, at: tip, offset: pi/2}
  float: {type: free, parent: ground, child: puck, coordinates: [x, y, th]}
loads:
  - spring: {a: puck.rim, b: pendulum.tip, k: k, length: 0.3}
  - joint_spring: {joint: rail, k: k, rest: 0.2, damping: 0.1}
outputs:
  reactions: [rail, hinge, W, float]
  energy: true
  points: [pendulum.tip, bar.com, cart.origin]
  accelerations: true
  expressions: {zeta: "s*dot(phi) + sin(t)", alpha: "L*cos(phi) + th"}
"""

EVERYTHING_NAMES = [
    "rail.Fx", "rail.Fy", "rail.Fn", "rail.Ft", "rail.M",
    "hinge.Fx", "hinge.Fy", "hinge.Fn", "hinge.Ft",
    "W.Fx", "W.Fy", "W.Fn", "W.Ft", "W.M",
    "float.Fx", "float.Fy", "float.Fn", "float.Ft",
    "energy.kinetic", "energy.potential", "energy.total",
    "pendulum.tip.x", "pendulum.tip.y", "pendulum.tip.vx", "pendulum.tip.vy",
    "bar.com.x", "bar.com.y", "bar.com.vx", "bar.com.vy",
    "cart.origin.x", "cart.origin.y", "cart.origin.vx", "cart.origin.vy",
    "ddot(s)", "ddot(phi)", "ddot(x)", "ddot(y)", "ddot(th)",
    "zeta", "alpha",
]  # fmt: skip


@pytest.fixture(scope="module")
def every_group(scratch: Path) -> Case:
    EXPRESSIONS["every_group"] = {
        "zeta": lambda t, s, p: s["s"] * s["dot(phi)"] + np.sin(t),
        "alpha": lambda t, s, p: p["L"] * np.cos(s["phi"]) + s["th"],
    }
    path = scratch / "every_group.yaml"
    path.write_text(EVERYTHING_YAML)
    return _build(str(path))


def test_output_names_and_order_follow_the_spec(every_group: Case) -> None:
    model = every_group.model
    assert list(model.output_names) == EVERYTHING_NAMES
    y = np.random.default_rng(902).uniform(-1, 1, model.n_state)
    assert list(model.outputs(0.3, y)) == EVERYTHING_NAMES
    assert "outputs" in model.metadata["generated"]


def test_every_group_values(every_group: Case) -> None:
    rng = np.random.default_rng(903)
    for t, y in random_states(rng, every_group.model.n_state, count=6):
        assert_outputs_match(every_group, t, y)
        assert_outputs_match(every_group, t, y, scaled_parameters(every_group, rng))


@pytest.mark.parametrize("name", WITHOUT_OUTPUTS)
def test_no_outputs_function_without_outputs(name: str) -> None:
    compiled = compile_mechanism(EXAMPLES / f"{name}.yaml")
    model = compiled.model
    assert "outputs" not in model.metadata["generated"]
    assert model.output_names == ()
    source = (compiled.package / f"{model.name}.c").read_text()
    assert not re.search(r"output_at\s*\(", source), "C source computes outputs"
    stub = re.search(r"int \w+_outputs\(.*?\n}", source, re.DOTALL).group(0)
    assert "return NEMC_NOT_BUILT;" in stub  # the interface's function says: none built
    assert model.outputs(0.0, np.zeros(model.n_state)) == {}
    res = model.simulate(t_span=(0.0, 0.5))
    assert res.success and res.outputs == {}
    # the same check finds the function where outputs were asked for
    with_outputs = compile_mechanism(EXAMPLES / "compound_pendulum.yaml")
    c_file = with_outputs.package / f"{with_outputs.model.name}.c"
    assert re.search(r"output_at\s*\(", c_file.read_text())


def test_energy_only_has_no_reactions(scratch: Path) -> None:
    data = yaml.safe_load((EXAMPLES / "double_pendulum.yaml").read_text())
    data["name"], data["outputs"] = "double_pendulum_energy", {"energy": True}
    path = scratch / "double_pendulum_energy.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    case = _build(str(path))
    names = ["energy.kinetic", "energy.potential", "energy.total"]
    assert list(case.model.output_names) == names
    y = np.array([0.3, -0.2, 1.1, 0.5])
    out = case.model.outputs(1.0, y)
    assert list(out) == names
    kinetic, potential = case.ref.energy(1.0, y)
    assert out["energy.kinetic"] == pytest.approx(kinetic, rel=1e-12)
    assert out["energy.potential"] == pytest.approx(potential, rel=1e-12)


def test_one_state_gives_floats_many_give_arrays() -> None:
    case = example("body_frame_thruster")  # thrust depends on t
    rng = np.random.default_rng(904)
    n_t = 7
    ts, ys = rng.uniform(0, 5, n_t), rng.uniform(-2, 2, (case.model.n_state, n_t))
    many = case.model.outputs(ts, ys)
    assert list(many) == list(case.model.output_names)
    for k in range(n_t):
        one = case.model.outputs(float(ts[k]), ys[:, k])
        assert list(one) == list(case.model.output_names)
        for name, value in one.items():
            assert type(value) is float, name
            assert isinstance(many[name], np.ndarray) and many[name].shape == (n_t,), name
            assert many[name][k] == pytest.approx(value, rel=1e-14, abs=1e-14), name
