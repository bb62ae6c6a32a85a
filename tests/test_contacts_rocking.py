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
    RockingBlock,
    rocking_accumulation_time,
    rocking_impact_speeds,
    rocking_impact_times,
    rocking_pivot_force,
)

import nemc

DATA = Path(__file__).parent / "data" / "friction"
BLOCK = RockingBlock()
TH0 = 0.8 * BLOCK.alpha
COMPARED = 12  # impacts compared one by one


@pytest.fixture(scope="module")
def block():
    return nemc.compile(DATA / "rocking_block.yaml")


def impacts(result) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Every corner impact in time order: times, which corner, the states before them."""
    found = sorted((t, name, tuple(state)) for name in ("left_corner", "right_corner")
                   for t, state in zip(*result.events[f"{name}.contact"]))
    return (np.array([t for t, _, _ in found]), [n for _, n, _ in found],
            np.array([s for _, _, s in found]))


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
    # the rocking accumulates: the rest starts before t_inf by the flights the rule skipped
    # (measured 8.1e-6 s; the flights shrink as r = 31/34 per impact)
    assert 0 < rocking_accumulation_time(BLOCK, TH0) - times[-1] < 2e-5
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
