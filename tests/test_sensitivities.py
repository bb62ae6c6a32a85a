"""Forward sensitivities along a run (issue 47; interface.md "the model as a plant"): the
variational equations integrated with the state against two independent paths, central
differences of tight runs (rtol 1e-13) and an augmented system built from the Lagrange oracle
(tests/reference.py: M and f differentiated by sympy, integrated by solve_ivp at 1e-12); the
outputs' sensitivities against differences of the outputs; and one clear refusal for each
thing that has none."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import sympy as sp
from reference import ReferenceModel, _definitions
from scipy.integrate import solve_ivp

import nemc
from nemc.front.mechanism import TIME, symbol
from nemc.front.validate import validate_text
from nemc.runtime.failures import ModelError

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
TIGHT = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-14}

# The book's 5.1 pendulum with a viscous damper at its pin and its initial angle a parameter
# (so d y0 / d theta0 starts a column).
DAMPED_PENDULUM = """\
name: damped_pendulum
parameters: {W: 12, L: 3, g: 32.2, m: W/g, c: 0.4, theta0: 0.7}
gravity: [0, -g]
bodies:
  rod: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  O: {type: revolute, parent: ground, child: rod, coordinate: theta}
loads:
  - {torque: -c*dot(theta), body: rod}
outputs:
  reactions: [O]
  energy: true
simulation:
  t_span: [0, 4]
  initial: {theta: theta0}
  t_eval: {step: 0.25}
"""


@pytest.fixture(scope="module")
def double_pendulum() -> nemc.runtime.Model:
    return nemc.compile(EXAMPLES / "double_pendulum.yaml")


@pytest.fixture(scope="module")
def damped(tmp_path_factory: pytest.TempPathFactory) -> nemc.runtime.Model:
    path = tmp_path_factory.mktemp("sens") / "damped_pendulum.yaml"
    path.write_text(DAMPED_PENDULUM)
    return nemc.compile(path)


def relative_error(ours: np.ndarray, reference: np.ndarray) -> float:
    return float(np.abs(ours - reference).max() / max(np.abs(reference).max(), 1e-300))


def differences(model, name: str, value: float, t_eval: np.ndarray, h: float,
                **run) -> np.ndarray:
    """d y(t) / d NAME by central differences of tight runs (a parameter, or a state entry's
    initial value)."""
    ends = []
    for sign in (1, -1):
        if name in model.parameter_names:
            params = {**run.get("params", {}), name: value + sign * h}
            result = model.simulate(t_eval=t_eval, **{**run, "params": params}, **TIGHT)
        else:
            y0 = np.array(run["y0"], dtype=float)
            y0[model.state_names.index(name)] += sign * h
            result = model.simulate(t_eval=t_eval, **{**run, "y0": y0}, **TIGHT)
        ends.append(result.y)
    return (ends[0] - ends[1]) / (2 * h)


def test_double_pendulum_matches_central_differences(double_pendulum) -> None:
    model = double_pendulum
    t_eval = np.linspace(0, 3, 31)
    y0 = model.initial_state()
    res = model.simulate((0, 3), y0, t_eval=t_eval, sensitivities=["y0", *model.parameter_names],
                         method="DOP853", rtol=1e-12, atol=1e-14)
    assert res.success, res.message
    assert res.sensitivities["y0"].shape == (4, 4, 31)
    assert np.array_equal(res.t, t_eval)
    for name, value in model.parameters.items():
        assert res.sensitivities[name].shape == (4, 31)
        reference = differences(model, name, value, t_eval, 1e-5 * max(1.0, value), y0=y0)
        assert relative_error(res.sensitivities[name], reference) < 1e-7, name
    for j, name in enumerate(model.state_names):
        reference = differences(model, name, y0[j], t_eval, 1e-6, y0=y0)
        assert relative_error(res.sensitivities["y0"][:, j], reference) < 1e-7, name


def test_a_parameter_of_the_initial_state_starts_its_column(damped) -> None:
    """theta(0) = theta0: d y / d theta0 starts at e_theta, and equals d y / d theta(0)."""
    res = damped.simulate(sensitivities=["theta0", "theta", "c"], rtol=1e-12, atol=1e-14)
    assert np.array_equal(res.sensitivities["theta0"][:, 0], [1.0, 0.0])
    assert relative_error(res.sensitivities["theta0"], res.sensitivities["theta"]) < 1e-12
    reference = differences(damped, "c", 0.4, res.t, 1e-6, y0=damped.initial_state())
    assert relative_error(res.sensitivities["c"], reference) < 1e-7
    given = damped.simulate(y0=[0.7, 0.0], sensitivities=["theta0"])
    assert np.all(given.sensitivities["theta0"] == 0.0)  # a given y0 does not move with it


def oracle_sensitivities(path: Path, names: list[str], t_eval: np.ndarray,
                         y0: np.ndarray) -> dict[str, np.ndarray]:
    """The variational equations of the Lagrange oracle: qdd = M^-1 f, its derivatives
    d qdd = M^-1 (df - dM qdd) from sympy's of M and f (derived parameters written out), the
    state and the columns integrated by solve_ivp at 1e-12."""
    mech = validate_text(path.read_bytes(), path.name)
    oracle = ReferenceModel(mech)
    lag, n = oracle.lagrangian, oracle.n
    definitions = _definitions(mech)
    runtime = {p.name for p in mech.parameters if p.name in names}
    expand = {s: e for s, e in definitions.items() if s.name not in runtime}
    mass, force = oracle.M, oracle.f
    for _ in range(len(expand) + 1):  # derived parameters in runtime parameters only
        mass, force = mass.xreplace(expand), force.xreplace(expand)
    state = [s for pair in zip(lag.q, lag.u) for s in pair]
    seeds = [*state, *(symbol(name) for name in names)]
    args = (TIME, *state, *(symbol(name) for name in names))
    dmass = [sp.lambdify(args, mass.diff(s)) for s in seeds]
    dforce = [sp.lambdify(args, force.diff(s)) for s in seeds]
    at_mass, at_force = sp.lambdify(args, mass), sp.lambdify(args, force)
    values = [float(sp.sympify(definitions[symbol(name)])) for name in names]
    k = len(names)

    def system(t: float, z: np.ndarray) -> np.ndarray:
        y, s = z[: 2 * n], z[2 * n:].reshape(k + 2 * n, 2 * n)  # rows: y0's, then p's
        call = (t, *y, *values)
        m_inv = np.linalg.inv(np.array(at_mass(*call), dtype=float))
        qdd = m_inv @ np.array(at_force(*call), dtype=float).ravel()
        partial = np.array([m_inv @ (np.array(df(*call), dtype=float).ravel()
                                     - np.array(dm(*call), dtype=float) @ qdd)
                            for dm, df in zip(dmass, dforce)])  # d qdd / d seed, a row each
        dy = np.empty(2 * n)
        dy[0::2], dy[1::2] = y[1::2], qdd
        ds = np.empty_like(s)
        ds[:, 0::2] = s[:, 1::2]
        ds[:, 1::2] = s @ partial[: 2 * n] + np.vstack([np.zeros((2 * n, n)), partial[2 * n:]])
        return np.concatenate([dy, ds.ravel()])

    start = np.vstack([np.eye(2 * n), np.zeros((k, 2 * n))])
    solution = solve_ivp(system, (t_eval[0], t_eval[-1]), np.concatenate([y0, start.ravel()]),
                         method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t_eval)
    s = solution.y[2 * n:].reshape(k + 2 * n, 2 * n, -1)
    return {"y0": s[: 2 * n].transpose(1, 0, 2), **{name: s[2 * n + i]
                                                   for i, name in enumerate(names)}}


@pytest.mark.parametrize("example", ["double_pendulum", "damped_spring_pendulum"])
def test_sensitivities_match_the_oracles_variational_equations(example: str) -> None:
    path = EXAMPLES / f"{example}.yaml"
    model = nemc.compile(path)
    names = list(model.parameter_names)
    t_eval = np.linspace(0, 2, 21)
    y0 = model.initial_state()
    res = model.simulate((0, 2), y0, t_eval=t_eval, sensitivities=["y0", *names],
                         method="DOP853", rtol=1e-12, atol=1e-14)
    reference = oracle_sensitivities(path, names, t_eval, y0)
    for name, expected in reference.items():
        assert relative_error(res.sensitivities[name], expected) < 1e-8, name


def test_outputs_sensitivities_are_the_chain_rule(damped) -> None:
    res = damped.simulate(sensitivities=["c", "L", "y0"], rtol=1e-12, atol=1e-14)
    h = 1e-6
    for name, value in (("c", 0.4), ("L", 3.0)):
        up = damped.simulate(params={name: value + h}, t_eval=res.t, **TIGHT).outputs
        down = damped.simulate(params={name: value - h}, t_eval=res.t, **TIGHT).outputs
        for output in damped.output_names:
            reference = (up[output] - down[output]) / (2 * h)
            ours = res.output_sensitivities[name][output]
            assert np.abs(ours - reference).max() < 1e-6 * max(1.0, np.abs(reference).max()), \
                (name, output)
    assert res.output_sensitivities["y0"]["O.Fx"].shape == (2, res.t.size)


def test_implicit_methods_and_every_scipy_method_agree(damped) -> None:
    reference = damped.simulate(sensitivities=["c"], rtol=1e-12, atol=1e-14).sensitivities["c"]
    for method in ("RK45", "Radau", "BDF", "LSODA"):
        res = damped.simulate(sensitivities=["c"], method=method, rtol=1e-9, atol=1e-11)
        assert res.success, res.message
        assert relative_error(res.sensitivities["c"], reference) < 1e-5, method


def test_an_inputs_sensitivity_is_the_derivative_by_its_value(tmp_path: Path) -> None:
    path = tmp_path / "pushed.yaml"
    path.write_text(DAMPED_PENDULUM.replace("name: damped_pendulum", "name: pushed")
                    .replace("loads:\n", "inputs: {T: 0}\nloads:\n  - {torque: T, body: rod}\n"))
    model = nemc.compile(path)
    res = model.simulate(inputs={"T": 1.5}, sensitivities=["T"], rtol=1e-12, atol=1e-14)
    h = 1e-6
    up = model.simulate(inputs={"T": 1.5 + h}, t_eval=res.t, **TIGHT).y
    down = model.simulate(inputs={"T": 1.5 - h}, t_eval=res.t, **TIGHT).y
    assert relative_error(res.sensitivities["T"], (up - down) / (2 * h)) < 1e-7
    table = model.simulate(inputs={"T": ([0, 4], [1.5, 1.5])}, sensitivities=["T"],
                           rtol=1e-12, atol=1e-14)  # a table: d/d a constant added to it
    assert relative_error(table.sensitivities["T"], res.sensitivities["T"]) < 1e-8


@pytest.mark.parametrize("names, message", [
    (["mass2"], "unknown name 'mass2'"),
    (["m"], "parameter 'm' is derived (m = W/g)"),
    (["c", "c"], "['c'] asked for more than once"),
    ([], "no name given"),
    ([3], "names are strings"),
])
def test_bad_names_get_one_clear_error(damped, names, message: str) -> None:
    with pytest.raises(ModelError) as error:
        damped.simulate(sensitivities=names)
    assert message in str(error.value)


@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Vern9"])
def test_the_native_methods_integrate_the_system_in_c(double_pendulum, method: str) -> None:
    """The same sensitivities as scipy's tight run, and the same states as the plain native
    run to the tolerance (the error control now holds the columns too)."""
    names = ["y0", *double_pendulum.parameter_names]
    t_eval = np.linspace(0, 5, 51)
    reference = double_pendulum.simulate((0, 5), t_eval=t_eval, sensitivities=names,
                                         method="DOP853", rtol=1e-12, atol=1e-14)
    res = double_pendulum.simulate((0, 5), t_eval=t_eval, sensitivities=names, method=method,
                                   rtol=1e-10, atol=1e-12)
    assert res.success and res.method == method
    for name in names:
        assert relative_error(res.sensitivities[name], reference.sensitivities[name]) < 1e-7
    plain = double_pendulum.simulate((0, 5), t_eval=t_eval, method=method, rtol=1e-10,
                                     atol=1e-12)
    assert np.abs(res.y - plain.y).max() < 1e-7
    steps = double_pendulum.simulate((0, 5), sensitivities=["m2"], method=method)
    assert steps.t.size == steps.sensitivities["m2"].shape[1] > 2  # the solver's own steps


def test_native_radau_integrates_the_system_with_its_newton_matrix(double_pendulum) -> None:
    """nemc.Radau on the sensitivity system (its Newton matrix from the build's J_y and the
    columns' coupling): scipy's tight run's sensitivities, and its error shrinking with rtol."""
    names = ["y0", *double_pendulum.parameter_names]
    t_eval = np.linspace(0, 5, 51)
    reference = double_pendulum.simulate((0, 5), t_eval=t_eval, sensitivities=names,
                                         method="DOP853", rtol=1e-12, atol=1e-14)
    errors = []
    for rtol in (1e-8, 1e-11):
        res = double_pendulum.simulate((0, 5), t_eval=t_eval, sensitivities=names,
                                       method="nemc.Radau", rtol=rtol, atol=rtol * 1e-2)
        assert res.success and res.method == "nemc.Radau" and res.nlu > 0, res.message
        errors.append(max(relative_error(res.sensitivities[name], reference.sensitivities[name])
                          for name in names))
    assert errors[1] < 1e-8 and errors[1] < errors[0] / 100, errors


def test_radaus_block_solves_equal_the_dense_lus(double_pendulum,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """nemc.Radau factors J_y once and solves block by block, the columns' coupling blocks
    C_j = d f_j / d y (forward differences of the system's right-hand side) applied between:
    the same iteration as its dense LU of the whole Newton matrix [[J_y, 0], [C_j, J_y]]
    (handed to the drivers as one Jacobian of the system's size, built here the same way)."""
    from nemc.runtime import sensitivities as variational

    names = ["y0", "m2", "g"]
    run = {"t_eval": np.linspace(0, 3, 7), "sensitivities": names, "method": "nemc.Radau",
           "rtol": 1e-9, "atol": 1e-11}
    blocks = double_pendulum.simulate((0, 3), **run)
    n, size = double_pendulum.n_state, double_pendulum.n_state * (1 + 4 + 2)
    calls = []

    def dense(drivers: Any, build: Any, spec: Any) -> tuple[Any, int]:
        compiled = build.compiled

        def system(t: float, z: np.ndarray, p: np.ndarray) -> np.ndarray:
            out = np.empty(size)
            assert compiled.functions["sensitivity_rhs"](t, compiled.buffer(z),
                                                          compiled.buffer(p),
                                                          compiled.buffer(out)) == 0
            return out

        def jacobian(t: float, z_pointer: Any, p_pointer: Any, jac: Any) -> int:
            z = np.frombuffer(drivers.ffi.buffer(z_pointer, 8 * size)).copy()
            count = int(drivers.ffi.cast("double *", p_pointer)[spec.p.size])  # the columns
            p = np.frombuffer(drivers.ffi.buffer(p_pointer,
                                                 8 * (spec.p.size * (1 + count) + 1))).copy()
            block = np.empty((n, n))
            status = compiled.functions["jacobian"](t, compiled.buffer(z), compiled.buffer(p),
                                                    compiled.buffer(block))
            whole = np.frombuffer(drivers.ffi.buffer(jac, 8 * size * size)).reshape(size, size)
            whole[:] = np.kron(np.eye(size // n), block)
            f = system(t, z, p)
            for m in range(n):  # the coupling as radau_jacobian takes it
                moved = z.copy()
                moved[m] += np.sqrt(np.finfo(float).eps) * max(1.0, abs(z[m]))
                whole[n:, m] = (system(t, moved, p) - f)[n:] / (moved[m] - z[m])
            calls.append(t)
            return status

        callback = drivers.ffi.callback("nemc_system_fn", jacobian)
        dense.keep = callback
        return callback, size

    monkeypatch.setattr(variational, "newton_block", dense)
    whole = double_pendulum.simulate((0, 3), **run)
    assert calls and whole.njev == blocks.njev == len(calls) and whole.nlu == blocks.nlu
    assert relative_error(whole.y, blocks.y) < 1e-13
    for name in names:
        assert relative_error(whole.sensitivities[name], blocks.sensitivities[name]) < 1e-12


def test_native_radau_on_a_stiff_arm_matches_differences_and_the_oracle() -> None:
    """The book's stiff 5.4 arm (its scene's method nemc.Radau, stiffness ~1e3): the run's
    sensitivities against central differences of tight nemc.Vern9 runs (rtol 1e-13, an
    explicit method) and the Lagrange oracle's augmented system."""
    path = EXAMPLES / "two_link_robot_arm.yaml"
    model = nemc.compile(path)
    names = ["b01", "g12", "m2"]
    t_eval = np.linspace(0, 1, 11)
    y0 = model.initial_state()
    res = model.simulate((0, 1), y0, t_eval=t_eval, sensitivities=["y0", *names],
                         rtol=1e-11, atol=1e-13)  # the scene's method
    assert res.success and res.method == "nemc.Radau" and res.njev > 0, res.message
    tight = {"method": "nemc.Vern9", "rtol": 1e-13, "atol": 1e-15, "t_eval": t_eval}
    for name in names:
        value = model.parameters[name]
        h = 1e-4 * max(1.0, value)  # m2's columns are ~1e-3 of y: a smaller h rounds
        up = model.simulate((0, 1), y0, params={name: value + h}, **tight).y
        down = model.simulate((0, 1), y0, params={name: value - h}, **tight).y
        assert relative_error(res.sensitivities[name], (up - down) / (2 * h)) < 1e-7, name
    reference = oracle_sensitivities(path, names, t_eval, y0)
    for name, expected in reference.items():
        assert relative_error(res.sensitivities[name], expected) < 1e-8, name


def test_auto_takes_a_native_method_and_events_are_located() -> None:
    model = nemc.compile(EXAMPLES / "double_pendulum_events.yaml")
    plain = model.simulate((0, 4), method="nemc.Vern9", rtol=1e-11, atol=1e-13)
    res = model.simulate((0, 4), method="auto", rtol=1e-11, atol=1e-13,
                         sensitivities=["m2"])
    assert res.method == "nemc.Vern9"
    for name, (times, states) in plain.events.items():
        assert np.allclose(res.events[name][0], times, atol=1e-8)
        assert res.events[name][1].shape == states.shape
    scipy = model.simulate((0, 4), method="DOP853", rtol=1e-11, atol=1e-13,
                           sensitivities=["m2"], t_eval=res.t)
    assert relative_error(res.sensitivities["m2"], scipy.sensitivities["m2"]) < 1e-6


def test_a_table_input_runs_natively_too(tmp_path: Path) -> None:
    path = tmp_path / "pushed.yaml"
    path.write_text(DAMPED_PENDULUM.replace("name: damped_pendulum", "name: pushed_table")
                    .replace("loads:\n", "inputs: {T: 0}\nloads:\n  - {torque: T, body: rod}\n"))
    model = nemc.compile(path)
    table = ([0, 1, 2, 4], [0.0, 2.0, -1.0, 0.5])
    native = model.simulate(inputs={"T": table}, sensitivities=["T", "c"], rtol=1e-11,
                            atol=1e-13, method="nemc.Vern9")
    scipy = model.simulate(inputs={"T": table}, sensitivities=["T", "c"], rtol=1e-12,
                           atol=1e-14, method="DOP853")
    for name in ("T", "c"):
        assert relative_error(native.sensitivities[name], scipy.sensitivities[name]) < 1e-7


# What has no sensitivities is refused by name: a closed loop's refusals (its solved entries,
# what decision 0035's amendment leaves out) in tests/test_loop_sensitivities.py, nemc.Taylor's
# (a closed loop) in tests/test_sensitivities_taylor.py.


def test_long_programs_in_parts_give_the_same_sensitivities(double_pendulum) -> None:
    """Printed in part functions (chunk_steps 4: the tangent's coefficients then computed in
    each column, as the Jacobian's are), the same numbers as the one-body build's."""
    from nemc.pipeline import compile_mechanism

    parts = compile_mechanism(EXAMPLES / "double_pendulum.yaml", chunk_steps=4,
                              sensitivities=True).model
    names = ["y0", "m2", "g"]
    ours = parts.simulate((0, 2), sensitivities=names, method="nemc.Vern9", rtol=1e-11,
                          atol=1e-13)
    whole = double_pendulum.simulate((0, 2), sensitivities=names, method="nemc.Vern9",
                                     rtol=1e-11, atol=1e-13, t_eval=ours.t)
    for name in names:
        assert relative_error(ours.sensitivities[name], whole.sensitivities[name]) < 1e-9
    for output in ("A.Fx", "energy.total"):
        assert relative_error(ours.output_sensitivities["g"][output],
                              whole.output_sensitivities["g"][output]) < 1e-9
