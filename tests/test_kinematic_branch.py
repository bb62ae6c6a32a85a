"""A kinematic analysis (0 DOF: the crank driven) through singular configurations (issue 51,
decision 0036's section on kinematic analyses): a driven parallelogram four-bar lies flat twice
a turn, where its branch crosses the crossed (anti-parallelogram) one.

- The parallelogram stays on its branch over several revolutions, against the closed form: the
  coupler level (its absolute angle 0, at rest), the rocker parallel to the crank (q3 = q1), and
  the drive torque from virtual work (the kinetic energy is constant at constant crank speed, so
  the torque is dV/dq1 = g cos(q1) (m1 L1/2 + m2 L1 + m3 L1/2)), to 1e-9; with requested times
  exactly at the flat positions, and with steps that cross them in one.
- The anti-parallelogram stays on the crossed branch: its joint C the mirror image, in the line
  BD, of the parallelogram's, to 1e-9.
- A crank driven towards the flat position and held there (the loss of rank lasts) stops the
  analysis, naming the constraint.
- The examples away from singular configurations (fourbar_driven, slider_crank_driven) give the
  states of the previous procedure (each time assembled from the one before) bit for bit, and
  that procedure is the one that jumped to the crossed branch here.
"""

from __future__ import annotations

import functools
import math
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.runtime.model import Model
from nemc.runtime.results import SimulationResult

ROOT = Path(__file__).resolve().parent.parent
L0, L1, M1, M2, M3, G, W = 0.4, 0.1, 0.5, 1.5, 1.2, 9.81, 2 * math.pi
START = math.pi / 4  # the crank's angle at t = 0; flat (q1 = k pi) at t = 3/8 + k/2
PARALLELOGRAM = f"""\
name: parallelogram_driven
parameters: {{L0: {L0}, L1: {L1}, m1: {M1}, m2: {M2}, m3: {M3}, g: {G}, w: 2*pi}}
gravity: [0, -g]
bodies:
  crank: {{mass: m1, inertia: m1*L1**2/12, com: [L1/2, 0], points: {{B: [L1, 0]}}}}
  coupler: {{mass: m2, inertia: m2*L0**2/12, com: [L0/2, 0], points: {{C: [L0, 0]}}}}
  rocker: {{mass: m3, inertia: m3*L1**2/12, com: [L1/2, 0], points: {{C: [L1, 0]}}}}
joints:
  A: {{type: revolute, parent: ground, child: crank, at: [0, 0], coordinate: q1,
      motion: MOTION}}
  B: {{type: revolute, parent: crank, child: coupler, at: B, coordinate: q2, angle: absolute}}
  D: {{type: revolute, parent: ground, child: rocker, at: [L0, 0], coordinate: q3}}
constraints:
  C: {{type: revolute, a: rocker.C, b: coupler.C}}
outputs: {{drives: [A], energy: true}}
simulation:
  t_span: [0, 4]
  guess: GUESS
"""
CROSSED_GUESS = "{q2: -0.42, q3: -1.2}"  # the crossed assembly at q1 = pi/4


@functools.cache
def folder() -> Path:
    return Path(tempfile.mkdtemp(prefix="nemc-parallelogram-"))


@functools.cache
def model(motion: str = "pi/4 + w*t", guess: str = "{q2: 0.01, q3: 0.8}") -> Model:
    """The parallelogram with the crank's MOTION, assembled from GUESS."""
    path = folder() / f"parallelogram_{len(list(folder().iterdir()))}.yaml"
    path.write_text(PARALLELOGRAM.replace("MOTION", motion).replace("GUESS", guess))
    return nemc.compile(path)


def crank(t: np.ndarray) -> np.ndarray:
    return START + W * t


def drive_torque(t: np.ndarray) -> np.ndarray:
    """Virtual work: tau = dV/dq1, the kinetic energy constant along the parallelogram."""
    return G * np.cos(crank(t)) * (M1 * L1 / 2 + M2 * L1 + M3 * L1 / 2)


def flat_times(span: float) -> np.ndarray:
    return np.arange(3 / 8, span, 1 / 2)


def passed(message: str) -> int:
    found = re.search(r"passed (\d+) singular configuration", message)
    return int(found.group(1)) if found else 0


def assert_parallelogram(result: SimulationResult, tolerance: float = 1e-9) -> None:
    q2, dq2, q3, dq3 = result.y
    q1 = crank(result.t)
    assert np.max(np.abs(q2)) < tolerance and np.max(np.abs(dq2)) < tolerance
    assert np.max(np.abs(q3 - q1)) < tolerance and np.max(np.abs(dq3 - W)) < tolerance
    assert np.max(np.abs(result.outputs["A.drive"] - drive_torque(result.t))) < tolerance


def test_a_driven_parallelogram_keeps_its_branch_over_four_revolutions() -> None:
    """Every 5 ms over 4 turns, the 8 flat positions among the times: the closed form to 1e-9
    at every time (the ones near a flat position interpolated), the passages in the message."""
    times = np.union1d(np.linspace(0.0, 4.0, 801), flat_times(4.0))
    result = model().simulate(t_span=(0.0, 4.0), t_eval=times)
    assert result.success, result.message
    assert_parallelogram(result)
    assert passed(result.message) == len(flat_times(4.0))


@pytest.mark.parametrize("times", [np.linspace(0.0, 10.0, 7), np.linspace(0.0, 4.0, 201)])
def test_steps_across_the_flat_positions_stay_on_the_parallelogram(times: np.ndarray) -> None:
    """Requested times 1.67 s (10.5 rad) and 20 ms apart: the steps between them refined where
    the assembly would leave the branch; the closed form to 1e-9 (here 20 turns)."""
    result = model().simulate(t_span=(times[0], times[-1]), t_eval=times)
    assert result.success, result.message
    assert_parallelogram(result)


def test_the_crossed_branch_is_followed_through_its_flat_positions() -> None:
    """Started crossed, it stays crossed: C is the mirror image of the parallelogram's C in the
    line BD at every time (q2, q3 from it), to 1e-9, over 3 turns; its drive power is the rate
    of its total energy (central differences, 1e-3 of the power's size)."""
    times = np.linspace(0.0, 3.0, 1201)
    result = model(guess=CROSSED_GUESS).simulate(t_span=(0.0, 3.0), t_eval=times)
    assert result.success, result.message
    q1 = crank(times)
    b = L1 * np.stack([np.cos(q1), np.sin(q1)])
    d = np.array([[L0], [0.0]])
    c = b + np.array([[L0], [0.0]])
    u = (d - b) / np.linalg.norm(d - b, axis=0)
    mirrored = 2 * (b + np.sum((c - b) * u, axis=0) * u) - c
    q2 = np.arctan2(mirrored[1] - b[1], mirrored[0] - b[0])
    q3 = np.arctan2(mirrored[1] - d[1], mirrored[0] - d[0])
    wrap = np.vectorize(lambda a: math.remainder(a, 2 * math.pi))
    assert np.max(np.abs(wrap(result.y[0] - q2))) < 1e-9
    assert np.max(np.abs(wrap(result.y[2] - q3))) < 1e-9
    assert np.max(np.abs(result.y[0])) > 0.5  # not the parallelogram's level coupler
    power = result.outputs["A.drive"] * W
    rate = np.gradient(result.outputs["energy.total"], times)
    assert np.max(np.abs(power - rate)[1:-1]) < 1e-3 * np.max(np.abs(power))


def test_a_crank_held_at_the_flat_position_stops_the_analysis() -> None:
    """q1 = pi - exp(-3 t)/2 reaches the flat position only as t grows: the loss of rank lasts,
    the analysis stops where it enters the configuration, naming constraint C, its states
    before on the parallelogram."""
    result = model(motion="pi - exp(-3*t)/2", guess="{q2: 0.01, q3: 2.6}").simulate(
        t_span=(0.0, 5.0))
    assert not result.success and result.status == -1
    assert "constraint 'C'" in result.message and "lasts" in result.message
    assert 0.3 < result.t[-1] < 1.0
    q1 = math.pi - np.exp(-3 * result.t) / 2
    assert np.max(np.abs(result.y[0])) < 1e-9 and np.max(np.abs(result.y[2] - q1)) < 1e-9


def assembled_from_the_previous(model: Model, result: SimulationResult
                                ) -> np.ndarray:
    """The previous procedure: each time's state assembled from the one before."""
    loops, p = model.loops, model.parameter_vector()
    nothing = np.zeros(len(model.state_names), dtype=bool)
    state = loops.assembled(result.t[0], model.state_vector(None), nothing, p)[0]
    states = []
    for t in result.t:
        state = loops.assembled(float(t), state, nothing, p, check_start=False)[0]
        states.append(state)
    return np.array(states).T


@pytest.mark.parametrize("name", ["fourbar_driven", "slider_crank_driven"])
def test_examples_away_from_singular_configurations_are_unchanged_bit_for_bit(name: str
                                                                             ) -> None:
    """Over 5 s (5 turns, every 5 ms): the states of the previous procedure, bit for bit."""
    built = nemc.compile(ROOT / "examples" / f"{name}.yaml")
    result = built.simulate(t_span=(0.0, 5.0), t_eval=np.linspace(0.0, 5.0, 1001))
    assert result.success and passed(result.message) == 0
    assert np.array_equal(result.y, assembled_from_the_previous(built, result))


def test_the_previous_procedure_left_the_parallelogram() -> None:
    """What issue 51 found: assembled from the previous state, the parallelogram switches to the
    crossed branch after its first flat position (the coupler no longer level)."""
    built = model()
    result = built.simulate(t_span=(0.0, 1.0), t_eval=np.linspace(0.0, 1.0, 101))
    previous = assembled_from_the_previous(built, result)
    assert np.max(np.abs(previous[0])) > 0.1


def test_a_crank_driven_past_a_dead_point_stops_there() -> None:
    """fourbar_driven with a crank of 0.3 (not a Grashof crank, it cannot turn round): the
    analysis stops at the dead point the crank reaches before t = 0.13, saying so; the states
    before it close the loop."""
    text = (ROOT / "examples" / "fourbar_driven.yaml").read_text().replace("L1: 0.1\n",
                                                                           "L1: 0.3\n")
    path = folder() / "fourbar_dead_point.yaml"
    path.write_text(text)
    built = nemc.compile(path)
    result = built.simulate()
    assert not result.success and result.status == -1
    assert "dead point" in result.message and result.t[-1] < 0.13
    assert np.max(built.constraint_residual(result.y, result.t)) < 1e-9
