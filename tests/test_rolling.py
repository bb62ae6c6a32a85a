"""Format v3 rolling and knife edges, each against something it does not compute itself: the
closed form of a disc rolling down an incline (its motion, the normal force and the friction the
rolling needs), a disc rolling inside a ring against its one-coordinate reduction (written here
from the geometry, integrated by scipy at tight tolerance), the Chaplygin sleigh against its
reduced equations (Neimark and Fufaev's v' = a w^2, w' = -m a v w / (I + m a^2)) with its
energy kept; the counts `nemc check` prints; and one clear error per misuse."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from loop_reference import LoopReference
from scipy.integrate import solve_ivp

import nemc
from nemc.errors import InputError
from nemc.front.validate import load_mechanism, validate_text
from nemc.runtime.model import ModelError
from nemc.tools.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

INCLINE = """\
name: incline
parameters: {m: 2.0, R: 0.3, I: 0.09, g: 9.81, alpha: 0.5}
gravity: [0, -g]
bodies:
  disc: {mass: m, inertia: I}
joints:
  flight: {type: free, parent: ground, child: disc, coordinates: [x, y, th]}
constraints:
  roll: {type: rolling, disc: disc, radius: R, on: {body: ground, at: [0, 0]},
         axis: [cos(alpha), -sin(alpha)]}
outputs:
  reactions: [roll]
  energy: true
simulation:
  t_span: [0, 1.5]
  initial: {x: 0.3*sin(alpha), y: 0.3*cos(alpha), th: 0.2}
"""

RING = (EXAMPLES / "wheel_in_ring.yaml").read_text()

SLEIGH = (EXAMPLES / "chaplygin_sleigh.yaml").read_text()


def compiled(text: str, folder: Path, name: str) -> nemc.runtime.Model:
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return nemc.compile(path)


def test_a_disc_rolls_down_an_incline_as_its_closed_form_says(tmp_path: Path) -> None:
    """s'' = g sin(alpha) / (1 + I / (m R^2)) along the slope, th = th0 - s / R, the normal force
    m g cos(alpha), the friction m s'' - m g sin(alpha)."""
    model = compiled(INCLINE, tmp_path, "incline")
    m, radius, inertia, g, alpha = 2.0, 0.3, 0.09, 9.81, 0.5
    times = np.linspace(0, 1.5, 7)
    result = model.simulate(method="nemc.DOP853", rtol=1e-11, atol=1e-12, t_eval=times)
    assert result.success, result.message
    accel = g * math.sin(alpha) / (1 + inertia / (m * radius**2))
    s = 0.5 * accel * times**2
    x, y, th = (result.y[k] for k in (0, 2, 4))
    np.testing.assert_allclose(x, radius * math.sin(alpha) + s * math.cos(alpha), atol=1e-10)
    np.testing.assert_allclose(y, radius * math.cos(alpha) - s * math.sin(alpha), atol=1e-10)
    np.testing.assert_allclose(th, 0.2 - s / radius, atol=1e-9)
    np.testing.assert_allclose(result.outputs["roll.Fn"], m * g * math.cos(alpha), rtol=1e-9)
    np.testing.assert_allclose(result.outputs["roll.Ft"], m * accel - m * g * math.sin(alpha),
                               rtol=1e-9)
    energy = result.outputs["energy.total"]
    assert np.ptp(energy) < 1e-9 * np.abs(energy).max()


def ring_reduction(beta0: float, rate0: float, times: np.ndarray) -> np.ndarray:
    """The disc's center angle beta (from straight down) in a ring, from its Lagrangian:
    (m + I / R^2) (Rb - R)^2 beta'' = -m g (Rb - R) sin(beta), rolling making the disc turn at
    -(Rb - R) / R beta'."""
    m, radius, inertia, ring, g = 1.5, 0.1, 0.004, 0.5, 9.81
    arm = ring - radius

    def rhs(t: float, z: np.ndarray) -> list[float]:
        return [z[1], -m * g * arm * math.sin(z[0]) / ((m + inertia / radius**2) * arm**2)]

    return solve_ivp(rhs, (0, times[-1]), [beta0, rate0], t_eval=times, rtol=1e-12,
                     atol=1e-13, method="DOP853").y


def test_a_disc_rolls_inside_a_ring_as_its_reduction_says(tmp_path: Path) -> None:
    model = compiled(RING, tmp_path, "ring")
    times = np.linspace(0, 3, 13)
    result = model.simulate(method="nemc.DOP853", rtol=1e-11, atol=1e-12, t_eval=times)
    assert result.success, result.message
    x, y, th = (result.y[k] for k in (0, 2, 4))
    beta = np.arctan2(x, -y)
    np.testing.assert_allclose(np.hypot(x, y), 0.4, atol=1e-10)
    expected = ring_reduction(1.0, 0.0, times)
    np.testing.assert_allclose(beta, expected[0], atol=1e-8)
    # the rolling: the disc turns -(Rb - R) / R times the center's angle, from where it started
    np.testing.assert_allclose(th - 0.3, -(0.4 / 0.1) * (beta - 1.0), atol=1e-7)
    # the normal force holds the disc on its circle: m (v^2 / arm + g cos(beta)) at rest start
    m, g, arm = 1.5, 9.81, 0.4
    speed = arm * expected[1]
    fn = m * (speed**2 / arm + g * np.cos(expected[0]))
    np.testing.assert_allclose(result.outputs["roll.Fn"], fn, rtol=1e-7)
    energy = result.outputs["energy.total"]
    assert np.ptp(energy) < 1e-8 * np.abs(energy).max()


def sleigh_reduction(v0: float, w0: float, times: np.ndarray) -> np.ndarray:
    m, inertia, a = 2.0, 0.05, 0.2

    def rhs(t: float, z: np.ndarray) -> list[float]:
        v, w = z
        return [a * w * w, -m * a * v * w / (inertia + m * a * a)]

    return solve_ivp(rhs, (0, times[-1]), [v0, w0], t_eval=times, rtol=1e-12, atol=1e-13,
                     method="DOP853").y


def test_the_chaplygin_sleigh_against_its_reduced_equations(tmp_path: Path) -> None:
    """The blade's forward speed v and the turning rate w obey the reduced equations; the blade
    never moves sideways; energy is kept; the knife edge's force does the turning."""
    model = compiled(SLEIGH, tmp_path, "sleigh")
    times = np.linspace(0, 6, 25)
    result = model.simulate(method="nemc.DOP853", rtol=1e-11, atol=1e-12, t_eval=times)
    assert result.success, result.message
    th, dx, dy, w = result.y[4], result.y[1], result.y[3], result.y[5]
    forward = np.cos(th) * dx + np.sin(th) * dy
    sideways = -np.sin(th) * dx + np.cos(th) * dy
    v, omega = sleigh_reduction(1.0, 1.5, times)
    np.testing.assert_allclose(forward, v, atol=1e-8)
    np.testing.assert_allclose(w, omega, atol=1e-8)
    assert np.abs(sideways).max() < 1e-10
    energy = result.outputs["energy.total"]
    assert np.ptp(energy) < 1e-9 * np.abs(energy).max()
    # the mass center's sideways acceleration, a w' + v w, is the blade's force / m
    m, a = 2.0, 0.2
    dw = -m * a * v * omega / (0.05 + m * a * a)
    np.testing.assert_allclose(result.outputs["skate.Fn"], m * (a * dw + v * omega), atol=1e-7)


def sleigh_closed_form(v0: float, w0: float, times: np.ndarray) -> tuple[np.ndarray, ...]:
    """The reduced equations solved in closed form: energy 2E = m v^2 + J w^2 (J = I + m a^2)
    gives v' = (m a / J)(V^2 - v^2), V^2 = 2E / m, so v = V tanh(m a V t / J + atanh(v0 / V))
    and w = sign(w0) sqrt(m / J) sqrt(V^2 - v^2): the turning dies out, the sleigh glides
    along its blade at speed V."""
    m, inertia, a = 2.0, 0.05, 0.2
    big_j = inertia + m * a * a
    speed = math.sqrt(v0 * v0 + big_j * w0 * w0 / m)
    phase = m * a * speed * times / big_j + math.atanh(v0 / speed)
    v = speed * np.tanh(phase)
    w = math.copysign(1.0, w0) * math.sqrt(m / big_j) * speed / np.cosh(phase)
    return v, w, speed


def test_the_chaplygin_sleigh_glides_as_its_closed_form_says(tmp_path: Path) -> None:
    """The blade's forward speed and the turning rate to 1e-9 against the closed form (and
    against scipy's tight-tolerance solution of the reduced equations): the velocity turns to
    the blade's direction; energy kept."""
    model = compiled(SLEIGH, tmp_path, "sleigh")
    times = np.linspace(0, 6, 25)
    result = model.simulate(method="nemc.Vern9", rtol=1e-13, atol=1e-14, t_eval=times)
    assert result.success, result.message
    th, dx, dy, w = result.y[4], result.y[1], result.y[3], result.y[5]
    forward = np.cos(th) * dx + np.sin(th) * dy
    v, omega, speed = sleigh_closed_form(1.0, 1.5, times)
    np.testing.assert_allclose(forward, v, atol=1e-9)
    np.testing.assert_allclose(w, omega, atol=1e-9)
    reduced = sleigh_reduction(1.0, 1.5, times)
    np.testing.assert_allclose(reduced[0], v, atol=1e-9)
    np.testing.assert_allclose(reduced[1], omega, atol=1e-9)
    # the mass center's velocity (the blade's plus w x a) turns to the blade's direction
    a = 0.2
    drift = np.arctan2(dy + a * w * np.cos(th), dx - a * w * np.sin(th)) - th
    np.testing.assert_allclose(drift, np.arctan2(a * omega, v), atol=1e-9)
    assert abs(drift[0]) > 0.25 and abs(drift[-1]) < 1e-3
    assert np.hypot(dx, dy)[-1] == pytest.approx(speed, rel=1e-9)


def test_check_counts_the_freedoms_of_position_and_of_motion(tmp_path: Path, capsys) -> None:
    path = tmp_path / "sleigh.yaml"
    path.write_text(SLEIGH)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "3 degrees of freedom of position, 2 of motion" in out, out


@pytest.mark.parametrize("change, where, message", [
    ("on: {body: ground, at: [0, 0]},", "", "constraints.roll.on: a rolling disc rolls on a line"),
    ("disc: disc, radius: R", "disc: ground, radius: R", "constraints.roll.disc"),
    ("axis: [cos(alpha), -sin(alpha)]", "axis: [0, 0]", "constraints.roll.axis"),
    ("on: {body: ground, at: [0, 0]}", "on: {body: disc, at: [0, 0]}",
     "constraints.roll.on: a disc cannot roll on itself"),
    ("disc: disc, radius: R", "disc: disc, radius: 0*R", "constraints.roll.radius: must be > 0"),
])
def test_a_bad_rolling_disc_is_refused_with_its_line(change: str, where: str,
                                                     message: str) -> None:
    with pytest.raises(InputError) as caught:
        validate_text(INCLINE.replace(change, where).encode(), "incline.yaml")
    assert message in str(caught.value), str(caught.value)


def test_a_knife_edge_on_the_ground_is_refused() -> None:
    with pytest.raises(InputError, match="a knife edge is a point of a moving body"):
        validate_text(SLEIGH.replace("at: sleigh.blade", "at: {body: ground, at: [0, 0]}")
                      .encode(), "sleigh.yaml")


PLANK = (EXAMPLES / "wheel_on_platform.yaml").read_text()

PLANETARY = (EXAMPLES / "planetary.yaml").read_text()


def test_a_disc_rolls_on_a_moving_plank(tmp_path: Path) -> None:
    """Nothing pushes the pair sideways but the spring on the plank: their momentum changes by
    its impulse alone; energy is kept (rolling does no work); the disc's center moves on the
    plank by what it turns (x - s + R th as at the start)."""
    model = compiled(PLANK, tmp_path, "plank")
    times = np.linspace(0, 4, 41)
    result = model.simulate(method="nemc.DOP853", rtol=1e-11, atol=1e-12, t_eval=times)
    assert result.success, result.message
    s, x, y, th = (result.y[k] for k in (0, 2, 4, 6))
    np.testing.assert_allclose(x - s + 0.2 * th, x[0] - s[0] + 0.2 * th[0], atol=1e-10)
    np.testing.assert_allclose(y, 0.2, atol=1e-12)
    energy = result.outputs["energy.total"]
    assert np.ptp(energy) < 1e-9 * np.abs(energy).max()
    for k in range(0, 41, 8):  # the momentum's rate is the spring's force, at every state
        dy = model.rhs(times[k], result.y[:, k])
        assert 3.0 * dy[1] + 1.0 * dy[3] == pytest.approx(-40.0 * s[k], abs=1e-10)
    np.testing.assert_allclose(result.outputs["roll.Fn"], 9.81, rtol=1e-9)  # m g


def test_a_planetary_gear_keeps_willis_ratio(tmp_path: Path) -> None:
    """The ring fixed: the sun turns 1 + R_ring / R_sun times the carrier; the planet's own rate
    relative to the carrier follows from the ring (Willis); the sun's torque's work is the
    kinetic energy gained. The rolling discs' distance equations are the carrier's geometry
    already (redundant): they are dropped, not a failure."""
    model = compiled(PLANETARY, tmp_path, "planetary")
    result = model.simulate(method="nemc.DOP853", rtol=1e-11, atol=1e-12,
                            t_eval=np.linspace(0, 1, 6))
    assert result.success, result.message
    qs, dqs, qc, dqc, qp, dqp = result.y
    ring = 0.1 + 2 * 0.05
    np.testing.assert_allclose(dqs, (1 + ring / 0.1) * dqc, rtol=1e-9, atol=1e-12)
    # the planet's absolute rate: its contact with the fixed ring at rest, its center moving at
    # (Rs + Rp) dqc: (Rs + Rp) dqc - Rp (dqc + dqp) = 0 (on the ring's side)
    np.testing.assert_allclose(dqc + dqp, -(0.15 / 0.05) * dqc, rtol=1e-9, atol=1e-12)
    work = 0.5 * qs
    np.testing.assert_allclose(result.outputs["energy.total"], work, rtol=1e-8, atol=1e-12)


def test_a_nonholonomic_linearization_is_refused_by_name(tmp_path: Path) -> None:
    model = compiled(SLEIGH, tmp_path, "sleigh")
    with pytest.raises(ModelError, match=r"constraints \['skate'\] are on the velocities"):
        model.linearize(model.initial_state())


@pytest.mark.parametrize("example", ["wheel_in_ring", "wheel_on_platform", "planetary",
                                     "chaplygin_sleigh"])
def test_each_kind_against_the_lagrange_multiplier_oracle(example: str, tmp_path: Path) -> None:
    """Accelerations and the rolling's and knife edge's reactions at random consistent states
    (each a run's, from a random start) against tests/loop_reference.py, which writes these
    constraints from the spec with its own Lagrangian."""
    path = EXAMPLES / f"{example}.yaml"
    model, reference = nemc.compile(path), LoopReference(load_mechanism(path))
    rng = np.random.default_rng(4949)
    for _ in range(3):
        start = model.initial_state() + rng.normal(0, 0.3, model.n_state)
        p = model.loops.started(0.0, start, model.parameter_vector())
        start = model.loops.projected(np.zeros(1), start.reshape(-1, 1), p)[:, 0]  # consistent
        result = model.simulate((0, 0.5), start, method="nemc.DOP853", t_eval=[0.5])
        t, y = 0.5, result.y[:, -1]
        np.testing.assert_allclose(model.rhs(t, y), reference.rhs(t, y), rtol=1e-10,
                                   atol=1e-10)
        ours, theirs = model.outputs(t, y), reference.outputs(t, y)
        for name in theirs:
            assert ours[name] == pytest.approx(theirs[name], rel=1e-9, abs=1e-9), name
