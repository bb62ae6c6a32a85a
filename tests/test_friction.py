"""Coulomb friction that sticks and slips (format v3 `friction`), against closed forms and an
independent derivation: the block on a spring (its turning points, its rest, the energy
friction took), a block pushed by a growing force (the instant it breaks free and its slide),
a pendulum with pin friction (its normal force depends on its acceleration: solved together)
against a hand-derived equation integrated by scipy; and bad files, one clear error each."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import nemc
from nemc.errors import InputError
from nemc.runtime.failures import ModelError

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
M, K, G, MU, MU_S = 1.0, 10.0, 9.81, 0.1, 0.15


@pytest.fixture(scope="module")
def block():
    return nemc.compile(EXAMPLES / "coulomb_block.yaml")


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853", "auto"])
def test_the_block_turns_and_sticks_where_the_closed_form_says(block, method: str) -> None:
    result = block.simulate(method=method)
    assert result.success
    half = math.pi / math.sqrt(K / M)
    delta = 2 * MU * M * G / K
    turns = [(-1) ** n * (1.0 - n * delta) for n in range(1, 6)]
    assert abs(turns[-1]) * K <= MU_S * M * G < abs(turns[-2]) * K  # it sticks at the 5th
    times, states = result.events["slide.stick_slip"]
    np.testing.assert_allclose(times, [n * half for n in range(1, 6)], rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.asarray(states)[:, 0], turns, rtol=0, atol=1e-9)
    after = result.t > 5 * half + 1e-6
    assert np.all(result.y[1, after] == 0.0)  # held exactly
    assert np.all(result.y[0, after] == result.y[0, -1])
    assert np.all(result.outputs["slide.stuck"][after] == 1.0)
    sliding = (result.t > 1e-6) & (result.t < 5 * half - 1e-6)
    assert np.all(result.outputs["slide.stuck"][sliding] == 0.0)


def test_friction_takes_the_energy_its_work_says(block) -> None:
    """The power balance: energy lost = the integral of the friction's power F v, each swing
    mu m g times its path (closed form), to 1e-9; and F = -mu m g sign(v) while it slides."""
    result = block.simulate()
    energy = result.outputs["energy.total"]
    delta = 2 * MU * M * G / K
    path = sum(2 * (1.0 - n * delta) - delta for n in range(5))  # |x_n - x_{n+1}|
    assert energy[0] - energy[-1] == pytest.approx(MU * M * G * path, abs=1e-9)
    v, force = result.y[1], result.outputs["slide.friction"]
    moving = v != 0
    np.testing.assert_allclose(force[moving], -MU * M * G * np.sign(v[moving]), rtol=1e-12)
    held = ~moving
    np.testing.assert_allclose(force[held], K * result.y[0, held], rtol=1e-9, atol=1e-12)


PUSHED = """
name: pushed_block
parameters: {m: 2.0, g: 9.81, mu: 0.3, mu_s: 0.5, c: 4.0}
gravity: [0, -g]
bodies:
  block: {mass: m, inertia: 0.1}
joints:
  slide: {type: prismatic, parent: ground, child: block, coordinate: x}
loads:
  - {force: [c*t, 0], body: block}
friction:
  - {joint: slide, mu: mu, mu_static: mu_s}
simulation:
  t_span: [0, 6]
  rtol: 1.0e-11
  atol: 1.0e-13
"""


def test_a_pushed_block_breaks_free_when_the_push_reaches_static_friction(tmp_path: Path
                                                                          ) -> None:
    path = tmp_path / "pushed.yaml"
    path.write_text(PUSHED)
    model = nemc.compile(path)
    m, g, mu, mu_s, c = 2.0, 9.81, 0.3, 0.5, 4.0
    t_s = mu_s * m * g / c  # the push c t reaches mu_s m g
    for method in ("nemc.Vern9", "nemc.DOP853"):
        result = model.simulate(method=method, t_eval=[0.5 * t_s, 6.0])
        assert result.success
        times, _ = result.events["slide.stick_slip"]
        assert times[0] == pytest.approx(t_s, abs=1e-9)
        assert result.y[:, 0].tolist() == [0.0, 0.0]  # stuck before: exactly
        t = 6.0
        v = (c * (t**2 - t_s**2) / 2 - mu * m * g * (t - t_s)) / m
        x = (c * (t**3 - t_s**3) / 6 - c * t_s**2 * (t - t_s) / 2
             - mu * m * g * (t - t_s) ** 2 / 2) / m
        assert result.y[0, -1] == pytest.approx(x, rel=1e-9)
        assert result.y[1, -1] == pytest.approx(v, rel=1e-9)


PIN = """
name: pin_pendulum
parameters: {m: 1.5, L: 0.8, g: 9.81, mu: 0.2, r: 0.05}
gravity: [0, -g]
bodies:
  rod: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  pin: {type: revolute, parent: ground, child: rod, coordinate: th}
friction:
  - {joint: pin, mu: mu, radius: r}
simulation:
  initial: {th: -0.3, dot(th): 6.0}
  rtol: 1.0e-12
  atol: 1.0e-13
"""


def pin_reference(t_end: float) -> np.ndarray:
    """The rod's motion by hand: (I_O) th'' = -m g (L/2) cos(th) + tau, tau = -mu r |R|
    sign(th'), R = m a_C - m g (the pin's push on the rod), a_C from th'' and th'^2: tau and
    th'' solved together by fixed-point iteration (contracting: mu r m L/2 / I_O << 1)."""
    m, length, g, mu, r = 1.5, 0.8, 9.81, 0.2, 0.05
    arm, inertia = length / 2, m * length**2 / 3

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        th, w = y
        tau = 0.0
        for _ in range(200):
            a = (-m * g * arm * math.cos(th) + tau) / inertia
            ax = -arm * (a * math.sin(th) + w * w * math.cos(th))
            ay = arm * (a * math.cos(th) - w * w * math.sin(th))
            new = -mu * r * math.hypot(m * ax, m * ay + m * g) * math.copysign(1.0, w)
            if new == tau:
                break
            tau = new
        return [w, (-m * g * arm * math.cos(th) + tau) / inertia]

    sol = solve_ivp(rhs, (0, t_end), [-0.3, 6.0], method="DOP853", rtol=1e-13, atol=1e-14)
    return sol.y[:, -1]


def test_pin_friction_solved_with_its_reaction_matches_a_hand_derivation(tmp_path: Path
                                                                         ) -> None:
    path = tmp_path / "pin.yaml"
    path.write_text(PIN)
    model = nemc.compile(path)
    t_end = 0.3  # before its rate first reaches 0
    result = model.simulate((0, t_end), method="nemc.Vern9")
    assert result.success and np.all(result.y[1] > 0)
    np.testing.assert_allclose(result.y[:, -1], pin_reference(t_end), rtol=1e-9, atol=1e-11)
    torque = result.outputs["pin.friction"]
    assert np.all(torque < 0)


def test_implicit_methods_and_taylor_are_refused_by_name(block) -> None:
    """(scipy's explicit methods run friction: tests/test_friction_scipy.py)"""
    for method in ("nemc.Radau", "Radau", "BDF", "LSODA", "nemc.Taylor"):
        with pytest.raises(ModelError, match="Coulomb friction"):
            block.simulate(method=method)


BAD = {
    "mu: -0.1": "must be > 0",
    "mu: 0.3, mu_static: 0.2": "mu_static must be >= mu",
    "mu: 0.3, bogus: 1": "bogus",
}


@pytest.mark.parametrize("item, message", BAD.items())
def test_bad_friction_items_are_refused_with_their_line(tmp_path: Path, item: str,
                                                        message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(PUSHED.replace("{joint: slide, mu: mu, mu_static: mu_s}",
                                   "{joint: slide, " + item + "}"))
    with pytest.raises(InputError, match=message) as caught:
        nemc.compile(path)
    assert f"{path}:12:" in str(caught.value)


@pytest.mark.parametrize("joints, item, message", [
    ("slide: {type: weld, parent: ground, child: block}", "{joint: slide, mu: 0.2}",
     "revolute or prismatic"),
    ("slide: {type: revolute, parent: ground, child: block, coordinate: a}",
     "{joint: slide, mu: 0.2}", "needs `radius`"),
    ("slide: {type: prismatic, parent: ground, child: block, coordinate: x, motion: t}",
     "{joint: slide, mu: 0.2}", "is driven"),
    ("slide: {type: prismatic, parent: ground, child: block, coordinate: x}",
     "{constraint: guide, mu: 0.2}", "no constraint named 'guide'"),
])
def test_friction_on_a_joint_that_cannot_carry_it_is_refused(tmp_path: Path, joints: str,
                                                             item: str, message: str) -> None:
    text = f"""
name: bad
bodies:
  block: {{mass: 1, inertia: 0.1}}
joints:
  {joints}
friction:
  - {item}
"""
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        nemc.compile(path)


def slider_crank_break_free() -> float:
    """When the motor's ramped torque T0 t / 0.2 makes the slider-crank's stuck slider slip,
    from statics by hand (examples/slider_crank_friction.yaml's numbers): virtual work on the
    crank angle gives the holding force F = -(T + Q_gravity) / (ds/dq1), the rod's moments about
    its crank pin and the slider's vertical balance its normal force N = tan(phi) F + m2 g / 2 +
    ms g + load; it slips where |F| = mu_s N (both affine in T)."""
    r, length, m1, m2, ms, t0, mu_s, load, g = 0.1, 0.35, 0.4, 0.9, 1.2, 3.0, 0.4, 40.0, 9.81
    q1 = math.pi / 3
    phi = math.asin(-r * math.sin(q1) / length)  # the rod's angle: its end on the x axis
    ds = -r * math.sin(q1) + r * math.cos(q1) * math.tan(phi)
    q_gravity = -m1 * g * r / 2 * math.cos(q1) - m2 * g * r * math.cos(q1) / 2

    def margin(torque: float) -> float:
        force = -(torque + q_gravity) / ds
        normal = math.tan(phi) * force + m2 * g / 2 + ms * g + load
        return mu_s * normal - abs(force)

    from scipy.optimize import brentq
    torque = brentq(margin, 0.0, t0)
    return 0.2 * torque / t0


def test_the_slider_crank_breaks_free_when_statics_says() -> None:
    model = nemc.compile(EXAMPLES / "slider_crank_friction.yaml")
    result = model.simulate()
    assert result.success
    times, _ = result.events["S.stick_slip"]
    assert times[0] == pytest.approx(slider_crank_break_free(), abs=1e-9)
    before = result.t < times[0]
    assert np.ptp(result.y[0, before]) < 1e-12 and np.all(result.y[1, before] == 0.0)  # held
    assert np.all(result.outputs["S.stuck"][before] == 1.0)
    # it passes its dead centers (the slider's rate 0 by the kinematics): slips on
    assert len(times) > 3 and np.all(result.outputs["S.stuck"][result.t > times[0] + 1e-6] == 0)


def test_an_ensemble_starts_each_run_in_its_own_mode(block) -> None:
    """Runs from rest at several stretches: each turns and sticks where its closed form says
    (one too little stretched to move at all), on one thread and on two."""
    delta = 2 * MU * M * G / K
    starts = [1.0, 0.5, 0.1]
    expected = []
    for x in starts:  # the turning points until the spring cannot beat static friction
        while abs(x) * K > MU_S * M * G:
            x = -(x - math.copysign(delta, x))
        expected.append(x)
    y0s = np.array([[x, 0.0] for x in starts])
    for threads in (1, 2):
        runs = block.simulate_many(y0s, t_eval=[0.0, 7.0], threads=threads)
        assert np.all(runs.success)
        np.testing.assert_allclose(runs.y[:, 0, -1], expected, rtol=0, atol=1e-9)
        assert np.all(runs.y[:, 1, -1] == 0.0)


@pytest.mark.parametrize("call", ["linearize", "trim", "sensitivities", "taylor", "fmu"])
def test_what_needs_a_derivative_is_refused_by_name(block, call: str, tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="friction"):
        if call == "fmu":
            block.export_fmu(tmp_path / "block.fmu")
        elif call == "linearize":
            block.linearize()
        elif call == "trim":
            block.trim()
        elif call == "sensitivities":
            block.simulate(sensitivities=["mu"])
        else:
            block.simulate_many(np.array([[1.0, 0.0]]), method="nemc.Taylor")


def stick_slip_cycle() -> tuple[float, float, float]:
    """The belt-driven oscillator's first stick, then each slip and stick, in closed form
    (examples/stick_slip.yaml: a harmonic arc about x_k = mu m g / k from x_s = mu_s m g / k at
    the belt's speed to 2 x_k - x_s at the belt's speed again, then riding the belt back)."""
    m, k, g, mu, mu_s, v_b = 1.0, 100.0, 9.81, 0.3, 0.5, 0.5
    x_s, x_k, omega = mu_s * m * g / k, mu * m * g / k, math.sqrt(k / m)
    phi0 = math.atan2((x_s - x_k) * omega, v_b)
    return x_s / v_b, (2 * math.pi - 2 * phi0) / omega, 2 * (x_s - x_k) / v_b


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_the_stick_slip_oscillator_keeps_its_closed_form_cycle(method: str) -> None:
    """100 cycles at rtol 1e-11: every switch where the closed form has it, to 1e-9."""
    model = nemc.compile(EXAMPLES / "stick_slip.yaml")
    first, slip, stick = stick_slip_cycle()
    cycles = 100
    end = first + cycles * (slip + stick) - stick / 2
    result = model.simulate((0, end), method=method, t_eval=[0, end], rtol=1e-11)
    assert result.success
    times, _ = result.events["belt.stick_slip"]
    expected = first + np.cumsum([0.0] + [slip, stick] * cycles)[: 2 * cycles]
    assert len(times) == len(expected)
    np.testing.assert_allclose(times, expected, rtol=0, atol=1e-9)


INCLINE = dict(m=0.5, g=9.81, mu=0.35, mu_s=0.5, a0=0.2, w=0.4, s0=1.0)


def incline_reference(t_end: float) -> tuple[float, np.ndarray]:
    """The block on the tilting incline by hand, in the incline's turning frame: at rest
    static friction holds F = m g sin(a) - m w^2 s against mu_s N, N = m g cos(a), until
    they are equal (the break-free instant, by brentq); then it slides down, m s'' = -m g
    sin(a) + m w^2 s + F, F = mu |N| (up the incline), N = m g cos(a) + 2 m w s' (Coriolis)."""
    from scipy.optimize import brentq
    m, g, mu, mu_s, a0, w, s0 = (INCLINE[k] for k in ("m", "g", "mu", "mu_s", "a0", "w", "s0"))

    def margin(t: float) -> float:
        a = a0 + w * t
        return mu_s * m * g * math.cos(a) - abs(m * g * math.sin(a) - m * w * w * s0)

    t_free = brentq(margin, 0.0, 2.0, xtol=1e-15)

    def rhs(t: float, y: np.ndarray) -> list[float]:
        a = a0 + w * t
        normal = m * g * math.cos(a) + 2 * m * w * y[1]
        return [y[1], -g * math.sin(a) + w * w * y[0] + mu * abs(normal) / m]

    sol = solve_ivp(rhs, (t_free, t_end), [s0, 0.0], method="DOP853", rtol=1e-13, atol=1e-14)
    assert np.all(sol.y[1, 1:] < 0)  # it slides down all along: no other switch
    return t_free, sol.y[:, -1]


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_a_block_breaks_free_as_its_incline_tilts_and_slides_as_derived_by_hand(
        method: str) -> None:
    model = nemc.compile(EXAMPLES / "block_on_tilting_incline.yaml")
    t_end = 2.0
    result = model.simulate((0, t_end), method=method, t_eval=[0.0, t_end])
    assert result.success
    t_free, state = incline_reference(t_end)
    times, _ = result.events["slide.stick_slip"]
    assert times.tolist() == pytest.approx([t_free], abs=1e-9)
    np.testing.assert_allclose(result.y[:, -1], state, rtol=1e-9, atol=1e-10)


FLYWHEEL = """
name: flywheel
parameters: {I: 0.2, T_c: 0.5, T_a: 0.3, w0: 10.0}
bodies:
  wheel: {mass: 1, inertia: I}
joints:
  spin: {type: revolute, parent: ground, child: wheel, coordinate: th}
loads:
  - {torque: T_a, body: wheel}
friction:
  - {joint: spin, torque: T_c}
simulation:
  t_span: [0, 6]
  initial: {dot(th): w0}
  rtol: 1.0e-11
  atol: 1.0e-13
"""


def test_a_given_coulomb_torque_stops_a_flywheel_and_holds_it(tmp_path: Path) -> None:
    """Spinning down under a Coulomb torque T_c: w = w0 - T_c t / I until it stops at
    t = I w0 / T_c (4 s), angle w0^2 I / (2 T_c); with a torque T_a < T_c driving it, it stops
    later (w' = -(T_c - T_a) / I: at 10 s) and, once stopped, T_a cannot turn it again."""
    path = tmp_path / "flywheel.yaml"
    path.write_text(FLYWHEEL.replace("{torque: T_a, body: wheel}", "{torque: 0, body: wheel}"))
    plain = nemc.compile(path).simulate(t_eval=[0.0, 6.0])
    inertia, t_c, t_a, w0 = 0.2, 0.5, 0.3, 10.0
    t_stop = inertia * w0 / t_c
    assert plain.events["spin.stick_slip"][0].tolist() == pytest.approx([t_stop], abs=1e-9)
    assert plain.y[:, -1].tolist() == pytest.approx([w0**2 * inertia / (2 * t_c), 0.0],
                                                   abs=1e-9)
    path.write_text(FLYWHEEL)
    pushed = nemc.compile(path).simulate((0.0, 12.0), t_eval=[0.0, 12.0])
    t_stop = inertia * w0 / (t_c - t_a)
    angle = w0**2 * inertia / (2 * (t_c - t_a))
    assert pushed.events["spin.stick_slip"][0].tolist() == pytest.approx([t_stop], abs=1e-9)
    assert pushed.y[:, -1].tolist() == pytest.approx([angle, 0.0], abs=1e-9)
    assert pushed.outputs["spin.friction"][-1] == pytest.approx(-t_a, abs=1e-12)


ROD = """
name: painleve_rod
parameters: {m: 1.0, l: 0.5, g: 9.81, mu: 2.0, th0: 0.5235987755982988}
gravity: [0, -g]
bodies:
  foot: {mass: 0, inertia: 0}
  rod: {mass: m, inertia: m*l**2/3, com: [l, 0]}
joints:
  slide: {type: prismatic, parent: ground, child: foot, coordinate: x}
  hinge: {type: revolute, parent: foot, child: rod, coordinate: th}
friction:
  - {joint: slide, mu: mu}
outputs:
  reactions: [slide]
simulation:
  t_span: [0, 0.01]
  initial: {th: th0, dot(x): -1.0}
"""


def test_painleves_rod_normal_force_and_its_paradox(tmp_path: Path) -> None:
    """A rod (length 2l, I = m l^2/3) whose end slides on a rough floor, at rest at 30 degrees,
    its end moving away: by hand, N (1 + 3 cos^2 th - 3 mu sin th cos th) = m g. For mu = 2
    nemc's coupled solve gives that N; past mu = (1 + 3 cos^2 th) / (3 sin th cos th) = 2.50
    the factor is negative: Painleve's paradox, reported by name."""
    path = tmp_path / "rod.yaml"
    path.write_text(ROD)
    model = nemc.compile(path)
    th = math.pi / 6
    for mu in (0.5, 2.0):
        result = model.simulate(params={"mu": mu}, t_eval=[0.0, 0.01])
        assert result.success
        normal = 9.81 / (1 + 3 * math.cos(th) ** 2 - 3 * mu * math.sin(th) * math.cos(th))
        assert result.outputs["slide.Fy"][0] == pytest.approx(normal, rel=1e-12)
        assert result.outputs["slide.friction"][0] == pytest.approx(mu * normal, rel=1e-12)
    failed = model.simulate(params={"mu": 3.0})
    assert not failed.success and "Painleve's paradox" in failed.message


def test_a_sweep_over_the_stretch_sticks_each_run_where_its_closed_form_says(tmp_path: Path
                                                                            ) -> None:
    """`nemc sweep` takes friction's method (nemc.Vern9) and each run its own mode."""
    from nemc.tools.cli import main

    store = tmp_path / "block.zarr"
    assert main(["sweep", str(EXAMPLES / "coulomb_block.yaml"), "--grid", "x=0.1:1.0:4",
                 "--out", str(store)]) == 0
    swept = nemc.open_sweep(store)
    delta = 2 * MU * M * G / K
    assert swept.attrs["method"] == "nemc.Vern9"
    for x0, y in zip(swept.coords["x"].values, swept["y"].isel(time=-1).values):
        x = float(x0)
        while abs(x) * K > MU_S * M * G:
            x = -(x - math.copysign(delta, x))
        assert y[0] == pytest.approx(x, abs=1e-9) and y[1] == 0.0
