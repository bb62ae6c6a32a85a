"""Numerical stress: hostile scenes are either integrated correctly or stopped with a message
naming the time, the state and the likely cause; the stress measurements (Lyapunov exponent,
energy drift, stiffness, conditioning, error estimate) checked against independent values."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from nemc.pipeline import compile_mechanism
from nemc.runtime.model import IntegrationFailure, Model, ModelError
from nemc.tools import stress
from nemc.tools.cli import main

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"

# x'' = -(k/m) x - (c/m) x': eigenvalues +-2 for k = -4, m = 1, c = 0; -0.5 +- i sqrt(3.75)
# for k = 4, c = 1. No gravity: a linear system whose Lyapunov exponent is known exactly.
LINEAR = """
name: linear_cart
description: a cart on a joint spring of stiffness k and damping c
parameters: {m: 1, k: -4, c: 0}
gravity: [0, 0]
bodies:
  cart: {mass: m, inertia: m}
joints:
  rail: {type: prismatic, parent: ground, child: cart, at: [0, 0], coordinate: x}
loads:
  - joint_spring: {joint: rail, k: k, damping: c}
simulation:
  t_span: [0, 10]
  initial: {x: 1e-3}
"""

# omega' = omega^2 from omega(0) = 1: the rate is 1/(1 - t), infinite at t = 1.
RUNAWAY = """
name: runaway_arm
description: a torque growing with the square of the rate
parameters: {m: 1, L: 1}
gravity: [0, 0]
bodies:
  link: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  O: {type: revolute, parent: ground, child: link, at: [0, 0], coordinate: theta}
loads:
  - {torque: m*L**2/3*dot(theta)**2, body: link, reaction: ground}
simulation:
  t_span: [0, 2]
  initial: {dot(theta): 1}
"""

# sqrt(1 - theta) is nan once theta passes 1: the accelerations stop being finite.
ROOT_TORQUE = RUNAWAY.replace("m*L**2/3*dot(theta)**2", "sqrt(1 - theta)").replace(
    "runaway_arm", "root_torque_arm")

# Link 2 a point mass at distance c2: with m1 = I1 = I2 = 0, M(q) has rank 1 when q1 = q2.
POINT_MASS_CHAIN = """
name: point_mass_chain
description: two links, the second a point mass at distance c2 from B
parameters: {m1: 1, m2: 1, I1: 0.1, I2: 0.01, L1: 1, c2: 0.5, g: 10}
gravity: [0, -g]
bodies:
  link1: {mass: m1, inertia: I1, com: [0.5, 0], points: {B: [L1, 0]}}
  link2: {mass: m2, inertia: I2, com: [c2, 0]}
joints:
  A: {type: revolute, parent: ground, child: link1, at: [0, 0], coordinate: q1}
  B: {type: revolute, parent: link1, child: link2, at: B, coordinate: q2, angle: absolute}
simulation:
  t_span: [0, 1]
"""

# A slider on an almost massless arm, sliding through the pivot: the arm's rotational inertia
# I + m s^2 nearly vanishes at s = 0.
TELESCOPE = """
name: through_the_pivot
description: a slider passing through the pivot of a nearly massless arm
parameters: {ma: 1e-6, Ia: 1e-12, ms: 1, Is: 1e-12}
gravity: [0, 0]
bodies:
  arm: {mass: ma, inertia: Ia}
  slider: {mass: ms, inertia: Is}
joints:
  O: {type: revolute, parent: ground, child: arm, at: [0, 0], coordinate: q}
  P: {type: prismatic, parent: arm, child: slider, at: [0, 0], coordinate: s}
simulation:
  t_span: [0, 1]
  initial: {s: 0.5, dot(s): -1}
  method: DOP853
  rtol: 1e-9
  atol: 1e-12
"""


def build(tmp_path: Path, text: str, name: str) -> Model:
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return compile_mechanism(path).model


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("stress")


@pytest.fixture(scope="module")
def double() -> Model:
    return compile_mechanism(EXAMPLES / "double_pendulum.yaml", True).model


# -- the measurements against independent values ----------------------------------------------


def test_lyapunov_exponent_of_linear_systems_is_their_leading_eigenvalue(folder: Path) -> None:
    model = build(folder, LINEAR, "linear_cart")
    y0 = model.initial_state()
    unstable = stress.lyapunov(model, y0, 20.0)
    assert unstable.value == pytest.approx(2.0, rel=0.03) and unstable.exponential
    damped = stress.lyapunov(model, y0, 40.0, params={"k": 4, "c": 1})
    assert damped.value == pytest.approx(-0.5, abs=0.05) and not damped.exponential
    eigen = np.linalg.eigvals(model.jacobian(0.0, y0))
    np.testing.assert_allclose(sorted(eigen.real), [-2.0, 2.0], rtol=1e-9)


def test_book_double_pendulum_is_regular_and_chaotic_at_high_energy(double: Model) -> None:
    """The variational estimate against the divergence of two plain runs started 1e-9 apart."""
    regular = stress.lyapunov(double, double.initial_state(), 60.0)
    assert not regular.exponential and regular.value < 0.2
    start = double.state_vector({"q1": 2.0, "q2": 2.5})
    chaotic = stress.lyapunov(double, start, 60.0)
    assert chaotic.exponential and chaotic.value > 0.3
    moved = start.copy()
    moved[0] += 1e-9
    times = np.linspace(0, 8, 81)
    runs = [double.simulate((0, 8), y, method="DOP853", t_eval=times, rtol=1e-12, atol=1e-13)
            for y in (start, moved)]
    separation = np.linalg.norm(runs[0].y - runs[1].y, axis=0)
    rate = np.polyfit(times[10:], np.log(separation[10:]), 1)[0]  # exponential growth rate
    assert 0.3 * chaotic.value < rate < 3 * chaotic.value


def test_energy_drift_rate_scales_with_the_tolerance(double: Model) -> None:
    """An error-per-step controlled pair of order 8 leaves a drift rate ~ rtol^(7/8)."""
    times = np.linspace(0, 100, 401)
    ref = stress.reference(double, (0, 100), times, rtol=1e-11)
    drifts = [stress.energy_drift(double, ref, "DOP853", tol) for tol in (1e-5, 1e-7, 1e-9)]
    rates = [d.rate for d in drifts]
    assert rates[0] > rates[1] > rates[2] > 0
    assert 0.6 < stress.drift_exponent(drifts, "DOP853") < 1.3
    assert drifts[0].trusted_until < drifts[2].trusted_until  # a long horizon needs tight rtol


def test_conservative_scenes_are_told_from_damped_or_driven_ones() -> None:
    spring = compile_mechanism(EXAMPLES / "damped_spring_pendulum.yaml").model
    run = spring.simulate((0, 2), t_eval=np.linspace(0, 2, 21))
    assert stress.energy_power_ratio(spring, run) > 1e-3
    free = spring.simulate((0, 2), t_eval=np.linspace(0, 2, 21), params={"c": 0})
    assert stress.energy_power_ratio(spring, free, {"c": 0}) < stress.CONSERVED
    arm = compile_mechanism(EXAMPLES / "robot_arm.yaml", energy=True).model
    assert "energy.total" in arm.output_names  # the YAML asks for no energy: added for stress
    assert stress.energy_power_ratio(arm, arm.simulate()) > 1e-3


def test_error_estimate_is_close_to_the_true_error(double: Model,
                                                   capsys: pytest.CaptureFixture) -> None:
    run = double.simulate(rtol=1e-6, atol=1e-9)
    estimate, _, _ = stress.error_estimate(double, run)
    truth = double.simulate(method="DOP853", rtol=1e-12, atol=1e-14, t_eval=run.t)
    true_error = np.max(np.abs(run.y - truth.y), axis=1)
    np.testing.assert_allclose(list(estimate.values()), true_error, rtol=0.1)
    assert main(["simulate", str(EXAMPLES / "double_pendulum.yaml"), "--error-estimate"]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith("# error estimate") and "dot(q2)" in line
    assert re.search(r"dot\(q2\) [0-9.e+-]+ rad/s(,|$)", line), line  # with its unit


# -- hostile scenes that must integrate correctly ---------------------------------------------


def test_extreme_mass_and_inertia_ratios(double: Model, folder: Path) -> None:
    params = {"m2": 1e-6}
    run = double.simulate(method="DOP853", rtol=1e-10, atol=1e-12, params=params)
    assert run.success
    cond = stress.conditioning(double, run, params)
    assert cond.verdict == "ill-conditioned" and 1e6 < cond.worst < 1e8
    energy = run.outputs["energy.total"]
    assert np.max(np.abs(energy - energy[0])) < 1e-8 * stress.energy_scale(run)
    chain = build(folder, POINT_MASS_CHAIN, "point_mass_chain")
    tiny = {"I2": 1e-9, "m2": 1e-6}  # link 2: inertia/mass 1e-3, mass ratio 1e-6
    run = chain.simulate(y0={"q1": -1.0, "q2": 0.5}, method="DOP853", rtol=1e-10, atol=1e-12,
                         params=tiny)
    errors, _, _ = stress.error_estimate(chain, run, tiny)
    assert run.success and max(errors.values()) < 1e-6


def test_stiff_gains_are_detected_and_radau_recommended() -> None:
    """5.4 with every gain x100: poles near -1.7e5, Radau integrates it, RK45 is pinned."""
    arm = compile_mechanism(EXAMPLES / "two_link_robot_arm.yaml").model
    gains = {name: 100 * arm.parameters[name] for name in ("b01", "g01", "b12", "g12")}
    run = arm.simulate((0, 0.3), method="Radau", t_eval=np.linspace(0, 0.3, 31), params=gains)
    assert run.success
    found = stress.stiffness(arm, stress.Reference(run, 0.0), gains, samples=10)
    assert found.stiff and found.fastest_decay > 1e5 and found.ratio > 1e3
    assert found.explicit_nfev > 20 * found.implicit_nfev
    reference = arm.simulate((0, 0.3), method="Radau", t_eval=run.t, rtol=1e-10, atol=1e-12,
                             params=gains)
    assert np.max(np.abs(run.y - reference.y)) < 1e-5


def test_large_initial_velocities(double: Model) -> None:
    spin = {"q1": 0.3, "dot(q1)": 100.0, "q2": -1.0, "dot(q2)": -150.0}
    run = double.simulate((0, 2), spin, method="DOP853", rtol=1e-10, atol=1e-10)
    assert run.success and np.max(np.abs(run.y[1])) > 50
    errors, _, _ = stress.error_estimate(double, run)
    assert max(errors.values()) < 1e-5 * np.max(np.abs(run.y))
    energy = run.outputs["energy.total"]
    assert np.max(np.abs(energy - energy[0])) < 1e-8 * stress.energy_scale(run)


def test_near_singular_configuration_is_flagged_and_integrated(folder: Path) -> None:
    model = build(folder, TELESCOPE, "through_the_pivot")
    run = model.simulate(t_eval=np.linspace(0, 1, 201))
    assert run.success
    cond = stress.conditioning(model, run)
    assert cond.verdict == "near-singular"
    assert abs(cond.worst_state[model.state_names.index("s")]) < 0.01  # at the pivot
    s = run.y[model.state_names.index("s")]
    np.testing.assert_allclose(s, 0.5 - run.t, atol=1e-9)  # no force: uniform sliding


# -- failures are never silent ----------------------------------------------------------------


def test_blow_up_is_reported_with_time_state_and_cause(folder: Path,
                                                       capsys: pytest.CaptureFixture) -> None:
    model = build(folder, RUNAWAY, "runaway_arm")
    run = model.simulate()
    assert not run.success and run.status == -1
    assert "stopped near t=1.0" in run.message and "dot(theta)=" in run.message
    assert "grows without bound" in run.message
    assert main(["simulate", str(folder / "runaway_arm.yaml")]) == 1
    assert "integration failed" in capsys.readouterr().err


def test_non_finite_accelerations_stop_the_run(folder: Path) -> None:
    model = build(folder, ROOT_TORQUE, "root_torque_arm")
    run = model.simulate(method="nemc.DOP853")
    assert not run.success and run.status == -2  # equations failed (issue 51)
    assert "accelerations are not finite" in run.message and "theta=" in run.message
    taylor = model.simulate()  # auto: nemc.Taylor, whose series overflows first
    assert taylor.method == "nemc.Taylor" and not taylor.success and "overflows" in taylor.message
    t_fail = float(run.message.split("at t=")[1].split(":")[0])
    assert 0 < t_fail < 2 and run.t.size > 1 and run.t[-1] <= t_fail  # the steps before


def test_non_finite_state_is_named_as_the_cause(double: Model) -> None:
    with pytest.raises(IntegrationFailure, match="the state is not finite") as caught:
        double.rhs(0.0, [math.nan, 0.0, 0.1, 0.0])
    assert "q1=nan" in str(caught.value)


def test_mass_matrix_that_fails_to_factor_stops_the_run(folder: Path) -> None:
    chain = build(folder, POINT_MASS_CHAIN, "point_mass_chain")
    degenerate = {"m1": 1e-300, "I1": 1e-300, "I2": 1e-300}  # links aligned: rank 1
    run = chain.simulate(params=degenerate)
    assert not run.success
    # The articulated inertia through joint 1 is ~1e-300, not exactly 0: either the guard stops
    # the run, or accelerations of ~1e280 overflow within the first steps; both name the state.
    t_fail = float(run.message.split("at t=")[1].split(":")[0])
    assert t_fail < 1e-3 and "state: q1=" in run.message
    assert "through joint 1 " in run.message or "accelerations are not finite" in run.message \
        or "pivot 2 of its LDL^T" in run.message  # (auto's nemc.Taylor: the mass-matrix form)
    assert "through joint 2" not in run.message  # joint 2's inertia is fine: never blamed


@pytest.mark.parametrize(
    ("override", "message"),
    [({"m1": math.nan}, "must be finite"), ({"L2": math.inf}, "must be finite"),
     ({"m2": -1.0}, "must be >= 0")],
)
def test_bad_runtime_parameters_are_refused(double: Model, override: dict, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        double.simulate(params=override)


def test_a_parameter_that_makes_the_mass_matrix_singular_stops_the_run(double: Model) -> None:
    """L1 = 0 leaves link 1 a particle at the pin (mass and inertia may be 0 since format v3):
    joint 1's angle then moves nothing, which the check of what each joint carries cannot see
    for absolute angles; the run stops at its first step naming the singular mass matrix."""
    run = double.simulate(params={"L1": 0.0})
    assert not run.success and run.t[-1] == 0.0
    assert "mass matrix is singular" in run.message, run.message


def test_cli_refuses_nan_parameters(capsys: pytest.CaptureFixture) -> None:
    assert main(["simulate", str(EXAMPLES / "double_pendulum.yaml"), "--set", "m1=nan"]) == 2
    assert "must be finite" in capsys.readouterr().err


# -- the report ---------------------------------------------------------------------------------


def test_stress_command_writes_the_report(tmp_path: Path) -> None:
    assert main(["stress", str(EXAMPLES / "robot_arm.yaml"), "--out", str(tmp_path)]) == 0
    text = (tmp_path / "robot_arm.md").read_text()
    assert "stiff: use an implicit method" in text and "Not conservative" in text
    assert (tmp_path / "robot_arm.png").stat().st_size > 10_000
    assert main(["stress", "--out", str(tmp_path)]) == 2


def test_a_closed_loop_gets_its_constraint_drift(tmp_path: Path) -> None:
    """Issue 16: `nemc stress` reports the constraints' residuals of every explicit method on a
    closed loop (nemc.Taylor, which cannot run one, left out rather than failing the report)."""
    text = (EXAMPLES / "fourbar.yaml").read_text().replace("t_span: [0, 10]", "t_span: [0, 2]")
    path = tmp_path / "fourbar.yaml"
    path.write_text(text)
    assert main(["stress", str(path), "--out", str(tmp_path), "--horizon", "2"]) == 0
    report = (tmp_path / "fourbar.md").read_text()
    section = report.split("## Constraint drift")[1].split("\n## ")[0]
    rows = [line.split("|")[1:-1] for line in section.splitlines()
            if line.startswith("| nemc.") or line.startswith("| RK45")]
    assert {row[0].strip() for row in rows} == {"RK45", "nemc.DOP853", "nemc.Vern9"}
    assert "nemc.Taylor" not in report
    for row in rows:  # at every tolerance: on the constraints to rounding, not growing
        assert max(float(cell) for cell in row[3:7]) < 1e-12 and row[7].strip() == "no", row
