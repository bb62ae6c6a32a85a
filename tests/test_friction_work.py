"""The work account of Coulomb friction and contacts (issue 50): the outputs NAME.friction_work
and NAME.impact_loss against a power balance (energy.total + the friction's work + the impacts'
losses = the energy at the start, to 1e-8) and against closed forms: a block sliding to rest on
a flat floor and down an incline (the work -mu N d), the stick-slip oscillator's dissipation
per cycle, the bouncing ball's losses (tests/contact_reference.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from contact_reference import Ball, StickSlip, ball_rest, stick_slip_cycle

import nemc

ROOT = Path(__file__).parent.parent
EXAMPLES = ROOT / "examples"
DATA = Path(__file__).parent / "data" / "friction"
METHODS = ["nemc.Vern9", "nemc.DOP853", "DOP853", "RK45"]  # scipy's: nemc/runtime/account.py
BALANCE = 1e-8  # the power balance's tolerance (J)


def account(result: nemc.SimulationResult) -> np.ndarray:
    """The energy the friction and the impacts took up to each time: minus every
    NAME.friction_work, plus every NAME.impact_loss."""
    taken = np.zeros(result.t.size)
    for name, values in result.outputs.items():
        if name.endswith(".friction_work"):
            taken -= values
        elif name.endswith(".impact_loss"):
            taken += values
    return taken


def balance_error(result: nemc.SimulationResult) -> float:
    """The largest |energy.total + what the account took - the energy at the start|."""
    total = result.outputs["energy.total"]
    return float(np.max(np.abs(total + account(result) - total[0])))


@pytest.fixture(scope="module")
def coulomb_block() -> nemc.Model:
    return nemc.compile(EXAMPLES / "coulomb_block.yaml")


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("example", ["coulomb_block", "ball_to_rest", "rocking_block"])
def test_the_power_balance_of_the_friction_and_contact_examples(example: str,
                                                                method: str) -> None:
    result = nemc.compile(EXAMPLES / f"{example}.yaml").simulate(method=method)
    assert result.success
    assert balance_error(result) < BALANCE
    assert account(result)[-1] > 0.1  # each of them loses energy: the balance has a term


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("example", ["coulomb_block", "ball_to_rest"])
def test_the_power_balance_holds_at_every_step_too(example: str, method: str) -> None:
    """t_eval "steps": the account recorded at each step (the state before and after each
    impact) as the states are."""
    result = nemc.compile(EXAMPLES / f"{example}.yaml").simulate(method=method, t_eval="steps")
    assert 30 < result.t.size < 600  # the steps, not the scene's times
    assert balance_error(result) < BALANCE


def test_a_block_sliding_to_rest_on_a_flat_floor_does_its_kinetic_energy_as_work(
        coulomb_block: nemc.Model) -> None:
    """No spring, thrown at v0: it slides d = v0^2 / (2 mu g) and stops (stuck for good); the
    friction's work is -m v0^2 / 2 = -mu m g d."""
    m, g, mu, v0 = 1.0, 9.81, 0.1, 2.0
    result = coulomb_block.simulate(params={"k": 0.0}, y0={"x": 0.0, "dot(x)": v0},
                                    t_span=(0, 3))
    d = v0**2 / (2 * mu * g)
    assert result.y[0, -1] == pytest.approx(d, abs=1e-9)
    work = result.outputs["slide.friction_work"]
    assert work[-1] == pytest.approx(-m * v0**2 / 2, abs=1e-9)
    assert work[-1] == pytest.approx(-mu * m * g * d, abs=1e-9)
    # while sliding, the work so far is -mu m g times the distance so far
    sliding = result.t < v0 / (mu * g)
    np.testing.assert_allclose(work[sliding], -mu * m * g * result.y[0][sliding], rtol=0,
                               atol=1e-9)


def test_the_spring_block_dissipates_mu_m_g_times_its_path(coulomb_block: nemc.Model) -> None:
    """The file's swings: turning points x_n = (-1)^n (1 - n delta), delta = 2 mu m g / k,
    five half swings, then stuck: the path is the sum of |x_n - x_n+1|."""
    m, g, mu, k = 1.0, 9.81, 0.1, 10.0
    delta = 2 * mu * m * g / k
    turns = [(-1) ** n * (1 - n * delta) for n in range(6)]
    path = sum(abs(a - b) for a, b in zip(turns, turns[1:]))
    result = coulomb_block.simulate()
    assert result.outputs["slide.friction_work"][-1] == pytest.approx(-mu * m * g * path,
                                                                      abs=1e-9)


def test_a_block_sliding_down_a_fixed_incline_does_minus_mu_n_d() -> None:
    """tests/data/friction/block_incline.yaml with the incline held (w = 0) at 0.6 rad, past
    static friction: it slides from rest, N = m g cos(alpha), and its energy balances."""
    model = nemc.compile(DATA / "block_incline.yaml")
    alpha, m, g, mu = 0.6, 1.0, 9.81, 0.4
    result = model.simulate(params={"w": 0.0, "alpha0": alpha}, t_span=(0, 1))
    assert result.success
    s = result.y[model.state_names.index("s")]
    work = result.outputs["slide.friction_work"]
    np.testing.assert_allclose(work, -mu * m * g * math.cos(alpha) * np.abs(s), rtol=0,
                               atol=1e-9)
    assert s[-1] == pytest.approx(-g * (math.sin(alpha) - mu * math.cos(alpha)) / 2, abs=1e-9)
    assert balance_error(result) < BALANCE


@pytest.mark.parametrize("method", METHODS)
def test_the_power_balance_of_the_slider_crank_with_friction(method: str) -> None:
    """examples/slider_crank_friction.yaml (a closed loop) with its motor off, the crank
    thrown: the slider slips and sticks (243 stuck samples), the friction takes 10.9 J; the
    balance to the run's error (rtol 1e-11: 1.6e-10 J)."""
    model = nemc.compile(EXAMPLES / "slider_crank_friction.yaml")
    result = model.simulate(method=method, params={"T0": 0.0}, rtol=1e-11, atol=1e-13,
                            y0={"q1": math.pi / 3, "dot(q1)": 30.0})
    assert result.success
    assert np.any(result.outputs["S.stuck"] == 1.0)
    assert result.outputs["S.friction_work"][-1] < -10.0
    assert balance_error(result) < BALANCE


def test_the_stick_slip_oscillators_dissipation_is_the_closed_forms() -> None:
    """tests/data/friction/stick_slip.yaml (tests/contact_reference.py's StickSlip): stuck
    until k x = mu_s m g, then n limit cycles, each dissipating mu_k m g (v slip_time + 2 D)."""
    p = StickSlip()
    cycle = stick_slip_cycle(p)
    n = 5
    t_end = p.x_static / p.v_belt + n * cycle.period
    result = nemc.compile(DATA / "stick_slip.yaml").simulate(t_span=(0, t_end))
    assert result.success
    work = result.outputs["slide.friction_work"]
    assert work[-1] == pytest.approx(-n * cycle.dissipation, rel=1e-9)


def test_the_ball_to_rest_account_is_the_closed_forms() -> None:
    """The impacts' normal losses m g (y0 - r) (all the fall's energy) and the friction's work
    in the sliding impacts and the lasting slide, tests/contact_reference.py's ball_rest."""
    rest = ball_rest(Ball())
    result = nemc.compile(EXAMPLES / "ball_to_rest.yaml").simulate()
    assert result.outputs["floor.impact_loss"][-1] == pytest.approx(rest.impact_loss,
                                                                    rel=1e-10)
    assert result.outputs["floor.friction_work"][-1] == pytest.approx(rest.friction_work,
                                                                      rel=1e-10)
    # the losses only grow, by a jump at each impact, and nothing before the first
    loss = result.outputs["floor.impact_loss"]
    assert np.all(np.diff(loss) >= 0)
    first = result.events["floor.contact"][0][0]
    assert np.all(loss[result.t < first] == 0.0)


def test_the_rocking_blocks_impacts_take_the_energy_above_rest() -> None:
    """rocking_block.yaml: its corners stick in the impacts and while resting, so their friction
    works (nearly) nothing; the impacts take the energy above rest."""
    result = nemc.compile(EXAMPLES / "rocking_block.yaml").simulate()
    outputs = result.outputs
    for corner in ("left_corner", "right_corner"):
        assert abs(outputs[f"{corner}.friction_work"][-1]) < 1e-9
    taken = outputs["left_corner.impact_loss"][-1] + outputs["right_corner.impact_loss"][-1]
    total = outputs["energy.total"]
    assert taken == pytest.approx(total[0] - total[-1], abs=1e-9)
