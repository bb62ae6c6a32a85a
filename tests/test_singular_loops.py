"""Closed loops through their singular configurations (issue 49, decision 0036): the IFToMM
benchmark A02, the double four-bar of examples/double_fourbar.yaml, which lies flat (its
constraints losing rank) twice a turn.

- Its crank angle and crank tip at t = 10 against an independent solution: the 1-DOF
  minimal-coordinate ODE of the parallelogram (tests/loop_reference.double_fourbar_crank), to
  1e-6; its energy conserved; the couplers level and the cranks parallel (the physical branch)
  through every flat position.
- Every method that runs closed loops, nemc's and scipy's, passes the flat positions on that
  branch; nemc.Taylor is refused by name.
- A loss of rank that lasts (the linkage at rest at its flat position) stops the run with
  success=False, naming the constraint and the time.
"""

from __future__ import annotations

import functools
import math
import re
from pathlib import Path

import numpy as np
import pytest
from loop_reference import double_fourbar_crank

import nemc

ROOT = Path(__file__).resolve().parent.parent
DOUBLE_FOURBAR = ROOT / "examples" / "double_fourbar.yaml"
SPAN = (0.0, 10.0)
TIMES = np.linspace(*SPAN, 401)
G, L = 9.81, 1.0


@functools.cache
def model() -> nemc.runtime.model.Model:
    return nemc.compile(DOUBLE_FOURBAR)


def flat_positions_passed(q1: np.ndarray) -> int:
    """How many times the cranks' angle crosses a multiple of pi (the linkage lying flat)."""
    return int(np.count_nonzero(np.diff(np.floor(q1 / math.pi))))


def assert_on_the_parallelogram_branch(y: np.ndarray, tolerance: float) -> None:
    """The couplers level (q2, q4 = 0) and the three cranks parallel (q3 = q5 = q1)."""
    q1, q2, q3, q4, q5 = y[0::2]
    assert np.max(np.abs(q2)) < tolerance and np.max(np.abs(q4)) < tolerance
    assert np.max(np.abs(q3 - q1)) < tolerance and np.max(np.abs(q5 - q1)) < tolerance


def test_minimal_coordinate_reference_is_converged() -> None:
    """The reference's own error: two tolerances agree far below the test's 1e-6."""
    tight, looser = double_fourbar_crank(10.0, rtol=1e-13), double_fourbar_crank(10.0, rtol=1e-11)
    assert abs(tight[0] - looser[0]) < 1e-8


def test_a02_crank_at_t10_matches_the_minimal_coordinate_ode() -> None:
    """nemc.DOP853 at rtol 1e-10 over [0, 10]: 10 flat positions passed on the parallelogram
    branch; the crank angle and the crank tip B0 at t = 10 equal the 1-DOF ODE's to 1e-6 (the
    integrator's tolerance makes them 1e-8); energy conserved to 1e-8 of its size."""
    res = model().simulate(SPAN, method="nemc.DOP853", rtol=1e-10, atol=1e-12, t_eval=TIMES)
    assert res.success, res.message
    theta, _ = double_fourbar_crank(10.0)
    assert res.y[0, -1] == pytest.approx(theta, abs=1e-6)
    assert res.outputs["crank1.B0.x"][-1] == pytest.approx(L * math.cos(theta), abs=1e-6)
    assert res.outputs["crank1.B0.y"][-1] == pytest.approx(L * math.sin(theta), abs=1e-6)
    assert flat_positions_passed(res.y[0]) == 10
    assert_on_the_parallelogram_branch(res.y, 1e-9)
    energy = res.outputs["energy.total"]
    assert np.ptp(energy) < 1e-8 * np.max(np.abs(energy))
    # the energy is the minimal ODE's: 3/2 dtheta^2 + 7/2 g L sin(theta) at the start
    assert energy[0] == pytest.approx(1.5 + 3.5 * G * L, rel=1e-12)


@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Vern9", "nemc.Radau", "auto", "DOP853",
                                    "RK45", "RK23", "Radau", "BDF", "LSODA"])
def test_every_closed_loop_method_passes_the_flat_positions(method: str) -> None:
    """At rtol 1e-8 each method reaches t = 10 through every flat position on the
    parallelogram branch, the crank angle within its tolerance's error of the ODE's."""
    res = model().simulate(SPAN, method=method, rtol=1e-8, atol=1e-10, t_eval=TIMES)
    assert res.success, res.message
    assert flat_positions_passed(res.y[0]) == 10
    assert_on_the_parallelogram_branch(res.y, 1e-9)
    theta, _ = double_fourbar_crank(10.0)
    assert res.y[0, -1] == pytest.approx(theta, abs=1e-4)


def test_taylor_is_refused_by_name_on_the_double_fourbar() -> None:
    with pytest.raises(Exception, match=r"(?i)taylor"):
        model().simulate(SPAN, method="nemc.Taylor", rtol=1e-8, atol=1e-10)


def test_a_linkage_at_rest_at_its_flat_position_stops_naming_the_constraint(
        tmp_path: Path) -> None:
    """At rest 1e-4 rad from flat its motion does not carry it out of the singular
    configuration (the loss of rank lasts; which branch it would leave on is not determined):
    the run stops at once, naming a loop constraint, the time and the cause."""
    text = DOUBLE_FOURBAR.read_text()
    for old, new in (("name: double_fourbar", "name: locked"),
                     ("initial: {q1: pi/2, dot(q1): -1}", "initial: {q1: 1.0e-4, dot(q1): 0}"),
                     ("guess: {q2: 0, q3: pi/2, q4: 0, q5: pi/2}",
                      "guess: {q2: 0, q3: 0, q4: 0, q5: 0}")):
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "locked.yaml"
    path.write_text(text)
    locked = nemc.compile(path)
    for method in ("nemc.DOP853", "RK45"):
        res = locked.simulate((0.0, 1.0), method=method)
        assert not res.success
        assert re.search(r"constraint '(C1|C2)'", res.message), res.message
        assert re.search(r"at t=0\b", res.message), res.message
        assert re.search(r"singular|locked", res.message), res.message


def test_the_plain_right_hand_side_is_unchanged_away_from_the_flat_position() -> None:
    """Past two windows of the flat position the right-hand side is the plain index-1 one:
    at states on the parallelogram branch it is the minimal ODE's acceleration to rounding."""
    energy = 1.5 + 3.5 * G * L
    for theta in (0.3, 1.0, 2.0, -1.2, -2.8):
        rate = -math.sqrt((energy - 3.5 * G * L * math.sin(theta)) / 1.5)
        y = np.array([theta, rate, 0, 0, theta, rate, 0, 0, theta, rate])
        dy = model().rhs(0.0, y)
        accel = -7.0 / 6.0 * G / L * math.cos(theta)
        np.testing.assert_allclose(dy[1::2], [accel, 0, accel, 0, accel], atol=1e-12)


@pytest.mark.parametrize("distance", [3e-2, 1e-2, 1e-3, 1e-5, 1e-8])
def test_near_the_flat_position_the_right_hand_side_is_the_physical_branchs(
        distance: float) -> None:
    """Within the window the extrapolated right-hand side is the minimal ODE's acceleration
    (the couplers' 0) to 1e-9, on either side of both flat positions."""
    energy = 1.5 + 3.5 * G * L
    for flat in (0.0, -math.pi):
        for theta in (flat + distance, flat - distance):
            rate = -math.sqrt((energy - 3.5 * G * L * math.sin(theta)) / 1.5)
            y = np.array([theta, rate, 0, 0, theta, rate, 0, 0, theta, rate])
            dy = model().rhs(0.0, y)
            accel = -7.0 / 6.0 * G / L * math.cos(theta)
            np.testing.assert_allclose(dy[1::2], [accel, 0, accel, 0, accel], atol=1e-9)
            np.testing.assert_allclose(dy[0::2], y[1::2], atol=1e-9)


def test_a_state_returned_near_the_flat_position_is_on_the_physical_branch() -> None:
    """A state near the flat position, off the constraints by an integrator's error, is
    returned on the parallelogram branch: positions and rates (simulate's returned states are
    brought onto the constraints the same way)."""
    energy = 1.5 + 3.5 * G * L
    rng = np.random.default_rng(49)
    for theta in (1e-3, -1e-6, -math.pi + 2e-4):
        rate = -math.sqrt((energy - 3.5 * G * L * math.sin(theta)) / 1.5)
        exact = np.array([theta, rate, 0, 0, theta, rate, 0, 0, theta, rate])
        y = exact + rng.uniform(-1e-12, 1e-12, exact.size)
        projected = model().loops.projected(np.array([0.0]), y.reshape(-1, 1),
                                            model().parameter_vector())
        np.testing.assert_allclose(projected[:, 0], exact, atol=1e-9)
