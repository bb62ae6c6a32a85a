"""Sensitivities through the scene's events (issue 47): the jump of the columns at an impact
and the event times' own sensitivities, against the bouncing ball's closed form (its bounce
times and its flight between them, differentiated by sympy: a path independent of nemc's
derivation) over several bounces, and against central differences of tight runs (rtol 1e-13)
for a stop event and a located one."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import nemc
from nemc.build.builder import package_c_flags
from nemc.pipeline import compile_mechanism

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
TIGHT = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-14}
NAMES = ("e", "g", "r", "y")  # y: the drop height, the initial value of y
BOUNCES = 6  # over [0, 3]: the sixth at 2.88 s

# A pendulum thrown up from -1 rad that stops where it first swings down through the vertical, its
# apex located on the way.
STOPPING_PENDULUM = """\
name: stopping_pendulum
parameters: {m: 1.5, L: 0.8, g: 9.81, c: 0.3}
gravity: [0, -g]
bodies:
  rod: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  O: {type: revolute, parent: ground, child: rod, coordinate: theta}
loads:
  - {torque: -c*dot(theta), body: rod}
simulation:
  t_span: [0, 5]
  initial: {theta: -1.0, dot(theta): 1.0}
  events:
    apex: {when: dot(theta), direction: falling}
    down: {when: theta + 1.5707963267948966, direction: falling, action: stop}
"""


def bouncing_closed_form() -> tuple[list[sp.Expr], sp.Symbol, dict[str, sp.Symbol]]:
    """The ball's bounce times t_n (n = 1..BOUNCES) in e, g, r and the drop height h, from
    rest: t_1 = sqrt(2 (h - r) / g), each next 2 e^k v_1 / g later (v_1 = g t_1)."""
    e, g, r, h = sp.symbols("e g r h", positive=True)
    t1 = sp.sqrt(2 * (h - r) / g)
    times = [t1 + sum((2 * e**k * t1 for k in range(1, n)), sp.S.Zero)
             for n in range(1, BOUNCES + 1)]
    return times, t1, {"e": e, "g": g, "r": r, "y": h}


def flight(t: float, times: list[sp.Expr], t1: sp.Expr, symbols: dict[str, sp.Symbol],
           values: dict[sp.Symbol, float]) -> tuple[sp.Expr, sp.Expr]:
    """y(t) and dot(y)(t) of the closed form, as expressions, at a time between bounces."""
    e, g, r, h = (symbols[name] for name in NAMES)
    numeric = [float(tn.subs(values)) for tn in times]
    n = sum(tn < t for tn in numeric)
    if n == 0:
        return h - g * t**2 / 2, -g * t
    v = e**n * g * t1  # up, after the n-th bounce
    since = t - times[n - 1]
    return r + v * since - g * since**2 / 2, v - g * since


@pytest.fixture(scope="module")
def ball() -> nemc.runtime.Model:
    return nemc.compile(EXAMPLES / "bouncing_ball.yaml")


def relative_error(ours: np.ndarray, reference: np.ndarray) -> float:
    return float(np.abs(ours - reference).max() / max(np.abs(reference).max(), 1e-300))


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853", "nemc.Taylor", "DOP853"])
def test_bounces_match_the_closed_form(ball, method: str) -> None:
    """Over six bounces: the bounce times' sensitivities and the state's, y and dot(y), at
    times between the bounces, to the closed form's derivatives."""
    times, t1, symbols = bouncing_closed_form()
    values = {symbols["e"]: 0.8, symbols["g"]: 9.81, symbols["r"]: 0.05, symbols["y"]: 1.05}
    t_eval = np.linspace(0.0, 3.0, 37)[1:]
    res = ball.simulate((0, 3), t_eval=t_eval, sensitivities=list(NAMES), method=method,
                        rtol=1e-12, atol=1e-14)
    assert res.success, res.message
    fired = res.events["bounce"][0]
    assert fired.size == BOUNCES
    for name in NAMES:
        expected = [float(sp.diff(tn, symbols[name]).subs(values)) for tn in times]
        assert relative_error(res.event_sensitivities["bounce"][name],
                              np.array(expected)) < 1e-9, name
    row_y, row_dy = ball.state_names.index("y"), ball.state_names.index("dot(y)")
    for name in NAMES:
        reference = np.array([[float(sp.diff(expr, symbols[name]).subs(values))
                               for expr in flight(t, times, t1, symbols, values)]
                              for t in t_eval]).T
        ours = res.sensitivities[name][[row_y, row_dy]]
        assert relative_error(ours, reference) < 1e-7, name


def test_the_initial_values_jump_as_the_closed_form_says(ball) -> None:
    """d y / d y0 through the bounces: the column of y's initial value equals the named
    one, and x's columns never jump (x flies on at dot(x))."""
    res = ball.simulate((0, 2.5), sensitivities=["y0", "y"], method="nemc.Vern9",
                        rtol=1e-12, atol=1e-14)
    column = ball.state_names.index("y")
    assert relative_error(res.sensitivities["y0"][:, column], res.sensitivities["y"]) < 1e-12
    x, dx = ball.state_names.index("x"), ball.state_names.index("dot(x)")
    assert np.allclose(res.sensitivities["y0"][x, dx], res.t, rtol=0, atol=1e-10)
    bounces = res.event_sensitivities["bounce"]
    assert bounces["y0"].shape == (len(ball.state_names), 4)  # t_5 = 2.58 s
    assert np.array_equal(bounces["y0"][column], bounces["y"])


def stop_differences(model, name: str, h: float) -> tuple[float, float]:
    """The stop time's and the apex time's derivatives by NAME by central differences of
    tight runs."""
    ends = []
    for sign in (1, -1):
        params = {name: model.parameters[name] + sign * h}
        res = model.simulate(params=params, **TIGHT)
        ends.append((res.events["down"][0][0], res.events["apex"][0][0]))
    return tuple((ends[0][i] - ends[1][i]) / (2 * h) for i in range(2))


@pytest.mark.parametrize("method", ["nemc.Vern9", "DOP853"])
def test_a_stop_and_a_located_event_match_central_differences(tmp_path: Path, method: str
                                                              ) -> None:
    path = tmp_path / "stopping_pendulum.yaml"
    path.write_text(STOPPING_PENDULUM)
    model = nemc.compile(path)
    res = model.simulate(sensitivities=["c", "L", "g"], method=method, rtol=1e-12, atol=1e-14)
    assert res.status == 1 and res.events["down"][0].size == 1  # stopped by "down"
    for name in ("c", "L", "g"):
        stop, apex = stop_differences(model, name, 1e-5 * model.parameters[name])
        assert abs(res.event_sensitivities["down"][name][0] - stop) < 1e-7 * abs(stop), name
        assert abs(res.event_sensitivities["apex"][name][0] - apex) < 1e-7 * abs(apex), name


INPUT_EVENT = STOPPING_PENDULUM.replace("name: stopping_pendulum", "name: input_event").replace(
    "gravity:", "inputs: {u: 0.2}\ngravity:").replace(
    "torque: -c*dot(theta)", "torque: -c*dot(theta) + u").replace(
    "apex: {when: dot(theta), direction: falling}",
    "cross: {when: theta + 1.2 + u, direction: falling}")


def test_an_event_that_reads_an_input_moves_with_it(tmp_path: Path) -> None:
    """An event's function reading an input: its times' sensitivities to the input's value
    (g_p through the input's term) equal central differences."""
    path = tmp_path / "input_event.yaml"
    path.write_text(INPUT_EVENT)
    model = nemc.compile(path)
    res = model.simulate(sensitivities=["u"], method="nemc.Vern9", rtol=1e-12, atol=1e-14)
    runs = [model.simulate(inputs={"u": 0.2 + sign * 1e-6}, **TIGHT) for sign in (1, -1)]
    for event in ("cross", "down"):  # down: the stop, whose torque u changes
        reference = (runs[0].events[event][0] - runs[1].events[event][0]) / 2e-6
        assert reference.size == 1 and res.events[event][0].size == 1
        assert relative_error(res.event_sensitivities[event]["u"], reference) < 1e-7, event


def test_the_jump_compiles_warning_free(tmp_path: Path) -> None:
    """The bouncing ball's build with its sensitivities (the events' partials, the jump, the
    outputs' sensitivities) compiles under -Wall -Wextra -Werror."""
    package = compile_mechanism(EXAMPLES / "bouncing_ball.yaml", sensitivities=True).package
    source = package / "bouncing_ball.c"
    assert "event_crossing" in source.read_text()
    done = subprocess.run(["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror",
                           *package_c_flags(source), "-c", str(source), "-o",
                           str(tmp_path / "x.o")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "case 1: { /* apex */" in source.read_text()
