"""Contacts that last with Coulomb friction (issue 50; decision 0041), against the independent
closed form of tests/contact_reference.py (Ball, ball_rest): the spec's
tests/data/friction/ball_to_rest.yaml, a spinning ball whose every impact's friction impulse
slides, bouncing to rest, then sliding on the lasting contact until it rolls at 1/14 m/s."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from contact_reference import Ball, ball_bounce_times, ball_rest

import nemc

DATA = Path(__file__).parent / "data" / "friction"
BALL = Ball()
REST = ball_rest(BALL)
ZENO = 1e-6  # friction.c.tmpl's CONTACT_ZENO: the impacts accumulate below this flight x (1 + t)


@pytest.fixture(scope="module")
def ball():
    return nemc.compile(DATA / "ball_to_rest.yaml")


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_the_spinning_ball_bounces_slides_and_rolls_as_the_closed_form_says(ball,
                                                                            method: str) -> None:
    result = ball.simulate(method=method)
    assert result.success
    times, _ = result.events["floor.contact"]
    bounces = times[:-1]  # then the tail's one flight, landing at t_inf (the Zeno rule)
    np.testing.assert_allclose(bounces, ball_bounce_times(BALL, len(bounces)), rtol=0,
                               atol=1e-11)
    assert times[-1] == pytest.approx(REST.t_inf, abs=1e-9)
    assert ZENO * (1 + REST.t_inf) < REST.t_inf - bounces[-1]
    (rolls,), (state,) = result.events["floor.stick_slip"]
    assert rolls == pytest.approx(REST.t_roll, abs=1e-11)
    assert state[0] == pytest.approx(REST.x_roll, abs=1e-12)
    # on the lasting contact: sliding (x'' = -mu g) from t_inf, then rolling; the tail's flight
    # changes nothing tangentially there (its launch's and landing's normal impulses add up to
    # the bounces' it stands for, m v_k + m g T, and so do their sliding friction impulses)
    t, x, rate = result.t, result.y[0], result.y[1]
    since, sliding = t - REST.t_inf, t < REST.t_roll
    decel = BALL.mu * BALL.g
    expected_x = np.where(sliding, REST.x_inf + REST.xd_inf * since - decel * since ** 2 / 2,
                          REST.x_roll + REST.xd_roll * (t - REST.t_roll))
    expected_rate = np.where(sliding, REST.xd_inf - decel * since, REST.xd_roll)
    lasting = t > times[-1]
    np.testing.assert_allclose(x[lasting], expected_x[lasting], rtol=0, atol=1e-11)
    np.testing.assert_allclose(rate[lasting], expected_rate[lasting], rtol=0, atol=1e-11)
    rolling = t > rolls
    np.testing.assert_allclose(rate[rolling], 1 / 14, rtol=0, atol=1e-13)
    np.testing.assert_allclose(result.outputs["slip"][rolling], 0.0, rtol=0, atol=1e-13)
    outputs = result.outputs
    weight = BALL.m * BALL.g
    np.testing.assert_allclose(outputs["floor.Fn"][lasting], weight, rtol=1e-13)
    slides = lasting & ~rolling
    np.testing.assert_allclose(outputs["floor.Ft"][slides], -BALL.mu * weight, rtol=1e-13)
    np.testing.assert_allclose(outputs["floor.Ft"][rolling], 0.0, rtol=0, atol=1e-13)
    assert np.all(outputs["floor.active"][lasting] == 1.0)
    assert np.all(outputs["floor.active"][t < times[-1] - 1e-3] == 0.0)


def test_the_energy_lost_is_what_the_impacts_and_friction_took(ball) -> None:
    """The energy drop is the impacts' normal losses, m g (y0 - r), plus the friction's work in
    the impacts and on the lasting contact (the reference's 0.064285714286 J); the work on the
    lasting contact alone is mu m g times the slip's distance from the close to the roll."""
    result = ball.simulate()
    total = result.outputs["energy.total"]
    assert total[0] - total[-1] == pytest.approx(REST.impact_loss - REST.friction_work,
                                                 rel=1e-12)
    (closed,), (rolled,) = result.events["floor.contact"][1][-1:], result.events[
        "floor.stick_slip"][1]
    slid = (rolled[0] + BALL.r * rolled[4]) - (closed[0] + BALL.r * closed[4])
    # x' + r th' after the last (plastic, sliding) impact: its friction impulse mu m |y'| takes
    # mu |y'| (1 + m r^2 / i) = 3.5 mu |y'| from the slip, which then decays at 3.5 mu g
    slip = closed[1] + BALL.r * closed[5] - 3.5 * BALL.mu * abs(closed[3])
    assert slid == pytest.approx(slip ** 2 / (2 * BALL.mu * BALL.g * 3.5), rel=1e-9)


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_a_ball_on_a_free_plate_keeps_the_momenta_through_impacts_and_lasting_contact(
        method: str) -> None:
    """Every force internal (a spring between them, no gravity): the total momentum and the
    angular momentum about the origin are kept through the impacts, the lasting contact's
    slide and its sticking (the surface body's share of each contact force and couple); the
    energy never rises beyond the tolerance's drift."""
    model = nemc.compile(Path(__file__).parent / "data" / "contacts" / "ball_on_free_plate.yaml")
    result = model.simulate(method=method)
    assert result.success
    assert len(result.events["face.contact"][0]) > 15  # it bounced to rest,
    assert np.any(result.outputs["face.active"] == 1.0)  # and the contact lasted
    assert len(result.events["face.stick_slip"][0]) >= 5  # sliding and sticking
    X, dX, Y, dY, A, dA, x, dx, y, dy, th, dth = result.y
    m, big_m, big_i, i, k = 0.2, 2.0, 0.3, 0.4 * 0.2 * 0.05 ** 2, 40.0
    momentum = (m * dx + big_m * dX, m * dy + big_m * dY)
    angular = m * (x * dy - y * dx) + big_m * (X * dY - Y * dX) + big_i * dA + i * dth
    for kept, start in zip((*momentum, angular), (0.3, 0.0, 0.196)):
        np.testing.assert_allclose(kept, start, rtol=0, atol=1e-10)
    eye = (X + 0.1 * np.cos(A), Y + 0.1 * np.sin(A))
    energy = (m * (dx ** 2 + dy ** 2) + big_m * (dX ** 2 + dY ** 2) + big_i * dA ** 2
              + i * dth ** 2 + k * ((x - eye[0]) ** 2 + (y - eye[1]) ** 2)) / 2
    assert np.diff(energy).max() <= 1e-8 and energy[-1] < energy[0] / 5


def test_the_two_methods_agree_on_the_ball_on_a_free_plate() -> None:
    """Its stick and slip decisions (some sticks last nanoseconds) are made alike by both
    methods: their states agree to 1e-7 over the whole run."""
    model = nemc.compile(Path(__file__).parent / "data" / "contacts" / "ball_on_free_plate.yaml")
    vern, dop = (model.simulate(method=method) for method in ("nemc.Vern9", "nemc.DOP853"))
    assert vern.success and dop.success
    np.testing.assert_allclose(vern.y, dop.y, rtol=0, atol=1e-7)
