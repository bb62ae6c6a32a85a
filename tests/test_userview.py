"""The user's view: units, the drawing's positions, the notebook API (compile from text,
to_pandas, rich display), and the book's 5.4 steady state explained."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import fsolve

import nemc
from nemc.emit.units import label
from nemc.errors import InputError
from nemc.front.mechanism import Units
from nemc.front.validate import validate_text
from nemc.runtime.model import Model
from nemc.runtime.results import SimulationResult, model_html

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
ROBOT_ARM = (EXAMPLES / "robot_arm.yaml").read_text()


def model_of(name: str):
    return nemc.compile(EXAMPLES / f"{name}.yaml")


# ---- units ----------------------------------------------------------------------------------


@pytest.mark.parametrize(("units", "message"), [
    ("units: {length: 3}", "units.length: expected a unit label such as m"),
    ("units: {angle: degrees}", "units.angle: unknown angle display (how figures show angles) "
                                "'degrees' (did you mean 'deg'?)"),
    ("units: {lenght: m}", "units.lenght: unknown key 'lenght' (did you mean 'length'?)"),
    ("units: [m, kg]", "units: expected a mapping {length, mass, time, angle}, got a list of 2"),
    ("units: {time: \"$s$\"}", "units.time: a unit label starts with a letter"),
])
def test_bad_units_are_refused_with_file_line_and_key(units: str, message: str) -> None:
    text = ROBOT_ARM.replace("units: {length: m, mass: kg, time: s, angle: deg}", units)
    line = text.splitlines().index(next(row for row in text.splitlines()
                                        if row.startswith("units:"))) + 1
    with pytest.raises(InputError) as error:
        validate_text(text, "arm.yaml")
    assert str(error.value).startswith(f"arm.yaml:{line}: {message}")


def test_units_are_optional_and_angle_defaults_to_radians() -> None:
    text = ROBOT_ARM.replace("units: {length: m, mass: kg, time: s, angle: deg}", "")
    assert validate_text(text, "arm.yaml").units == Units()
    assert validate_text(ROBOT_ARM, "arm.yaml").units == Units("m", "kg", "s", "deg")


@pytest.mark.parametrize(("units", "kind", "expected"), [
    (Units("m", "kg", "s"), "joint force", "N"),
    (Units("m", "kg", "s"), "energy", "J"),
    (Units("m", "kg", "s"), "couple", "N*m"),
    (Units("ft", "slug", "s"), "joint force", "lb"),
    (Units("m", "kg", "s"), "acceleration", "m/s^2"),
    (Units("mm", "g", "ms"), "joint force", "mm*g/ms^2"),
    (Units("m", "kg", "s"), "angular rate", "rad/s"),
    (Units("m", None, "s"), "joint force", ""),  # no mass unit: no force unit
    (Units(None, None, None), "angle", "rad"),
    (Units("m", "kg", "s"), None, ""),  # an expression: no kind, no unit
])
def test_unit_labels_are_composed_from_the_declared_units(units, kind, expected) -> None:
    assert label(kind, units) == expected


def test_a_builds_metadata_names_each_columns_unit() -> None:
    labels = model_of("compound_pendulum").metadata["unit_labels"]
    assert labels["t"] == "s"
    assert labels["theta"] == "rad" and labels["dot(theta)"] == "rad/s"
    assert labels["O.Fx"] == "lb" and labels["energy.total"] == "ft*lb"  # the book's 5.1 units
    assert labels["ddot(theta)"] == "rad/s^2"


# ---- the drawing's positions come from the compiled model ------------------------------------


def test_positions_of_the_double_pendulum_match_its_geometry() -> None:
    """Absolute angles (book 5.2): B = L1 (cos q1, sin q1), D = B + L2 (cos q2, sin q2)."""
    model = model_of("double_pendulum")
    rng = np.random.default_rng(20)
    y = rng.uniform(-3, 3, size=(4, 7))
    xy = model.positions(0.0, y, params={"L1": 1.3, "L2": 0.7})
    q1, q2 = y[0], y[2]
    b = np.array([1.3 * np.cos(q1), 1.3 * np.sin(q1)])
    d = b + np.array([0.7 * np.cos(q2), 0.7 * np.sin(q2)])
    np.testing.assert_allclose(xy["link1.B"], b, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(xy["link2.origin"], b, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(xy["link2.D"], d, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(xy["link2.com"], (b + d) / 2, rtol=1e-14, atol=1e-14)
    single = model.positions(0.0, y[:, 0])
    np.testing.assert_allclose(single["link1.B"], [np.cos(q1[0]), np.sin(q1[0])], atol=1e-15)


def test_positions_on_a_rail_and_after_a_weld() -> None:
    cart = model_of("prismatic_cart_pendulum")  # rail at [1, 0] along [4, 3]; hinge [0, -0.1]
    s, phi = 0.7, 0.4
    xy = cart.positions(0.0, [s, 0, phi, 0])
    origin = np.array([1.0, 0.0]) + s * np.array([0.8, 0.6])
    np.testing.assert_allclose(xy["cart.origin"], origin, atol=1e-15)
    hinge = origin + [0.0, -0.1]
    tip = hinge + 0.8 * np.array([math.cos(phi - math.pi / 2), math.sin(phi - math.pi / 2)])
    np.testing.assert_allclose(xy["pendulum.tip"], tip, atol=1e-14)
    np.testing.assert_allclose(xy["ground.rail.axis"] - xy["ground.rail"], [0.8, 0.6],
                               atol=1e-15)
    tee = model_of("weld_t_pendulum")  # rod hangs at theta = 0; the bar is welded at +90 deg
    theta = 0.3
    xy = tee.positions(0.0, [theta, 0])
    tip = np.array([math.sin(theta), -math.cos(theta)])
    np.testing.assert_allclose(xy["rod.tip"], tip, atol=1e-15)
    end = tip + 0.8 * np.array([math.cos(theta), math.sin(theta)])
    np.testing.assert_allclose(xy["bar.end"], end, atol=1e-14)


# ---- notebooks ------------------------------------------------------------------------------


def test_compile_from_text_names_the_text_in_messages() -> None:
    model = nemc.compile(text=ROBOT_ARM)
    assert model.name == "robot_arm" and model.metadata["source"] == "<text>"
    np.testing.assert_allclose(model.rhs(0.0, [0.3, 0.1]), model_of("robot_arm").rhs(
        0.0, [0.3, 0.1]), rtol=1e-15)
    with pytest.raises(InputError, match=r"^<text>:\d+: bodies\.link\.mass: .*'\*\*'"):
        nemc.compile(text=ROBOT_ARM.replace("mass: m", "mass: m^2"))
    with pytest.raises(InputError, match=r"^cell 3:\d+: bodies\.link\.mass: must be >= 0"):
        nemc.compile(text=ROBOT_ARM.replace("mass: m", "mass: -1"), name="cell 3")
    with pytest.raises(TypeError):
        nemc.compile(EXAMPLES / "robot_arm.yaml", text=ROBOT_ARM)


def test_to_pandas_holds_the_table_with_units() -> None:
    model = model_of("compound_pendulum")
    res = model.simulate()
    frame = res.to_pandas()
    assert frame.index.name == "t"
    np.testing.assert_array_equal(frame.index.to_numpy(), res.t)
    assert list(frame.columns) == [*model.state_names, *model.output_names]
    np.testing.assert_array_equal(frame["dot(theta)"].to_numpy(), res.y[1])
    np.testing.assert_array_equal(frame["O.Fy"].to_numpy(), res.outputs["O.Fy"])
    assert frame.attrs["units"]["O.Fy"] == "lb" and frame.attrs["units"]["t"] == "s"
    assert frame.loc[0.0, "ddot(theta)"] == pytest.approx(
        -3 * 32.2 / (2 * 3) * math.cos(math.pi / 4), rel=1e-12)


def test_models_and_results_display_as_html() -> None:
    model = model_of("double_pendulum")
    assert Model._repr_html_ is model_html  # what a notebook shows
    page = model_html(model)
    assert "double_pendulum" in page and "<td>dot(q1)</td>" in page and "<td>m2</td>" in page
    assert "<td>N</td>" in page  # the reactions' unit
    res = model.simulate()
    assert SimulationResult._repr_html_ is SimulationResult.to_html
    table = res.to_html()
    assert "RK45" in table and table.count("<tr>") == 1 + len(res.t)  # 11 rows: all shown
    assert "<th>dot(q1)<br>[rad/s]</th>" in table and "<th>A.Fx<br>[N]</th>" in table
    long = model.simulate(t_eval=np.linspace(0, 5, 50)).to_html()
    assert long.count("<tr>") == 1 + 11 and "&hellip;" in long  # 5 first, ..., 5 last


# ---- the book's 5.4 settles at 29.53 degrees --------------------------------------------------


def test_two_link_arm_settles_where_its_control_law_balances() -> None:
    """The equilibrium of the controlled arm (accelerations zero at rest) is
    q1 = q1f - m2 g L2/2 cos(q2f) / g01 (T01 leaves link 2's reaction torque uncompensated),
    q2 = q2f; the run reaches it."""
    model = model_of("two_link_robot_arm")
    q = fsolve(lambda v: model.rhs(0.0, [v[0], 0.0, v[1], 0.0])[[1, 3]], [0.5, 1.0],
               xtol=1e-14)
    expected = math.pi / 6 - 1 * 9.81 * 0.5 * math.cos(math.pi / 3) / 300
    assert q[0] == pytest.approx(expected, rel=1e-12)
    assert q[1] == pytest.approx(math.pi / 3, rel=1e-12)
    assert math.degrees(q[0]) == pytest.approx(29.5316, abs=1e-4)
    late = model.simulate(t_span=(0, 60), rtol=1e-10, atol=1e-12)
    assert late.y[0, -1] == pytest.approx(expected, abs=1e-9)
