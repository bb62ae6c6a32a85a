"""A sliding impulse among several contacts (issue 50; decision 0041's amendment): Housner's
block (tests/data/friction/rocking_block.yaml) with its right corner's mu (0.1) below what a
sticking impact needs (0.1846), its left corner's (0.5) holding the rocking. At its first
impact no set of sticking impulses is consistent; the right corner's friction impulse slides
and the left corner lifts, as the closed form of tests/contact_reference.py
(rocking_sliding_impact, Newton-Euler of the impulses by hand) says. Without the sliding
impulse the block was brought to rest at that impact."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from contact_reference import (
    RockingBlock,
    rocking_impact_speeds,
    rocking_impact_times,
    rocking_sliding_impact,
)

import nemc

DATA = Path(__file__).parent / "data" / "friction"
BLOCK = RockingBlock()
TH0 = 0.8 * math.atan(BLOCK.b / BLOCK.h)  # the file's th0
MU_RIGHT = 0.1


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    text = (DATA / "rocking_block.yaml").read_text()
    changed = text.replace("  mu: 0.5\n", f"  mu: 0.5\n  mu_r: {MU_RIGHT}\n").replace(
        "restitution: 0, mu: mu}\noutputs", "restitution: 0, mu: mu_r}\noutputs")
    assert changed.count("mu_r") == 2
    path = tmp_path_factory.mktemp("sliding") / "rocking_block_sliding.yaml"
    path.write_text(changed)
    return nemc.compile(path)


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_the_first_impact_slides_as_the_closed_form_says(block, method: str) -> None:
    assert BLOCK.impact_friction_ratio > MU_RIGHT  # a sticking impact would need more
    t1 = rocking_impact_times(BLOCK, TH0, 1)[0]
    after, lift = rocking_sliding_impact(BLOCK, -rocking_impact_speeds(BLOCK, TH0, 1)[0],
                                         MU_RIGHT)
    assert lift > 0.1  # the left corner leaves: the set without it is the consistent one
    steps = np.array([1e-7, 2e-7])  # after the impact: extrapolated back to it (error ~1e-12)
    result = block.simulate(method=method, t_span=(0, 0.6), t_eval=t1 + steps)
    assert result.success, result.message
    (impact, *_), _ = result.events["right_corner.contact"]
    assert impact == pytest.approx(t1, abs=1e-9)
    rates = result.y[[1, 3, 5]]  # x', y', th'
    at_impact = rates[:, 0] - (rates[:, 1] - rates[:, 0]) * (t1 - impact + steps[0]) / (
        steps[1] - steps[0])
    np.testing.assert_allclose(at_impact, after, rtol=0, atol=1e-9)


def test_the_block_slides_and_comes_to_rest_without_gaining_energy(block) -> None:
    result = block.simulate()
    assert result.success, result.message
    energy = result.outputs["energy.total"]
    assert np.max(np.diff(energy)) < 1e-9
    assert abs(result.y[0, -1]) > 1e-2  # it slid (a sticking rest would leave x at 0)
    np.testing.assert_allclose(result.y[[1, 3, 5], -1], 0.0, atol=1e-9)  # at rest on its base
    assert result.y[2, -1] == pytest.approx(BLOCK.h, abs=1e-9)  # y = h, th = 0
    assert result.y[4, -1] == pytest.approx(0.0, abs=1e-9)
