"""Coulomb friction and contacts with scipy's explicit methods (RK45, RK23, DOP853 through
solve_ivp; nemc/runtime/scipy_switches.py): the closed forms and the references the native
methods meet (tests/test_friction.py, tests/contact_reference.py), switch by switch, a stuck
rate exactly 0, a holding margin that dips inside one long step found there, and the implicit
methods refused by name."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from contact_reference import (
    BasePulse,
    RockingBlock,
    SliderCrank,
    StickSlip,
    rocking_accumulation_time,
    rocking_base_accumulation_time,
    rocking_impact_times,
    slider_crank_run,
    stick_slip_switches,
)
from scipy.optimize import brentq
from scipy.special import erf

import nemc
from nemc.runtime.failures import ModelError

ROOT = Path(__file__).resolve().parent
EXAMPLES, DATA = ROOT.parent / "examples", ROOT / "data"
METHODS = ["DOP853", "RK45"]
TOLERANCES = [1e-10, 1e-8]
M, K, G, MU, MU_S = 1.0, 10.0, 9.81, 0.1, 0.15  # examples/coulomb_block.yaml


@pytest.fixture(scope="module")
def block():
    return nemc.compile(EXAMPLES / "coulomb_block.yaml")


@pytest.mark.parametrize("rtol", TOLERANCES)
@pytest.mark.parametrize("method", METHODS)
def test_the_coulomb_block_turns_and_sticks_where_the_closed_form_says(block, method: str,
                                                                     rtol: float) -> None:
    result = block.simulate(method=method, rtol=rtol, atol=rtol / 100)
    assert result.success and result.method == method
    half = math.pi / math.sqrt(K / M)
    delta = 2 * MU * M * G / K
    turns = [(-1) ** n * (1.0 - n * delta) for n in range(1, 6)]
    times, states = result.events["slide.stick_slip"]
    np.testing.assert_allclose(times, [n * half for n in range(1, 6)], rtol=0, atol=1e-7)
    np.testing.assert_allclose(np.asarray(states)[:, 0], turns, rtol=0, atol=100 * rtol)
    after = result.t > 5 * half + 1e-6
    assert after.sum() > 3
    assert np.all(result.y[1, after] == 0.0)  # held exactly
    assert np.all(result.y[0, after] == result.y[0, -1])
    assert np.all(result.outputs["slide.stuck"][after] == 1.0)


@pytest.mark.parametrize("method", METHODS)
def test_the_belt_stick_slip_oscillator_switches_at_its_closed_form_times(method: str) -> None:
    model = nemc.compile(DATA / "friction" / "stick_slip.yaml")
    end = float(model.scene["t_span"][1])
    result = model.simulate(t_eval=[0.0, end], method=method, rtol=1e-10, atol=1e-12)
    assert result.success
    expected = [t for t, _ in stick_slip_switches(StickSlip(), end) if t < end - 1e-6]
    times = result.events["slide.stick_slip"][0]
    times = times[times < end - 1e-6]
    assert len(expected) > 20 and len(times) == len(expected)
    np.testing.assert_allclose(times, expected, rtol=0, atol=1e-7)


PULSED = """
name: pulsed_block
parameters: {m: 2.0, g: 9.81, mu: 0.45, mu_s: 0.5, a: 19.62, w: 2.0, tp: 5.0}
gravity: [0, -g]
bodies:
  block: {mass: m, inertia: 0.1}
joints:
  slide: {type: prismatic, parent: ground, child: block, coordinate: x}
loads:
  - {force: ["a*exp(-((t - tp)/w)**2)", 0], body: block}
friction:
  - {joint: slide, mu: mu, mu_static: mu_s}
simulation:
  t_span: [0, 20]
"""


def pulsed_reference() -> tuple[float, float]:
    """The block at rest pushed by a Gaussian pulse a exp(-((t - tp)/w)^2) that passes mu_s m g:
    it breaks free where the push reaches mu_s m g, then m v' = push - mu m g (v by erf) until
    v returns to 0 (brentq), where the push is below mu_s m g: it sticks."""
    m, g, mu, mu_s, a, w, tp = 2.0, 9.81, 0.45, 0.5, 19.62, 2.0, 5.0
    t_free = tp - w * math.sqrt(math.log(a / (mu_s * m * g)))

    def speed(t: float) -> float:
        pushed = a * w * math.sqrt(math.pi) / 2 * (erf((t - tp) / w) - erf((t_free - tp) / w))
        return (pushed - mu * m * g * (t - t_free)) / m

    t_stop = brentq(speed, tp, 20.0, xtol=1e-15)
    assert a * math.exp(-(((t_stop - tp) / w) ** 2)) < mu_s * m * g  # it holds there
    return t_free, t_stop


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK23"])
def test_a_margin_that_dips_inside_one_long_step_is_found_there(tmp_path: Path,
                                                                method: str) -> None:
    """At rest the right-hand side is exactly 0 and the steps grow tenfold: one step takes
    the solver from t ~ 1 past the pulse, over which the holding margin dips below 0 and
    recovers. Looked at only at the steps' ends, the pulse would be missed (checked: the
    run's steps at rest pass over it); the inner samples find it."""
    path = tmp_path / "pulsed.yaml"
    path.write_text(PULSED)
    model = nemc.compile(path)
    t_free, t_stop = pulsed_reference()
    result = model.simulate(method=method, rtol=1e-10, atol=1e-12)
    assert result.success
    times, _ = result.events["slide.stick_slip"]
    np.testing.assert_allclose(times, [t_free, t_stop], rtol=0, atol=1e-7)
    stuck = (result.t < t_free) | (result.t > t_stop)
    assert np.all(result.y[1, stuck] == 0.0)
    before = np.unique(result.t[result.t <= t_free])  # the switch: its state before and after
    assert before[-1] == times[0] and before[-1] - before[-2] > 2.0  # one step at rest to it


M_BALL, R_BALL, E_BALL, Y0_BALL = 0.2, 0.05, 0.5, 1.05  # tests/data/contacts/ball_on_floor.yaml


@pytest.mark.parametrize("rtol", TOLERANCES)
@pytest.mark.parametrize("method", METHODS)
def test_the_ball_bounces_where_the_closed_form_says_then_rests(method: str,
                                                                rtol: float) -> None:
    ball = nemc.compile(DATA / "contacts" / "ball_on_floor.yaml")
    result = ball.simulate(method=method, rtol=rtol, atol=rtol / 100)
    assert result.success
    times, _ = result.events["floor.contact"]
    t1 = math.sqrt(2 * (Y0_BALL - R_BALL) / G)
    expected = t1 + 2 * t1 * np.concatenate(([0.0], np.cumsum(E_BALL ** np.arange(1, 19))))
    assert len(times) == 20  # 19 bounces, then the Zeno tail's landing at t_inf
    np.testing.assert_allclose(times[:-1], expected, rtol=0, atol=1e-9)
    assert times[-1] == pytest.approx(t1 * (1 + E_BALL) / (1 - E_BALL), abs=1e-9)
    resting = result.t > times[-1]
    assert resting.sum() > 3
    assert np.all(result.y[3, resting] == 0.0)  # the closed contact holds it exactly
    np.testing.assert_allclose(result.y[2, resting], R_BALL, rtol=0, atol=1e-13)
    np.testing.assert_allclose(result.outputs["floor.Fn"][resting], M_BALL * G, rtol=1e-12)


@pytest.mark.parametrize("rtol", TOLERANCES)
@pytest.mark.parametrize("method", METHODS)
def test_the_rocking_block_rocks_as_housner_says_and_comes_to_rest(method: str,
                                                                   rtol: float) -> None:
    rocking = RockingBlock()
    model = nemc.compile(DATA / "friction" / "rocking_block.yaml")
    result = model.simulate(method=method, rtol=rtol, atol=rtol / 100)
    assert result.success
    times = np.sort(np.concatenate([result.events[f"{corner}.contact"][0]
                                    for corner in ("left_corner", "right_corner")]))
    np.testing.assert_allclose(times[:12], rocking_impact_times(rocking, 0.8 * rocking.alpha, 12),
                               rtol=0, atol=1e-7)
    assert times[-1] == pytest.approx(rocking_accumulation_time(rocking, 0.8 * rocking.alpha),
                                      abs=1e-8 if rtol == 1e-10 else 1e-6)  # the tail's landing
    resting = result.t > times[-1]
    assert resting.sum() > 3
    for i in (1, 3, 4, 5):
        np.testing.assert_allclose(result.y[i, resting], 0.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("rtol", TOLERANCES)
@pytest.mark.parametrize("method", METHODS)
def test_the_slider_crank_under_motor_pulses_switches_as_the_reference(method: str,
                                                                       rtol: float) -> None:
    model = nemc.compile(DATA / "friction" / "slider_crank_friction_tree.yaml")
    result = model.simulate(t_eval=[0.0, 3.0], method=method, rtol=rtol, atol=rtol / 100)
    assert result.success
    reference = slider_crank_run(SliderCrank(), 3.0, np.pi / 3)
    times, _ = result.events["S.stick_slip"]
    assert len(reference.switches) == 6
    np.testing.assert_allclose(times, [t for t, _ in reference.switches], rtol=0,
                               atol=1e-9 if rtol == 1e-10 else 1e-7)


@pytest.mark.parametrize("rtol", TOLERANCES)
@pytest.mark.parametrize("method", METHODS)
def test_on_a_shaken_table_the_block_lifts_rocks_and_rests_as_the_reference_says(
        method: str, rtol: float) -> None:
    """rocking_block_pulse.yaml: the numbers tests/test_contacts_rocking.py holds the native
    methods to (tests/contact_reference.py, rocking_base_run)."""
    model = nemc.compile(DATA / "friction" / "rocking_block_pulse.yaml")
    result = model.simulate(method=method, rtol=rtol, atol=rtol / 100)
    assert result.success
    times = np.sort(np.concatenate([result.events[f"{corner}.contact"][0]
                                    for corner in ("left_corner", "right_corner")]))
    np.testing.assert_allclose(times[:5], [0.052521951990, 0.442335662650, 0.693868674237,
                                           0.919565957500, 1.122732730433], rtol=0,
                               atol=1e-9 if rtol == 1e-10 else 1e-7)
    assert np.abs(result.y[4]).max() == pytest.approx(0.0374781, abs=5e-7)
    assert times[-1] == pytest.approx(rocking_base_accumulation_time(RockingBlock(), BasePulse(),
                                                                     3.5, 0.5),
                                      abs=1e-8 if rtol == 1e-10 else 1e-6)  # the tail's landing
    resting = result.t > times[-1]
    np.testing.assert_allclose(result.y[4, resting], 0.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("method", ["RK23", "DOP853"])
def test_a_scene_with_contacts_may_name_scipys_explicit_methods(tmp_path: Path,
                                                                method: str) -> None:
    """The front end's check (vocabulary.CONTACT_METHODS) takes them; the run is theirs."""
    text = (DATA / "contacts" / "ball_on_floor.yaml").read_text()
    path = tmp_path / "ball.yaml"
    path.write_text(text.replace("simulation:\n", f"simulation:\n  method: {method}\n", 1))
    result = nemc.compile(path).simulate()
    assert result.success and result.method == method
    assert len(result.events["floor.contact"][0]) == 20


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA"])
def test_scipys_implicit_methods_are_refused_by_name(block, method: str) -> None:
    with pytest.raises(ModelError, match=f"{method} cannot run a mechanism with Coulomb "
                       "friction or contacts .*Newton iteration"):
        block.simulate(method=method)
