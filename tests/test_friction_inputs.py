"""Coulomb friction with inputs that vary along the run (a table of samples, a Python
function): a block on the ground pushed by F(t) sticks, breaks free, stops and sticks again,
and breaks free the other way, at the instants the closed form gives. The reference below is
an event-driven solution written apart from nemc: on each linear piece of F the slide's
velocity is a quadratic of t and its breaking instant a linear root, each found exactly
(numpy's polynomial roots); for F = A sin(w t) the same laws in closed form with brentq."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial import Polynomial
from scipy.optimize import brentq

import nemc

M, G, MU, MU_S = 1.0, 9.81, 0.3, 0.5
TIMES = np.array([0.0, 2.0, 4.0, 4.5, 10.0, 11.0, 14.0])
PUSH = np.array([0.0, 8.0, 8.0, 0.0, 0.0, -6.0, -6.0])  # breaks free, stops, the other way
METHODS = ["nemc.Vern9", "nemc.DOP853", "RK45", "DOP853"]

PUSHED = """
name: pushed_block
parameters: {m: 1.0, g: 9.81, mu: 0.3, mu_s: 0.5}
inputs: {F: 0}
gravity: [0, -g]
bodies:
  block: {mass: m, inertia: 0.1}
joints:
  slide: {type: prismatic, parent: ground, child: block, coordinate: x, axis: [1, 0]}
loads:
  - {force: [F, 0], body: block, at: [0, 0]}
friction:
  - {joint: slide, mu: mu, mu_static: mu_s}
simulation:
  t_span: [0, 14]
"""


@pytest.fixture(scope="module")
def block(tmp_path_factory: pytest.TempPathFactory):
    path = Path(tmp_path_factory.mktemp("pushed")) / "pushed_block.yaml"
    path.write_text(PUSHED)
    return nemc.compile(path)


def first_root(poly: Polynomial, a: float, b: float) -> float | None:
    """POLY's first real root in (a, b] (its variable: the time from a), or None."""
    roots = [r.real for r in poly.trim().roots() if abs(r.imag) < 1e-12 and 1e-12 < r.real <= b - a]
    return a + min(roots) if roots else None


def table_reference(mu: float = MU) -> tuple[list[float], float, float]:
    """The switch instants and (x, v) at the table's end: stuck until |F| reaches mu_s m g,
    slipping against v (F - s mu m g = m a) until v = 0, then stuck if |F| <= mu_s m g."""
    x, v, s, switches = 0.0, 0.0, 0, []  # s: the slip's direction, 0 stuck
    hold, slide = MU_S * M * G, mu * M * G
    for i in range(len(TIMES) - 1):
        a, b = TIMES[i], TIMES[i + 1]
        k = (PUSH[i + 1] - PUSH[i]) / (b - a)
        force = Polynomial([PUSH[i], k])  # of the time from a
        while a < b:
            if s == 0:
                ends = [first_root(force - side * hold, a, b) for side in (1, -1)]
                ends = [e for e in ends if e is not None]
                if not ends:
                    break
                t = min(ends)
                force = Polynomial([force(t - a), k])
                s, a = int(np.sign(force(0))), t
                switches.append(t)
                continue
            acceleration = (force - s * slide) / M
            speed = v + acceleration.integ()
            position = x + speed.integ()
            t = first_root(speed, a, b)
            if t is None:
                x, v = position(b - a), speed(b - a)
                break
            x, v = position(t - a), 0.0
            force = Polynomial([force(t - a), k])
            s = 0 if abs(force(0)) <= hold else int(np.sign(force(0)))
            switches.append(t)
            a = t
    return switches, x, v


def test_the_reference_switches_where_hand_arithmetic_says() -> None:
    """The reference's first instants by hand: F = 4 t reaches mu_s m g at 1.22625 s; the
    slide stops 9.0389 s (its speed's integral over the pieces); -6 (t - 10) reaches it at
    10.8175 s."""
    switches, _, _ = table_reference()
    assert switches[0] == pytest.approx(MU_S * M * G / 4.0, abs=1e-14)
    assert switches[2] == pytest.approx(10.0 + MU_S * M * G / 6.0, abs=1e-14)
    v_45 = (2 * (4 - switches[0] ** 2) - MU * M * G * (2 - switches[0])
            + 2 * (8 - MU * M * G) + (8 * 0.5 - 8 * 0.25 - MU * M * G * 0.5)) / M
    assert switches[1] == pytest.approx(4.5 + v_45 / (MU * G), abs=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_a_block_pushed_by_a_table_sticks_and_slips_where_the_closed_form_says(
        block, method: str) -> None:
    switches, x, v = table_reference()
    tight = {"rtol": 1e-12, "atol": 1e-12} if method.startswith("nemc") else \
        {"rtol": 1e-10, "atol": 1e-12}
    result = block.simulate(method=method, inputs={"F": (TIMES, PUSH)},
                            t_eval=np.linspace(0, 14, 281), **tight)
    assert result.success, result.message
    times, _ = result.events["slide.stick_slip"]
    np.testing.assert_allclose(times, switches, rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.y[:, -1], [x, v], rtol=1e-9)
    stuck = result.outputs["slide.stuck"]
    inside = [(t0 + 1e-6 < result.t) & (result.t < t1 - 1e-6)
              for t0, t1 in zip([0.0, *switches], [*switches, 14.0])]
    assert [set(stuck[span]) for span in inside] == [{1.0}, {0.0}, {1.0}, {0.0}]
    held = stuck == 1.0
    assert np.all(result.y[1, held] == 0.0)  # held exactly
    push = np.interp(result.t, TIMES, PUSH)
    np.testing.assert_allclose(result.outputs["slide.friction"][held], -push[held], atol=1e-9)
    slipping = result.y[1] != 0.0
    np.testing.assert_allclose(result.outputs["slide.friction"][slipping],
                               -MU * M * G * np.sign(result.y[1, slipping]), rtol=1e-12)


def test_an_ensemble_with_a_table_sticks_each_run_where_its_closed_form_says(block) -> None:
    """Each run its own kinetic coefficient, the same table: each run's final state as its
    reference (the C keeps each run's modes in its own copy of the parameters)."""
    mus = np.array([0.2, 0.3, 0.45])
    runs = block.simulate_many(np.zeros((3, 2)), params={"mu": mus},
                               inputs={"F": (TIMES, PUSH)}, t_eval=[0.0, 14.0],
                               rtol=1e-12, atol=1e-12)
    assert np.all(runs.status == 0)
    for k, mu in enumerate(mus):
        _, x, v = table_reference(mu)
        np.testing.assert_allclose(runs.y[k, :, -1], [x, v], rtol=1e-9)


def sine_reference(amplitude: float, w: float, t_end: float) -> tuple[list[float], float]:
    """F = A sin(w t) from rest: the switch instants up to t_end and the speed there, each law
    in closed form (v from the integral of F - s mu m g), each root bracketed on a 1 ms grid
    and refined by brentq."""
    hold, slide = MU_S * M * G, MU * M * G

    def law(u: float, t0: float, s: int) -> float:
        """Stuck (s = 0): the push's margin over static friction; slipping: the speed."""
        if s == 0:
            return abs(amplitude * math.sin(w * u)) - hold
        return (amplitude * (math.cos(w * t0) - math.cos(w * u)) / w - s * slide * (u - t0)) / M

    t, s, switches, grid = 0.0, 0, [], 1e-3
    while True:
        u, side = t + grid, np.sign(law(t + 1e-9, t, s))
        while u < t_end and np.sign(law(u, t, s)) == side:
            u += grid
        if u >= t_end:
            return switches, law(t_end, t, s) if s else 0.0
        root = brentq(law, u - grid, u, args=(t, s), xtol=1e-15, rtol=1e-15)
        force = amplitude * math.sin(w * root)
        s = int(np.sign(force)) if s == 0 or abs(force) > hold else 0
        switches.append(root)
        t = root


@pytest.mark.parametrize("method", ["RK45", "DOP853"])
def test_a_block_pushed_by_a_python_function_with_scipys_methods(block, method: str) -> None:
    amplitude, w = 7.0, 1.3
    switches, v = sine_reference(amplitude, w, 12.0)
    assert len(switches) >= 4  # breaks free, stops, breaks free the other way, stops
    result = block.simulate(method=method, t_span=(0, 12),
                            inputs={"F": lambda t, y: amplitude * math.sin(w * t)},
                            rtol=1e-10, atol=1e-12)
    assert result.success, result.message
    times, _ = result.events["slide.stick_slip"]
    np.testing.assert_allclose(times, switches, rtol=0, atol=1e-8)
    assert result.y[1, -1] == pytest.approx(v, abs=1e-8)
