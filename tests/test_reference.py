"""The test reference (tests/reference.py) against equations derived by hand.

The mechanisms here are built directly as ``nemc.front.mechanism`` values, so these checks depend on
neither the loader nor the pipeline.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import sympy as sp
import yaml
from reference import (
    JOINT_SPRING_ANGLE_INCLUDES_OFFSET,
    ReferenceModel,
    book_two_link_rhs,
    random_mechanism_yaml,
    resolve_parameters,
)

from nemc.front.mechanism import (
    GROUND,
    TIME,
    Body,
    Loc,
    Mechanism,
    Outputs,
    Param,
    PointRef,
    Simulation,
    rate_symbol,
    symbol,
)
from nemc.kinds.joints import JOINT_KINDS, Joint
from nemc.kinds.loads import Force, JointSpring, Spring, Torque

LOC = Loc("hand.yaml", 1, 1, "hand")
FUNCTIONS = {"sin", "cos", "sqrt", "pi", "e"}


def S(text: object) -> sp.Expr:
    """An expression with the model's real symbols (``dot(q)`` -> the rate symbol of q)."""
    text = re.sub(r"dot\((\w+)\)", r"__dot_\1", str(text))
    names = {}
    for name in set(re.findall(r"[A-Za-z_]\w*", text)) - FUNCTIONS:
        names[name] = (
            TIME
            if name == "t"
            else rate_symbol(name[6:])
            if name.startswith("__dot_")
            else symbol(name)
        )
    return sp.parse_expr(text, local_dict=names)


def rod(name: str, m: str, L: str, **points: tuple) -> Body:
    pts = {k: (S(x), S(y)) for k, (x, y) in points.items()}
    return Body(name, S(m), S(f"{m}*{L}**2/12"), (S(L) / 2, S(0)), pts, LOC)


def joint(name: str, kind: str, parent: str, child: str, coords=(), at=(0, 0), **kw) -> Joint:
    kw = {
        k: (tuple(S(a) for a in v) if k == "axis" else S(v) if k == "offset" else v)
        for k, v in kw.items()
    }
    return JOINT_KINDS[kind](name=name, parent=parent, child=child, at=(S(at[0]), S(at[1])),
                             coordinates=tuple(coords), loc=LOC, **kw)


def mechanism(
    params: dict,
    bodies,
    joints,
    loads=(),
    gravity=("0", "-g"),
    initial=None,
    constants: dict | None = None,
) -> Mechanism:
    return Mechanism(
        name="hand",
        description="",
        source="hand.yaml",
        source_hash="",
        parameters=tuple(Param(k, S(v), LOC) for k, v in params.items()),
        constants=tuple(Param(k, S(v), LOC) for k, v in (constants or {}).items()),
        gravity=(S(gravity[0]), S(gravity[1])),
        bodies=tuple(bodies),
        joints=tuple(joints),
        loads=tuple(loads),
        outputs=Outputs(),
        simulation=Simulation(initial={k: S(v) for k, v in (initial or {}).items()}),
    )


def states(rng: np.random.Generator, n: int, count: int = 5) -> list[np.ndarray]:
    return [rng.uniform(-2, 2, 2 * n) for _ in range(count)]


def compound_pendulum() -> Mechanism:
    return mechanism(
        {"W": 12, "L": 3, "g": 32.2, "m": "W/g"},
        [rod("rod", "m", "L")],
        [joint("O", "revolute", GROUND, "rod", ["theta"])],
        initial={"theta": "pi/4"},
    )


def test_compound_pendulum_book_equation() -> None:
    ref = ReferenceModel(compound_pendulum())
    assert ref.rhs(0, [0.0, 0.0])[1] == pytest.approx(-16.1, rel=1e-14)
    for y in states(np.random.default_rng(1), 1):
        assert ref.rhs(0, y) == pytest.approx([y[1], -3 * 32.2 * math.cos(y[0]) / 6], rel=1e-13)
        assert ref.rhs(0, y, {"W": 24}) == pytest.approx(ref.rhs(0, y), rel=1e-13)


def test_derived_parameter_follows_its_inputs() -> None:
    mech = compound_pendulum()
    assert resolve_parameters(mech)["m"] == pytest.approx(12 / 32.2)
    assert resolve_parameters(mech, {"W": 24})["m"] == pytest.approx(24 / 32.2)
    T, V = ReferenceModel(mech).energy(0, [0.3, 2.0], {"W": 24})
    m = 24 / 32.2
    assert T == pytest.approx(0.5 * m * 9 / 3 * 4, rel=1e-14)
    assert V == pytest.approx(m * 32.2 * 1.5 * math.sin(0.3), rel=1e-14)
    assert ReferenceModel(mech).initial_state() == pytest.approx([math.pi / 4, 0])


def test_robot_arm_book_equation() -> None:
    mech = mechanism(
        {"L": 1, "m": 1, "g": 9.81, "beta": 45, "gamma": 30, "thetaf": "pi/3"},
        [rod("link", "m", "L")],
        [joint("O", "revolute", GROUND, "link", ["theta"])],
        [
            Torque(
                S("-beta*dot(theta) - gamma*(theta - thetaf) + 0.5*g*L*m*cos(theta)"),
                "link",
                GROUND,
                LOC,
            )
        ],
    )
    ref = ReferenceModel(mech)
    for y in states(np.random.default_rng(2), 1):
        expected = -135 * y[1] - 90 * y[0] + 30 * math.pi
        assert ref.rhs(0, y)[1] == pytest.approx(expected, rel=1e-12, abs=1e-11)


def double_pendulum(loads=()) -> Mechanism:
    return mechanism(
        {"m1": 1, "m2": 1, "L1": 1, "L2": 0.5, "g": 10},
        [rod("link1", "m1", "L1", B=("L1", 0)), rod("link2", "m2", "L2", D=("L2", 0))],
        [
            joint("A", "revolute", GROUND, "link1", ["q1"]),
            joint("B", "revolute", "link1", "link2", ["q2"], at=("L1", 0), angle="absolute"),
        ],
        loads,
    )


def double_pendulum_by_hand(y: np.ndarray, m1=1.0, m2=1.0, L1=1.0, L2=0.5, g=10.0):
    q1, u1, q2, u2 = y
    c2 = L2 / 2
    d = q1 - q2
    M = np.array(
        [
            [m1 * L1**2 / 3 + m2 * L1**2, m2 * L1 * c2 * math.cos(d)],
            [m2 * L1 * c2 * math.cos(d), m2 * L2**2 / 12 + m2 * c2**2],
        ]
    )
    f = np.array(
        [
            -m2 * L1 * c2 * math.sin(d) * u2**2 - (m1 * L1 / 2 + m2 * L1) * g * math.cos(q1),
            m2 * L1 * c2 * math.sin(d) * u1**2 - m2 * c2 * g * math.cos(q2),
        ]
    )
    return M, f


def test_double_pendulum_standard_mass_matrix() -> None:
    ref = ReferenceModel(double_pendulum())
    for y in states(np.random.default_rng(3), 2):
        M, f = ref.mass_forcing(0, y)
        M0, f0 = double_pendulum_by_hand(y)
        np.testing.assert_allclose(M, M0, rtol=1e-13, atol=1e-14)
        np.testing.assert_allclose(f, f0, rtol=1e-13, atol=1e-13)
        M0, f0 = double_pendulum_by_hand(y, m2=3.0, L1=0.7)
        M, f = ref.mass_forcing(0, y, {"m2": 3.0, "L1": 0.7})
        np.testing.assert_allclose(M, M0, rtol=1e-13, atol=1e-14)
        np.testing.assert_allclose(f, f0, rtol=1e-13, atol=1e-13)


def test_two_link_robot_arm_matches_book_newton_euler() -> None:
    mech = mechanism(
        {
            "L1": 1,
            "L2": 1,
            "m1": 1,
            "m2": 1,
            "g": 9.81,
            "b01": 450,
            "g01": 300,
            "b12": 200,
            "g12": 300,
            "q1f": "pi/6",
            "q2f": "pi/3",
        },
        [rod("link1", "m1", "L1", B=("L1", 0)), rod("link2", "m2", "L2", D=("L2", 0))],
        [
            joint("A", "revolute", GROUND, "link1", ["q1"]),
            joint("B", "revolute", "link1", "link2", ["q2"], at=("L1", 0), angle="absolute"),
        ],
        [
            Torque(
                S("-b01*dot(q1) - g01*(q1 - q1f) + 0.5*g*L1*m1*cos(q1) + g*L1*m2*cos(q1)"),
                "link1",
                GROUND,
                LOC,
            ),
            Torque(S("-b12*dot(q2) - g12*(q2 - q2f) + 0.5*g*L2*m2*cos(q2)"), "link2", "link1", LOC),
        ],
    )
    ref = ReferenceModel(mech)
    for y in states(np.random.default_rng(4), 2):
        np.testing.assert_allclose(ref.rhs(0, y), book_two_link_rhs(0, y), rtol=1e-12, atol=1e-9)


def test_relative_angles_equal_absolute_ones() -> None:
    rel = mechanism(
        {"m1": 1, "m2": 1, "L1": 1, "L2": 0.5, "g": 10},
        [rod("link1", "m1", "L1", B=("L1", 0)), rod("link2", "m2", "L2")],
        [
            joint("A", "revolute", GROUND, "link1", ["q1"]),
            joint("B", "revolute", "link1", "link2", ["p"], at=("L1", 0), offset="0.3"),
        ],
    )
    ref_rel, ref_abs = ReferenceModel(rel), ReferenceModel(double_pendulum())
    for y in states(np.random.default_rng(5), 2):
        q1, u1, p, up = y
        y_abs = np.array([q1, u1, q1 + p + 0.3, u1 + up])
        d_abs = ref_abs.rhs(0, y_abs)
        d_rel = ref_rel.rhs(0, y)
        assert d_rel[1] == pytest.approx(d_abs[1], rel=1e-12)
        assert d_rel[3] == pytest.approx(d_abs[3] - d_abs[1], rel=1e-12, abs=1e-12)


def test_cart_pendulum_prismatic() -> None:
    # cart (mass M) on an inclined rail at angle a with a pendulum hanging from its origin
    a = math.atan2(3, 4)
    mech = mechanism(
        {"M": 2, "m": 0.5, "L": 0.8, "g": 9.81},
        [Body("cart", S("M"), S("0.1"), (S(0), S(0)), {}, LOC), rod("pend", "m", "L")],
        [
            joint("rail", "prismatic", GROUND, "cart", ["s"], at=(1, 0), axis=(4, 3)),
            joint("hinge", "revolute", "cart", "pend", ["phi"], offset="-pi/2"),
        ],
    )
    ref = ReferenceModel(mech)
    M_, m, L, g = 2.0, 0.5, 0.8, 9.81
    for y in states(np.random.default_rng(6), 2):
        s, us, phi, uphi = y
        th = phi - math.pi / 2  # pendulum angle from x
        c = L / 2
        # T = 1/2 (M+m) us^2 + m us c uphi (e . n') + 1/2 (I_O) uphi^2, e = (cos a, sin a),
        # n' = (-sin th, cos th)
        en = -math.cos(a) * math.sin(th) + math.sin(a) * math.cos(th)
        en_th = -math.cos(a) * math.cos(th) - math.sin(a) * math.sin(th)
        Mm = np.array([[M_ + m, m * c * en], [m * c * en, m * L**2 / 3]])
        f = np.array(
            [-m * c * en_th * uphi**2 - (M_ + m) * g * math.sin(a), -m * g * c * math.cos(th)]
        )
        expected = np.linalg.solve(Mm, f)
        np.testing.assert_allclose(ref.rhs(0, y)[1::2], expected, rtol=1e-12, atol=1e-12)


def test_free_body_with_spring_and_body_force() -> None:
    mech = mechanism(
        {"m": 1.5, "I": 0.2, "k": 60, "l0": 0.5, "c": 0.7, "F": 2.0, "g": 9.81},
        [Body("plate", S("m"), S("I"), (S(0), S(0)), {"eye": (S("0.3"), S("0.1"))}, LOC)],
        [joint("float", "free", GROUND, "plate", ["x", "y", "th"])],
        [
            Spring(
                PointRef("plate", (S("0.3"), S("0.1")), "plate.eye"),
                PointRef(GROUND, (S(0), S(1)), "ground.[0, 1]"),
                S("k"),
                S("l0"),
                S("c"),
                LOC,
            ),
            Force((S(0), S("F")), "plate", (S("0.3"), S(0)), "body", LOC),
        ],
    )
    ref = ReferenceModel(mech)
    m, inertia, k, l0, c, F, g = 1.5, 0.2, 60, 0.5, 0.7, 2.0, 9.81
    for y in states(np.random.default_rng(7), 3):
        x, ux, yy, uy, th, uth = y
        R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        arm = R @ [0.3, 0.1]
        p = np.array([x, yy]) + arm
        vp = np.array([ux, uy]) + uth * np.array([-arm[1], arm[0]])
        d = p - [0, 1]
        ell = np.linalg.norm(d)
        e = d / ell
        Fs = -(k * (ell - l0) + c * (vp @ e)) * e
        Fb = R @ [0, F]
        arm_b = R @ [0.3, 0]
        force = Fs + Fb + [0, -m * g]
        torque = arm[0] * Fs[1] - arm[1] * Fs[0] + arm_b[0] * Fb[1] - arm_b[1] * Fb[0]
        expected = [force[0] / m, force[1] / m, torque / inertia]
        np.testing.assert_allclose(ref.rhs(0, y)[1::2], expected, rtol=1e-12, atol=1e-12)


def test_weld_equals_one_composite_body() -> None:
    # a T pendulum (rod + crossbar welded at its tip, at a right angle) against one body
    welded = mechanism(
        {"g": 9.81},
        [rod("rod", "1", "1", tip=(1, 0)), rod("bar", "0.6", "0.8")],
        [
            joint("O", "revolute", GROUND, "rod", ["theta"]),
            joint("W", "weld", "rod", "bar", at=(1, 0), offset="pi/2"),
        ],
    )
    # composite: mass 1.6, com at (1*0.5 + 0.6*1)/1.6 along x, 0.6*0.4/1.6 along y
    xc, yc = (0.5 + 0.6) / 1.6, 0.6 * 0.4 / 1.6
    i_o = 1 / 3 + 0.6 * 0.64 / 12 + 0.6 * (1 + 0.16)
    one = mechanism(
        {"g": 9.81},
        [Body("t", S("1.6"), S(i_o - 1.6 * (xc**2 + yc**2)), (S(xc), S(yc)), {}, LOC)],
        [joint("O", "revolute", GROUND, "t", ["theta"])],
    )
    a, b = ReferenceModel(welded), ReferenceModel(one)
    for y in states(np.random.default_rng(8), 1):
        np.testing.assert_allclose(a.rhs(0, y), b.rhs(0, y), rtol=1e-12)
        np.testing.assert_allclose(a.energy(0, y), b.energy(0, y), rtol=1e-12)


@pytest.mark.parametrize("angle", ["relative", "absolute"])
def test_joint_springs_and_torque_reaction(angle: str) -> None:
    # two links, angle p at B with a damped torsion spring, and a torque of l1 on l2
    mech = mechanism(
        {"k": 5.0, "r": 0.2, "c": 0.3, "tau": 0.7},
        [rod("l1", "1", "1"), rod("l2", "1", "1")],
        [
            joint("A", "revolute", GROUND, "l1", ["q"]),
            joint("B", "revolute", "l1", "l2", ["p"], at=(1, 0), offset="0.4", angle=angle),
        ],
        [JointSpring("B", S("k"), S("r"), S("c"), LOC), Torque(S("tau*t"), "l2", "l1", LOC)],
        gravity=(0, 0),
    )
    ref = ReferenceModel(mech)
    free = ReferenceModel(mechanism({}, mech.bodies, mech.joints, gravity=(0, 0)))
    offset = 0.4 if JOINT_SPRING_ANGLE_INCLUDES_OFFSET else 0.0
    t = 0.9
    for y in states(np.random.default_rng(9), 2):
        q, uq, p, up = y
        if angle == "relative":
            rel, rate, grad = p + offset, up, np.array([0.0, 1.0])
        else:
            rel, rate, grad = p + offset - q, up - uq, np.array([-1.0, 1.0])
        torque = -5.0 * (rel - 0.2) - 0.3 * rate + 0.7 * t
        _, f = ref.mass_forcing(t, y)
        _, f0 = free.mass_forcing(t, y)
        np.testing.assert_allclose(f - f0, torque * grad, rtol=1e-12, atol=1e-12)


def test_prismatic_joint_spring_oscillator() -> None:
    mech = mechanism(
        {"m": 2.0, "k": 8.0, "c": 0.5},
        [Body("mass", S("m"), S("0.1"), (S(0), S(0)), {}, LOC)],
        [joint("P", "prismatic", GROUND, "mass", ["s"], axis=(0, 2), offset="1.0")],
        [
            JointSpring("P", S("k"), S("0.25"), S("c"), LOC),
            Force((S(0), S("-m*g0")), "mass", (S(0), S(0)), "ground", LOC),
        ],
        gravity=(0, 0),
        constants={"g0": 9.81},
    )
    ref = ReferenceModel(mech)
    for y in states(np.random.default_rng(10), 1):
        expected = (-8.0 * (y[0] - 0.25) - 0.5 * y[1] - 2.0 * 9.81) / 2.0
        assert ref.rhs(0, y)[1] == pytest.approx(expected, rel=1e-13)


@pytest.mark.parametrize("seed", range(6))
def test_random_yaml_is_well_formed(seed: int) -> None:
    rng = np.random.default_rng(seed)
    data = yaml.safe_load(random_mechanism_yaml(rng, 2 + seed % 4, tree=seed % 2 == 1))
    assert set(data["bodies"]) == {f"b{i}" for i in range(1, len(data["bodies"]) + 1)}
    children = [j["child"] for j in data["joints"].values()]
    assert sorted(children) == sorted(data["bodies"])
    coordinates = [j.get("coordinate") for j in data["joints"].values()]
    assert any(coordinates) or any("coordinates" in j for j in data["joints"].values())
    assert sum(j["type"] == "free" for j in data["joints"].values()) <= 1
    assert symbol("q1").name == "q1"
