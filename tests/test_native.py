"""The native integrators (nemc.DOP853, nemc.Radau, nemc.Vern9) against scipy's solve_ivp, step
for step, against tight references, and the ensemble call's failures and checks. (Every method
against the independent reference, ensembles against single runs, backwards and empty
intervals: tests/test_scenarios.py.)"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import scenarios
from scipy.integrate import solve_ivp

import nemc
from nemc.runtime import runs
from nemc.runtime.model import ModelError
from nemc.runtime.native import simulate_native
from nemc.runtime.outcome import RunSpec
from nemc.runtime.scipy_run import integrator_jacobian

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
PENDULUM = EXAMPLES / "double_pendulum.yaml"
COMPOUND = EXAMPLES / "compound_pendulum.yaml"
ONE_LINK_ARM, TWO_LINK_ARM = EXAMPLES / "robot_arm.yaml", EXAMPLES / "two_link_robot_arm.yaml"

# A pendulum whose drive torque overflows to inf near t = 0.71: the equations fail there.
OVERFLOW = """\
name: overflow
parameters: {m: 1, L: 1, g: 10}
gravity: [0, -g]
bodies:
  rod: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  O: {type: revolute, parent: ground, child: rod, at: [0, 0], coordinate: q}
loads:
  - {torque: exp(1000*t), body: rod, reaction: ground}
simulation:
  t_span: [0, 2]
  initial: {q: 0.5}
"""


def scipy_run(model, method: str, span, y0, **options):
    """scipy's solve_ivp on the model's compiled RHS (and Jacobian for Radau)."""
    p = model.parameter_vector()
    jac = {"jac": integrator_jacobian(model, p)} if method == "Radau" else {}
    return solve_ivp(model.compiled.integrator_rhs(p), span, y0, method=method, **jac,
                     **options)


def native_steps(model, method: str, span, y0, rtol: float, atol: float):
    """A native run returning every accepted step (simulate returns the scene's t_eval)."""
    p = model.parameter_vector()
    return simulate_native(model, RunSpec(method, span, y0, None, rtol, atol, p,
                                          runs.DEFAULT_SETTINGS, []))


def assert_same_steps(native, scipy, t_rtol: float, y_atol: float) -> None:
    assert (native.nfev, native.njev, native.nlu) == (scipy.nfev, scipy.njev, scipy.nlu)
    assert native.t.shape == scipy.t.shape
    np.testing.assert_allclose(native.t, scipy.t, rtol=t_rtol, atol=0)
    np.testing.assert_allclose(native.y, scipy.y, rtol=0, atol=y_atol)


@pytest.fixture(scope="module")
def pendulum():
    return nemc.compile(PENDULUM)


@pytest.fixture(scope="module")
def chain():
    return scenarios.model("chain")  # the table's random chain (seed 7, 4 bodies)


# The error estimate is a sum that cancels to a small fraction of its terms, and numpy's BLAS
# sums it in another order than C: steps agree to rounding times that conditioning. It is
# worst where a step is far more accurate than asked (the first steps, states near 0: the
# chain starts at rest) and estimate and step size then follow rounding noise. States then
# differ by about |dy/dt| times the time points' difference. (The pendulum's bounds were 1e-9
# and 3e-7 with the articulated-body RHS; its mass-matrix program rounds otherwise: 1.9e-9 and
# 4.4e-7, the same 41 steps.)
@pytest.mark.parametrize(("case", "t_rtol", "y_atol"), [("pendulum", 1e-8, 1e-6),
                                                        ("chain", 1e-7, 1e-5)])
def test_dop853_takes_scipys_steps(case: str, t_rtol: float, y_atol: float,
                                   request: pytest.FixtureRequest) -> None:
    model = request.getfixturevalue(case)
    y0, span = model.initial_state(), (0.0, 5.0)
    native = native_steps(model, "nemc.DOP853", span, y0, 1e-3, 1e-6)
    reference = scipy_run(model, "DOP853", span, y0, rtol=1e-3, atol=1e-6)
    assert_same_steps(native, reference, t_rtol=t_rtol, y_atol=y_atol)
    rejected = (native.nfev - 2 - 12 * (native.t.size - 1)) / 12
    assert rejected >= 1 and rejected == int(rejected)  # the rejected-step rule was exercised


def test_dop853_dense_output_at_t_eval(pendulum) -> None:
    y0, times = pendulum.initial_state(), np.linspace(0.0, 5.0, 37)
    native = pendulum.simulate((0, 5), y0, method="nemc.DOP853", t_eval=times, rtol=1e-3,
                               atol=1e-6)
    reference = scipy_run(pendulum, "DOP853", (0, 5), y0, t_eval=times, rtol=1e-3, atol=1e-6)
    assert native.nfev == reference.nfev  # 3 extra stages exactly on the steps with points
    np.testing.assert_array_equal(native.t, times)
    np.testing.assert_allclose(native.y, reference.y, rtol=0, atol=1e-8)
    assert native.success and native.message == reference.message and native.status == 0


def test_dop853_takes_scipys_steps_backwards(pendulum) -> None:
    """(Back to the start and the empty interval, every method: test_scenarios.py.)"""
    y0 = pendulum.initial_state()
    back = native_steps(pendulum, "nemc.DOP853", (2.0, 0.0), y0, 1e-3, 1e-6)
    assert_same_steps(back, scipy_run(pendulum, "DOP853", (2.0, 0.0), y0, rtol=1e-3,
                                      atol=1e-6), t_rtol=1e-9, y_atol=1e-8)


def test_vern9_converges_with_order_9() -> None:
    """Final error against a tight DOP853 reference falls as (steps)^-9 (DOP853's here: ^-7.9)."""
    model = nemc.compile(COMPOUND)
    span, y0 = (0.0, 10.0), model.initial_state()
    ref = model.simulate(span, method="DOP853", rtol=1e-13, atol=1e-15, t_eval=[10.0]).y[:, -1]
    steps, errors = [], []
    for rtol in 10.0 ** -np.arange(4, 10):
        run = native_steps(model, "nemc.Vern9", span, y0, rtol, rtol * 1e-3)
        steps.append(run.t.size - 1)
        errors.append(np.abs(run.y[:, -1] - ref).max())
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert 8.5 < -slope < 10.5


def test_vern9_at_tight_tolerance_beats_dop853(pendulum) -> None:
    """At rtol 1e-12 Vern9 meets a DOP853 rtol 1e-13 reference with fewer evaluations."""
    span, times = (0.0, 10.0), [10.0]
    tight = pendulum.simulate(span, method="nemc.DOP853", t_eval=times, rtol=1e-13, atol=1e-15)
    vern9 = pendulum.simulate(span, method="nemc.Vern9", t_eval=times, rtol=1e-12, atol=1e-15)
    dop853 = pendulum.simulate(span, method="nemc.DOP853", t_eval=times, rtol=1e-12, atol=1e-15)
    assert vern9.success and vern9.method == "nemc.Vern9"
    assert np.abs(vern9.y - tight.y).max() < 1e-10
    assert vern9.nfev < 0.85 * dop853.nfev


def test_vern9_dense_output(pendulum) -> None:
    """Points inside steps (Verner's interpolant) are as accurate as the steps' ends."""
    y0, times = pendulum.initial_state(), np.linspace(0.0, 3.0, 31)
    tight = pendulum.simulate((0, 3), y0, method="nemc.DOP853", t_eval=times, rtol=1e-13,
                              atol=1e-15)
    native = pendulum.simulate((0, 3), y0, method="nemc.Vern9", t_eval=times, rtol=1e-10,
                               atol=1e-13)
    steps = native_steps(pendulum, "nemc.Vern9", (0, 3), y0, 1e-10, 1e-13)
    assert np.abs(steps.y[:, -1] - tight.y[:, -1]).max() < 1e-8
    assert np.abs(native.y - tight.y).max() < 1e-8
    np.testing.assert_array_equal(native.y[:, -1], steps.y[:, -1])  # end point: the step's own
    interior = ~np.isin(times, steps.t)
    holding = np.unique(np.searchsorted(steps.t, times[interior]))  # steps holding a point
    assert native.nfev == steps.nfev + 4 * len(holding)  # the interpolant: 4 stages a step


@pytest.mark.parametrize("rtol", [1e-6, 1e-9, 1e-12])
def test_vern9_interpolant_is_as_accurate_as_the_steps(pendulum, rtol: float) -> None:
    """2,001 points over [0, 20] against nemc.Taylor at rtol 2.5e-14 (another method): the
    interpolant's largest error is within 1.5x of the steps' own (the global error), for a
    fifth more evaluations than the steps alone."""
    y0, times = pendulum.initial_state(), np.linspace(0.0, 20.0, 2001)
    dense = pendulum.simulate((0, 20), y0, method="nemc.Vern9", t_eval=times, rtol=rtol,
                              atol=rtol * 1e-3)
    steps = native_steps(pendulum, "nemc.Vern9", (0, 20), y0, rtol, rtol * 1e-3)
    def reference(at: np.ndarray) -> np.ndarray:
        return pendulum.simulate((0, 20), y0, method="nemc.Taylor", rtol=2.5e-14, atol=1e-16,
                                 t_eval=at).y

    dense_error = np.abs(dense.y - reference(times)).max()
    step_error = np.abs(steps.y - reference(steps.t)).max()
    assert dense_error < 1.5 * step_error
    assert dense.nfev < 1.3 * steps.nfev


@pytest.mark.parametrize("path", [ONE_LINK_ARM, TWO_LINK_ARM], ids=["5.3", "5.4"])
def test_radau_takes_scipys_steps_on_the_stiff_arms(path: Path) -> None:
    model = nemc.compile(path)
    y0, span = model.initial_state(), tuple(model.scene["t_span"])
    for rtol, atol, t_rtol in ((1e-3, 1e-6, 1e-9), (1e-6, 1e-9, 1e-6)):
        native = native_steps(model, "nemc.Radau", span, y0, rtol, atol)
        reference = scipy_run(model, "Radau", span, y0, rtol=rtol, atol=atol)
        assert_same_steps(native, reference, t_rtol=t_rtol, y_atol=1e-7)


def test_radau_against_a_tight_reference_and_at_t_eval() -> None:
    """5.4 at rtol 1e-8 against DOP853 at 1e-13 (another method), at the scene's times."""
    model = nemc.compile(TWO_LINK_ARM)
    assert model.scene["method"] == "nemc.Radau"
    times = np.arange(16.0)
    tight = model.simulate((0, 15), method="nemc.DOP853", t_eval=times, rtol=1e-13, atol=1e-13)
    native = model.simulate((0, 15), t_eval=times, rtol=1e-8, atol=1e-10)
    assert native.method == "nemc.Radau" and native.njev >= 1 and native.nlu >= 2
    assert np.abs(native.y - tight.y).max() < 1e-6
    assert set(native.outputs) == set(model.output_names)


def test_radau_builds_the_jacobian_on_first_need(pendulum) -> None:
    assert "jacobian" not in pendulum.metadata["generated"]
    native = pendulum.simulate((0, 1), method="nemc.Radau", t_eval=[1.0], rtol=1e-8, atol=1e-10)
    tight = pendulum.simulate((0, 1), method="nemc.DOP853", t_eval=[1.0], rtol=1e-12,
                              atol=1e-12)
    assert native.success and np.abs(native.y - tight.y).max() < 1e-6


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Radau"])
def test_failure_is_reported_as_with_scipy(method: str, tmp_path: Path) -> None:
    path = tmp_path / "overflow.yaml"
    path.write_text(OVERFLOW)
    model = nemc.compile(path)
    native = model.simulate(method=method, rtol=1e-3, atol=1e-6)
    assert (native.success, native.status) == (False, -2)
    assert native.message.startswith("integration failed: at t=0.7")
    assert "; state: q=" in native.message
    if method == "nemc.DOP853":  # (Radau's Newton iterates reach nan first; scipy's LU refuses)
        reference = model.simulate(method="DOP853", rtol=1e-3, atol=1e-6)
        assert "not finite" in native.message
        assert native.message == reference.message  # the same steps fail at the same stage


def test_vern9_reports_a_step_too_small_as_scipy(tmp_path: Path) -> None:
    """Vern9's stages stay short of the overflow (t ~ 0.71): its steps shrink to nothing first."""
    path = tmp_path / "overflow.yaml"
    path.write_text(OVERFLOW)
    native = nemc.compile(path).simulate(method="nemc.Vern9", rtol=1e-3, atol=1e-6)
    assert (native.success, native.status) == (False, -1)
    assert "Required step size is less than spacing between numbers." in native.message
    assert "integration stopped near t=0.7" in native.message  # where, and the state
    assert 0.6 < native.t[-1] < 0.72


def test_t_eval_is_checked(pendulum) -> None:
    with pytest.raises(ModelError, match="not properly sorted"):
        pendulum.simulate((0, 1), method="nemc.DOP853", t_eval=[0.5, 0.2])
    with pytest.raises(ModelError, match="not within"):
        pendulum.simulate((0, 1), method="nemc.DOP853", t_eval=[2.0])
    with pytest.raises(ModelError, match="not within"):
        pendulum.simulate((0, 1), method="nemc.DOP853", t_eval=[0.5, float("nan")])
    backwards = pendulum.simulate((1, 0), method="nemc.DOP853", t_eval=[0.75, 0.25])
    assert backwards.success and list(backwards.t) == [0.75, 0.25]


@pytest.mark.parametrize("method", ["nemc.DOP853", "auto", "ensemble"])
def test_rtol_below_100_eps_is_raised_with_a_warning_at_the_callers_line(pendulum,
                                                                          method: str) -> None:
    """As scipy's validate_tol: rtol 1e-20 runs at 100 eps, and the warning names the line of
    the caller's call, however deep in nemc it is made."""
    with pytest.warns(UserWarning, match="`rtol` is too small") as record:
        if method == "ensemble":
            result = pendulum.simulate_many(np.array([pendulum.initial_state()] * 2),
                                            t_span=(0, 0.1), method="nemc.DOP853", rtol=1e-20)
        else:
            result = pendulum.simulate((0, 0.1), method=method, rtol=1e-20)
    assert result.rtol == 100 * np.finfo(float).eps
    assert [Path(warning.filename) for warning in record] == [Path(__file__)]


def test_default_method_is_native_when_the_scene_names_none(tmp_path: Path) -> None:
    path = tmp_path / "no_method.yaml"
    path.write_text(re.sub(r"(?m)^  method: RK45.*\n", "", PENDULUM.read_text()))
    model = nemc.compile(path)
    assert model.scene["method"] is None
    assert model.simulate().method == "nemc.Taylor"  # auto's choice (tests/test_auto.py)


def test_ensemble_failures_and_checks(tmp_path: Path, pendulum) -> None:
    path = tmp_path / "overflow.yaml"
    path.write_text(OVERFLOW)
    model = nemc.compile(path)
    runs = model.simulate_many(np.array([[0.5, 0.0], [0.1, 0.0]]), t_span=(0, 2),
                               t_eval=[0.5, 1.0, 2.0], method="nemc.DOP853", rtol=1e-3,
                               atol=1e-6)
    np.testing.assert_array_equal(runs.status, [-2, -2])  # the equations failed in both
    assert np.isfinite(runs.y[:, :, 0]).all() and np.isnan(runs.y[:, :, 1:]).all()
    with pytest.raises(ModelError, match="disagree on the number of runs"):
        pendulum.simulate_many(np.zeros((3, 4)), params={"L2": [0.5, 0.6]})
    with pytest.raises(ModelError, match="method must be one of"):
        pendulum.simulate_many(np.zeros((3, 4)), method="RK45")
