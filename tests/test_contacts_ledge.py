"""Contacts on a surface with ends (`surface.length`; issue 50, decision 0042): reading it (a
bad length refused at its FILE:LINE with its key), the corner's geometry against a second
derivation, and the dynamics against tests/ledge_reference.py (written apart from nemc's code
path): examples/ball_off_ledge.yaml's roll to the edge, its slip and leaving on the corner and
its landing, and a disc set over a corner leaving it where the closed forms say."""

from __future__ import annotations

import math
import random
from pathlib import Path

import numpy as np
import pytest
import sympy
from ledge_reference import (
    Ledge,
    frictionless_leave_angle,
    point_off_edge,
    rolling_leave_angle,
    rolling_speed,
    rolling_time,
    slip_angle,
    slipping_leave,
    timeline,
)

import nemc
from nemc.derive.kinematics import Kinematics
from nemc.errors import InputError
from nemc.front.validate import load_mechanism, validate_text
from nemc.kinds.terms import rate_symbol, symbol
from nemc.runtime.failures import ModelError

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "ball_off_ledge.yaml"
CORNER = ROOT / "tests" / "data" / "contacts" / "disc_over_corner.yaml"
POINT = ROOT / "tests" / "data" / "contacts" / "point_off_edge.yaml"
METHODS = ("nemc.Vern9", "nemc.DOP853")
X, XD, Y, YD, TH, THD = range(6)  # the state's layout: each coordinate, then its rate

TEXT = EXAMPLE.read_text()
LEDGE = "          surface: {body: ground, at: [-L, h], axis: [1, 0], length: L},"
LEDGE_LINE = TEXT.splitlines().index(LEDGE) + 1

# the ledge's surface line's replacement, its problem's key path, the message's words
BAD = {
    "negative length": ("length: -L", "contacts.ledge.surface.length", "must be > 0"),
    "zero length": ("length: L - 1", "contacts.ledge.surface.length", "must be > 0"),
    "an unknown name": ("length: Lx", "contacts.ledge.surface.length", "Lx"),
    "a coordinate": ("length: x", "contacts.ledge.surface.length", "x"),
    "a string": ("length: 'one metre'", "contacts.ledge.surface.length", ""),
    "a list": ("length: [1, 2]", "contacts.ledge.surface.length", ""),
    "not finite": ("length: log(h - 1)", "contacts.ledge.surface.length", "finite"),
    "a misspelt key": ("lenght: L", "contacts.ledge.surface", "lenght"),
}


@pytest.mark.parametrize("case", BAD)
def test_a_bad_length_is_refused_at_its_line_with_its_key(case: str, tmp_path: Path) -> None:
    replacement, key, words = BAD[case]
    path = tmp_path / "bad.yaml"
    path.write_text(TEXT.replace("length: L}", replacement + "}"))
    assert path.read_text() != TEXT
    with pytest.raises(InputError) as caught:
        load_mechanism(path)
    text = str(caught.value)
    assert f"{path}:{LEDGE_LINE}: {key}" in text, text
    assert words in text


def test_a_length_that_falls_to_0_at_a_runs_parameters_is_refused() -> None:
    model = nemc.compile(EXAMPLE)
    with pytest.raises(ModelError, match=r"contacts.ledge.surface.length must be > 0"):
        model.simulate(params={"L": 0.0})


MOVING = """name: moving
parameters: {R: 0.3, c: 0.7, d: -0.2, len: 0.5}
bodies:
  disc: {mass: 1, inertia: 0.1}
  cart: {mass: 2, inertia: 0.2}
  plate: {mass: 1, inertia: 0.1}
joints:
  flight: {type: free, parent: ground, child: disc, coordinates: [x, y, th]}
  rail: {type: prismatic, parent: ground, child: cart, coordinate: s, axis: [1, 2]}
  tilt: {type: revolute, parent: cart, child: plate, coordinate: a, at: [0.5, 0.1]}
contacts:
  touch: {point: disc.origin, radius: R,
          surface: {body: plate, at: [c, d], axis: [2, 1], length: len}}
"""


def _values(seed: int) -> dict[sympy.Symbol, float]:
    """Random coordinates and rates (seeded), and the parameters of MOVING."""
    draw = random.Random(seed)
    names = ("x", "y", "th", "s", "a")
    return {**{s: draw.uniform(-2, 2) for n in names for s in (symbol(n), rate_symbol(n))},
            symbol("R"): 0.3, symbol("c"): 0.7, symbol("d"): -0.2, symbol("len"): 0.5}


@pytest.mark.parametrize("seed", range(8))
def test_on_a_moving_segment_the_gap_is_the_distance_to_its_part_and_the_speed_its_rate(
        seed: int) -> None:
    """A disc against a segment of a plate that slides and turns: the gap is, by where the
    center projects on the axis (s), the distance to the corner at `at` (s <= 0), to the far
    corner (s >= length) or to the line; and the normal speed is the gap's time derivative
    (written here from the plate's own frame, not through the kind's regions)."""
    mech = validate_text(MOVING, "moving.yaml")
    contact = mech.contacts[0]
    kin = Kinematics(mech)
    gap = contact.gap(kin)
    normal, _ = contact.speeds(kin)
    plate, disc = kin.frame("plate"), kin.frame("disc")
    u = plate.rotate((2 / sympy.sqrt(5), 1 / sympy.sqrt(5)))
    p, a = disc.origin, plate.point((symbol("c"), symbol("d")))
    b = (a[0] + symbol("len") * u[0], a[1] + symbol("len") * u[1])
    at = _values(seed)
    s = float((u[0] * (p[0] - a[0]) + u[1] * (p[1] - a[1])).xreplace(at))
    corner = a if s <= 0 else b if s >= 0.5 else None
    if corner is None:
        expected = -u[1] * (p[0] - a[0]) + u[0] * (p[1] - a[1]) - symbol("R")
    else:
        expected = sympy.sqrt((p[0] - corner[0]) ** 2 + (p[1] - corner[1]) ** 2) - symbol("R")
    value = float(gap.xreplace(at))
    assert value == pytest.approx(float(expected.xreplace(at)), rel=1e-13, abs=1e-13)
    rate = float(kin.rate(expected).xreplace(at))
    assert float(normal.xreplace(at)) == pytest.approx(rate, rel=1e-12, abs=1e-12)


def test_the_seeds_reach_every_part_of_the_segment() -> None:
    """The test above sees both corners and the line (else it could not fail there)."""
    seen = {"before": 0, "after": 0, "along": 0}
    mech = validate_text(MOVING, "moving.yaml")
    kin = Kinematics(mech)
    plate, disc = kin.frame("plate"), kin.frame("disc")
    u = plate.rotate((2 / sympy.sqrt(5), 1 / sympy.sqrt(5)))
    p, a = disc.origin, plate.point((symbol("c"), symbol("d")))
    for seed in range(8):
        s = float((u[0] * (p[0] - a[0]) + u[1] * (p[1] - a[1])).xreplace(_values(seed)))
        seen["before" if s <= 0 else "after" if s >= 0.5 else "along"] += 1
    assert all(seen.values()), seen


def test_a_segment_is_drawn_between_its_ends() -> None:
    from nemc.derive.geometry import drawing

    picture = drawing(load_mechanism(EXAMPLE))
    (segment,) = picture.segments
    ends = [[float(v.subs({symbol("L"): 1, symbol("h"): 0.5})) for v in picture.points[k][1:]]
            for k in (segment["a"], segment["b"])]
    assert ends == [[-1.0, 0.5], [0.0, 0.5]]
    assert len(picture.surfaces) == 1  # the floor, a line


@pytest.fixture(scope="module")
def ledge():
    return nemc.compile(EXAMPLE)


def test_an_animation_draws_the_segment_between_its_ends(ledge) -> None:
    from nemc.tools.animate import render_frame

    _, ax = render_frame(ledge, 0.0, [-0.5, 0.0, 0.9, 0.0, 0.0, 0.0])
    drawn = [np.column_stack(line.get_data()) for line in ax.lines]
    assert any(d.shape == (2, 2) and np.allclose(d, [[-1, 0.5], [0, 0.5]]) for d in drawn)


@pytest.mark.parametrize("method", METHODS)
def test_the_ball_rolls_off_the_ledge_when_and_where_the_reference_says(ledge,
                                                                         method: str) -> None:
    """examples/ball_off_ledge.yaml against the reference: the roll at 2/3 of the throw's
    speed reaches the edge at t_edge; it sticks on the corner until the closed form's slip
    angle, slips, leaves where its normal force falls to 0, and lands on the floor, each to
    1e-9 (time in s, angle in rad)."""
    ref, p = timeline(), Ledge()
    result = ledge.simulate(method=method)
    assert result.success
    times, states = result.events["ledge.contact"]
    rests = times[-2]  # the Zeno tail's landing, which closes the contact; then the release
    assert rests == pytest.approx(ref.t_inf, abs=1e-9)
    t, x = result.t, result.y[X]
    rolling = (t > rests + 1e-3) & (x < 0)  # on the ledge's line, at rest on it
    np.testing.assert_allclose(x[rolling], ref.x1 + ref.v_roll * (t[rolling] - ref.t1),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.y[XD][rolling], ref.v_roll, rtol=0, atol=1e-10)
    last = np.flatnonzero(rolling)[-1]  # the edge from its last sample's place and speed
    assert t[last] - x[last] / result.y[XD][last] == pytest.approx(ref.t_edge, abs=1e-9)
    assert ref.t_edge - t[last] < 0.01
    (t_slip, *_), (slipped, *_) = result.events["ledge.stick_slip"]
    assert t_slip == pytest.approx(ref.t_slip, abs=1e-9)
    assert math.atan2(slipped[X], slipped[Y] - p.h) == pytest.approx(ref.theta_slip, abs=1e-9)
    leaves = states[-1]
    assert times[-1] == pytest.approx(ref.t_leave, abs=1e-9)
    assert math.atan2(leaves[X], leaves[Y] - p.h) == pytest.approx(ref.theta_leave, abs=1e-9)
    assert math.hypot(leaves[XD], leaves[YD]) == pytest.approx(ref.speed_leave, abs=1e-9)
    landings, _ = result.events["floor.contact"]
    assert landings[0] == pytest.approx(ref.t_land, abs=1e-9)
    fn = result.outputs["ledge.Fn"]
    assert np.all(fn[(t > ref.t_leave) | (t < ref.t1)] == 0.0)
    assert np.all(result.outputs["floor.active"][t > landings[-1] + 1e-3] == 1.0)


def test_the_ball_comes_to_rest_on_the_floor(ledge) -> None:
    result = ledge.simulate()
    p, ref = Ledge(), timeline()
    landings, _ = result.events["floor.contact"]
    resting = result.t > landings[-1] + 1e-3
    assert resting.any() and landings[-1] < result.t[-1]
    np.testing.assert_allclose(result.y[Y][resting], p.r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.outputs["floor.Fn"][resting], p.m * p.g, rtol=1e-9)
    assert landings[0] > ref.t_leave


@pytest.fixture(scope="module")
def corner():
    return nemc.compile(CORNER)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("v0", [0.05, 0.2, 0.5])
def test_a_frictionless_disc_leaves_the_corner_where_energy_and_the_normal_force_say(
        corner, method: str, v0: float) -> None:
    """From right over the corner at speed v0 (any spin; mu 0): it leaves at cos θ = (2 +
    v0² / (g r)) / 3, and the corner does no work on it (the energy kept to 1e-10)."""
    p = Ledge(h=0.0)
    result = corner.simulate(y0=[0.0, v0, p.r, 0.0, 0.0, 3.0], params={"mu": 0.0},
                             method=method)
    assert result.success
    (leaves,), (state,) = result.events["edge.contact"]
    assert math.atan2(state[X], state[Y]) == pytest.approx(frictionless_leave_angle(p, v0),
                                                          abs=1e-9)
    energy = result.outputs["energy.total"]
    np.testing.assert_allclose(energy, energy[0], rtol=0, atol=1e-10)
    assert leaves < result.t[-1]


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("v0, mu", [(0.2, 0.3), (0.5, 0.8), (0.1, 3.0)])
def test_a_rolling_disc_slips_then_leaves_the_corner_where_the_reference_says(
        corner, method: str, v0: float, mu: float) -> None:
    """Rolling from right over the corner at speed v0: it sticks until k sin θ = mu ((3 + k)
    cos θ - 2 - (1 + k) v0² / (g r)) (the closed form from energy with the disc's inertia and
    the normal force), then slips forward and leaves where the reference's slide says."""
    p = Ledge(h=0.0, mu=mu)
    result = corner.simulate(y0=[0.0, v0, p.r, 0.0, 0.0, -v0 / p.r], params={"mu": mu},
                             method=method)
    assert result.success
    theta_slip = slip_angle(p, v0)
    t_slip = rolling_time(p, v0, theta_slip)
    (t1, *_), (slips, *_) = result.events["edge.stick_slip"]
    assert t1 == pytest.approx(t_slip, abs=1e-9)
    assert math.atan2(slips[X], slips[Y]) == pytest.approx(theta_slip, abs=1e-9)
    dt, theta_leave, speed = slipping_leave(p, theta_slip, rolling_speed(p, v0, theta_slip))
    (t2,), (leaves,) = result.events["edge.contact"]
    assert t2 == pytest.approx(t_slip + dt, abs=1e-9)
    assert math.atan2(leaves[X], leaves[Y]) == pytest.approx(theta_leave, abs=1e-9)
    assert math.hypot(leaves[XD], leaves[YD]) == pytest.approx(speed, abs=1e-9)


def test_with_a_huge_mu_it_rolls_without_slip_to_the_rolling_closed_forms_angle(corner) -> None:
    """mu = 1e9: it sticks until its normal force is 1e-10 of its weight, so its slip starts
    where a disc rolling without slip would leave, cos θ = (2 + (1 + k) v0² / (g r)) / (3 + k)
    (k = 1/2); the run ends just after (a slip under such a mu is as stiff as Painlevé's)."""
    p, v0 = Ledge(h=0.0), 0.2
    result = corner.simulate(y0=[0.0, v0, p.r, 0.0, 0.0, -v0 / p.r], params={"mu": 1e9},
                             t_span=(0.0, 0.15))
    assert result.success
    (_, *_), (slips, *_) = result.events["edge.stick_slip"]
    assert math.atan2(slips[X], slips[Y]) == pytest.approx(rolling_leave_angle(p, v0), abs=1e-9)


@pytest.mark.parametrize("method, tolerance", [("nemc.Vern9", 1e-9), ("RK45", 1e-9),
                                               ("nemc.DOP853", 1e-6)])
@pytest.mark.parametrize("mu", [0.0, 0.1])
def test_a_point_sliding_past_the_end_leaves_there(method: str, tolerance: float,
                                                   mu: float) -> None:
    """A point (radius 0) on a corner has no normal: there the line's is taken, and past it
    the corner's normal turns across the motion, so the contact opens at the end and the
    point flies the parabola. nemc.DOP853 records a stick of about 1 µs at the corner first
    (the slip, measured across the corner's normal, jumps to about 0) and ends 10⁻⁷ m off:
    its looser bound here (decision 0042)."""
    model = nemc.compile(POINT)
    result = model.simulate(method=method, params={"mu": mu})
    assert result.success
    t_e, x, y = point_off_edge(-0.1, 0.5, mu, 9.81, result.t)
    (leaves, *_), _ = result.events["edge.contact"]
    assert leaves == pytest.approx(t_e, abs=tolerance)
    np.testing.assert_allclose(result.y[X], x, rtol=0, atol=tolerance)
    np.testing.assert_allclose(result.y[Y], y, rtol=0, atol=tolerance)


@pytest.mark.parametrize("method", [*METHODS, "RK45"])
@pytest.mark.parametrize("rtol", [1e-4, 1e-6])
def test_at_loose_tolerances_the_ledge_run_keeps_its_story(ledge, method: str,
                                                           rtol: float) -> None:
    """The corner's kink is not an event; at loose tolerances the step controller still
    takes it: the ball leaves the ledge and lands within 10 rtol s of the reference (measured
    within 0.16 rtol), and rests on the floor."""
    ref, p = timeline(), Ledge()
    result = ledge.simulate(method=method, rtol=rtol, atol=rtol * 1e-2)
    assert result.success
    leaves, _ = result.events["ledge.contact"]
    landings, _ = result.events["floor.contact"]
    assert leaves[-1] == pytest.approx(ref.t_leave, abs=10 * rtol)
    assert landings[0] == pytest.approx(ref.t_land, abs=10 * rtol)
    assert result.y[Y][-1] == pytest.approx(p.r, abs=10 * rtol)
