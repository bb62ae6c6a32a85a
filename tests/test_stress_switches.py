"""`nemc stress` on mechanisms with Coulomb friction and contacts (issue 50): the switches it
counts against the closed forms of tests/contact_reference.py, its chattering rule, and the
report on every friction and contact example."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from contact_reference import (
    Ball,
    StickSlip,
    ball_accumulation_time,
    ball_bounce_times,
    ball_rest,
    stick_slip_switches,
)

from nemc.pipeline import compile_mechanism
from nemc.runtime.model import Model, SimulationResult
from nemc.tools import stress, switches
from nemc.tools.cli import main

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
FRICTION_EXAMPLES = ("coulomb_block", "stick_slip", "block_on_tilting_incline",
                     "slider_crank_friction", "ball_to_rest", "rocking_block")
STICK_SLIP = StickSlip(m=1.0, k=100.0, g=9.81, mu_s=0.5, mu_k=0.3, v_belt=0.5)  # the example's
ZENO = 1e-6  # decision 0041: a flight shorter than ZENO (1 + t): the impacts accumulate


def tight_run(name: str) -> tuple[Model, SimulationResult]:
    """The example's scene run as the report's reference is: nemc.Vern9 at rtol 1e-12."""
    model = compile_mechanism(EXAMPLES / f"{name}.yaml", True, energy=True).model
    return model, model.simulate(method="nemc.Vern9", rtol=1e-12, atol=1e-14)


def test_the_stick_slip_oscillators_switches_are_the_closed_forms() -> None:
    """Two switches a period, a slip where k x reaches mu_s m g and a stick where the slip
    speed is 0 again: the counts, and each located event's time, are the closed form's."""
    model, run = tight_run("stick_slip")
    expected = stick_slip_switches(STICK_SLIP, float(run.t[-1]))
    found = switches.count_switches(model, run)
    kinds = [kind for _, kind in expected]
    assert found.counts == {"belt": {"stick": kinds.count("stick"),
                                     "slip": kinds.count("slip")}}
    times, _ = run.events["belt.stick_slip"]
    assert np.max(np.abs(times - [t for t, _ in expected])) < 1e-8
    assert not found.chattering and found.bursts[0].span > 10 * found.window


def closed_form_impacts(p: Ball) -> int:
    """The impacts the accumulation rule lets happen: the bounces up to the first k whose next
    flight, 2 e^k t1, or the one after (e times the tail, the next / (1 - e)), is shorter than
    ZENO (1 + t_k) (t_k the closed form's bounce times), then the tail's landing."""
    times = ball_bounce_times(p, 200)
    flights = 2 * p.t1 * p.e ** np.arange(1, times.size + 1)
    short = np.minimum(flights, p.e * flights / (1 - p.e)) < ZENO * (1 + times)
    return int(np.argmax(short)) + 2


def test_the_balls_impacts_are_counted_up_to_their_accumulation_then_it_chatters() -> None:
    """20 impacts (the closed form's count up to the accumulation rule, the last the tail's
    landing at t_inf), the contact closed by the last, then one friction switch (it rolls
    from t_roll); the bounces' tightest burst ends at t_inf, within the chattering window:
    flagged."""
    p = Ball()
    model, run = tight_run("ball_to_rest")
    found = switches.count_switches(model, run)
    assert closed_form_impacts(p) == 20
    assert found.counts == {"floor": {"impact": closed_form_impacts(p), "closing": 1,
                                      "contact stick/slip": 1}}
    rolls, _ = run.events["floor.stick_slip"]
    assert rolls[0] == pytest.approx(ball_rest(p).t_roll, abs=1e-8)
    (burst,) = found.chattering
    t_inf = ball_accumulation_time(p)
    assert burst.event == "floor.contact" and burst.start < t_inf
    assert burst.start + burst.span == pytest.approx(t_inf, abs=1e-9)


def test_closings_and_releases_account_for_each_contacts_modes() -> None:
    """The rocking block: for each corner, closings minus releases is its mode at the end
    minus at the start (every change of NAME.active counted once, also the releases another
    corner's impulse makes)."""
    model, run = tight_run("rocking_block")
    found = switches.count_switches(model, run)
    start = switches.modes_at(model, float(run.t[0]), run.y[:, 0],
                              switches.mode_names(model), None)
    for corner in ("left_corner", "right_corner"):
        counts = found.counts[corner]
        assert counts["impact"] > 100
        end = run.outputs[f"{corner}.active"][-1]
        assert counts["closing"] - counts.get("release", 0) == end - start[corner]


def test_a_burst_is_the_tightest_run_of_consecutive_events() -> None:
    """Seeded random event times with five planted within 1e-6: that burst, and only it."""
    rng = np.random.default_rng(50)
    spread = np.sort(rng.uniform(0.0, 10.0, 40))
    planted = 4.2 + np.arange(switches.CHATTER_COUNT) * 2e-7
    times = np.sort(np.concatenate([spread[np.abs(spread - 4.2) > 0.1], planted]))
    events = [(float(t), "a.contact", np.zeros(2)) for t in times]
    (burst,) = switches.tightest_bursts(events)
    assert burst.start == pytest.approx(4.2) and burst.span == pytest.approx(8e-7)
    assert switches.tightest_bursts(events[:switches.CHATTER_COUNT - 1]) == ()


def test_the_energy_balance_closes_where_friction_and_impacts_are_the_only_losses() -> None:
    """The Coulomb block on a joint spring (in the energy): the energy it loses is the friction's
    work; the spinning ball (ball_to_rest): the impacts' losses and the friction's work, the
    closed form's (tests/contact_reference.py); both to the run's error. With the belt's
    driven spring (stick_slip, not in the energy) the rest is that spring's work, not 0."""
    block = compile_mechanism(EXAMPLES / "coulomb_block.yaml", True, energy=True).model
    balance = stress.energy_balance(block, block.scene["t_span"])
    assert balance.change < -1.0 and abs(balance.rest) < 1e-9 * abs(balance.change)
    assert balance.impact_loss == 0.0
    ball = compile_mechanism(EXAMPLES / "ball_to_rest.yaml", True, energy=True).model
    balance = stress.energy_balance(ball, ball.scene["t_span"])
    rest = ball_rest(Ball())
    assert balance.impact_loss == pytest.approx(rest.impact_loss, rel=1e-10)
    assert balance.friction_work == pytest.approx(rest.friction_work, rel=1e-10)
    assert abs(balance.rest) < 1e-9 * abs(balance.change)
    belt = compile_mechanism(EXAMPLES / "stick_slip.yaml", True, energy=True).model
    assert abs(stress.energy_balance(belt, belt.scene["t_span"]).rest) > 1.0


@pytest.mark.parametrize("name", FRICTION_EXAMPLES)
def test_the_report_runs_on_every_friction_and_contact_example(name: str, tmp_path: Path,
                                                               capsys) -> None:
    """Each example's report: its two methods, its switches, and the sections skipped with
    their reason instead of a number."""
    assert main(["stress", str(EXAMPLES / f"{name}.yaml"), "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    text = (tmp_path / f"{name}.md").read_text()
    assert "| rtol / atol | nemc.Vern9 | nemc.DOP853 |" in text and "| RK45" not in text
    assert "Truth: nemc.Vern9 at rtol 1e-12" in text and "## Switches" in text
    assert text.count("Skipped: ") == 2 and "## Energy balance" in text
    chatters = "chatters**" in text
    assert chatters == (name in ("ball_to_rest", "rocking_block")), name


@pytest.mark.parametrize("name", ["bouncing_ball", "fourbar_driven"])
def test_the_report_still_runs_on_scenes_issue_51_saw_exit_2(name: str, tmp_path: Path,
                                                             capsys) -> None:
    assert main(["stress", str(EXAMPLES / f"{name}.yaml"), "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    assert "## Switches" not in (tmp_path / f"{name}.md").read_text()
