"""Contacts that last, run (issue 50; decision 0041): one frictionless contact against closed
forms. A ball bouncing on a floor (impact times, the accumulation and the rest that follows,
the energy the impacts take, each from its pre-impact speed), and a ball released by a plate
accelerating downward faster than gravity (the contact force while it lasts, the instant it
reaches 0, the flight after)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.errors import InputError
from nemc.runtime.failures import ModelError

DATA = Path(__file__).parent / "data" / "contacts"
M, R, E, G, Y0 = 0.2, 0.05, 0.5, 9.81, 1.05
T1 = math.sqrt(2 * (Y0 - R) / G)
T_INF = T1 * (1 + E) / (1 - E)
ZENO = 1e-6  # friction.c.tmpl's CONTACT_ZENO: the impacts accumulate below this flight x (1 + t)


@pytest.fixture(scope="module")
def ball():
    return nemc.compile(DATA / "ball_on_floor.yaml")


@pytest.fixture(scope="module")
def plate():
    return nemc.compile(DATA / "platform_release.yaml")


@pytest.mark.parametrize("rtol", [1e-10, 1e-12])
@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_the_ball_bounces_where_the_closed_form_says_then_rests_from_t_inf(
        ball, method: str, rtol: float) -> None:
    result = ball.simulate(method=method, rtol=rtol, atol=rtol / 100)
    assert result.success
    times, states = result.events["floor.contact"]
    bounces = times[:-1]
    expected = T1 + 2 * T1 * np.concatenate(([0.0], np.cumsum(E ** np.arange(1, len(bounces)))))
    np.testing.assert_allclose(bounces, expected, rtol=0, atol=1e-10)
    # the last bounce flies the flights left as one (the Zeno rule: the one after next would
    # be shorter than ZENO (1 + t)), which lands, and the contact closes, at t_inf
    assert times[-1] == pytest.approx(T_INF, abs=1e-11)  # measured within 8e-13
    assert ZENO * (1 + T_INF) < T_INF - bounces[-1] <= ZENO * (1 + T_INF) / (1 - E)
    assert len(times) == 20
    y, rate = result.y[2], result.y[3]
    resting = result.t > times[-1]
    np.testing.assert_allclose(y[resting], R, rtol=0, atol=1e-13)
    np.testing.assert_allclose(rate[resting], 0.0, rtol=0, atol=1e-13)
    np.testing.assert_allclose(result.outputs["floor.Fn"][resting], M * G, rtol=1e-13)
    assert np.all(result.outputs["floor.active"][resting] == 1.0)
    flying = result.t < times[-1] - 1e-3
    assert np.all(result.outputs["floor.Fn"][flying] == 0.0)
    assert np.all(result.outputs["floor.active"][flying] == 0.0)
    np.testing.assert_allclose(result.y[1], 0.3, rtol=1e-13)


@pytest.mark.parametrize("e", [0.1, 0.9])
def test_with_any_restitution_the_rest_starts_at_t_inf(ball, e: float) -> None:
    """e = 0.1: the tail is flown where the flight after the next would be under the rule
    (e T), e = 0.9: where the next would (its tail up to ten times that); both land at
    t1 (1 + e) / (1 - e), the bounces before at the closed form's times."""
    result = ball.simulate(params={"e": e}, t_span=(0.0, 40.0), t_eval=[0.0, 40.0])
    assert result.success
    times, _ = result.events["floor.contact"]
    expected = T1 + 2 * T1 * np.concatenate(([0.0], np.cumsum(e ** np.arange(1, len(times) - 1))))
    np.testing.assert_allclose(times[:-1], expected, rtol=0, atol=1e-10)
    assert times[-1] == pytest.approx(T1 * (1 + e) / (1 - e), abs=1e-10)
    # at rest on the floor: the closed contact's normal acceleration is Newton's solve's, 0 to
    # its rounding (e = 0.9: the rate -5e-20 m/s after 30 s at rest)
    assert result.y[2][-1] == pytest.approx(R, abs=1e-15)
    assert result.y[3][-1] == pytest.approx(0.0, abs=1e-15)


def test_between_the_last_bounce_and_t_inf_the_ball_flies_one_parabola(ball) -> None:
    """The tail T = t_inf - t_k after the last located bounce t_k is flown as one flight: the
    parabola y = r + (g / 2) s (T - s) (s = t - t_k), g T^2 / 8 at most (the bounces it stands
    for rise g T^2 (1 - e)^2 / 8 at most: both O(g T^2)); the rest starts at t_inf, y = r."""
    times, _ = ball.simulate().events["floor.contact"]
    t_k, t_inf = times[-2:]
    inside = np.linspace(t_k, t_inf, 11)[1:-1]
    result = ball.simulate(t_eval=np.r_[inside, t_inf + 1e-3], t_span=(0.0, t_inf + 1e-3))
    s, tail = inside - t_k, t_inf - t_k
    np.testing.assert_allclose(result.y[2][:-1] - R, G / 2 * s * (tail - s), rtol=0,
                               atol=1e-16)  # y's rounding; the apex is 1.5e-11 m
    assert result.y[2][-1] == R and result.y[3][-1] == 0.0


@pytest.mark.parametrize("t_end", [1000.0, 1e5])
@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853", "RK45"])
def test_a_run_much_longer_than_the_bounces_ends_at_rest(ball, method: str, t_end: float
                                                         ) -> None:
    """1000 s and 1e5 s: the run control's chattering window (1e-9 of the run: 2e-6 s apart
    chatter at 1000 s, 2e-4 s at 1e5 s) is at most 1e-8 (1 + t) for a contact's switches,
    shorter than every flight the Zeno rule flies (ZENO (1 + t) = 2.35e-6 s)."""
    result = ball.simulate(method=method, t_span=(0.0, t_end), t_eval=[0.0, t_end])
    assert result.success
    assert result.events["floor.contact"][0][-1] == pytest.approx(T_INF, abs=1e-9)
    assert result.y[2][-1] == pytest.approx(R, abs=1e-13)
    assert result.y[3][-1] == pytest.approx(0.0, abs=1e-13)


def test_the_impacts_take_the_energy_their_restitution_says(ball) -> None:
    """Each bounce takes (1 - e^2) m v^2 / 2 of its pre-impact speed v; the tail (the last
    bounce's launch into one flight and that flight's plastic landing) m v^2 / 2 of the last
    bounce's, as the bounces it stands for would; their sum is the energy drop, m g (y0 - r);
    between impacts none is lost."""
    result = ball.simulate()
    times, states = result.events["floor.contact"]
    speeds = np.asarray(states)[:, 3]
    taken = 0.5 * M * speeds[:-1] ** 2 * np.r_[np.full(len(speeds) - 2, 1 - E ** 2), 1.0]
    total = result.outputs["energy.total"]
    assert total[0] - total[-1] == pytest.approx(taken.sum(), rel=1e-10)
    assert taken.sum() == pytest.approx(M * G * (Y0 - R), rel=1e-9)
    for start, end in zip(np.r_[0.0, times[:-1]], times):
        flight = (result.t > start + 1e-9) & (result.t < end - 1e-9)
        if flight.any():
            assert np.ptp(total[flight]) <= 1e-10


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_the_ball_leaves_the_plate_when_its_contact_force_would_turn_negative(
        plate, method: str) -> None:
    c = 2.0
    released = G / (6 * c)
    result = plate.simulate(method=method)
    assert result.success
    times, _ = result.events["seat.contact"]
    np.testing.assert_allclose(times, [released], rtol=0, atol=1e-12)
    t, y = result.t, result.y[2]
    holding = t < released
    np.testing.assert_allclose(result.outputs["seat.Fn"][holding],
                               M * (G - 6 * c * t[holding]), rtol=0, atol=1e-12)
    assert np.all(result.outputs["seat.active"][holding] == 1.0)
    flight = t - released
    expected = np.where(holding, R - c * t ** 3, R - c * released ** 3
                        - 3 * c * released ** 2 * flight - G / 2 * flight ** 2)
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-10)
    gone = t > released
    assert np.all(result.outputs["seat.Fn"][gone] == 0.0)
    assert np.all(result.outputs["seat.active"][gone] == 0.0)


def test_a_restitution_above_1_at_a_runs_parameters_is_refused(ball) -> None:
    with pytest.raises(ModelError, match=r"1 - contacts.floor.restitution must be >= 0"):
        ball.simulate(params={"e": 1.5})


@pytest.mark.parametrize("method", ["LSODA", "Radau", "nemc.Radau", "nemc.Taylor"])
def test_methods_that_cannot_run_contacts_are_refused_by_name(ball, method: str) -> None:
    with pytest.raises(ModelError, match=f"{method} cannot run a mechanism with Coulomb "
                                         r"friction or contacts \(on floor\)"):
        ball.simulate(method=method)


@pytest.mark.parametrize("call", ["linearize", "sensitivities", "fmu"])
def test_what_needs_a_derivative_is_refused_by_name(ball, call: str, tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="contacts"):
        if call == "fmu":
            ball.export_fmu(tmp_path / "ball.fmu")
        elif call == "linearize":
            ball.linearize()
        else:
            ball.simulate(sensitivities=["e"])


def test_an_ensemble_runs_each_drop_with_its_own_contact_modes(ball) -> None:
    """Two drops from different heights at once (each run's modes its own, set at its start,
    written by its switches): both end at rest on the floor."""
    heights = np.array([1.05, 0.3])
    y0s = np.array([[0.0, 0.3, y, 0.0, 0.0, 0.0] for y in heights])
    runs = ball.simulate_many(y0s, t_eval=[0.0, 3.0])
    assert np.all(runs.success)
    np.testing.assert_allclose(runs.y[:, 2, -1], R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(runs.y[:, 3, -1], 0.0, rtol=0, atol=1e-12)


def test_a_closed_loop_strikes_as_the_same_tree_does() -> None:
    """A rod pinned at the origin swings from horizontal onto a wall (restitution and friction):
    as a tree (a revolute joint) and as a closed loop (a free joint and a revolute constraint:
    projected dynamics, the impulses through the same passes) the runs agree; the first impact
    is where the energy integral says, t = int dq / sqrt(-(3 g / L) sin q) from pi to
    2 pi - acos(d / L), at q' = sqrt(-(3 g / L) sin q)."""
    from scipy.integrate import quad

    tree = nemc.compile(DATA / "pendulum_wall_tree.yaml").simulate()
    loop = nemc.compile(DATA / "pendulum_wall_loop.yaml").simulate()
    assert tree.success and loop.success
    times, states = tree.events["wall.contact"]
    np.testing.assert_allclose(loop.events["wall.contact"][0], times, rtol=0, atol=1e-9)
    assert len(times) == 3
    np.testing.assert_allclose(loop.y[4], tree.y[0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(loop.y[5], tree.y[1], rtol=0, atol=1e-8)
    np.testing.assert_allclose(loop.outputs["wall.Fn"], tree.outputs["wall.Fn"], atol=1e-9)
    g, length, d = 9.81, 1.0, 0.3
    hit = 2 * math.pi - math.acos(d / length)
    expected, _ = quad(lambda q: 1 / math.sqrt(-3 * g / length * math.sin(q)), math.pi, hit,
                       epsabs=1e-13, epsrel=1e-13)
    assert times[0] == pytest.approx(expected, abs=1e-9)
    assert states[0][1] == pytest.approx(math.sqrt(-3 * g / length * math.sin(hit)), rel=1e-10)


def test_the_regressor_of_a_mechanism_with_contacts_is_refused_at_the_contact(ball) -> None:
    zeros = np.zeros(3)
    with pytest.raises(InputError, match=r"ball_on_floor.yaml:20: contacts.floor: the "
                                         "inverse-dynamics regressor of a mechanism with "
                                         "contacts is not available"):
        ball.regressor(0.0, zeros, zeros, zeros)
