"""Arrays handed to a compiled model: refused with ModelError, or converted to exactly what C
expects (contiguous float64 of the right length) -- never a pointer C could read past."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.runtime.model import Model, ModelError

ROOT = Path(__file__).resolve().parent.parent
COMPOUND = ROOT / "examples" / "compound_pendulum.yaml"  # state [theta, dot(theta)], outputs
Y = np.array([0.4, -0.3])
YS = np.array([[0.4, 0.1, -1.2], [-0.3, 0.0, 2.5]])  # three states, (n_state, 3)


@pytest.fixture(scope="module")
def model() -> Model:
    return nemc.compile(COMPOUND, jacobian=True)


def single_calls(model: Model) -> dict[str, Callable]:
    """Every entry point that takes one state, returning an array."""
    return {
        "rhs": lambda y, t=0.5, params=None: model.rhs(t, y, params=params),
        "jacobian": lambda y, t=0.5, params=None: model.jacobian(t, y, params=params),
        "outputs": lambda y, t=0.5, params=None: np.array(
            list(model.outputs(t, y, params=params).values())),
    }


def many_calls(model: Model) -> dict[str, Callable]:
    """Every entry point that takes states of shape (n_state, n)."""
    return {
        "rhs_many": lambda ys, t=0.5, params=None: model.rhs_many(t, ys, params=params),
        "outputs": lambda ys, t=0.5, params=None: np.array(
            list(model.outputs(t, ys, params=params).values())),
    }


BAD_STATES = [
    ([0.4], r"shape \(2,\)"),
    ([0.4, -0.3, 0.0], r"shape \(2,\)"),
    ([0.4, -0.3, 0.0, 1.0], r"shape \(2,\)"),  # would fit (2, 2) if reshaped: must not be
    (np.float64(0.4), r"shape \(2,\)"),
    (np.zeros(0), r"shape \(2,\)"),
    (np.zeros((1, 2)), r"shape \(2,\)"),
    (np.zeros((2, 1, 1)), r"shape \(2,\)"),
    (["a", "b"], "real numbers"),
    (np.array([1, None], dtype=object), "real numbers"),
    (np.array([0.4 + 1j, 0.0]), "real numbers"),
    ([[0.4], [0.1, 0.2]], "array of real numbers"),  # ragged
    (None, "real numbers"),
    ({"theta": 1.0}, "real numbers"),
]


@pytest.mark.parametrize("y, message", BAD_STATES, ids=range(len(BAD_STATES)))
@pytest.mark.parametrize("call", ["rhs", "jacobian", "outputs"])
def test_bad_single_state_is_refused(model: Model, call: str, y, message: str) -> None:
    if call == "outputs" and np.ndim(np.asarray(y, dtype=object)) != 1:
        message = "shape|real"  # outputs reads anything not 1-d as many states
    with pytest.raises(ModelError, match=message):
        single_calls(model)[call](y)


BAD_MANY = [
    (np.zeros((3, 4)), r"shape \(2, n\)"),
    (np.zeros(4).reshape(1, 4), r"shape \(2, n\)"),
    (np.zeros((2, 2, 2)), r"shape \(2, n\)"),
    (np.zeros((2, 3), dtype=complex), "real numbers"),
    (np.array([[1, "x"], [2, 3]], dtype=object), "real numbers"),
    (np.float64(1.0), r"shape \(2, n\)"),
]


@pytest.mark.parametrize("ys, message", BAD_MANY, ids=range(len(BAD_MANY)))
@pytest.mark.parametrize("call", ["rhs_many", "outputs"])
def test_bad_many_states_are_refused(model: Model, call: str, ys, message: str) -> None:
    if call == "outputs" and np.ndim(ys) == 1:
        pytest.skip("a 1-d array is one state for outputs")
    with pytest.raises(ModelError, match=message):
        many_calls(model)[call](ys)


@pytest.mark.parametrize("t, message", [
    (np.array([0.1, 0.2]), "scalar"),
    ("soon", "real numbers"),
    (1j, "real numbers"),
    (None, "real numbers"),
])
@pytest.mark.parametrize("call", ["rhs", "jacobian"])
def test_bad_time_is_refused(model: Model, call: str, t, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        single_calls(model)[call](Y, t=t)


@pytest.mark.parametrize("t, message", [
    (np.zeros(2), r"shape \(3,\)"),
    (np.zeros(4), r"shape \(3,\)"),
    (np.zeros((3, 1)), r"shape \(3,\)"),
    ("soon", "real numbers"),
])
@pytest.mark.parametrize("call", ["rhs_many", "outputs"])
def test_bad_times_are_refused(model: Model, call: str, t, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        many_calls(model)[call](YS, t=t)


def unusual_layouts(y: np.ndarray) -> dict[str, np.ndarray | list]:
    """The same values in every layout and type a caller might hand over."""
    strided = np.empty(2 * y.size)
    strided[::2] = y
    strided[1::2] = np.nan  # what C would read if it ignored the stride
    readonly = y.copy()
    readonly.flags.writeable = False
    return {
        "list": y.tolist(),
        "strided view": strided[::2],
        "read-only": readonly,
        "big-endian": y.astype(">f8"),
        "reversed view": y[::-1].copy()[::-1],
    }


@pytest.mark.parametrize("call", ["rhs", "jacobian", "outputs"])
def test_single_state_layouts_are_converted_exactly(model: Model, call: str) -> None:
    function = single_calls(model)[call]
    expected = function(Y)
    for name, y in unusual_layouts(Y).items():
        np.testing.assert_array_equal(function(y), expected, err_msg=name)
    integers = np.array([1, -2])
    np.testing.assert_array_equal(function(integers), function(integers.astype(float)))
    np.testing.assert_array_equal(function(np.float32([0.5, 0.25])), function([0.5, 0.25]))


@pytest.mark.parametrize("call", ["rhs_many", "outputs"])
def test_many_state_layouts_are_converted_exactly(model: Model, call: str) -> None:
    function = many_calls(model)[call]
    expected = function(YS)
    wide = np.full((2, 6), np.nan)
    wide[:, ::2] = YS
    readonly = YS.copy()
    readonly.flags.writeable = False
    layouts = {"fortran": np.asfortranarray(YS), "strided": wide[:, ::2], "read-only": readonly,
               "transposed": YS.T.copy().T, "list": YS.tolist(), "big-endian": YS.astype(">f8")}
    for name, ys in layouts.items():
        np.testing.assert_array_equal(function(ys), expected, err_msg=name)
    columns = [function(YS[:, [k]]) for k in range(YS.shape[1])]
    np.testing.assert_array_equal(np.hstack(columns), expected)  # one state at a time agrees
    assert function(np.zeros((2, 0))).shape[-1] == 0


def test_inputs_are_never_written(model: Model) -> None:
    y, ys = Y.copy(), YS.copy()
    model.rhs(0.0, y), model.jacobian(0.0, y), model.outputs(0.0, y)
    model.rhs_many(0.0, ys), model.outputs(0.0, ys)
    np.testing.assert_array_equal(y, Y)
    np.testing.assert_array_equal(ys, YS)


BAD_PARAMS = [
    ({"W": float("nan")}, "finite"),
    ({"W": float("inf")}, "finite"),
    ({"W": -12.0}, "bodies.rod.mass must be >= 0"),
    ({"W": 0.0}, r"joints.O \(mass or inertia of body 'rod' and what it carries\) must be > 0"),
    ({"W": "12"}, "expected a real number"),
    ({"W": 1 + 2j}, "expected a real number"),
    ({"W": None}, "expected a number"),
    ({"W": [12.0]}, "expected a number"),
    ({"W": np.array([12.0, 1.0])}, "expected a number"),
    ({"W": 10**400}, "expected a number"),
    ({"m": 1.0}, "derived"),
    ({"Wx": 1.0}, "did you mean 'W'"),
    ({1: 1.0}, "names are strings"),
    ([("W", 12.0)], "must be a mapping"),
]


@pytest.mark.parametrize("params, message", BAD_PARAMS, ids=range(len(BAD_PARAMS)))
def test_bad_params_are_refused_everywhere(model: Model, params, message: str) -> None:
    for name, call in {**single_calls(model), **many_calls(model)}.items():
        y = YS if name in ("rhs_many",) else Y
        with pytest.raises(ModelError, match=message):
            call(y, params=params)
    with pytest.raises(ModelError, match=message):
        model.simulate((0, 1), params=params)


def test_a_refused_override_leaves_the_next_call_right(model: Model) -> None:
    expected = model.rhs(0.0, Y, params={"W": 24.0})
    with pytest.raises(ModelError):
        model.rhs(0.0, Y, params={"W": -1.0})
    np.testing.assert_array_equal(model.rhs(0.0, Y, params={"W": np.float32(24.0)}), expected)
    np.testing.assert_array_equal(model.rhs(0.0, Y, params={"W": 24}), expected)


def test_a_params_dict_passed_again_is_checked_again_once_changed(model: Model) -> None:
    """The latest params dict is kept by its names and value objects (a repeated dict costs
    nothing): the same dict with a value replaced, even by an equal value of another kind, a
    name added, or a mutable value changed in place under the same object, is checked in full,
    refused as a fresh dict would be, and otherwise gives a fresh dict's numbers bit for bit."""
    calls = single_calls(model)
    params = {"W": 24.0}
    expected = {name: call(Y, params={"W": 24.0}) for name, call in calls.items()}
    for _ in range(2):  # checked, then kept
        for name, call in calls.items():
            np.testing.assert_array_equal(call(Y, params=params), expected[name])
    for bad, message in [(-1.0, "bodies.rod.mass must be >= 0"), (float("nan"), "finite"),
                         (24 + 0j, "expected a real number"), ("24", "expected a real number"),
                         (np.array([24.0, 1.0]), "expected a number")]:
        params["W"] = bad
        for call in calls.values():
            with pytest.raises(ModelError, match=message):
                call(Y, params=params)
        params["W"] = 24.0
        for name, call in calls.items():  # and the dict as it was is right again
            np.testing.assert_array_equal(call(Y, params=params), expected[name])
    params["Wx"] = 1.0
    with pytest.raises(ModelError, match="did you mean 'W'"):
        model.rhs(0.0, Y, params=params)
    del params["Wx"]
    params["W"] = 36.0
    np.testing.assert_array_equal(model.rhs(0.5, Y, params=params),
                                  model.rhs(0.5, Y, params={"W": 36.0}))
    value = np.array(24.0)  # a mutable value: the same object, another number
    held = {"W": value}
    np.testing.assert_array_equal(model.rhs(0.5, Y, params=held), expected["rhs"])
    value[...] = -1.0
    with pytest.raises(ModelError, match="bodies.rod.mass must be >= 0"):
        model.rhs(0.5, Y, params=held)
    value[...] = 36.0
    np.testing.assert_array_equal(model.rhs(0.5, Y, params=held),
                                  model.rhs(0.5, Y, params={"W": 36.0}))
