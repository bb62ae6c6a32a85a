"""Checks of tests/loop_reference.py itself, against things it does not compute itself.

- Andrews' squeezing mechanism: integrated by scipy from the example file, it reproduces the IVP
  test set's published solution at t = 0.03 (tests/data/andrews_reference.json), and at t = 0
  the test set's consistent accelerations and multipliers: the example encodes the problem.
- Energy: conserved along tight runs of conservative closed chains (the four-bar example, seeded
  random four-bars); the drives' and the loads' power is the rate of change of the total energy
  (fourbar_driven, kapitza, slider_crank).
- Multipliers: the four-bar's loop force equals the one solved from hand Newton-Euler balances of
  the rocker (about its ground pivot) and the coupler (about its crank pin); the ground pivots'
  reactions equal the bodies' force balances.
- Assembly: both branches of random four-bars against the circle intersection; a loop too short
  to close is refused naming the constraint.
- Kinds against each other: the slider-crank's prismatic constraint vs a prismatic joint closed by
  a revolute constraint vs a slot; Kapitza's pendulum against its hand equation of motion.
"""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
import yaml
from loop_reference import (
    AssemblyError,
    LoopReference,
    extended_precision_run,
    projected_run,
    random_fourbar,
    slider_crank_variants,
)
from scipy.integrate import solve_ivp

from nemc.front.validate import load_mechanism

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
ANDREWS = json.loads((ROOT / "tests" / "data" / "andrews_reference.json").read_text())


@functools.cache
def example(name: str, **params: float) -> LoopReference:
    return LoopReference(load_mechanism(EXAMPLES / f"{name}.yaml"), params or None)


def from_text(text: str, folder: Path, name: str) -> LoopReference:
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return LoopReference(load_mechanism(path))


def tight_run(ref: LoopReference, t_end: float, y0: np.ndarray | None = None, rtol: float = 1e-12,
              atol: float = 1e-13):
    y0 = ref.initial_state() if y0 is None else y0
    sol = solve_ivp(ref.rhs, (0.0, t_end), y0, method="DOP853", rtol=rtol, atol=atol,
                    dense_output=True)
    assert sol.success, sol.message
    return sol


# ---------------------------------------------------------------------------------------------
# Andrews' squeezing mechanism: the published solution


def test_andrews_initial_state_is_the_test_sets_consistent_one() -> None:
    ref = example("andrews")
    y0 = ref.initial_state()
    angles = [float(v) for k, v in ANDREWS["initial"].items() if k in ANDREWS["angles"]]
    np.testing.assert_allclose(y0[0::2], angles, rtol=0, atol=1e-15)
    assert np.all(y0[1::2] == 0)
    qdd, lam = ref.solve(0.0, y0)
    expected_qdd = [float(ANDREWS["initial"]["accelerations"][k]) for k in
                    ("ddot(beta)", "ddot(Theta)")]
    np.testing.assert_allclose(qdd[:2], expected_qdd, rtol=1e-12)
    np.testing.assert_allclose(qdd[2:], 0, atol=1e-9)
    # the test set writes M q'' = f - G^T lambda: its lambda is minus the reaction on FE
    np.testing.assert_allclose(-lam, [float(v) for v in ANDREWS["initial"]["lambda"]],
                               rtol=1e-12, atol=1e-10)


def test_andrews_reference_reproduces_the_published_solution() -> None:
    """scipy's DOP853 on the reference's index-1 equations to t = 0.03 (about 0.5 s)."""
    ref = example("andrews")
    sol = tight_run(ref, ANDREWS["t"], rtol=1e-12, atol=1e-14)
    y = sol.y[:, -1]
    angles = np.array(list(ANDREWS["angles"].values()))
    rates = np.array(list(ANDREWS["rates"].values()))
    np.testing.assert_allclose(y[0::2], angles, rtol=1e-8)  # measured: 3e-10
    assert np.linalg.norm(y[1::2] - rates) <= 1e-8 * np.linalg.norm(rates)  # measured: 1.4e-11
    qdd, lam = ref.solve(ANDREWS["t"], y)
    accelerations = np.array(list(ANDREWS["accelerations"].values()))
    assert np.linalg.norm(qdd - accelerations) <= 1e-6 * np.linalg.norm(accelerations)
    np.testing.assert_allclose(-lam, ANDREWS["lambda"], rtol=1e-5)
    position, velocity = ref.residual(ANDREWS["t"], y)
    assert np.abs(position).max() < 1e-13 and np.abs(velocity).max() < 1e-9


# ---------------------------------------------------------------------------------------------
# Energy and power


def relative_spread(values: np.ndarray) -> float:
    return float(np.ptp(values) / np.max(np.abs(values)))


def test_fourbar_energy_is_conserved() -> None:
    ref = example("fourbar")
    sol = tight_run(ref, 10.0)
    energy = [ref.energy(t, sol.sol(t)) for t in np.linspace(0, 10, 201)]
    assert relative_spread(np.array(energy)) < 1e-9  # measured 4e-11


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_conservative_fourbar_energy_is_conserved(seed: int, tmp_path: Path) -> None:
    fourbar = random_fourbar(np.random.default_rng(seed), f"conservative{seed}", loads=False)
    ref = from_text(fourbar.text, tmp_path, f"conservative{seed}")
    sol = tight_run(ref, 3.0)
    energy = np.array([ref.energy(t, sol.sol(t)) for t in np.linspace(0, 3, 61)])
    kinetic = max(ref.energies(t, sol.sol(t))[0] for t in np.linspace(0, 3, 61))
    assert np.ptp(energy) < 1e-9 * kinetic


def energy_and_work(ref: LoopReference, y0: np.ndarray, t_end: float, which: int):
    """Integrate the state and the work of the drives (which=0) or loads (which=1)."""
    def rhs(t: float, z: np.ndarray) -> np.ndarray:
        return np.append(ref.rhs(t, z[:-1]), ref.power_in(t, z[:-1])[which])

    sol = solve_ivp(rhs, (0.0, t_end), np.append(y0, 0.0), method="DOP853", rtol=1e-12,
                    atol=1e-13)
    assert sol.success
    y, work = sol.y[:-1, -1], sol.y[-1, -1]
    return ref.energy(t_end, y) - ref.energy(0.0, y0), work


def test_kapitza_drive_power_is_the_rate_of_total_energy() -> None:
    ref = example("kapitza")
    gained, work = energy_and_work(ref, ref.initial_state(), 0.7, which=0)
    assert abs(work) > 0.01  # the drive does work, in and out
    assert gained == pytest.approx(work, rel=1e-8, abs=1e-10)


def test_fourbar_driven_drive_power_is_the_rate_of_total_energy() -> None:
    """0 degrees of freedom: states assembled at each time; dE/dt by central differences."""
    ref = example("fourbar_driven")
    state = ref.initial_state()
    for t in np.linspace(0.05, 0.95, 7):
        state = ref.assemble(t, {}, dict(zip(("q2", "q3"), state[0::2])))
        h = 1e-4
        ahead = ref.assemble(t + h, {}, dict(zip(("q2", "q3"), state[0::2])))
        behind = ref.assemble(t - h, {}, dict(zip(("q2", "q3"), state[0::2])))
        dE = (ref.energy(t + h, ahead) - ref.energy(t - h, behind)) / (2 * h)
        drive, loads = ref.power_in(t, state)
        assert loads == 0.0
        assert drive == pytest.approx(dE, rel=1e-6, abs=1e-6)
    # and integrated: the rheonomic constraint's work over part of a revolution
    gained, work = energy_and_work(ref, ref.initial_state(), 0.37, which=0)
    assert gained == pytest.approx(work, rel=1e-7)


def test_slider_crank_load_power_is_the_rate_of_total_energy() -> None:
    ref = example("slider_crank")
    gained, work = energy_and_work(ref, ref.initial_state(), 1.0, which=1)
    assert gained == pytest.approx(work, rel=1e-8)


# ---------------------------------------------------------------------------------------------
# Multipliers and reactions against hand Newton-Euler balances


def cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def rot(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


class FourbarByHand:
    """The four-bar's bodies in numpy, from its YAML data: absolute angles, points, masses."""

    def __init__(self, data: dict, values: dict[str, float]) -> None:
        names = {k: sp.Float(v) for k, v in values.items()}

        def num(expr) -> float:
            return float(sp.sympify(str(expr), locals=names))

        self.num = num
        joints, bodies = data["joints"], data["bodies"]
        self.A = np.array([num(v) for v in joints["A"]["at"]])
        self.D = np.array([num(v) for v in joints["D"]["at"]])
        self.offsets = [num(joints[j].get("offset", 0)) for j in "ABD"]
        self.absolute = joints["B"].get("angle") == "absolute"
        self.mass = {b: num(spec["mass"]) for b, spec in bodies.items()}
        self.inertia = {b: num(spec["inertia"]) for b, spec in bodies.items()}
        self.com = {b: np.array([num(v) for v in spec["com"]]) for b, spec in bodies.items()}
        self.point = {b: {k: np.array([num(v) for v in xy]) for k, xy in spec["points"].items()}
                      for b, spec in bodies.items()}
        self.g = np.array([num(v) for v in data["gravity"]])

    def state(self, y: np.ndarray, qdd: np.ndarray):
        """Absolute angles, rates, accelerations of crank, coupler, rocker."""
        q, u, a = y[0::2], y[1::2], qdd
        o1, o2, o3 = self.offsets
        base = (0.0, 0.0, 0.0) if self.absolute else (q[0], u[0], a[0])
        th = (q[0] + o1, base[0] + q[1] + o2, q[2] + o3)
        w = (u[0], base[1] + u[1], u[2])
        al = (a[0], base[2] + a[1], a[2])
        return th, w, al


def rigid(origin, a_origin, th, w, al, r_body):
    """Position and acceleration of a body point (body coordinates r_body)."""
    r = rot(th) @ r_body
    perp = np.array([-r[1], r[0]])
    return origin + r, a_origin + al * perp - w**2 * r


def hand_loop_force(hand: FourbarByHand, y: np.ndarray, qdd: np.ndarray) -> dict:
    """The coupler-rocker force from the rocker's and the coupler's moment balances; then the
    ground's forces on crank and rocker from the force balances."""
    (t1, t2, t3), (w1, w2, w3), (a1, a2, a3) = hand.state(y, qdd)
    g = hand.g
    m, inertia, com = hand.mass, hand.inertia, hand.com
    B, aB = rigid(hand.A, 0, t1, w1, a1, hand.point["crank"]["B"])
    r1, acc1 = rigid(hand.A, 0, t1, w1, a1, com["crank"])
    r2, acc2 = rigid(B, aB, t2, w2, a2, com["coupler"])
    r3, acc3 = rigid(hand.D, 0, t3, w3, a3, com["rocker"])
    C = hand.D + rot(t3) @ hand.point["rocker"]["C"]
    # unknown F: the coupler's force on the rocker at C
    # rocker about D:   I3 a3 + (r3 - D) x m3 acc3 = (r3 - D) x m3 g + (C - D) x F
    # coupler about B:  I2 a2 + (r2 - B) x m2 acc2 = (r2 - B) x m2 g + (C - B) x (-F)
    rows = np.array([[-(C - hand.D)[1], (C - hand.D)[0]], [(C - B)[1], -(C - B)[0]]])
    rhs = np.array([
        inertia["rocker"] * a3 + cross(r3 - hand.D, m["rocker"] * (acc3 - g)),
        inertia["coupler"] * a2 + cross(r2 - B, m["coupler"] * (acc2 - g)),
    ])
    F = np.linalg.solve(rows, rhs)
    F_coupler_on_crank = -(m["coupler"] * (acc2 - g) + F)  # coupler: m2 a2 = m2 g + F_B - F
    return {
        "F": F,
        "A": m["crank"] * (acc1 - g) - F_coupler_on_crank,
        "D": m["rocker"] * (acc3 - g) - F,
        "crank_moment": inertia["crank"] * a1 + cross(r1 - hand.A, m["crank"] * (acc1 - g))
        - cross(B - hand.A, F_coupler_on_crank),  # no torque on the crank: must vanish
        "scale": float(np.abs(rhs).max() + np.abs(F).max()),
    }


def consistent_states(ref: LoopReference, rng: np.random.Generator, count: int):
    """States on the constraints: random crank angles and rates, assembled on the scene's
    branch (its guess)."""
    for _ in range(count):
        t = float(rng.uniform(0, 2))
        q1, w1 = float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(-4, 4))
        start = ref.initial_state()
        guess = dict(zip(("q2", "q3"), start[2::2]))
        # walk the crank there in small steps so the assembly stays on the branch
        for q in np.linspace(start[0], q1, 12)[1:]:
            guess = dict(zip(("q2", "q3"), ref.assemble(t, {"q1": q}, guess)[2::2]))
        yield t, ref.assemble(t, {"q1": q1, "dot(q1)": w1}, guess)


@pytest.mark.parametrize("seed", [None, 0, 1, 2, 3])
def test_fourbar_multipliers_are_the_newton_euler_loop_force(seed: int | None,
                                                              tmp_path: Path) -> None:
    if seed is None:  # the example
        data = yaml.safe_load((EXAMPLES / "fourbar.yaml").read_text())
        ref, a_body = example("fourbar"), "rocker"
    else:
        fourbar = random_fourbar(np.random.default_rng(seed), f"hand{seed}", loads=False)
        data, a_body = yaml.safe_load(fourbar.text), fourbar.constraint_a
        ref = from_text(fourbar.text, tmp_path, f"hand{seed}")
    hand = FourbarByHand(data, ref.values)
    rng = np.random.default_rng(50 + (seed or 0))
    for t, y in consistent_states(ref, rng, 4):
        qdd, _ = ref.solve(t, y)
        balance = hand_loop_force(hand, y, qdd)
        lam = ref.multipliers(t, y)["C"]
        on_rocker = lam if a_body == "rocker" else -lam
        tol = 1e-10 * max(1.0, balance["scale"])
        np.testing.assert_allclose(on_rocker, balance["F"], rtol=1e-9, atol=tol)
        assert abs(balance["crank_moment"]) < tol
        out = ref.outputs(t, y)
        for joint in ("A", "D"):
            got = np.array([out[f"{joint}.Fx"], out[f"{joint}.Fy"]])
            np.testing.assert_allclose(got, balance[joint], rtol=1e-9, atol=tol)


# ---------------------------------------------------------------------------------------------
# Assembly


@pytest.mark.parametrize("seed", range(4))
def test_assembly_finds_both_branches(seed: int, tmp_path: Path) -> None:
    fourbar = random_fourbar(np.random.default_rng(200 + seed), f"branches{seed}")
    ref = from_text(fourbar.text, tmp_path, f"branches{seed}")
    rng = np.random.default_rng(seed)
    for q2, q3 in fourbar.branches.values():
        guess = {"q2": q2 + rng.uniform(-0.15, 0.15), "q3": q3 + rng.uniform(-0.15, 0.15)}
        y = ref.assemble(0.0, {"q1": fourbar.q1, "dot(q1)": 1.5}, guess)
        got = np.array([y[2], y[4]])
        np.testing.assert_allclose(np.angle(np.exp(1j * (got - [q2, q3]))), 0, atol=1e-12)
        assert y[0] == fourbar.q1 and y[1] == 1.5
        position, velocity = ref.residual(0.0, y)
        assert np.abs(position).max() < 1e-14 and np.abs(velocity).max() < 1e-13


def test_a_loop_too_short_to_close_is_refused_naming_it(tmp_path: Path) -> None:
    text = (EXAMPLES / "fourbar.yaml").read_text().replace("L3: 0.3", "L3: 0.05")
    ref = from_text(text, tmp_path, "short")
    with pytest.raises(AssemblyError, match="constraint 'C' cannot hold"):
        ref.initial_state()


def test_values_over_determining_the_assembly_must_agree(tmp_path: Path) -> None:
    ref = example("fourbar")
    y = ref.initial_state()
    agreed = {"q1": y[0], "q2": y[2], "q3": y[4], "dot(q1)": y[1]}
    np.testing.assert_allclose(ref.assemble(0.0, agreed), y, atol=1e-14)
    with pytest.raises(AssemblyError, match="'C'"):
        ref.assemble(0.0, {**agreed, "q3": y[4] + 1e-6})


# ---------------------------------------------------------------------------------------------
# Constraint kinds against each other; a driven joint against its hand equation


def test_prismatic_constraint_equals_a_prismatic_joint_and_a_slot(tmp_path: Path) -> None:
    """The slider held by the prismatic constraint, by a prismatic joint to the ground plus a
    revolute constraint at the pin, and by a slot (its tilt then free and decoupled)."""
    variants = slider_crank_variants((EXAMPLES / "slider_crank.yaml").read_text())
    as_constraint = example("slider_crank")
    as_joint = from_text(variants["prismatic_joint"], tmp_path, "slider_joint")
    as_slot = from_text(variants["slot"], tmp_path, "slider_slot")
    rng = np.random.default_rng(7)
    for _ in range(5):
        t, q1, w1 = float(rng.uniform(0, 1)), float(rng.uniform(-3, 3)), float(rng.uniform(-9, 9))
        y = as_constraint.assemble(t, {"q1": q1, "dot(q1)": w1}, {"q2": 0.0, "q3": 0.0})
        x = as_constraint.outputs(t, y)["slider.origin.x"]
        vx = as_constraint.outputs(t, y)["slider.origin.vx"]
        y_joint = y.copy()
        y_joint[4:6] = x, vx
        y_slot = y.copy()
        y_slot[5] = float(rng.uniform(-5, 5))  # the slider's spin, free in the slot
        want = as_constraint.rhs(t, y)
        np.testing.assert_allclose(as_joint.rhs(t, y_joint)[:4], want[:4], rtol=1e-10)
        np.testing.assert_allclose(as_slot.rhs(t, y_slot)[:4], want[:4], rtol=1e-10)
        guide, rail = as_constraint.outputs(t, y), as_joint.outputs(t, y_joint)
        # the guide's force on the slider is the rail's normal force (the rail pushes along y)
        assert guide["guide.Fy"] == pytest.approx(rail["S.Fy"], rel=1e-9, abs=1e-9)
        assert guide["guide.Fx"] == pytest.approx(0.0, abs=1e-12)
        assert guide["guide.M"] == pytest.approx(rail["S.M"], rel=1e-9, abs=1e-9)
        assert guide["O.Fx"] == pytest.approx(rail["O.Fx"], rel=1e-9, abs=1e-9)


def test_kapitza_against_its_hand_equation() -> None:
    """Rod on a pivot at height s = A cos(W t): I_O th'' = -m (L/2) (g + s'') cos th; the drive
    force F = (mp + m)(g + s'') + m (L/2)(th'' cos th - th'^2 sin th)."""
    ref = example("kapitza")
    v = ref.values
    m, mp, L, g, A, W = (v[k] for k in ("m", "mp", "L", "g", "A", "W"))
    rng = np.random.default_rng(11)
    for _ in range(6):
        t, th, w = float(rng.uniform(0, 2)), float(rng.uniform(-3, 3)), float(rng.uniform(-9, 9))
        s_dd = -A * W**2 * math.cos(W * t)
        alpha = -m * L / 2 * (g + s_dd) * math.cos(th) / (m * L**2 / 3)
        dy = ref.rhs(t, np.array([th, w]))
        assert dy[1] == pytest.approx(alpha, rel=1e-12, abs=1e-12)
        force = (mp + m) * (g + s_dd) + m * L / 2 * (alpha * math.cos(th) - w**2 * math.sin(th))
        assert ref.drives(t, np.array([th, w]))["shaker"] == pytest.approx(force, rel=1e-11)


# ---------------------------------------------------------------------------------------------
# The integrators the benchmark builds on


def test_extended_precision_run_converges_to_the_double_precision_solution() -> None:
    """8th order: halving the step shrinks the difference about 2^8 times; the result agrees
    with scipy's tight DOP853 to that run's accuracy."""
    ref = example("fourbar")
    y0 = ref.initial_state()
    runs = [extended_precision_run(ref, (0.0, 0.5), y0, steps) for steps in (100, 200, 400)]
    first, second = (float(np.abs(a - b).max()) for a, b in zip(runs, runs[1:]))
    assert second < first / 100 and second < 1e-11, (first, second)
    tight = tight_run(ref, 0.5, y0, rtol=1e-13, atol=1e-14).y[:, -1]
    np.testing.assert_allclose(runs[-1].astype(float), tight, rtol=0, atol=1e-10)


def test_projected_run_keeps_the_loop_closed_and_follows_the_solution() -> None:
    ref = example("fourbar")
    y0 = ref.initial_state()
    run = projected_run(ref.rhs, ref.project, (0.0, 2.0), y0, 1e-8, 1e-11,
                        t_eval=np.linspace(0.0, 2.0, 9))
    assert run.t.tolist() == np.linspace(0.0, 2.0, 9).tolist() and run.steps > 10
    for t, y in zip(run.t, run.y.T):
        position, velocity = ref.residual(t, y)
        assert np.abs(position).max() < 1e-14 and np.abs(velocity).max() < 1e-12
    tight = tight_run(ref, 2.0, y0).sol(run.t)
    assert np.abs(run.y - tight).max() < 1e-5


@pytest.mark.parametrize(("W", "stable"), [(200.0, True), (50.0, False)])
def test_kapitza_example_claims_hold_in_the_reference(W: float, stable: bool) -> None:
    """The example's comment: A**2 W**2 = 16 > 2 g l = 3.9 keeps the rod upright over the
    scene's 3 s; A**2 W**2 = 1 lets it fall."""
    ref = example("kapitza", W=W)
    sol = tight_run(ref, 3.0, rtol=1e-9, atol=1e-11)
    tilt = np.abs(sol.sol(np.linspace(0, 3, 601))[0] - math.pi / 2).max()
    assert (tilt < 0.35) if stable else (tilt > 1.5), tilt
