"""nemc.Taylor (Taylor's method with coefficients from the program in Taylor arithmetic): its error
against a tight reference from another method as the tolerance falls, its steps, its rule for
the order and the step, its generated loop, failures and what it refuses. (Against the
independent reference on random mechanisms and on every recurrence, its ensembles, backwards
and empty intervals: tests/test_scenarios.py.)"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.derive.taylor import (
    LANES,
    SCALAR,
    SUMS_PER_BLOCK,
    Assignment,
    Recurrence,
    rows_read_back,
    sums_in_blocks,
    written,
)
from nemc.emit.taylor_c import TAYLOR_MARGIN, TAYLOR_MIN_EXPONENT, StepCosts, taylor_rule
from nemc.runtime import runs
from nemc.runtime.model import ModelError
from nemc.runtime.native import simulate_native
from nemc.runtime.outcome import RunSpec

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
PENDULUM = EXAMPLES / "double_pendulum.yaml"

MODELS = Path(__file__).resolve().parent / "models"
# A pendulum driven by a torque using every function with a Taylor recurrence (of the state and
# of time), and a slider pushed by a force that overflows near t = 0.71.
FUNCTIONS = (MODELS / "functions.yaml").read_text()
OVERFLOW = (MODELS / "overflow_slider.yaml").read_text()

# abs() has no Taylor recurrence (it is not smooth where its argument changes sign).
NOT_SMOOTH = FUNCTIONS.replace("0.05*dot(q)**3", "0.05*abs(dot(q))").replace(
    "name: functions", "name: not_smooth")


def tight(model, span, y0, t_eval):
    return model.simulate(span, y0, method="nemc.Vern9", rtol=1e-13, atol=1e-15,
                          t_eval=t_eval).y


@pytest.fixture(scope="module")
def pendulum():
    return nemc.compile(PENDULUM, taylor=True)


def compiled(tmp_path: Path, text: str, name: str):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return nemc.compile(path)


@pytest.mark.parametrize("rtol", [1e-6, 1e-9, 1e-12])
def test_error_follows_the_tolerance(pendulum, rtol: float) -> None:
    """The chaotic double pendulum over [0, 10]: the error at t_eval points (dense output,
    the step's own polynomial) follows rtol as Jorba and Zou's error bound promises (at the
    order and step nemc's cost model chooses: emit.taylor_c.taylor_rule)."""
    t_eval = np.linspace(0.0, 10.0, 41)
    y0 = pendulum.initial_state()
    result = pendulum.simulate((0.0, 10.0), y0, method="nemc.Taylor", rtol=rtol,
                               atol=rtol * 1e-3, t_eval=t_eval)
    assert result.success and result.method == "nemc.Taylor"
    error = np.abs(result.y - tight(pendulum, (0.0, 10.0), y0, t_eval)).max()
    assert error < 200 * rtol


def test_every_step_is_one_expansion(pendulum) -> None:
    """(Backwards and the empty interval: test_scenarios.py.)"""
    y0 = pendulum.initial_state()
    steps = simulate_native(pendulum, RunSpec("nemc.Taylor", (0.0, 3.0), y0, None, 1e-9, 1e-12,
                                              pendulum.parameter_vector(),
                                              runs.DEFAULT_SETTINGS, []))
    assert steps.t[0] == 0.0 and steps.t[-1] == 3.0 and np.all(np.diff(steps.t) > 0)
    # one expansion per accepted step, each at the step's start, and one at t_end that
    # accepts the last step (a step stands once the expansion at its end is finite)
    assert len(steps.t) == steps.nfev


def test_built_on_first_use_keeping_the_jacobian(tmp_path: Path) -> None:
    model = compiled(tmp_path, PENDULUM.read_text(), "double_pendulum")
    assert "taylor" not in model.metadata["generated"]
    model.jacobian(0.0, model.initial_state())  # the Jacobian variant first
    result = model.simulate((0.0, 1.0), method="nemc.Taylor", t_eval=[1.0])
    assert result.success
    variant = model.compiled_with("taylor")  # the build that ran it: both parts
    assert variant.has_part("taylor") and variant.has_part("jacobian")
    assert not model.has_part("taylor")  # using a part never changes a model's own build


def test_scene_method_builds_it(tmp_path: Path) -> None:
    text = PENDULUM.read_text().replace("method: RK45", "method: nemc.Taylor")
    model = compiled(tmp_path, text, "double_pendulum")
    assert "taylor" in model.metadata["generated"]
    assert model.simulate().method == "nemc.Taylor"


def test_not_smooth_loads_are_refused_by_name(tmp_path: Path) -> None:
    model = compiled(tmp_path, NOT_SMOOTH, "not_smooth")
    where = re.escape(f"{tmp_path / 'not_smooth.yaml'}:11: loads[0].torque: abs of a "
                      "time-varying value has no Taylor recurrence")
    with pytest.raises(ModelError, match=r"nemc.Taylor is not available for not_smooth: " + where):
        model.simulate(method="nemc.Taylor")
    assert model.simulate(method="nemc.Vern9").success  # the other methods are unaffected


def test_failure_is_reported_with_time_and_state(tmp_path: Path) -> None:
    result = compiled(tmp_path, OVERFLOW, "overflow").simulate(method="nemc.Taylor",
                                                               rtol=1e-6, atol=1e-9)
    assert (result.success, result.status) == (False, -2)
    assert result.message.startswith("integration failed: at t=0.6")  # coefficients overflow
    assert "not finite" in result.message and "; state: s=" in result.message


def jorba_zou_order(eps: float) -> int:
    """Jorba & Zou's order for tolerance eps (their rule, where A = 2)."""
    return int(np.ceil(-np.log(eps) / 2 + 1))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_step_rule_meets_jorba_and_zous_error_bound(seed: int) -> None:
    """At random tolerances and costs, the order and exponent meet the local error bound
    e^(-A p) <= eps / e^(2 + TAYLOR_MARGIN) (at the highest order, where it may not, A is
    Jorba & Zou's 2), from Jorba & Zou's order up, with A within [TAYLOR_MIN_EXPONENT, 2];
    where the Cauchy sums are the whole cost, the order is theirs or the next (the margin, and
    their exp(-0.7 / (p - 1)))."""
    rng = np.random.default_rng(seed)
    for _ in range(200):
        eps = float(10 ** rng.uniform(-16, -1))
        costs = StepCosts(*(float(c) for c in rng.uniform(0, 1000, 3)))
        order, exponent = taylor_rule(eps, costs)
        assert jorba_zou_order(eps) <= order <= 40
        assert TAYLOR_MIN_EXPONENT <= exponent <= 2.0
        assert exponent * order >= -np.log(eps) + 2 + TAYLOR_MARGIN - 1e-9
        sums_only = taylor_rule(eps, StepCosts(0.0, 0.0, costs.sums + 1.0))
        assert sums_only[0] - jorba_zou_order(eps) in (0, 1)
    assert taylor_rule(1e-300, StepCosts(1.0, 1.0, 1.0)) == (40, 2.0)
    assert taylor_rule(0.0, StepCosts(1.0, 1.0, 1.0)) == (40, 2.0)
    assert taylor_rule(0.9, StepCosts(1.0, 1.0, 1.0)) == (3, 1.5)


def test_the_c_rule_is_the_python_rule(pendulum) -> None:
    """The build's taylor_rule (C, <model>_taylor_order) chooses what emit.taylor_c.taylor_rule does
    with the build's costs."""
    costs = StepCosts(4 * 120.0, 27.0, 13.0)  # the double pendulum's program
    exponent = pendulum.compiled.ffi.new("double *")
    c_rule = pendulum.compiled.function("taylor_order")
    for eps in [*np.logspace(-15, -1, 57), 1e-300, 0.0, 0.9]:
        order = c_rule(float(eps), exponent)
        assert (order, exponent[0]) == taylor_rule(float(eps), costs)


def test_a_series_in_t_to_the_fourth_takes_finite_steps() -> None:
    """A pendulum released at rest from the horizontal is a series in t^4 (cos q' = 0 there):
    at an order that is a multiple of 4 its last two coefficients vanish, and the step was
    infinite, one step past the vertical whose event it then missed or placed 3e-5 late. The
    two coefficients before them bound it now: the event at the quarter period (the complete
    elliptic integral K(1/2)) at every tolerance, whatever the order."""
    from scipy.special import ellipk

    model = nemc.compile(EXAMPLES / "pendulum_to_vertical.yaml", taylor=True)
    quarter = ellipk(0.5) / np.sqrt(3 * 9.81 / (2 * 1.5))
    for rtol in np.logspace(-4, -13, 19):
        result = model.simulate(method="nemc.Taylor", rtol=rtol, atol=rtol * 1e-2)
        times, _ = result.events["vertical"]
        assert result.success and result.nfev > 2
        assert abs(times[0] - quarter) < 10 * rtol


def test_values_read_back_keep_rows_the_others_are_locals() -> None:
    """A value whose earlier coefficients a recurrence reads keeps a row of the work array;
    one needed only at coefficient k becomes a local of the loop's body, defined where its
    row's coefficient k was written and read where it was read."""
    loop = [Recurrence("product", "s0", ("xq0", "xdq0")),
            Assignment("w1", "(s0[k] + xq0[k])"),
            Recurrence("product", "s2", ("w1", "xq0")),
            Recurrence("reciprocal", "s3", ("w1", "s3")),
            "if (k == 0 && !(s2[k] > 0.0))",
            "    return 1;",
            "xdq0[k + 1] = (s2[k] + s0[k] * s3[k]) * (1.0 / (k + 1));"]
    rows = ["s0", "w1", "s2", "s3"]
    assert rows_read_back(rows, loop) == ["w1", "s3"]
    local = frozenset({"s0", "s2"})
    assert [written(item, local, SCALAR) for item in loop] == [
        "const double s0 = series_product(xq0, xdq0, k);",
        "w1[k] = (s0 + xq0[k]);",
        "const double s2 = series_product(w1, xq0, k);",
        "s3[k] = series_reciprocal(w1, s3, k);",
        "if (k == 0 && !(s2 > 0.0))",
        "    return 1;",
        "xdq0[k + 1] = (s2 + s0 * s3[k]) * (1.0 / (k + 1));"]
    assert rows_read_back(rows, loop[:2]) == []  # nothing reads a row back
    assert [written(item, frozenset(rows), LANES) for item in loop[:2]] == [
        "const lanes s0 = lanes_product(xq0, xdq0, k);", "const lanes w1 = (s0 + xq0[k]);"]


def test_products_and_squares_sum_their_older_terms_in_blocks() -> None:
    """Each product's and square's terms below k are summed in a block's loop over j, before
    its line, which then adds its coefficient-k terms (series_*_end); squares (half the terms)
    in blocks of their own, at most SUMS_PER_BLOCK sums a block, every other line unchanged."""
    products = [Recurrence("product", f"s{i}", (f"w{i}", "xq0"))
                for i in range(SUMS_PER_BLOCK + 1)]
    loop = [Assignment("w0", "(xq0[k] + xdq0[k])"), products[0],
            Recurrence("square", "s99", ("w0",)), *products[1:],
            "xdq0[k + 1] = s99[k] * (1.0 / (k + 1));"]
    blocked = sums_in_blocks(loop, frozenset({"s99"}), SCALAR)
    text = "\n".join(blocked)
    assert blocked[0] == "w0[k] = (xq0[k] + xdq0[k]);"
    assert blocked[-1] == "xdq0[k + 1] = s99 * (1.0 / (k + 1));"
    assert "series_product(" not in text and "series_square(" not in text
    assert text.count("TAYLOR_LOOP(j, 1, k, ") == 2  # 12 products, then the 13th
    assert ("TAYLOR_LOOP(j, 1, (k + 1) / 2, old_s99 = TAYLOR_MULADD(w0[j], w0[k - j], old_s99););"
            in text)
    assert "old_s0 = TAYLOR_MULADD(w0[j], xq0[k - j], old_s0);" in text
    first, second = (text.index(f"/* the terms below k of the next {count}") for count in
                     (f"{SUMS_PER_BLOCK} sums", "1 sum "))
    assert first < text.index("s0[k] = series_product_end(w0, xq0, old_s0, k);") < second
    assert second < text.index(f"s{SUMS_PER_BLOCK}[k] = series_product_end(")
    assert "const double s99 = series_square_end(w0, old_s99, k);" in text


def test_every_recurrence_but_the_power_finishes_a_blocked_sum() -> None:
    """Quotients, reciprocals, sin-cos pairs, exp and log sum their older terms in the blocks
    too (each with the terms of templates/taylor.c.tmpl's recurrence); a power, whose exponent
    is no name, keeps its own loop."""
    loop = [Recurrence("sincos", None, ("w1", "s3", "s4", "s5")),
            Recurrence("quotient", "s6", ("w1", "s5", "s6")),
            Recurrence("log", "s7", ("w1", "s7")),
            Recurrence("power", "s8", ("w1", "s8"), ("c3",)),
            Recurrence("exp", "s9", ("w1", "s10", "s9")),
            Recurrence("reciprocal", "s11", ("w1", "s11"))]
    text = "\n".join(sums_in_blocks(loop, frozenset(), SCALAR))
    for term in ("old_s4 = TAYLOR_MULADD(s3[j], s5[k - j], old_s4);",  # j a[j] cos[k-j]
                 "old_s5 = TAYLOR_MULADD(s3[j], s4[k - j], old_s5);",  # j a[j] sin[k-j]
                 "old_s6 = TAYLOR_MULADD(s5[j], s6[k - j], old_s6);",  # b[j] q[k-j]
                 "old_s7 = TAYLOR_MULADD((double)j * s7[j], w1[k - j], old_s7);",
                 "old_s9 = TAYLOR_MULADD(s10[j], s9[k - j], old_s9);",
                 "old_s11 = TAYLOR_MULADD(w1[j], s11[k - j], old_s11);"):
        assert term in text
    assert "series_sincos_end(w1, s3, s4, s5, old_s4, old_s5, k);" in text
    assert "s8[k] = series_power(w1, s8, c3, k);" in text and "old_s8" not in text
