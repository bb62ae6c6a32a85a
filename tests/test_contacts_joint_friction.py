"""Contacts together with friction on joints (issue 50; decision 0041's amendment), against
the independent event-driven reference of tests/contact_reference.py (CartPendulumWall,
Lagrange's equations by hand): tests/data/contacts/cart_pendulum_wall.yaml, a cart with dry
friction on a rough floor whose rod's tip strikes a wall. Three parameter sets take every
branch of Coulomb's law in the impulse: a slipping cart stopped by the impact and a stuck one
held through it (the file's), a stuck cart the impact sets sliding, and a slipping cart the
impact turns (it cannot stick: it slides back). The native methods and scipy's DOP853 alike.
And tests/data/contacts/cart_ball_floor.yaml, a sliding cart whose ball bounces to rest on a
rough floor, against the closed form of CartBall: the impacts' friction impulses, the lasting
contact, and the cart and the ball's contact sticking at the same instant (one slip). And
tests/data/contacts/rocking_block_on_cart.yaml: Housner's block rocks to rest on a cart its
friction holds, as on the floor (the impacts among closed contacts, the accumulation's rest)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from contact_reference import (
    CartBall,
    CartPendulumWall,
    RockingBlock,
    cart_ball_motion,
    cart_impact,
    cart_pendulum_run,
    rocking_accumulation_time,
    rocking_impact_times,
)
from scipy.integrate import simpson

import nemc
from nemc.errors import InputError
from nemc.front.validate import load_mechanism
from nemc.runtime.failures import ModelError

DATA = Path(__file__).parent / "data" / "contacts"
T_END, PHI0 = 3.0, -1.2  # the file's t_span and initial angle
CASES = {  # name: (the parameters changed from the file's, the impacts' ways in the reference)
    "stops_and_holds": ({}, ["stick", "stick"]),
    "held_cart_slides": ({"mu": 0.15, "mu_s": 0.25, "d": 0.3}, ["slide"] * 3),
    "slipping_cart_turns": ({"mu": 0.1, "mu_s": 0.15}, ["slide"]),
}


@pytest.fixture(scope="module")
def cart():
    return nemc.compile(DATA / "cart_pendulum_wall.yaml")


def reference(params: dict[str, float]):
    return cart_pendulum_run(CartPendulumWall(**params), T_END, PHI0)


def test_the_cases_take_the_impulse_laws_branches() -> None:
    """The reference's impacts go the ways the cases say (else a case tests less than it
    claims): each impact replayed from the reference's state just before it."""
    for params, ways in CASES.values():
        p, run = CartPendulumWall(**params), reference(params)
        found = []
        for t in run.switch_times("impact"):
            before = [seg for seg in run.segments if seg.t1 == t][0]
            found.append(cart_impact(p, before.state(t), before.mode == "stick")[1])
        assert found == ways
    # the third case's impact: slipping before, sliding the other way after
    p, run = CartPendulumWall(**CASES["slipping_cart_turns"][0]), \
        reference(CASES["slipping_cart_turns"][0])
    (t,) = run.switch_times("impact")
    assert run.state(t - 1e-9)[2] * run.state(t)[2] < 0


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853", "DOP853"])
@pytest.mark.parametrize("case", list(CASES))
def test_cart_and_rod_follow_the_independent_reference(cart, case: str, method: str) -> None:
    params = CASES[case][0]
    run = reference(params)
    result = cart.simulate(method=method, params=params)
    assert result.success, result.message
    impacts, _ = result.events["wall.contact"]
    switches, _ = result.events["slide.stick_slip"]
    np.testing.assert_allclose(impacts, run.switch_times("impact"), rtol=0, atol=1e-9)
    np.testing.assert_allclose(switches, [t for t, name in run.switches if name != "impact"],
                               rtol=0, atol=1e-9)
    expected = np.array([run.state(t) for t in result.t]).T  # x, phi, x', phi' (nemc: x, x', ...)
    np.testing.assert_allclose(result.y[[0, 2, 1, 3]], expected, rtol=0, atol=5e-9)
    p = CartPendulumWall(**params)
    energy = [p.energy(state) for state in expected.T]
    np.testing.assert_allclose(result.outputs["energy.total"], energy, rtol=0, atol=5e-9)
    stuck = result.outputs["slide.stuck"] == 1.0
    assert np.all(result.y[1][stuck] == 0.0) and stuck.any() and not stuck.all()


def test_between_events_the_energy_drops_by_the_friction_work(cart) -> None:
    """Power balance: between any two events the total energy changes by the integral of the
    floor's friction force times the cart's speed (Simpson's rule on the 1 ms samples)."""
    result = cart.simulate(params=CASES["slipping_cart_turns"][0])
    events = np.sort(np.concatenate([result.events[name][0] for name in result.events]))
    edges = np.concatenate([[result.t[0]], events, [result.t[-1]]])
    power = result.outputs["slide.friction"] * result.y[1]  # x'
    energy, checked = result.outputs["energy.total"], 0
    for t0, t1 in zip(edges[:-1], edges[1:]):
        inside = (result.t > t0 + 1e-6) & (result.t < t1 - 1e-6)
        if inside.sum() < 21:
            continue
        t, w = result.t[inside], power[inside]
        worked = simpson(w, x=t)
        assert energy[inside][-1] - energy[inside][0] == pytest.approx(worked, abs=1e-8)
        checked += abs(worked) > 1e-3
    assert checked >= 3


ZENO = 1e-6  # friction.c.tmpl's CONTACT_ZENO: the impacts accumulate below this flight x (1 + t)


@pytest.fixture(scope="module")
def cart_ball():
    return nemc.compile(DATA / "cart_ball_floor.yaml")


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853", "DOP853"])
def test_the_cart_slows_through_the_balls_bounces_and_sticks_as_the_closed_form_says(
        cart_ball, method: str) -> None:
    p = CartBall()
    result = cart_ball.simulate(method=method)
    assert result.success, result.message
    impacts, _ = result.events["floor.contact"]
    times, _ = p.impacts()
    np.testing.assert_allclose(impacts[:-1], times[:len(impacts) - 1], rtol=0, atol=1e-9)
    closes = impacts[-2]  # the accumulation: the flights left flown as one from here
    assert times[len(impacts) - 1] - closes < ZENO * (1 + p.t_inf) / p.e  # a short next
    assert impacts[-1] == pytest.approx(p.t_inf, abs=1e-9)  # that flight lands at t_inf
    x, rate, t_stop, x_stop = cart_ball_motion(p, result.t)
    (stops, *more), _ = result.events["slide.stick_slip"]
    assert not more and stops == pytest.approx(t_stop, abs=1e-9)
    outside = (result.t < closes) | (result.t > p.t_inf)  # nemc rests from `closes`
    np.testing.assert_allclose(result.y[0][outside], x[outside], rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.y[1][outside], rate[outside], rtol=0, atol=1e-9)
    assert result.y[0, -1] == pytest.approx(x_stop, abs=1e-9) and result.y[1, -1] == 0.0
    out, t = result.outputs, result.t
    sliding = t < t_stop  # the cart's normal force M g: the slider passes no vertical force
    np.testing.assert_allclose(out["slide.friction"][sliding], -p.mu * p.M * p.g, rtol=1e-12)
    assert np.all(out["slide.stuck"][t > t_stop] == 1.0)
    resting = t > p.t_inf
    np.testing.assert_allclose(out["floor.Fn"][resting], p.m * p.g, rtol=1e-12)


@pytest.mark.parametrize("old, new, line, key, words", [
    ("  rtol: 1.0e-10", "  method: Radau\n  rtol: 1.0e-10", 36, "simulation.method",
     "cannot run a mechanism with contacts"),
    ("mu_static: mu_s}", "mu_static: 0.1}", 26, "friction[0].mu_static", "must be >= mu"),
    ("restitution: e}", "restitution: -e}", 28, "contacts.wall.restitution", ">= 0"),
])
def test_a_bad_file_with_both_is_refused_at_its_line(tmp_path: Path, old: str, new: str,
                                                      line: int, key: str, words: str) -> None:
    text = (DATA / "cart_pendulum_wall.yaml").read_text()
    assert text.count(old) == 1
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace(old, new))
    with pytest.raises(InputError) as caught:
        load_mechanism(path)
    assert f"{path}:{line}: {key}" in str(caught.value) and words in str(caught.value)


@pytest.mark.parametrize("kwargs, words", [
    ({"method": "LSODA"}, "cannot run a mechanism with Coulomb friction or contacts"),
    ({"params": {"mu_s": 0.1}}, "mu_static - mu must be >= 0"),
    ({"params": {"e": 1.5}}, "restitution must be >= 0"),
])
def test_a_bad_run_of_both_is_refused_by_name(cart, kwargs: dict, words: str) -> None:
    with pytest.raises(ModelError, match=words):
        cart.simulate(**kwargs)


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853", "DOP853"])
def test_a_block_rocks_to_rest_on_a_held_cart_as_on_the_floor(method: str) -> None:
    block, th0 = RockingBlock(), 0.8 * math.atan(0.1 / 0.4)  # the file's b, h and th0
    result = nemc.compile(DATA / "rocking_block_on_cart.yaml").simulate(method=method)
    assert result.success, result.message
    impacts = np.sort(np.concatenate([result.events[f"{corner}_corner.contact"][0]
                                      for corner in ("left", "right")]))
    np.testing.assert_allclose(impacts[:12], rocking_impact_times(block, th0, 12), rtol=0,
                               atol=1e-9)
    assert 0 < rocking_accumulation_time(block, th0) - impacts[-1] < 2e-5  # rests early
    assert not len(result.events["slide.stick_slip"][0])
    assert np.all(result.y[0] == 0.0) and np.all(result.y[1] == 0.0)  # the cart held
    np.testing.assert_allclose(result.y[[2, 4], -1], [0.0, block.h], atol=1e-9)  # x, y: rest
    np.testing.assert_allclose(result.y[[3, 5, 6, 7], -1], 0.0, atol=1e-9)


def test_a_start_the_equations_cannot_take_fails_as_a_run_without_friction_does(cart) -> None:
    """A rod of length 0 (no inertia about its pin): the friction's start cannot be solved,
    the mass matrix singular; the run fails at t = 0 with its state, a failed result (it
    raised a TypeError: the start's error was built without its state)."""
    result = cart.simulate(params={"L": 0.0})
    assert not result.success
    assert "at t=0: the mass matrix is singular" in result.message, result.message
