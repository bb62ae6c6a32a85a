"""Two contacts that last (issue 50; decision 0041): Housner's block rocking on its two corners
(the spec's tests/data/friction/rocking_block.yaml), against the independent reference of
tests/contact_reference.py (RockingBlock: the impact times by quadrature of the energy integral,
the speeds before each impact from the amplitudes' exact decay, the pivot's force by Newton for
the mass center). Each impact at one corner lifts the other (the enumeration of which contacts
take an impulse), and the rocking accumulates into the block resting on its base."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from contact_reference import (
    BasePulse,
    RockingBlock,
    base_slide_closed_form,
    rocking_accumulation_time,
    rocking_base_accumulation_time,
    rocking_impact_speeds,
    rocking_impact_times,
    rocking_pivot_force,
    rocking_tail,
)

import nemc

DATA = Path(__file__).parent / "data" / "friction"
BLOCK = RockingBlock()
TH0 = 0.8 * BLOCK.alpha
COMPARED = 12  # impacts compared one by one
T_INF = rocking_accumulation_time(BLOCK, TH0)


@pytest.fixture(scope="module")
def block():
    return nemc.compile(DATA / "rocking_block.yaml")


def impacts(result) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Every corner impact in time order: times, which corner, the states before them."""
    found = sorted((t, name, tuple(state)) for name in ("left_corner", "right_corner")
                   for t, state in zip(*result.events[f"{name}.contact"]))
    return (np.array([t for t, _, _ in found]), [n for _, n, _ in found],
            np.array([s for _, _, s in found]))


def tail_of(result) -> tuple[float, float]:
    """The last located impact's time and its tail: the time from it to where the rest starts
    (the lifted corner's landing), and the closed form's tail (rocking_tail) from the speed
    before that impact (the impacting corner's record; the lifted one's, at the same
    instant, is after the impulse)."""
    times, corners, states = impacts(result)
    last = times[times < times[-1]][-1]
    (before,) = [s[5] for t, c, s in zip(times, corners, states) if t == last
                 and c != corners[-1]]
    return times[-1] - last, rocking_tail(BLOCK, abs(before))


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_the_block_rocks_as_housner_says_and_comes_to_rest(block, method: str) -> None:
    result = block.simulate(method=method)
    assert result.success
    times, corners, states = impacts(result)
    np.testing.assert_allclose(times[:COMPARED], rocking_impact_times(BLOCK, TH0, COMPARED),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.abs(states[:COMPARED, 5]),
                               rocking_impact_speeds(BLOCK, TH0, COMPARED), rtol=0, atol=1e-9)
    assert corners[:4] == ["right_corner", "left_corner", "right_corner", "left_corner"]
    # the rocking accumulates: the last impact's tail (the flights left, shrinking as
    # r = 31/34) is flown as one flight, whose landing starts the rest; it is the closed form's
    # from that impact's speed, and t_inf is as good as the located impacts at the scene's rtol
    # (1e-10: their drift is 3.5e-9 s, Vern9, and 4.4e-8 s, DOP853, by the last)
    tail, expected = tail_of(result)
    assert tail == pytest.approx(expected, abs=1e-11)
    assert times[-1] == pytest.approx(T_INF, abs=5e-8)
    resting = result.t > times[-1]
    np.testing.assert_allclose(result.y[4, resting], 0.0, rtol=0, atol=1e-12)
    for rate in (1, 3, 5):
        np.testing.assert_allclose(result.y[rate, resting], 0.0, rtol=0, atol=1e-12)
    weight = BLOCK.m * BLOCK.g
    for corner in ("left_corner", "right_corner"):
        np.testing.assert_allclose(result.outputs[f"{corner}.Fn"][resting], weight / 2,
                                   rtol=1e-9)
        np.testing.assert_allclose(result.outputs[f"{corner}.Ft"][resting], 0.0, rtol=0,
                                   atol=1e-9)
        assert np.all(result.outputs[f"{corner}.active"][resting] == 1.0)


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_at_a_tight_tolerance_the_rest_starts_at_the_references_t_inf(block, method) -> None:
    """rtol 1e-12: the rest starts within 1.5e-9 s of the reference's t_inf (measured 1.2e-9,
    Vern9, 9.1e-10, DOP853: the drift of the 121 located impacts, the last's 6.3e-10 and
    8.1e-10, and of its speed; the tail itself is the closed form's to 1e-11)."""
    result = block.simulate(method=method, rtol=1e-12, atol=1e-14)
    assert result.success
    tail, expected = tail_of(result)
    assert tail == pytest.approx(expected, abs=1e-11)
    assert impacts(result)[0][-1] == pytest.approx(T_INF, abs=1.5e-9)


def test_the_impacts_take_all_the_energy_above_rest(block) -> None:
    result = block.simulate()
    total = result.outputs["energy.total"]
    above = BLOCK.m * BLOCK.g * (BLOCK.radius * math.cos(BLOCK.alpha - TH0) - BLOCK.h)
    assert total[0] - total[-1] == pytest.approx(above, rel=1e-9)
    times, _, _ = impacts(result)
    for start, end in zip(times[:COMPARED - 1], times[1:COMPARED]):  # none lost while rocking
        rocking = (result.t > start + 1e-9) & (result.t < end - 1e-9)
        if rocking.any():
            assert np.ptp(total[rocking]) <= 1e-9


def test_the_pivot_carries_the_force_newton_says_and_the_other_corner_none(block) -> None:
    """Before the first impact the block pivots on its left corner: that contact's forces are
    m (a_G - g) (tests/contact_reference.py, rocking_pivot_force), the right corner's 0."""
    result = block.simulate()
    first = impacts(result)[0][0]
    pivoting = result.t < first - 1e-6
    expected = np.array([rocking_pivot_force(BLOCK, th, thd) for th, thd in
                         zip(result.y[4, pivoting], result.y[5, pivoting])])
    np.testing.assert_allclose(result.outputs["left_corner.Ft"][pivoting], expected[:, 0],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.outputs["left_corner.Fn"][pivoting], expected[:, 1],
                               rtol=0, atol=1e-9)
    assert np.all(result.outputs["right_corner.Fn"][pivoting] == 0.0)
    # the friction it needs stays inside the cone (mu = 0.5): the corner does not slide
    assert np.all(np.abs(expected[:, 0]) <= 0.5 * expected[:, 1])
    assert result.events["left_corner.stick_slip"][0].size == 0


def test_the_lifted_corner_carries_nothing_exactly(block) -> None:
    """Between the first two impacts the block pivots on its right corner: the left one is
    open, its forces exactly 0 and its `active` 0 (not the rounding of Newton's elimination)."""
    result = block.simulate()
    times = impacts(result)[0]
    lifted = (result.t > times[0] + 1e-6) & (result.t < times[1] - 1e-6)
    for output in ("Fn", "Ft", "active"):
        assert np.all(result.outputs[f"left_corner.{output}"][lifted] == 0.0)
    assert np.all(result.outputs["right_corner.active"][lifted] == 1.0)


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_on_a_shaken_table_the_block_lifts_rocks_and_rests_as_the_reference_says(
        method: str) -> None:
    """rocking_block_pulse.yaml (mu = 0.5): the contacts' surface is a driven table; the block
    lifts onto its left corner when the table's acceleration reaches g tan(alpha), rocks, and
    rests again (its header's numbers: tests/contact_reference.py, rocking_base_run)."""
    model = nemc.compile(DATA / "rocking_block_pulse.yaml")
    result = model.simulate(method=method)
    assert result.success
    (lifted,) = result.events["right_corner.stick_slip"][0]  # it stuck until it lifted
    times = impacts(result)[0]  # the right corner's release, then the impacts
    np.testing.assert_allclose(times[:5], [0.052521951990, 0.442335662650, 0.693868674237,
                                           0.919565957500, 1.122732730433], rtol=0, atol=1e-9)
    assert lifted == pytest.approx(0.052521951990, abs=1e-12)  # the right corner lets go
    assert np.abs(result.y[4]).max() == pytest.approx(0.0374781, abs=5e-7)
    tail, expected = tail_of(result)  # the rest from the tail's landing, at t_inf
    assert tail == pytest.approx(expected, abs=1e-11)
    assert times[-1] == pytest.approx(rocking_base_accumulation_time(BLOCK, BasePulse(), 3.5,
                                                                     0.5), abs=5e-8)
    resting = result.t > times[-1]
    np.testing.assert_allclose(result.y[4, resting], 0.0, rtol=0, atol=1e-12)


def test_on_a_shaken_table_with_less_friction_the_block_slides_then_sticks() -> None:
    """rocking_block_pulse.yaml with mu = 0.2: no rocking; the block slides on the table from
    t0 = (tp / pi) asin(mu g / A) until it sticks, both corners at once, having slid the closed
    form's distance (tests/contact_reference.py, base_slide_closed_form)."""
    start, stop, slid = base_slide_closed_form(BasePulse(), BLOCK.g, 0.2)
    model = nemc.compile(DATA / "rocking_block_pulse.yaml")
    result = model.simulate(params={"mu": 0.2})
    assert result.success
    assert all(result.events[f"{c}.contact"][0].size == 0 for c in ("left_corner", "right_corner"))
    right = result.events["right_corner.stick_slip"][0]
    np.testing.assert_allclose(right, [start, stop], rtol=0, atol=1e-10)
    assert result.events["left_corner.stick_slip"][0][-1] == pytest.approx(stop, abs=1e-10)
    assert result.outputs["slide"][-1] == pytest.approx(slid, abs=1e-10)
    np.testing.assert_allclose(result.y[4], 0.0, rtol=0, atol=1e-12)  # it never tilts
