"""The model as a plant (format v3 `inputs:`, interface.md "the model as a plant"): inputs set at
run time in C by every method, each way checked against an independent path; the exact
linearization against complex-step derivatives of the Lagrange oracle (tests/reference.py) and
a closed loop's against its closed-form one-degree-of-freedom reduction; trim; Floquet
multipliers against Kapitza's small-amplitude theory; an LQR design closed through
nemc.feedback; and one clear error for each kind of misuse."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from reference import complex_step_linearization
from scipy.linalg import solve_continuous_are

import nemc
from nemc.errors import InputError
from nemc.front.validate import validate_text
from nemc.runtime.failures import ModelError

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
NATIVE = ("nemc.DOP853", "nemc.Vern9", "nemc.Radau", "nemc.Taylor")

CART_POLE = """\
name: cart_pole
parameters: {M: 1.0, m: 0.3, L: 0.5, g: 9.81, c: 0.1}
inputs:
  F: 0
gravity: [0, -g]
bodies:
  cart: {mass: M, inertia: 0.01}
  pole: {mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {tip: [L, 0]}}
joints:
  rail: {type: prismatic, parent: ground, child: cart, coordinate: x}
  hinge: {type: revolute, parent: cart, child: pole, coordinate: th, angle: absolute}
loads:
  - {force: [F, 0], body: cart}
  - {torque: -c*dot(th)*F**2/(1 + F**2), body: pole, reaction: cart}
outputs:
  reactions: [hinge]
  energy: true
  points: [pole.tip]
  accelerations: true
  expressions: {power: "F*dot(x)", lean: "L*cos(th) + F*sin(th)"}
simulation:
  t_span: [0, 2]
  initial: {th: 1.7}
"""


@pytest.fixture(scope="module")
def cart_pole(tmp_path_factory: pytest.TempPathFactory) -> nemc.runtime.Model:
    path = tmp_path_factory.mktemp("plant") / "cart_pole.yaml"
    path.write_text(CART_POLE)
    return nemc.compile(path)


def with_force(value: str) -> str:
    """The cart-pole with F written into the file: the independent path for a constant."""
    return CART_POLE.replace("inputs:\n  F: 0\n", "").replace("F", f"({value})")


# ---- the format --------------------------------------------------------------------------


@pytest.mark.parametrize("text, where, message", [
    (CART_POLE.replace("inertia: 0.01", "inertia: F"), "bodies.cart.inertia",
     "'F' is an input, not allowed in body"),
    (CART_POLE.replace("initial: {th: 1.7}", "initial: {th: 1.7}\n  inputs: {G: 2}"),
     "simulation.inputs.G", "unknown input 'G'; the inputs: F"),
    (CART_POLE.replace("F: 0\n", "F: 1/0*g\n"), "inputs.F", "finite"),
    (CART_POLE.replace("F: 0\n", "F: dot(x)\n"), "inputs.F", "not allowed in inputs"),
    (CART_POLE.replace("  F: 0\n", "  g: 0\n"), "inputs.g", "already used by the parameter"),
    (CART_POLE.replace("initial: {th: 1.7}", "initial: {th: 1.7}\n  inputs: {F: x}"),
     "simulation.inputs.F", "not allowed in simulation.inputs"),
])
def test_bad_inputs_are_refused_with_their_line(text: str, where: str, message: str) -> None:
    with pytest.raises(InputError) as caught:
        validate_text(text.encode(), "cart_pole.yaml")
    found = str(caught.value)
    assert "cart_pole.yaml:" in found and where in found and message in found, found


# ---- runs with inputs ----------------------------------------------------------------------


def final_state(model, method: str, **options) -> np.ndarray:
    result = model.simulate((0.0, 2.0), method=method, rtol=1e-11, atol=1e-12,
                            t_eval=[0.5, 1.0, 1.5, 2.0], **options)
    assert result.success, result.message
    return result.y


@pytest.mark.parametrize("method", [*NATIVE, "DOP853", "auto"])
def test_a_constant_input_is_the_constant_in_the_file(cart_pole, method: str,
                                                      tmp_path: Path) -> None:
    path = tmp_path / "cart_pole_pushed.yaml"
    path.write_text(with_force("0.7"))
    written = final_state(nemc.compile(path), method)
    np.testing.assert_allclose(final_state(cart_pole, method, inputs={"F": 0.7}), written,
                               rtol=0, atol=1e-9)


def test_the_scene_sets_an_input_by_an_expression_of_t(cart_pole, tmp_path: Path) -> None:
    scene = CART_POLE.replace("initial: {th: 1.7}", "initial: {th: 1.7}\n  inputs: {F: "
                              "0.5*sin(3*t)}")
    path = tmp_path / "scene_input.yaml"
    path.write_text(scene)
    model = nemc.compile(path)
    reference = final_state(cart_pole, "DOP853", inputs={"F": lambda t, y: 0.5 * np.sin(3 * t)})
    for method in NATIVE:
        np.testing.assert_allclose(final_state(model, method), reference, atol=1e-8)


@pytest.mark.parametrize("method", [*NATIVE, "DOP853", "LSODA"])
def test_a_table_is_linear_between_samples_held_beyond(cart_pole, method: str) -> None:
    """Against scipy with numpy's interp as the input (an independent interpolation), the
    samples as tstops: every method, forward and back."""
    times, values = np.array([0.2, 0.7, 1.0, 1.6]), np.array([0.0, 1.5, -0.5, 0.8])
    reference = final_state(cart_pole, "DOP853", tstops=times,
                            inputs={"F": lambda t, y: np.interp(t, times, values)})
    forward = final_state(cart_pole, method, inputs={"F": (times, values)})
    np.testing.assert_allclose(forward, reference, atol=1e-8)
    y_end = reference[:, -1]
    back = cart_pole.simulate((2.0, 0.0), y_end, method=method, rtol=1e-11, atol=1e-12,
                              t_eval=[0.0], inputs={"F": (times, values)})
    np.testing.assert_allclose(back.y[:, -1], cart_pole.initial_state(), atol=1e-7)


@pytest.mark.parametrize("method", [*NATIVE, "DOP853"])
def test_a_feedback_runs_in_c_as_the_same_law_in_python(cart_pole, method: str) -> None:
    K = np.array([-1.0, -2.0, 30.0, 4.0])
    y_ref = np.array([0.0, 0.0, np.pi / 2, 0.0])
    reference = final_state(cart_pole, "DOP853",
                            inputs={"F": lambda t, y: 0.2 - K @ (y - y_ref)})
    ours = final_state(cart_pole, method, inputs={"F": nemc.feedback(K, y_ref, 0.2)})
    np.testing.assert_allclose(ours, reference, atol=1e-8)


def test_outputs_are_at_the_inputs_values(cart_pole) -> None:
    times, values = np.array([0.0, 2.0]), np.array([1.0, 3.0])
    result = cart_pole.simulate((0, 2), method="nemc.Vern9", t_eval=[0.5, 1.0],
                                inputs={"F": (times, values)})
    force = np.interp(result.t, times, values)
    np.testing.assert_allclose(result.outputs["power"], force * result.y[1], rtol=1e-14)


@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Taylor"])
def test_ensembles_take_the_same_inputs_bit_for_bit(cart_pole, method: str) -> None:
    """A feedback shared, a constant run by run, a table shared: each run as simulate's."""
    K = nemc.feedback([0.0, 0.0, 5.0, 1.0], [0, 0, np.pi / 2, 0])
    y0s = np.array([[0, 0, 1.6, 0], [0, 0, 1.5, 0.1], [0.1, 0, 1.4, 0]])
    table = (np.array([0.0, 0.4, 1.0]), np.array([0.0, 1.0, -1.0]))
    for inputs, single_inputs in (({"F": K}, lambda k: {"F": K}),
                                  ({"F": np.array([0.1, -0.2, 0.3])},
                                   lambda k: {"F": [0.1, -0.2, 0.3][k]}),
                                  ({"F": table}, lambda k: {"F": table})):
        runs = cart_pole.simulate_many(y0s, method=method, t_span=(0, 1), t_eval=[1.0],
                                       inputs=inputs)
        for k, y0 in enumerate(y0s):
            single = cart_pole.simulate((0, 1), y0, method=method, t_eval=[1.0],
                                        inputs=single_inputs(k))
            np.testing.assert_array_equal(runs.y[k][:, -1], single.y[:, -1])


# ---- the linearization ---------------------------------------------------------------------


def relative_error(ours: np.ndarray, reference: np.ndarray) -> float:
    return float(np.abs(ours - reference).max() / max(np.abs(reference).max(), 1.0))


def test_a_and_b_are_the_complex_step_derivatives_of_the_oracle(cart_pole) -> None:
    mech = validate_text(CART_POLE.encode(), "cart_pole.yaml")
    rng = np.random.default_rng(46)
    for _ in range(5):
        y, u = rng.uniform(-1.5, 1.5, 4), float(rng.uniform(-2, 2))
        lin = cart_pole.linearize(y, {"F": u}, t=0.3)
        a, b = complex_step_linearization(mech, 0.3, y, {"F": u})
        assert relative_error(lin.A, a) < 1e-12 and relative_error(lin.B, b) < 1e-12


@pytest.mark.parametrize("example", ["double_pendulum", "robot_arm", "prismatic_cart_pendulum",
                                     "free_body_on_spring", "joint_spring_telescope",
                                     "weld_t_pendulum", "damped_spring_pendulum"])
def test_every_tree_example_linearizes_as_the_oracle(example: str) -> None:
    path = EXAMPLES / f"{example}.yaml"
    model = nemc.compile(path)
    mech = validate_text(path.read_bytes(), path.name)
    rng = np.random.default_rng(7)
    for _ in range(3):
        y = rng.uniform(-1, 1, model.n_state)
        a, _ = complex_step_linearization(mech, 0.2, y, {})
        assert relative_error(model.linearize(y, t=0.2).A, a) < 1e-12


def central_differences(f, x: np.ndarray, h: float = 1e-5) -> np.ndarray:
    columns = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h * max(1.0, abs(x[j]))
        columns.append((f(x + e) - f(x - e)) / (2 * e[j]))
    return np.column_stack(columns)


def test_c_and_d_are_the_outputs_derivatives(cart_pole) -> None:
    """Against central differences of the outputs (a different way of differentiating the
    same outputs): reactions, energy, points, accelerations and expressions."""
    y, u = np.array([0.3, -0.4, 1.2, 0.7]), 0.6
    lin = cart_pole.linearize(y, {"F": u})
    names = cart_pole.output_names

    def outputs(x: np.ndarray) -> np.ndarray:
        p_u = x[4]
        result = cart_pole.simulate((0, 0), x[:4], t_eval=[0.0], method="nemc.DOP853",
                                    inputs={"F": p_u})
        return np.array([result.outputs[name][0] for name in names])

    numeric = central_differences(outputs, np.append(y, u))
    np.testing.assert_allclose(lin.C, numeric[:, :4], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(lin.D, numeric[:, 4:], rtol=1e-6, atol=1e-7)


def fourbar_reduction(theta: float) -> tuple[float, float]:
    """The four-bar's one-degree-of-freedom form m(q1) q1'' + m'(q1) q1'^2 / 2 + V'(q1) = 0 in
    closed form (the loop closed by the law of cosines, open branch), at rest:
    d q1''/d q1 = -V''(q1) / m(q1)."""
    q1 = sp.Symbol("q1")
    l0, l1, l2, l3, m1, m2, m3, g = 0.4, 0.1, 0.35, 0.3, 0.5, 1.5, 1.2, 9.81
    b = sp.Matrix([l1 * sp.cos(q1), l1 * sp.sin(q1)])
    d = sp.Matrix([l0, 0])
    bd = d - b
    r = sp.sqrt(bd.dot(bd))
    gamma = sp.atan2(bd[1], bd[0])
    q2 = gamma + sp.acos((l2**2 + r**2 - l3**2) / (2 * l2 * r))  # the open assembly
    c = b + l2 * sp.Matrix([sp.cos(q2), sp.sin(q2)])
    q3 = sp.atan2(c[1], c[0] - l0)
    coms = [b / 2, b + l2 / 2 * sp.Matrix([sp.cos(q2), sp.sin(q2)]),
            d + l3 / 2 * sp.Matrix([sp.cos(q3), sp.sin(q3)])]
    angles, masses, lengths = [q1, q2, q3], [m1, m2, m3], [l1, l2, l3]
    mass = sum(mk * sp.diff(ck, q1).dot(sp.diff(ck, q1)) + mk * lk**2 / 12 * sp.diff(ak, q1)**2
               for mk, ck, ak, lk in zip(masses, coms, angles, lengths))
    potential = sum(mk * g * ck[1] for mk, ck in zip(masses, coms))
    at = {q1: theta}
    return float(mass.subs(at)), float(sp.diff(potential, q1, 2).subs(at))


def test_a_closed_loops_a_is_its_closed_form_reduction() -> None:
    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    op = model.trim({"q1": -1.5, "q2": -0.2, "q3": 1.2})
    lin = model.linearize(op.y)
    assert lin.state_names == ("q1", "dot(q1)") and lin.dependent == ("q2", "q3")
    mass, stiffness = fourbar_reduction(op.y[0])
    expected = np.array([[0.0, 1.0], [-stiffness / mass, 0.0]])
    assert relative_error(lin.A, expected) < 1e-10
    frequency = lin.modes().frequencies
    np.testing.assert_allclose(frequency, np.sqrt(stiffness / mass), rtol=1e-10)
    other = model.linearize(op.y, independent=["q3"])  # the same motion in another coordinate
    np.testing.assert_allclose(other.modes().frequencies, frequency, rtol=1e-10)


def test_a_closed_loops_c_and_d_are_its_outputs_derivatives() -> None:
    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    y = model.simulate((0, 0.3), t_eval=[0.3]).y[:, 0]
    lin = model.linearize(y)
    step = 1e-6
    for column in range(2):  # along the reduced state's directions, on the constraints
        direction = lin.tangent[:, column] * step
        up = model.loops.projected(np.array([0.0]), (y + direction).reshape(-1, 1),
                                   model.parameter_vector())[:, 0]
        down = model.loops.projected(np.array([0.0]), (y - direction).reshape(-1, 1),
                                     model.parameter_vector())[:, 0]
        out_up, out_down = model.outputs(0.0, up), model.outputs(0.0, down)
        numeric = np.array([(out_up[n] - out_down[n]) / (2 * step) for n in
                            model.output_names])
        np.testing.assert_allclose(lin.C[:, column], numeric, rtol=1e-5, atol=1e-5)


# ---- trim, Floquet, LQR -------------------------------------------------------------------


def test_trim_finds_the_cart_poles_upright_and_says_what_it_leaves(cart_pole) -> None:
    op = cart_pole.trim({"th": 1.4, "x": 0.3})
    assert op.y[2] == pytest.approx(np.pi / 2, abs=1e-12) and op.residual < 1e-12
    assert op.undetermined == ("x",) and op.y[0] == 0.3  # the cart may stand anywhere
    with pytest.raises(ModelError, match=r"does not fix \['x'\]"):
        cart_pole.trim(free=["x", "th"])
    with pytest.raises(ModelError, match=r"no equilibrium: d\(dot\(x\)\)/dt stays"):
        cart_pole.trim(u={"F": 1.0}, free=["th"])  # a pushed cart never comes to rest


def test_floquet_finds_kapitzas_stability_boundary() -> None:
    """Upright stable for A^2 W^2 > 2 g l (l = 2L/3 for a rod; Landau and Lifshitz, section
    30): the boundary in W, bisected on the monodromy's trace (|tr| = 2), within 0.5%."""
    model = nemc.compile(EXAMPLES / "kapitza.yaml")
    amplitude, length, g = 0.002, 0.3, 9.81
    theory = np.sqrt(2 * g * 2 * length / 3) / amplitude

    def unstable(w: float) -> bool:
        result = model.floquet(2 * np.pi / w, {"th": np.pi / 2}, params={"A": amplitude,
                                                                         "W": w})
        return abs(np.trace(result.monodromy)) > 2

    low, high = 0.9 * theory, 1.1 * theory
    assert unstable(low) and not unstable(high)
    for _ in range(12):
        middle = (low + high) / 2
        low, high = (middle, high) if unstable(middle) else (low, middle)
    assert abs(high / theory - 1) < 0.005


def test_an_lqr_design_from_linearize_holds_the_pole_up(cart_pole) -> None:
    op = cart_pole.trim({"th": 1.5})
    lin = cart_pole.linearize(op.y, op.u)
    Q, R = np.diag([1.0, 1.0, 10.0, 1.0]), np.array([[0.1]])
    P = solve_continuous_are(lin.A, lin.B, Q, R)
    K = np.linalg.solve(R, lin.B.T @ P)
    assert np.all(np.linalg.eigvals(lin.A - lin.B @ K).real < 0)
    start = op.y + np.array([0.0, 0.0, 0.3, 0.0])
    result = cart_pole.simulate((0, 10), start, method="nemc.DOP853", t_eval=[10.0],
                                inputs={"F": lin.feedback(K)})
    assert result.success and np.abs(result.y[:, -1] - op.y).max() < 1e-3
    open_loop = cart_pole.simulate((0, 3), start, method="nemc.DOP853", t_eval=[3.0])
    assert abs(open_loop.y[2, -1] - np.pi / 2) > 0.3  # it falls without


# ---- misuse ----------------------------------------------------------------------------------


@pytest.mark.parametrize("inputs, message", [
    ({"G": 1.0}, "unknown input 'G'; this model's inputs: F"),
    ({"F": nemc.feedback(np.ones(3))}, r"feedback gain K of shape \(3,\): expected \(1, 4\)"),
    ({"F": ([0.0, 1.0], [1.0, np.nan])}, "input F's table values: not every entry is finite"),
    ({"F": ([1.0, 0.5], [1.0, 2.0])}, "its times must increase"),
    ({"F": "push"}, "input F: expected a number, a table"),
    ({"F": np.inf}, "is not a finite number"),
    ([1.0], "inputs: expected a mapping"),
])
def test_bad_inputs_at_run_time_get_one_clear_error(cart_pole, inputs, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        cart_pole.simulate((0, 1), inputs=inputs)


def test_a_python_input_needs_scipys_methods(cart_pole) -> None:
    with pytest.raises(ModelError, match="runs with scipy's methods"):
        cart_pole.simulate((0, 1), method="nemc.DOP853", inputs={"F": lambda t, y: 1.0})
    assert cart_pole.simulate((0, 1), inputs={"F": lambda t, y: 1.0}).method == "LSODA"


def test_a_sweep_takes_inputs_as_simulate_many(cart_pole) -> None:
    pytest.importorskip("xarray")
    forces = np.array([0.0, 0.5, -0.5, 1.0])
    swept = nemc.sweep(cart_pole, params={"c": 0.1}, t_span=(0, 1), t_eval=[1.0],
                       method="nemc.DOP853", inputs={"F": forces})
    many = cart_pole.simulate_many(np.tile(cart_pole.initial_state(), (4, 1)), t_span=(0, 1),
                                   t_eval=[1.0], method="nemc.DOP853", inputs={"F": forces})
    np.testing.assert_array_equal(swept.dataset["y"].values[:, :, -1], many.y[:, :, -1])
    np.testing.assert_array_equal(swept.dataset["F"].values, forces)


def test_the_command_line_linearizes(tmp_path: Path, capsys) -> None:
    from nemc.tools.cli import main

    path = tmp_path / "cart_pole.yaml"
    path.write_text(CART_POLE)
    out = tmp_path / "lin.npz"
    assert main(["linearize", str(path), "--at", "th=1.5707963267948966", "--input", "F=0",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "A = d(dy/dt)/dy (4 x 4)" in printed and "B = d(dy/dt)/du (4 x 1)" in printed
    saved = np.load(out)
    model = nemc.compile(path)
    lin = model.linearize({"th": np.pi / 2}, {"F": 0.0})
    np.testing.assert_array_equal(saved["A"], lin.A)
    np.testing.assert_array_equal(saved["B"], lin.B)
    assert main(["linearize", str(path), "--input", "G=1"]) == 2
    assert "unknown inputs ['G']" in capsys.readouterr().err
