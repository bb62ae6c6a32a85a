"""Events (format v2, simulation.events): located by every method against analytic times,
a tight reference and scipy's own event location on an independent expression; impacts,
stops, several events in one step, an event at t0, chattering, the CLI table. (Ensembles' event
times against single runs, every native method: tests/test_scenarios.py.)"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipk

import nemc
from nemc.runtime.model import ModelError
from nemc.tools.cli import main

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
NATIVE = ["nemc.DOP853", "nemc.Vern9", "nemc.Radau", "nemc.Taylor"]
SCIPY = ["DOP853", "RK45", "Radau"]

# A body gliding at unit speed along x with no force: every method's steps grow to the whole
# interval, so the events below all fall in one step.
GLIDER = """\
name: glider
bodies:
  puck: {mass: 1, inertia: 1}
joints:
  slide: {type: free, parent: ground, child: puck, coordinates: [x, y, th]}
simulation:
  t_span: [0, 1]
  initial: {dot(x): 1}
  events:
    late: {when: x - 0.6}
    early: {when: x - 0.3}
%s
"""


@pytest.fixture(scope="module")
def ball():
    return nemc.compile(EXAMPLES / "bouncing_ball.yaml")


def bounce_times(t_end: float, h: float = 1.0, e: float = 0.8, g: float = 9.81) -> np.ndarray:
    """The ball's impacts, exactly: free flight between them (bouncing_ball.yaml)."""
    first = np.sqrt(2 * h / g)
    times = [first]
    while times[-1] < t_end:
        times.append(times[-1] + 2 * e ** len(times) * g * first / g)
    return np.array([t for t in times if t < t_end])


@pytest.mark.parametrize("method", NATIVE + SCIPY)
def test_bounce_times_match_the_analytic_sequence(ball, method: str) -> None:
    result = ball.simulate(method=method)
    exact = bounce_times(4.0)
    times, states = result.events["bounce"]
    assert result.success and len(exact) == 19
    np.testing.assert_allclose(times, exact, rtol=0, atol=1e-10)
    # the states just before each impact: on the floor, falling at e^k times the first speed
    np.testing.assert_allclose(states[:, 2], 0.05, atol=1e-10)
    np.testing.assert_allclose(states[:, 3], -9.81 * exact[0] * 0.8 ** np.arange(19), rtol=1e-9)
    # the apexes (record events) lie halfway between impacts, and the first is the release
    apex = result.events["apex"][0]
    np.testing.assert_allclose(apex[1:], (exact[:-1] + exact[1:]) / 2, atol=1e-9)
    assert apex[0] == 0.0  # dot(y) is exactly 0 at t0 and then falls: it fires there (scipy)


def test_the_chattering_ball_stops_with_a_message(ball) -> None:
    accumulation = bounce_times(1.0)[0] * (1 + 0.8) / (1 - 0.8)  # where the bounces pile up
    for method in ("nemc.DOP853", "RK45"):
        result = ball.simulate((0, 5), method=method)
        assert result.status == -10 and not result.success
        assert "event 'bounce' chatters at t = 4.06" in result.message
        assert 0 < accumulation - result.events["bounce"][0][-1] < 1e-7
        assert result.t[-1] <= accumulation


def test_an_impact_that_does_not_separate_is_chattering(tmp_path: Path) -> None:
    text = (EXAMPLES / "bouncing_ball.yaml").read_text().replace("-e*dot(y)", "0")
    path = tmp_path / "dead.yaml"
    path.write_text(text.replace("name: bouncing_ball", "name: dead_ball"))
    model = nemc.compile(path)
    for method in ("nemc.DOP853", "nemc.Vern9", "DOP853"):
        result = model.simulate(method=method)
        assert result.status == -10, method
        impacts = result.events["bounce"][0]  # the impact, then repeats at once: it rests
        assert 2 <= len(impacts) <= 10
        np.testing.assert_allclose(impacts, bounce_times(1.0)[0], atol=1e-6)


def resting_ball(tmp_path: Path, law: str) -> nemc.Model:
    """The bouncing ball whose impact law stops it on the floor (y := law, dot(y) := 0):
    gravity then pulls it on through the floor, a law that does not separate."""
    text = (EXAMPLES / "bouncing_ball.yaml").read_text().replace(
        "-e*dot(y)", f"0, y: {law}").replace("name: bouncing_ball", "name: resting_ball")
    path = tmp_path / "resting.yaml"
    path.write_text(text)
    return nemc.compile(path)


@pytest.mark.parametrize("law", ["r - 1.0e-12", "r"])
@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Radau", "DOP853", "LSODA"])
def test_an_impact_left_on_the_crossed_side_chatters(tmp_path: Path, law: str,
                                                     method: str) -> None:
    """After an impact that does not separate, the event's value lies on the side it crossed
    to (a rounding, here made on purpose) or at zero: it fires again at once and the run
    chatters, whatever the method. It used to pass unseen with scipy's methods: the ball fell
    35 m through the floor and the run succeeded."""
    model = resting_ball(tmp_path, law)
    result = model.simulate(method=method)
    assert result.status == -10 and not result.success, result.message
    impacts = result.events["bounce"][0]
    assert len(impacts) == 2 and impacts[1] - impacts[0] <= 8e-9
    np.testing.assert_allclose(impacts, bounce_times(1.0)[0], atol=1e-6)
    height = result.y[model.state_names.index("y")]
    assert height.min() > 0.05 - 1e-9  # never below the floor (y = r)


def test_scipy_runs_of_many_segments_end_by_their_budget(tmp_path: Path) -> None:
    """An impact law that lifts the ball 1e-12 above the floor makes an impact every 0.45 us:
    thousands of solve_ivp segments. The stiffness test, every 1000 steps, once fell on a
    segment's first step and failed (scipy's t_old is None there); the budget ends the run
    (at this pace it cannot reach the end within it: status -8)."""
    result = resting_ball(tmp_path, "r + 1.0e-12").simulate(method="DOP853", max_steps=5000)
    assert result.status == -8 and not result.success
    assert "max_steps" in result.message


@pytest.mark.parametrize("method", NATIVE + SCIPY)
def test_the_pendulum_stops_at_the_vertical(method: str) -> None:
    model = nemc.compile(EXAMPLES / "pendulum_to_vertical.yaml")
    result = model.simulate(method=method)
    quarter = ellipk(0.5) / np.sqrt(3 * 9.81 / (2 * 1.5))  # a quarter of a 90-degree swing
    times, states = result.events["vertical"]
    assert result.status == 1 and result.success
    assert times == pytest.approx([quarter], abs=1e-9)
    assert states[0, 0] == pytest.approx(-np.pi / 2, abs=1e-9)
    assert result.t[-1] <= times[0]  # nothing after the stop
    if method.startswith("nemc."):
        assert result.message == f"event 'vertical' stopped the run at t = {times[0]:.9g}"


@pytest.fixture(scope="module")
def swinging():
    return nemc.compile(EXAMPLES / "double_pendulum_events.yaml")


def tip_height(y: np.ndarray) -> float:
    """The tip's height from the book's geometry (L1 = 1, L2 = 0.5), in Python."""
    return np.sin(y[0]) + 0.5 * np.sin(y[2]) + 1.3


@pytest.fixture(scope="module")
def scipy_tip_events(swinging) -> tuple[np.ndarray, np.ndarray]:
    """scipy's own event location on the compiled RHS, the event written in Python."""
    def low(t, y):
        return tip_height(y)

    def up(t, y):
        return tip_height(y)

    low.direction, up.direction = -1, 1
    rhs = swinging.compiled.integrator_rhs(swinging.parameter_vector())
    sol = solve_ivp(rhs, (0, 5), swinging.initial_state(), method="DOP853", rtol=1e-13,
                    atol=1e-14, events=[low, up])
    return sol.t_events[0], sol.t_events[1]


@pytest.mark.parametrize("method", NATIVE + SCIPY)
def test_height_events_against_scipys_on_a_tight_run(swinging, scipy_tip_events,
                                                     method: str) -> None:
    result = swinging.simulate(method=method)
    low, up = scipy_tip_events
    assert len(low) == len(up) == 5
    np.testing.assert_allclose(result.events["tip_low"][0], low, rtol=0, atol=1e-7)
    np.testing.assert_allclose(result.events["tip_up"][0], up, rtol=0, atol=1e-7)
    for name in ("tip_low", "tip_up"):  # the recorded states are on the event's surface
        heights = [tip_height(y) for y in result.events[name][1]]
        np.testing.assert_allclose(heights, 0, atol=1e-7)
    swings = result.events["swing"]  # both directions: q1 alternates through -pi/2
    np.testing.assert_allclose(swings[1][:, 0], -np.pi / 2, atol=1e-7)
    assert np.all(np.diff(np.sign(swings[1][:, 1])) != 0)


def test_native_events_equal_scipys_on_the_same_steps(swinging) -> None:
    """At a loose tolerance nemc.DOP853 takes scipy's steps (test_native.py), so the events,
    located on the same interpolant by the same Brent's method, agree to rounding."""
    native = swinging.simulate(method="nemc.DOP853", rtol=1e-4, atol=1e-7)
    scipy = swinging.simulate(method="DOP853", rtol=1e-4, atol=1e-7)
    for name in native.events:
        np.testing.assert_allclose(native.events[name][0], scipy.events[name][0], atol=1e-12)


@pytest.mark.parametrize("method", NATIVE + ["DOP853"])
def test_several_events_in_one_step_in_time_order(tmp_path: Path, method: str) -> None:
    path = tmp_path / "glider.yaml"
    path.write_text(GLIDER % "    halt: {when: x - 0.5, action: stop}")
    model = nemc.compile(path)
    result = model.simulate(method=method, t_eval=None)
    # to rounding: Vern9's interpolant sums weights of up to 1e4 (the others' about 1)
    rounding = 1e-12 if method == "nemc.Vern9" else 1e-14
    assert result.events["early"][0] == pytest.approx([0.3], abs=rounding)
    assert result.events["halt"][0] == pytest.approx([0.5], abs=rounding)
    assert result.events["late"][0].size == 0  # after the stop
    assert result.t[-1] == pytest.approx(0.5, abs=rounding) and result.status == 1
    assert result.t[-2] < 0.3  # the three crossings fall in the last step, cut at the stop


def test_two_events_in_one_step_are_listed_in_time_order(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "glider_both.yaml"
    path.write_text((GLIDER % "").replace("name: glider", "name: glider_both"))
    result = nemc.compile(path).simulate(method="nemc.DOP853", t_eval=None)
    assert result.events["early"][0] == pytest.approx([0.3], abs=1e-14)
    assert result.events["late"][0] == pytest.approx([0.6], abs=1e-14)
    assert result.t[-2] < 0.3  # both in the last step
    assert main(["simulate", str(path)]) == 0
    marked = [line.split()[-1] for line in capsys.readouterr().out.splitlines() if "<-" in line]
    assert marked == ["early", "late"]  # "late" is listed first in the file


@pytest.mark.parametrize(("direction", "fires"), [("rising", True), ("falling", False),
                                                  ("both", True)])
def test_an_event_at_t0_fires_only_if_it_then_moves_its_way(tmp_path: Path, direction: str,
                                                             fires: bool) -> None:
    path = tmp_path / f"start_{direction}.yaml"
    path.write_text((GLIDER % f"    start: {{when: x, direction: {direction}}}").replace(
        "name: glider", f"name: start_{direction}"))
    model = nemc.compile(path)
    for method in ("nemc.DOP853", "nemc.Taylor", "DOP853"):
        times = model.simulate(method=method).events["start"][0]
        assert list(times) == ([0.0] if fires else []), method


def test_users_events_with_scipy_and_refused_with_native(swinging, scipy_tip_events) -> None:
    def low(t, y):
        return tip_height(y)

    low.direction = -1
    result = swinging.simulate(method="DOP853", events=low, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(result.events["low"][0], scipy_tip_events[0], atol=1e-8)
    np.testing.assert_allclose(result.t_events[3], scipy_tip_events[0], atol=1e-8)

    def stop_early(t, y):
        return t - 1.0

    stop_early.terminal = True
    stopped = swinging.simulate(method="RK45", events=[stop_early])
    assert stopped.status == 1 and stopped.t[-1] <= 1.0
    with pytest.raises(ModelError, match="events= callables need one of scipy's methods"):
        swinging.simulate(method="nemc.DOP853", events=low)


def test_the_cli_table_marks_event_rows(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", str(EXAMPLES / "pendulum_to_vertical.yaml")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[-1] == "event"
    assert lines[-2].endswith("<- vertical") and lines[-2].split()[0] == "0.59196"
    assert "event 'vertical' stopped the run" in lines[-1]


def test_bad_events_are_refused_with_file_and_line(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text((GLIDER % """\
    bounce: {when: y, direction: down, action: {dot(z): 1}}
    puck: {when: y}
    empty: {when: y, action: {}}
    body: {when: "puck + 1"}
    odd: {when: y, action: halt}
  tstops: [0.5, 0.2]
  max_steps: 2.5
  max_step: 0""").replace("name: glider", "name: bad"))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    for line in (
        "bad.yaml:12: simulation.events.bounce.direction: unknown direction 'down'",
        "bad.yaml:12: simulation.events.bounce.action.dot(z): unknown coordinate or rate",
        "bad.yaml:13: simulation.events.puck: event name 'puck' is already used by the body",
        "bad.yaml:14: simulation.events.empty.action: an impact law needs at least one new",
        "bad.yaml:15: simulation.events.body.when: 'puck' is a body, not allowed in events",
        "bad.yaml:16: simulation.events.odd.action: unknown action 'halt'",
        "bad.yaml:17: simulation.tstops[1]: times must increase, got 0.2 after 0.5",
        "bad.yaml:18: simulation.max_steps: expected a whole number of steps >= 0",
        "bad.yaml:19: simulation.max_step: must be a number > 0, got 0",
    ):
        assert line in err, line


def test_an_impact_on_a_closed_loop_is_projected_onto_its_constraints(tmp_path: Path) -> None:
    """The spec: with constraints, an impact law's new rates are projected onto them. A bumper
    reverses the four-bar's crank at half its speed; the coupler's and rocker's rates follow
    from the constraints, and the impact loses kinetic energy."""
    law = '{when: q1 - 2.5, direction: rising, action: {dot(q1): "-0.5*dot(q1)"}}'
    text = (EXAMPLES / "fourbar.yaml").read_text().replace(
        "  t_eval: {step: 0.05}", f"  t_eval: {{step: 0.05}}\n  events:\n    bumper: {law}")
    path = tmp_path / "fourbar_bumper.yaml"
    path.write_text(text)
    model = nemc.compile(path)
    result = model.simulate(t_span=(0, 0.2), method="nemc.DOP853")  # one impact (at 0.098)
    times, before = result.events["bumper"]
    assert result.success and len(times) >= 1
    p = model.parameter_vector(None)
    events = model.compiled.model_events(p)
    after = events.impact(0, times[0], before[0])  # what the run went on from
    rates = after[1::2]
    assert after[1] == pytest.approx(-0.5 * before[0][1], rel=1e-12)
    assert model.constraint_residual(before[0], times[0])[1] < 1e-8
    assert model.constraint_residual(after, times[0])[1] < 1e-8  # rates on the constraints
    naive = before[0].copy()
    naive[1] = -0.5 * naive[1]  # the law alone leaves the loop's rates inconsistent
    assert model.constraint_residual(naive, times[0])[1] > 1e-2
    assert not np.allclose(rates[1:], before[0][3::2])  # the other links' rates changed too
    energy = result.outputs["energy.total"]
    k = np.searchsorted(result.t, times[0])
    assert energy[k] < energy[k - 1] - 1e-3  # the bumper took energy out
    np.testing.assert_allclose(energy[k:], energy[k], rtol=1e-6)  # conserved again after it
