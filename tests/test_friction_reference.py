"""nemc's Coulomb friction against tests/contact_reference.py, the event-driven reference written
apart from nemc (maximal coordinates and Lagrange multipliers, hand-derived equations, closed
forms): the example files of tests/data/friction/ that nemc takes, run by nemc and compared
switch by switch."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from contact_reference import (
    Incline,
    SliderCrank,
    StickSlip,
    incline_run,
    slider_crank_run,
    stick_slip_switches,
)

import nemc

DATA = Path(__file__).resolve().parent / "data" / "friction"
METHODS = ["nemc.Vern9", "nemc.DOP853"]


@pytest.mark.parametrize("method", METHODS)
def test_the_slider_crank_under_motor_pulses_switches_as_the_reference(method: str) -> None:
    """A flywheel crank pushed in pulses, the slider's friction pressed by the guide's reaction:
    stuck, slipping, stuck again between pulses, through a dead center; every switch and the
    state at 3 s as the reference's (its own tree-free derivation) to 1e-8."""
    model = nemc.compile(DATA / "slider_crank_friction_tree.yaml")
    result = model.simulate(t_eval=[0.0, 3.0], method=method)
    assert result.success
    reference = slider_crank_run(SliderCrank(), 3.0, np.pi / 3)
    times, _ = result.events["S.stick_slip"]
    np.testing.assert_allclose(times, [t for t, _ in reference.switches], rtol=0, atol=1e-8)
    index = [model.state_names.index(name) for name in ("q1", "dot(q1)")]
    np.testing.assert_allclose(result.y[index, -1], reference.state(3.0), rtol=1e-8)


@pytest.mark.parametrize("method", METHODS)
def test_the_belt_stick_slip_file_switches_as_the_reference(method: str) -> None:
    """The spec's belt example (a driven belt body, the block's friction on its joint on it):
    100 periods' switches as the reference's closed-form cycle at rtol 1e-11, to 1e-8 (the one
    the file's span ends on, to rounding, left out)."""
    model = nemc.compile(DATA / "stick_slip.yaml")
    end = float(model.scene["t_span"][1])
    result = model.simulate(t_eval=[0.0, end], method=method, rtol=1e-11)
    assert result.success
    expected = [t for t, _ in stick_slip_switches(StickSlip(), end) if t < end - 1e-6]
    times = result.events["slide.stick_slip"][0]
    times = times[times < end - 1e-6]
    assert len(times) == len(expected)
    np.testing.assert_allclose(times, expected, rtol=0, atol=1e-8)


@pytest.mark.parametrize("method", METHODS)
def test_the_incline_file_slips_and_slides_as_the_reference(method: str) -> None:
    model = nemc.compile(DATA / "block_incline.yaml")
    result = model.simulate(t_eval=[0.0, 4.0], method=method)
    assert result.success
    reference = incline_run(Incline(), 4.0)
    times, _ = result.events["slide.stick_slip"]
    np.testing.assert_allclose(times, [t for t, _ in reference.switches], rtol=0, atol=1e-9)
    index = [model.state_names.index(name) for name in ("s", "dot(s)")]
    np.testing.assert_allclose(result.y[index, -1], reference.state(4.0), rtol=1e-9)
