"""Checks of tests/contact_reference.py itself, against what it does not compute the same way.

- Block on a driven incline: the event-driven run against the closed-form slip time and slide,
  the friction work against the quadrature of the closed form, and the polar equation of motion
  against Newton in Cartesian axes (the closed form's position differentiated numerically).
- Stick-slip oscillator: switch times and states against the closed-form limit cycle over 20
  periods; dissipation per cycle; the harmonic limit mu_s = mu_k.
- Slider-crank with friction: the power balance (motor work + friction work = change of
  energy); the crank's acceleration against a one-coordinate Lagrange equation with the
  friction as a given force; the normal force against the moment balance of rod and slider
  about the crank pin; the holding force against virtual work; the stick and slip thresholds.
- Ball: bounce times from located events against the closed form, t_inf by summation, angular
  momentum about the contact point through impacts (the rolling speed at the end), the
  friction's and the impacts' energy.
- Rocking block: impact times and speeds from located events against quadrature and energy;
  energy between impacts; r and the impact's friction ratio from the momentum change. On a
  table shaken by a pulse: the onset of rocking or sliding in closed form, the slide and its
  friction work in closed form, the pulse's work equal to the impacts' losses, free decay after
  the pulse, and the friction the pivot needs.
- The example files of tests/data/friction/: their parameters and initial states are the
  references' (read as YAML: nemc does not load them until issue 50 lands), and their
  `friction` and `contacts` entries use only the spec's keys.
- Cart and rod striking a wall: the hand-derived equations against sympy's Lagrange with the
  rod's vertical momentum for the normal force; a stuck cart's impact takes the fixed-pin
  pendulum's (1 - e^2) m_eff v_n^2 / 2.
- Cart carrying a bouncing ball: the floor's impulses add up to the momentum the ball loses
  plus gravity's impulse until t_inf. Rocking block's sliding impact: its impulses from the
  momentum change (the corner stops along the normal, |P_t| = mu P_n) and its energy loss.
- benchmarks/stick_slip_tanh.py: its smooth law peaks at mu_s N, and its stick-phase error
  tells a creeping regularization from a nearly sticking one.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
import yaml
from contact_reference import (
    Ball,
    BasePulse,
    CartBall,
    CartPendulumWall,
    Incline,
    PainleveError,
    RockingBlock,
    SliderCrank,
    StickSlip,
    ball_accumulation_time,
    ball_bounce_times,
    ball_rest,
    ball_run,
    base_slide_closed_form,
    cart_impact,
    incline_friction_work,
    incline_run,
    incline_slide,
    incline_slip_time,
    rocking_accumulation_time,
    rocking_amplitudes,
    rocking_base_run,
    rocking_energy,
    rocking_impact_speeds,
    rocking_impact_times,
    rocking_pivot_force,
    rocking_run,
    rocking_sliding_impact,
    slider_crank_energy,
    slider_crank_holding,
    slider_crank_pose,
    slider_crank_run,
    slider_crank_sliding,
    slider_crank_torque,
    stick_slip_closed_form,
    stick_slip_cycle,
    stick_slip_run,
    stick_slip_stick_intervals,
    stick_slip_switches,
)

# --- a. block on a driven incline ------------------------------------------------------------


def test_incline_slips_when_tan_alpha_reaches_mu_static() -> None:
    p = Incline()
    run = incline_run(p, 4.0)
    assert [n for _, n in run.switches] == ["slip"]
    assert run.switches[0][0] == pytest.approx(incline_slip_time(p), abs=1e-9)
    assert math.tan(p.alpha(incline_slip_time(p))) == pytest.approx(p.mu_s, rel=1e-12)


def test_incline_slide_and_friction_work_match_the_closed_form() -> None:
    p = Incline()
    run = incline_run(p, 4.0)
    for t in np.linspace(incline_slip_time(p), 4.0, 7):
        s, sd = incline_slide(p, t)
        assert run.state(t) == pytest.approx([s, sd], abs=1e-9)
    assert run.friction_work == pytest.approx(incline_friction_work(p, 4.0), abs=1e-9)
    assert run.friction_work < -1.0


def test_incline_closed_form_obeys_newton_in_cartesian_axes() -> None:
    """m a = m g + N e_n + mu_k N e_t, with a the second difference of s(t) e_t(alpha(t))."""
    p = Incline()
    h = 1e-3

    def position(t: float) -> np.ndarray:
        s, _ = incline_slide(p, t)
        a = p.alpha(t)
        return float(s) * np.array([math.cos(a), math.sin(a)])

    for t in (2.8, 3.3, 3.9):
        acc = (position(t + h) - 2 * position(t) + position(t - h)) / h**2
        a = p.alpha(t)
        _, sd = incline_slide(p, t)
        n = p.normal(t, float(sd))
        force = np.array([0.0, -p.m * p.g]) + n * np.array([-math.sin(a), math.cos(a)])
        force += p.mu_k * n * np.array([math.cos(a), math.sin(a)])
        assert p.m * acc == pytest.approx(force, abs=1e-5)


def test_incline_stuck_off_the_pivot_slips_where_holding_reaches_its_limit() -> None:
    p = Incline(w=0.5)
    s0 = 0.8
    run = incline_run(p, 3.0, s0=s0)
    t = run.switches[0][0]
    assert abs(p.holding(t, s0)) == pytest.approx(p.mu_s * p.normal(t, 0.0), rel=1e-9)
    # the centrifugal term holds it longer than at the pivot
    assert t > incline_slip_time(p) + 0.01


# --- b. stick-slip oscillator ----------------------------------------------------------------


def test_stick_slip_switches_match_the_limit_cycle() -> None:
    p = StickSlip()
    cycle = stick_slip_cycle(p)
    t_end = 20 * cycle.period
    run = stick_slip_run(p, t_end)
    expected = stick_slip_switches(p, t_end)
    assert [n for _, n in run.switches] == [n for _, n in expected]
    assert np.array([t for t, _ in run.switches]) == pytest.approx(
        [t for t, _ in expected], abs=1e-9)
    rng = np.random.default_rng(50)
    for t in rng.uniform(0.0, t_end, 40):
        x, xd, _ = stick_slip_closed_form(p, t)
        assert run.state(t) == pytest.approx([x, xd], abs=1e-9)


def test_stick_slip_dissipation_per_cycle() -> None:
    p = StickSlip()
    cycle = stick_slip_cycle(p)
    n = 10
    t_end = p.x_static / p.v_belt + n * cycle.period  # the first stick dissipates nothing
    run = stick_slip_run(p, t_end)
    assert -run.friction_work == pytest.approx(n * cycle.dissipation, rel=1e-9)
    # the slip arc ends at the stick start with the belt's velocity (energy on the ellipse)
    d = p.x_static - p.x_kinetic
    assert cycle.x_stick == pytest.approx(p.x_kinetic - d)
    assert math.hypot(cycle.x_stick - p.x_kinetic, p.v_belt / p.omega) == pytest.approx(
        cycle.amplitude)


def test_stick_slip_equal_coefficients_is_harmonic() -> None:
    p = StickSlip(mu_s=0.3, mu_k=0.3)
    cycle = stick_slip_cycle(p)
    assert cycle.stick_time == 0.0
    assert cycle.period == pytest.approx(2 * math.pi / p.omega, rel=1e-14)


def test_stick_slip_intervals_have_the_stick_time() -> None:
    p = StickSlip()
    cycle = stick_slip_cycle(p)
    spans = stick_slip_stick_intervals(p, 5 * cycle.period)
    assert spans[0] == pytest.approx((0.0, p.x_static / p.v_belt))
    assert [b - a for a, b in spans[1:-1]] == pytest.approx([cycle.stick_time] * (len(spans) - 2))


# --- c. slider-crank with friction -----------------------------------------------------------


@pytest.fixture(scope="module")
def crank_run():
    p = SliderCrank()
    return p, slider_crank_run(p, 3.0, math.pi / 3)


def test_slider_crank_sticks_slips_and_passes_a_dead_centre(crank_run) -> None:
    p, run = crank_run
    names = [n for _, n in run.switches]
    assert names[:5] == ["slip", "stick", "slip", "stick", "slip"]
    assert "dead_centre" in names
    for t, name in run.switches:
        if name not in ("stick", "slip"):
            continue  # at a dead centre the holding problem is singular
        th, _ = run.state(t)
        f, n = slider_crank_holding(p, t, float(th))
        if name == "stick":
            assert abs(f) < p.mu_s * abs(n)
        elif name == "slip":
            assert abs(f) == pytest.approx(p.mu_s * abs(n), rel=1e-8)


def test_slider_crank_power_balance(crank_run) -> None:
    p, run = crank_run
    th, thd = run.state(3.0)
    change = slider_crank_energy(p, th, thd) - slider_crank_energy(p, math.pi / 3, 0.0)
    assert change == pytest.approx(run.input_work + run.friction_work, abs=1e-8)
    assert run.friction_work < -0.1


def _mass_and_potential(p: SliderCrank, th: float) -> tuple[float, float]:
    """The one-coordinate mechanism's generalized mass and potential energy."""
    q, v = slider_crank_pose(p, th, 1.0)
    masses = [p.m1, p.m1, p.i1, p.m2, p.m2, p.m2 * p.rod**2 / 12, p.ms, p.ms, 0.0]
    return float(np.sum(np.array(masses) * v**2)), p.g * (p.m2 * q[4] + p.ms * q[7])


@pytest.mark.parametrize("th, thd, sigma", [(0.7, 3.0, -1.0), (2.2, 5.0, -1.0), (4.0, -2.0, -1.0),
                                             (5.0, 6.0, 1.0)])
def test_slider_crank_acceleration_by_lagrange(th: float, thd: float, sigma: float) -> None:
    """M(th) th'' + M'(th) th'^2 / 2 + V'(th) = T + F dx3/dth, F the reference's friction."""
    p = SliderCrank()
    t = 0.1
    acc, _, friction = slider_crank_sliding(p, t, th, thd, sigma)
    h = 1e-5
    m0, _ = _mass_and_potential(p, th)
    dm = (_mass_and_potential(p, th + h)[0] - _mass_and_potential(p, th - h)[0]) / (2 * h)
    dv = (_mass_and_potential(p, th + h)[1] - _mass_and_potential(p, th - h)[1]) / (2 * h)
    jx = slider_crank_pose(p, th, 1.0)[1][6]
    expected = (slider_crank_torque(p, t) + friction * jx - dv - 0.5 * dm * thd**2) / m0
    assert acc[2] == pytest.approx(expected, rel=1e-7)


@pytest.mark.parametrize("th, thd, sigma", [(0.7, 3.0, -1.0), (2.2, 5.0, -1.0), (5.0, 6.0, 1.0)])
def test_slider_crank_normal_force_by_moments_about_the_pin(th: float, thd: float,
                                                            sigma: float) -> None:
    """Rod and slider about the crank pin B: the moments of N, F and gravity equal
    sum (r_i - r_B) x m_i a_i + I_2 alpha_2."""
    p = SliderCrank()
    acc, normal, friction = slider_crank_sliding(p, 0.1, th, thd, sigma)
    q, _ = slider_crank_pose(p, th, thd)
    pin = p.r * np.array([math.cos(th), math.sin(th)])
    rod, slider = q[3:5] - pin, q[6:8] - pin

    def cross(a: np.ndarray, b: np.ndarray) -> float:
        return float(a[0] * b[1] - a[1] * b[0])

    applied = (cross(slider, np.array([friction, normal - p.ms * p.g]))
               + cross(rod, np.array([0.0, -p.m2 * p.g])))
    inertial = (cross(rod, p.m2 * acc[3:5]) + cross(slider, p.ms * acc[6:8])
                + p.m2 * p.rod**2 / 12 * acc[5])
    assert applied == pytest.approx(inertial, abs=1e-9)
    assert friction == pytest.approx(-sigma * p.mu_k * abs(normal))


def test_slider_crank_holding_force_by_virtual_work() -> None:
    """At rest: T - V'(th) + F dx3/dth = 0."""
    p = SliderCrank()
    for t, th in ((0.1, 1.0), (0.3, 2.5), (0.7, 4.0)):
        f, _ = slider_crank_holding(p, t, th)
        h = 1e-6
        dv = (_mass_and_potential(p, th + h)[1] - _mass_and_potential(p, th - h)[1]) / (2 * h)
        jx = slider_crank_pose(p, th, 1.0)[1][6]
        assert slider_crank_torque(p, t) - dv + f * jx == pytest.approx(0.0, abs=1e-8)


@pytest.mark.parametrize("sigma, count", [(1.0, 0), (-1.0, 2)])
def test_slider_crank_painleve_is_reported(sigma: float, count: int) -> None:
    """A friction coefficient large enough for the coupled problem to have no solution (one
    direction of sliding) or two (the other) is refused by name."""
    p = SliderCrank(mu_k=50.0, ms=0.01, m2=0.01, rod=0.12)
    with pytest.raises(PainleveError, match=f"Painleve's paradox at t = 0.0: {count} solutions"):
        slider_crank_sliding(p, 0.0, math.radians(15), 1.0, sigma)
    # the default mechanism has one solution in every position, both directions
    q = SliderCrank()
    for th in np.linspace(0.0, 2 * math.pi, 37):
        for direction in (1.0, -1.0):
            slider_crank_sliding(q, 0.0, th, 1.0, direction)


# --- d. ball bouncing to rest ----------------------------------------------------------------


def test_ball_bounce_times_and_accumulation() -> None:
    p = Ball()
    times, _ = ball_run(p, 12)
    assert times == pytest.approx(ball_bounce_times(p, 12), abs=1e-12)
    intervals = np.diff(ball_bounce_times(p, 2000))
    assert p.t1 + intervals.sum() == pytest.approx(ball_accumulation_time(p), abs=1e-12)
    assert ball_accumulation_time(p) == pytest.approx(p.t1 * 3.0)  # e = 0.5


def test_ball_angular_momentum_about_the_contact_is_kept() -> None:
    """I th' - m r x' is kept by every impact (the impulses act at the contact point), the
    flights and the sliding on the floor: it fixes the final rolling speed."""
    p = Ball()
    kept = p.inertia * p.thd0 - p.m * p.r * p.xd0
    _, states = ball_run(p, 12)
    assert p.inertia * states[:, 5] - p.m * p.r * states[:, 3] == pytest.approx(
        np.full(12, kept), abs=1e-14)
    rest = ball_rest(p)
    assert rest.xd_roll == pytest.approx(-kept / (p.inertia / p.r + p.m * p.r), rel=1e-12)
    assert rest.t_roll > rest.t_inf  # still sliding when the bounces end


def test_ball_energy_goes_to_impacts_and_friction() -> None:
    p = Ball()
    rest = ball_rest(p)
    assert rest.impact_loss == pytest.approx(p.m * p.g * (p.y0 - p.r), rel=1e-14)
    start = 0.5 * p.m * p.xd0**2 + 0.5 * p.inertia * p.thd0**2
    end = 0.5 * (p.m + p.inertia / p.r**2) * rest.xd_roll**2
    assert rest.friction_work == pytest.approx(end - start, rel=1e-12)


def test_ball_that_sticks_at_its_first_impact_rolls_at_five_sevenths() -> None:
    p = Ball(mu=0.5, thd0=0.0, xd0=0.3)
    rest = ball_rest(p)
    assert rest.t_roll == pytest.approx(p.t1)
    assert rest.xd_roll == pytest.approx(5 / 7 * 0.3, rel=1e-12)


# --- e. rocking block ------------------------------------------------------------------------


def test_rocking_impacts_match_quadrature_and_energy() -> None:
    p = RockingBlock()
    theta0 = 0.8 * p.alpha
    times, speeds, run = rocking_run(p, theta0, 12)
    assert times == pytest.approx(rocking_impact_times(p, theta0, 12), abs=1e-9)
    assert np.abs(speeds) == pytest.approx(rocking_impact_speeds(p, theta0, 12), abs=1e-9)
    for seg in run.segments:
        energies = [rocking_energy(p, *seg.state(t)) for t in np.linspace(seg.t0, seg.t1, 9)]
        assert np.ptp(energies) < 1e-10 * energies[0]


def test_rocking_restitution_from_angular_momentum() -> None:
    """Velocity of the mass center before (about the left corner) and after (about the right),
    with w+ = r w-: the angular momentum about the right corner is the same; the impulse's
    tangential to normal ratio is the one the reference states."""
    p = RockingBlock()
    w = -1.0
    i_g = p.m * (p.b**2 + p.h**2) / 3
    before = w * np.array([-p.h, p.b])
    after = p.restitution * w * np.array([-p.h, -p.b])
    arm = np.array([-p.b, p.h])  # right corner -> mass center

    def momentum(omega: float, vel: np.ndarray) -> float:
        return i_g * omega + p.m * (arm[0] * vel[1] - arm[1] * vel[0])

    assert momentum(p.restitution * w, after) == pytest.approx(momentum(w, before), rel=1e-14)
    impulse = p.m * (after - before)
    assert impulse[1] > 0
    assert abs(impulse[0] / impulse[1]) == pytest.approx(p.impact_friction_ratio, rel=1e-12)


def test_rocking_amplitudes_decay_as_r_squared_when_small() -> None:
    p = RockingBlock()
    amp = rocking_amplitudes(p, 1e-6 * p.alpha, 5)
    assert amp[1:] / amp[:-1] == pytest.approx(np.full(4, p.restitution**2), rel=1e-5)


def test_rocking_accumulation_time() -> None:
    p = RockingBlock()
    theta0 = 0.8 * p.alpha
    many = rocking_impact_times(p, theta0, 400)
    assert rocking_accumulation_time(p, theta0) == pytest.approx(many[-1], abs=1e-9)
    assert rocking_accumulation_time(p, theta0) > many[40]


# --- rocking block on a shaken table --------------------------------------------------------


@pytest.fixture(scope="module")
def pulse_rocking():
    p, base = RockingBlock(), BasePulse()
    return p, base, rocking_base_run(p, base, 4.0, 0.5, 0.5)


def test_pulse_lifts_the_block_at_g_tan_alpha(pulse_rocking) -> None:
    p, base, run = pulse_rocking
    assert run.switches[0][1] == "rock"
    assert run.switches[0][0] == pytest.approx(base.onset(p.g * p.b / p.h), abs=1e-9)
    assert base.accel(run.switches[0][0]) == pytest.approx(p.g * p.b / p.h, rel=1e-9)
    assert run.switches[-1][1] == "rest"
    assert run.state(3.9) == pytest.approx([0.0, 0.0, 0.0, 0.0], abs=0.0)


def test_pulse_work_goes_to_the_impacts(pulse_rocking) -> None:
    """The table's inertial force works on the rocking; the impacts take it all back (the
    block ends at rest on both corners, as it started)."""
    p, _, run = pulse_rocking
    i_o = 4.0 / 3.0 * p.m * p.radius**2
    rests = [t for t, n in run.switches if n == "rest"]
    losses = 0.0
    for seg in run.segments:
        if seg.mode == "rock":
            w = seg.state(seg.t1)[1]
            kept = 0.0 if seg.t1 in rests else p.restitution**2
            losses += 0.5 * i_o * w**2 * (1.0 - kept)
    assert run.input_work > 1e-3
    assert losses == pytest.approx(run.input_work, rel=1e-9)


def test_pulse_rocking_is_free_after_the_pulse(pulse_rocking) -> None:
    p, base, run = pulse_rocking
    speeds = [abs(seg.state(seg.t1)[1]) for seg in run.segments
              if seg.mode == "rock" and seg.t0 > base.tp]
    ratios = np.array(speeds[1:30]) / np.array(speeds[:29])
    assert ratios == pytest.approx(np.full(29, p.restitution), rel=1e-9)


def test_pulse_rocking_pivot_needs_less_than_the_examples_mu(pulse_rocking) -> None:
    p, base, run = pulse_rocking
    ratios = []
    for t in np.linspace(0.0, 2.0, 4001):
        th, thd, _, _ = run.state(t)
        if th != 0.0:
            ft, fn = rocking_pivot_force(p, th, thd, base.accel(t))
            assert fn > 0.0
            ratios.append(abs(ft / fn))
    assert 0.2 < max(ratios) < 0.5


def test_pulse_slides_a_block_with_little_friction() -> None:
    p, base = RockingBlock(), BasePulse()
    run = rocking_base_run(p, base, 1.0, 0.2, 0.2)
    t0, stick, dist = base_slide_closed_form(base, p.g, 0.2)
    assert [n for _, n in run.switches] == ["slide", "stick"]
    assert [t for t, _ in run.switches] == pytest.approx([t0, stick], abs=1e-9)
    assert run.state(1.0) == pytest.approx([0.0, 0.0, dist, 0.0], abs=1e-9)
    assert run.friction_work == pytest.approx(-0.2 * p.m * p.g * abs(dist), rel=1e-9)


# --- the example files (tests/data/friction/) hold the references' numbers ---------------------

FRICTION_DATA = Path(__file__).parent / "data" / "friction"
FRICTION_KEYS = {"joint", "constraint", "mu", "mu_static", "radius", "torque", "force"}
CONTACT_KEYS = {"point", "radius", "surface", "restitution", "mu"}


def _file(name: str) -> dict:
    return yaml.safe_load((FRICTION_DATA / name).read_text())


def _number(value: object, names: dict[str, float] | None = None) -> float:
    return float(sp.sympify(str(value)).subs(names or {}))


@pytest.mark.parametrize("name, reference, renamed", [
    ("block_incline.yaml", Incline(), {}),
    ("stick_slip.yaml", StickSlip(), {"v": "v_belt"}),
    ("slider_crank_friction.yaml", SliderCrank(), {"l": "rod"}),
    ("ball_to_rest.yaml", Ball(), {}),
    ("rocking_block.yaml", RockingBlock(), {}),
    ("rocking_block_pulse.yaml", RockingBlock(), {}),
    ("rocking_block_pulse.yaml", BasePulse(), {}),
])
def test_example_files_have_the_references_parameters(name: str, reference: object,
                                                      renamed: dict[str, str]) -> None:
    data = _file(name)
    fields = {f.name for f in dataclasses.fields(reference)}
    compared = 0
    for key, value in data["parameters"].items():
        field = renamed.get(key, key)
        if field in fields:
            assert _number(value) == pytest.approx(getattr(reference, field), rel=1e-15), key
            compared += 1
    assert compared >= 2
    for item in data.get("friction", []):
        assert set(item) <= FRICTION_KEYS
    for contact in data.get("contacts", {}).values():
        assert set(contact) <= CONTACT_KEYS


def test_example_files_initial_states() -> None:
    ball, sim = Ball(), _file("ball_to_rest.yaml")["simulation"]
    assert [sim["initial"][k] for k in ("y", "dot(x)", "dot(th)")] == [ball.y0, ball.xd0, ball.thd0]
    p = StickSlip()
    t_end = _file("stick_slip.yaml")["simulation"]["t_span"][1]
    assert t_end == pytest.approx(p.x_static / p.v_belt + 100 * stick_slip_cycle(p).period,
                                  rel=1e-15)
    block = RockingBlock()
    data = _file("rocking_block.yaml")
    values = {sp.Symbol(k): _number(v) for k, v in data["parameters"].items() if k != "th0"}
    th0 = _number(data["parameters"]["th0"], values)
    assert th0 == pytest.approx(0.8 * block.alpha, rel=1e-15)
    values[sp.Symbol("th0")] = th0
    x, y = (_number(data["simulation"]["initial"][k], values) for k in ("x", "y"))
    corner = np.array([x, y]) + np.array([[math.cos(th0), -math.sin(th0)],
                                          [math.sin(th0), math.cos(th0)]]) @ [-block.b, -block.h]
    assert corner == pytest.approx([-block.b, 0.0], abs=1e-15)  # on the floor, where it pivots


# --- the smooth-law baseline (benchmarks/stick_slip_tanh.py) measures what it says ------------


@pytest.fixture(scope="module")
def tanh_baseline():
    path = Path(__file__).resolve().parent.parent / "benchmarks" / "stick_slip_tanh.py"
    spec = importlib.util.spec_from_file_location("stick_slip_tanh", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_tanh_law_peaks_at_mu_static(tanh_baseline) -> None:
    p = StickSlip()
    c = tanh_baseline.bump_coefficient(p.mu_s, p.mu_k)
    speeds = np.linspace(-3e-5, 3e-5, 600001)
    force = tanh_baseline.friction(p, speeds, 1e-5, c)
    assert np.max(np.abs(force)) == pytest.approx(p.mu_s * p.m * p.g, rel=1e-9)
    assert abs(tanh_baseline.friction(p, 1.0, 1e-5, c)) == pytest.approx(
        p.mu_k * p.m * p.g, rel=1e-12)


def test_tanh_baseline_stick_error_follows_its_creep(tanh_baseline) -> None:
    """A wide regularization creeps through the stick phases; a narrow one nearly sticks."""
    wide = tanh_baseline.run_tanh(1e-2, 1e-9, periods=3)
    narrow = tanh_baseline.run_tanh(1e-6, 1e-9, periods=3)
    assert wide["success"] and narrow["success"]
    assert wide["stick_error"] > 0.05
    assert 1e-7 < narrow["stick_error"] < 1e-4


# --- f, g. contacts with joint friction; a sliding impact among contacts ---------------------


@pytest.mark.parametrize("phi, phid, sigma", [(0.3, 1.2, 1.0), (-0.9, -2.0, -1.0),
                                              (1.1, 0.4, -1.0)])
def test_cart_pendulum_equations_by_lagrange(phi: float, phid: float, sigma: float) -> None:
    p = CartPendulumWall()
    t = sp.Symbol("t")
    x, th = sp.Function("x")(t), sp.Function("th")(t)
    c = p.L / 2
    gx, gy = x + c * sp.sin(th), -c * sp.cos(th)  # the rod's centre
    kinetic = (p.M * x.diff(t) ** 2 + p.m * (gx.diff(t) ** 2 + gy.diff(t) ** 2)
               + p.m * p.L ** 2 / 12 * th.diff(t) ** 2) / 2
    lagrangian = kinetic - p.m * p.g * gy
    xdd, thdd, force = sp.symbols("xdd thdd force")
    normal = (p.M + p.m) * p.g + p.m * gy.diff(t, 2)  # the floor's push: vertical momentum
    eqs = [lagrangian.diff(q.diff(t)).diff(t) - lagrangian.diff(q) - f
           for q, f in ((x, force), (th, 0))]
    values = {x.diff(t, 2): xdd, th.diff(t, 2): thdd}
    values2 = {th.diff(t): phid, th: phi}
    eqs = [e.subs(values).subs(values2) for e in eqs]
    n = normal.subs(values).subs(values2)
    solved = sp.solve([*eqs, force + sigma * p.mu * n], [xdd, thdd, force], dict=True)[0]
    ours = p.sliding(phi, phid, sigma)
    np.testing.assert_allclose([float(solved[xdd]), float(solved[thdd]), float(solved[force])],
                               ours[:3], rtol=1e-12)


def test_cart_held_through_an_impact_loses_the_fixed_pin_pendulums_energy() -> None:
    p = CartPendulumWall()
    y = np.array([0.0, 0.5, 0.0, 3.0])  # the cart at rest, the rod swinging at the wall
    after, how = cart_impact(p, y, stuck=True)
    assert how == "stick" and after[2] == 0.0
    arm = p.L * math.cos(y[1])  # the tip's normal speed per unit phi'
    m_eff = p.inertia / arm ** 2
    lost = (1 - p.e ** 2) * m_eff * (arm * y[3]) ** 2 / 2
    assert p.energy(y) - p.energy(after) == pytest.approx(lost, rel=1e-12)


def test_cart_ball_floor_impulses_balance_the_balls_momentum() -> None:
    p = CartBall()
    times, speeds = p.impacts()
    impulses = (1 + p.e) * p.m * speeds
    # from just before the first impact to rest at t_inf: the impulses take m v_1 and gravity's
    assert impulses.sum() == pytest.approx(p.m * speeds[0] + p.m * p.g * (p.t_inf - times[0]),
                                           rel=1e-12)


def test_rocking_sliding_impact_stops_the_corner_with_friction_at_mu() -> None:
    p, mu, w = RockingBlock(), 0.1, -1.0
    (vx, vy, w_after), lift = rocking_sliding_impact(p, w, mu)
    pt, pn = p.m * (vx - -p.h * w), p.m * (vy - p.b * w)  # from the centre's momentum
    inertia = p.m * (p.b ** 2 + p.h ** 2) / 3
    assert inertia * (w_after - w) == pytest.approx(p.b * pn + p.h * pt, rel=1e-12)
    assert vy + p.b * w_after == pytest.approx(0.0, abs=1e-14)  # plastic at the corner
    assert pn > 0 and abs(pt) == pytest.approx(mu * pn, rel=1e-12)
    assert lift > 0  # the left corner leaves: the set without it is consistent
    before = (p.m * (p.h ** 2 + p.b ** 2) * w ** 2 + inertia * w ** 2) / 2
    after = (p.m * (vx ** 2 + vy ** 2) + inertia * w_after ** 2) / 2
    assert after < before
