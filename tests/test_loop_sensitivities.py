"""Closed loops' sensitivities, the formulation decision 0035's amendment chose, checked before
its C exists: the index-1 variational equations (the derivative of qdd = qdd_tree + W lambda,
K lambda = -(G + Phi_q qdd_tree), along each column) with the columns started in the
constraints' tangent space (the assembly's sensitivity to the given initial values: Phi_q s_q
= 0 on the solved coordinates, and the rates' likewise), integrated beside the run.

`reference_sensitivities` is that formulation in numpy on the build's exact pieces (the part
"linearization"'s loop_tangents, solved by nemc/runtime/linear.py's solve_index_one), in
scipy's DOP853 at rtol 1e-12: the oracle a C implementation will be compared with. Here it is
compared with fourth-order central differences of runs at rtol 1e-13 (the four-bar and the
slider-crank, the initial values the scenes give), and its columns are checked to stay in the
tangent space along the run.

Then the C (templates/loop_sensitivities.c.tmpl and loop_output_sensitivities.c.tmpl, the
runtime's start columns in nemc/runtime/loop_sensitivities.py) is compared with that reference
(the given initial values' columns, by nemc.Vern9, nemc.DOP853 and scipy's DOP853) and with
differences of runs (the parameters', an input's, the outputs', an event time's), the total
energy's sensitivities are checked constant in time, a fit recovers known parameters, and what
the formulation leaves out is checked to be refused by name."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import nemc
from nemc.runtime.failures import ModelError
from nemc.runtime.linear import LoopPieces, solve_index_one

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
RTOL = 1e-12  # the reference's integration
STEP = 3e-4  # the central differences' step in each given initial value


class Pieces:
    """The loop's exact pieces at a state (loop_tangents: the accelerations' program's
    results and their derivatives along each state entry)."""

    def __init__(self, model: nemc.runtime.Model):
        self.model = model
        self.build = model.compiled_with("linearization")
        meta = model.metadata
        self.n = len(model.coordinate_names)
        self.drives = len(meta["drive_names"])
        self.m = len(meta["constraint_equations"])
        self.size = (self.m + 1) * (self.n + self.drives) + self.m * (self.n + 3)
        self.columns = model.n_state + len(model.input_names)
        self.p = model.parameter_vector(None)

    def at(self, t: float, y: np.ndarray) -> LoopPieces:
        acc, dacc = np.empty(self.size), np.empty((self.columns, self.size))
        buffer = self.build.compiled.buffer
        status = self.build.compiled.functions["loop_tangents"](
            t, buffer(np.ascontiguousarray(y)), buffer(self.p), buffer(acc), buffer(dacc))
        assert status == 0
        return LoopPieces(self.n, self.drives, self.m, acc, dacc)

    def directions(self, s: np.ndarray) -> np.ndarray:
        """State directions S (rows) as the pieces' columns (the inputs' zero)."""
        out = np.zeros((len(s), self.columns))
        out[:, :self.model.n_state] = s
        return out

    def residuals(self, t: float, y: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Each column's Phi_q s_q and d/ds (Phi_q qdot + Phi_t): the constraints' tangent
        space's equations (0 in it), a row per column."""
        pieces = self.at(t, y)
        at = pieces.split(pieces.acc)
        moved = pieces.split(self.directions(s) @ pieces.dacc)
        positions = s[:, 0::2] @ at["phi_q"].T
        rates = (s[:, 1::2] @ at["phi_q"].T + np.einsum("cij,j->ci", moved["phi_q"], y[1::2])
                 + moved["phi_t"])
        return np.hstack([positions, rates])


def start_columns(pieces: Pieces, y0: np.ndarray, given: list[int]) -> np.ndarray:
    """d y0 / d (each given entry): the entry 1, the solved coordinates from Phi_q s_q = 0,
    then the solved rates from the rates' equation's derivative (a row per given entry)."""
    n_state = pieces.model.n_state
    at = pieces.at(0.0, y0)
    phi_q = at.split(at.acc)["phi_q"]
    solved_q = [i for i in range(pieces.n) if 2 * i not in given]
    solved_u = [i for i in range(pieces.n) if 2 * i + 1 not in given]
    columns = np.zeros((len(given), n_state))
    for row, entry in enumerate(given):
        s = columns[row]
        s[entry] = 1.0
        s[[2 * i for i in solved_q]] = np.linalg.lstsq(
            phi_q[:, solved_q], -phi_q @ s[0::2], rcond=None)[0]
        left = pieces.residuals(0.0, y0, s[None])[0, pieces.m:]
        s[[2 * i + 1 for i in solved_u]] = np.linalg.lstsq(phi_q[:, solved_u], -left,
                                                           rcond=None)[0]
    return columns


def reference_sensitivities(model: nemc.runtime.Model, t_eval: np.ndarray
                            ) -> tuple[np.ndarray, np.ndarray, list[int], Pieces]:
    """The run's states (n_state x n_t, on the constraints) and the given initial values'
    sensitivities (given x n_state x n_t) from the index-1 variational equations."""
    pieces, n_state = Pieces(model), model.n_state
    y0 = model.initial_state(None)
    given = [model.state_names.index(name) for name in model.metadata["initial_given"]]
    count = len(given)

    def system(t: float, z: np.ndarray) -> np.ndarray:
        y = model.loops.projected(np.array([t]), z[:n_state, None], pieces.p)[:, 0]
        s = z[n_state:].reshape(count, n_state)
        ds = np.empty_like(s)
        ds[:, 0::2] = s[:, 1::2]
        ds[:, 1::2] = solve_index_one(pieces.at(t, y), pieces.directions(s)).dqdd
        return np.concatenate([model.rhs(t, z[:n_state]), ds.ravel()])

    z0 = np.concatenate([y0, start_columns(pieces, y0, given).ravel()])
    run = solve_ivp(system, (t_eval[0], t_eval[-1]), z0, method="DOP853", rtol=RTOL,
                    atol=RTOL / 10, t_eval=t_eval)
    assert run.success
    y = model.loops.projected(run.t, run.y[:n_state], pieces.p)
    return y, run.y[n_state:].reshape(count, n_state, -1), given, pieces


def differences(model: nemc.runtime.Model, t_eval: np.ndarray, name: str) -> np.ndarray:
    """d y / d (given initial value NAME) by fourth-order central differences of runs at rtol
    1e-13, the other given values kept, the rest assembled."""
    base = {n: v for n, v in zip(model.state_names, model.initial_state(None))
            if n in model.metadata["initial_given"]}

    def run(shift: float) -> np.ndarray:
        start = {**base, name: base[name] + shift}
        return model.simulate((t_eval[0], t_eval[-1]), start, t_eval=t_eval, rtol=1e-13,
                              atol=1e-14, method="nemc.Vern9").y

    return (8 * (run(STEP) - run(-STEP)) - (run(2 * STEP) - run(-2 * STEP))) / (12 * STEP)


@pytest.mark.parametrize("example, span", [("fourbar", 3.0), ("slider_crank", 1.5)])
def test_the_index_one_variational_equations_equal_differences_of_runs(
        example: str, span: float) -> None:
    """The columns of the given initial values (q1, dot(q1)) equal differences of tight runs
    to 1e-8 relative (measured: 5.1e-11 ... 2.6e-9), and stay in the constraints' tangent
    space: |Phi_q s_q| and the rates' equation below 1e-10 of the column along the run
    (measured: 3.1e-13)."""
    model = nemc.compile(EXAMPLES / f"{example}.yaml")
    t_eval = np.linspace(0.0, span, 16)
    y, sensitivities, given, pieces = reference_sensitivities(model, t_eval)
    assert np.abs(model.constraint_residual(y, t_eval)).max() < 1e-12
    for column, entry in zip(sensitivities, given):
        expected = differences(model, t_eval, model.state_names[entry])
        error = np.abs(column - expected).max() / np.abs(expected).max()
        assert error < 1e-8, (model.state_names[entry], error)
        for k, t in enumerate(t_eval):
            left = pieces.residuals(t, y[:, k], column[None, :, k])
            assert np.abs(left).max() < 1e-10 * max(1.0, np.abs(column[:, k]).max())


def test_a_start_off_the_tangent_space_is_caught() -> None:
    """The tangent-space check is not vacuous: a column with its solved coordinates left at 0
    (q1 moved alone) breaks Phi_q s_q = 0."""
    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    pieces = Pieces(model)
    y0 = model.initial_state(None)
    alone = np.zeros((1, model.n_state))
    alone[0, 0] = 1.0
    assert np.abs(pieces.residuals(0.0, y0, alone)).max() > 0.1
    started = start_columns(pieces, y0, [0])
    assert np.abs(pieces.residuals(0.0, y0, started)).max() < 1e-12


# ---- the C (templates/loop_sensitivities.c.tmpl) against the reference and differences -----

METHODS = ("nemc.Vern9", "nemc.DOP853", "DOP853")  # the native system's drivers, and scipy's
PARAMETERS = {"fourbar": (3.0, ("L2", "m2", "g")), "slider_crank": (1.5, ("l", "ms"))}


def relative(found: np.ndarray, expected: np.ndarray) -> float:
    return float(np.abs(found - expected).max() / np.abs(expected).max())


@pytest.mark.parametrize("example, span", [("fourbar", 3.0), ("slider_crank", 1.5)])
def test_the_c_columns_equal_the_reference(example: str, span: float) -> None:
    """simulate(sensitivities=) of the given initial values, by each method that takes the
    system, equals the numpy reference to 1e-9 relative (measured: 1.7e-12 to 2.4e-11), and
    the states are the reference's, on the constraints."""
    model = nemc.compile(EXAMPLES / f"{example}.yaml")
    t_eval = np.linspace(0.0, span, 16)
    y, reference, given, _ = reference_sensitivities(model, t_eval)
    names = [model.state_names[entry] for entry in given]
    for method in METHODS:
        res = model.simulate((0.0, span), t_eval=t_eval, rtol=1e-12, atol=1e-13,
                             method=method, sensitivities=names)
        assert res.success, (method, res.message)
        assert np.abs(res.y - y).max() < 1e-9
        for name, column in zip(names, reference):
            assert relative(res.sensitivities[name], column) < 1e-9, (method, name)


def parameter_differences(model: nemc.runtime.Model, t_eval: np.ndarray, name: str
                          ) -> np.ndarray:
    """d y / d (parameter NAME) by fourth-order central differences of runs at rtol 1e-13 (a
    relative step of 3e-4: at 1e-3 g's truncation is 1.3e-7, at 3e-4 1.1e-9), each run
    assembled from the scene's given values."""
    value = model.parameters[name]
    step = 3e-4 * abs(value)

    def run(shift: float) -> np.ndarray:
        return model.simulate((t_eval[0], t_eval[-1]), params={name: value + shift},
                              t_eval=t_eval, rtol=1e-13, atol=1e-14, method="nemc.Vern9").y

    return (8 * (run(step) - run(-step)) - (run(2 * step) - run(-2 * step))) / (12 * step)


def tangent_residuals(model: nemc.runtime.Model, res: object, name: str) -> np.ndarray:
    """Along the run, each point's |Phi_q s_q + Phi_p e| and |d/d(s, e) (Phi_q qdot + Phi_t)|
    over the column's size: 0 in the constraints' tangent space."""
    from nemc.runtime.loop_sensitivities import pieces

    build = model.compiled_with("sensitivities")
    p = model.parameter_vector(None)
    e = np.zeros(p.size)
    if name in model.parameter_names:
        e[model.parameter_table.index(name)] = 1.0
    column = res.sensitivities[name]  # type: ignore[attr-defined]
    out = []
    for k, t in enumerate(res.t):  # type: ignore[attr-defined]
        y, s = res.y[:, k], column[:, k]  # type: ignore[attr-defined]
        at, moved = pieces(build, float(t), y, p, s, e)
        rates = at["phi_q"] @ s[1::2] + moved["phi_q"] @ y[1::2] + moved["phi_t"]
        out.append(np.abs(np.concatenate([moved["phi"], rates])).max()
                   / max(1.0, np.abs(s).max()))
    return np.array(out)


@pytest.mark.parametrize("example", sorted(PARAMETERS))
def test_parameter_columns_equal_differences_of_runs(example: str) -> None:
    """The parameters' columns (through the start's Phi_p term: L2 and l move the assembly)
    equal fourth-order central differences of tight runs to 1e-7 relative (measured: 2.5e-10
    to 2.1e-9), and stay in the constraints' tangent space along the run (measured: 4.1e-13
    of the column at most)."""
    model = nemc.compile(EXAMPLES / f"{example}.yaml")
    span, names = PARAMETERS[example]
    t_eval = np.linspace(0.0, span, 16)
    res = model.simulate((0.0, span), t_eval=t_eval, rtol=1e-12, atol=1e-13,
                         method="nemc.Vern9", sensitivities=list(names))
    assert res.success, res.message
    for name in names:
        expected = parameter_differences(model, t_eval, name)
        assert relative(res.sensitivities[name], expected) < 1e-7, name
        assert tangent_residuals(model, res, name).max() < 1e-9, name


def test_the_start_moves_the_solved_coordinates_with_the_geometry() -> None:
    """Not vacuous: L2's column starts with Phi_p e far from 0 (the solved coordinates move
    with it), while the started column's residual is at rounding."""
    from nemc.runtime.loop_sensitivities import pieces

    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    res = model.simulate((0.0, 0.1), t_eval=[0.0, 0.1], sensitivities=["L2"],
                         method="nemc.Vern9", rtol=1e-12, atol=1e-13)
    e = np.zeros(model.parameter_vector(None).size)
    e[model.parameter_table.index("L2")] = 1.0
    _, moved = pieces(model.compiled_with("sensitivities"), 0.0, res.y[:, 0],
                      model.parameter_vector(None), np.zeros(model.n_state), e)
    assert np.abs(moved["phi"]).max() > 0.1
    assert np.abs(res.sensitivities["L2"][0::2, 0]).max() > 0.1
    assert tangent_residuals(model, res, "L2").max() < 1e-12


def test_what_the_formulation_leaves_out_is_refused_by_name(tmp_path: Path) -> None:
    """The solved entries and "y0" (no column), equations held as at the start, equations on
    the velocities, impacts on a loop: one message each."""
    fourbar = nemc.compile(EXAMPLES / "fourbar.yaml")
    with pytest.raises(ModelError, match="'q2' is solved by the assembly"):
        fourbar.simulate(sensitivities=["q2"])
    with pytest.raises(ModelError, match="\"y0\" asks for every initial value"):
        fourbar.simulate(sensitivities=["y0"])
    with pytest.raises(ModelError, match="y0 gives every coordinate of a closed loop"):
        fourbar.simulate(y0=fourbar.initial_state(None), sensitivities=["g"])
    with pytest.raises(ModelError, match="gear_train.yaml:.*as at the start"):
        nemc.compile(EXAMPLES / "gear_train.yaml").simulate(sensitivities=["ra"])
    with pytest.raises(ModelError, match="chaplygin_sleigh.yaml:.*on the velocities"):
        nemc.compile(EXAMPLES / "chaplygin_sleigh.yaml").simulate(sensitivities=["y0"])
    text = (EXAMPLES / "fourbar.yaml").read_text().replace(
        "  rtol: 1.0e-9\n", "  rtol: 1.0e-9\n  events:\n"
        "    stop: {when: q1 - 3, direction: rising, action: {dot(q1): -dot(q1)}}\n", 1)
    impact = tmp_path / "fourbar_impact.yaml"
    impact.write_text(text)
    with pytest.raises(ModelError, match="fourbar_impact.yaml:.*impact on a closed loop"):
        nemc.compile(impact).simulate(sensitivities=["g"])


def test_the_outputs_sensitivities_equal_differences_and_keep_the_energy() -> None:
    """The four-bar's outputs' sensitivities (the chain rule through dqdd and dlambda, in C):
    the reactions' by g and L2 equal fourth-order differences of the runs' outputs to 1e-7
    relative (measured: 3.0e-10 at most), and the total energy's, conserved along the run,
    stay constant in time (measured: 1.6e-10 of it at most) for g, L2 and the given q1."""
    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    t_eval = np.linspace(0.0, 1.5, 16)
    res = model.simulate((0.0, 1.5), t_eval=t_eval, rtol=1e-12, atol=1e-13,
                         method="nemc.Vern9", sensitivities=["g", "L2", "q1"])
    assert res.success, res.message
    for name in ("g", "L2"):
        value = model.parameters[name]
        step = 3e-4 * abs(value)

        runs = {k: model.simulate((0.0, 1.5), params={name: value + k * step},
                                  t_eval=t_eval, rtol=1e-13, atol=1e-14,
                                  method="nemc.Vern9").outputs for k in (-2, -1, 1, 2)}
        for output in ("C.Fx", "A.Fy", "energy.total"):
            expected = (8 * (runs[1][output] - runs[-1][output])
                        - (runs[2][output] - runs[-2][output])) / (12 * step)
            found = res.output_sensitivities[name][output]
            assert relative(found, expected) < 1e-7, (name, output)
    for name in ("g", "L2", "q1"):
        energy = res.output_sensitivities[name]["energy.total"]
        assert np.ptp(energy) < 1e-9 * np.abs(energy).max(), name
        assert np.abs(energy).max() > 1e-3  # not vacuous: the energy moves with each


def test_a_driven_loops_drive_sensitivities_equal_differences() -> None:
    """The driven slider-crank (no given value: the crank's motion prescribed): the drive's and
    the reactions' sensitivities to ms, c and l (through the drives' tangent, ddrive) equal
    fourth-order differences of its kinematic runs to 1e-7 (measured: 1.7e-11 at most)."""
    model = nemc.compile(EXAMPLES / "slider_crank_driven.yaml")
    t_eval = np.linspace(0.0, 0.2, 16)
    res = model.simulate((0.0, 0.2), t_eval=t_eval, rtol=1e-12, atol=1e-13,
                         method="nemc.Vern9", sensitivities=["ms", "c", "l"])
    assert res.success, res.message
    for name in ("ms", "c", "l"):
        value = model.parameters[name]
        step = 3e-4 * abs(value)
        runs = {k: model.simulate((0.0, 0.2), params={name: value + k * step},
                                  t_eval=t_eval, rtol=1e-13, atol=1e-14,
                                  method="nemc.Vern9").outputs for k in (-2, -1, 1, 2)}
        for output in ("O.drive", "guide.Fy"):
            expected = (8 * (runs[1][output] - runs[-1][output])
                        - (runs[2][output] - runs[-2][output])) / (12 * step)
            assert np.abs(expected).max() > 1e-3  # the output moves with the parameter
            found = res.output_sensitivities[name][output]
            assert relative(found, expected) < 1e-7, (name, output)


def test_an_events_time_moves_as_differences_of_runs_say(tmp_path: Path) -> None:
    """A recording event on the four-bar (q1 passing 3): its time's sensitivities to g and L2
    (the tree's formula at the projected state) equal fourth-order differences of the event
    times of runs at rtol 1e-13 to 1e-7 relative (measured: 1.8e-10 at most), with nemc.Vern9
    and scipy's DOP853."""
    text = (EXAMPLES / "fourbar.yaml").read_text().replace(
        "  rtol: 1.0e-9\n", "  rtol: 1.0e-9\n  events:\n"
        "    pass3: {when: q1 - 3, direction: rising}\n", 1)
    path = tmp_path / "fourbar_event.yaml"
    path.write_text(text)
    model = nemc.compile(path)
    for method in ("nemc.Vern9", "DOP853"):
        res = model.simulate((0.0, 1.5), sensitivities=["g", "L2"], method=method,
                             rtol=1e-12, atol=1e-13)
        assert res.success and res.events["pass3"][0].size == 1, res.message
        for name in ("g", "L2"):
            value = model.parameters[name]
            step = 3e-4 * abs(value)
            tau = {k: model.simulate((0.0, 1.5), params={name: value + k * step},
                                     method="nemc.Vern9", rtol=1e-13,
                                     atol=1e-14).events["pass3"][0][0] for k in (-2, -1, 1, 2)}
            expected = (8 * (tau[1] - tau[-1]) - (tau[2] - tau[-2])) / (12 * step)
            found = res.event_sensitivities["pass3"][name][0]
            assert abs(found - expected) < 1e-7 * abs(expected), (method, name)


def test_a_singular_passage_ends_the_run_naming_its_constraint(tmp_path: Path) -> None:
    """The parallelogram lying flat at q1 = pi: the plain run passes it (decision 0036), the
    run with sensitivities ends before it, naming constraint C."""
    from test_loop_runtime import PARALLELOGRAM

    path = tmp_path / "parallelogram.yaml"
    path.write_text(PARALLELOGRAM)
    model = nemc.compile(path)
    assert model.simulate((0.0, 3.0)).success
    res = model.simulate((0.0, 3.0), sensitivities=["m", "q1"], method="nemc.Vern9")
    assert not res.success
    assert "constraint 'C' loses rank" in res.message
    assert "passage (decision 0036) is not differentiated" in res.message
    assert 0.5 < res.t[-1] < 3.0


def test_a_loop_printed_in_parts_gives_the_same_columns() -> None:
    """Printed in part functions (chunk_steps 4), the pieces' program and tangent give the same
    columns and outputs' sensitivities as the one-body build's, and so does the start
    (loop_sensitivity_pieces)."""
    from nemc.pipeline import compile_mechanism

    parts = compile_mechanism(EXAMPLES / "fourbar.yaml", chunk_steps=4,
                              sensitivities=True).model
    whole = nemc.compile(EXAMPLES / "fourbar.yaml")
    names = ["q1", "L2", "m2"]
    ours = parts.simulate((0, 1.0), sensitivities=names, method="nemc.Vern9", rtol=1e-11,
                          atol=1e-13)
    theirs = whole.simulate((0, 1.0), sensitivities=names, method="nemc.Vern9", rtol=1e-11,
                            atol=1e-13, t_eval=ours.t)
    for name in names:
        assert relative(ours.sensitivities[name], theirs.sensitivities[name]) < 1e-9, name
        for output in ("C.Fx", "energy.total"):
            assert relative(ours.output_sensitivities[name][output],
                            theirs.output_sensitivities[name][output]) < 1e-9, (name, output)


def test_a_fit_of_a_closed_loop_recovers_its_parameters() -> None:
    """nemc.fit on the four-bar (its exact Jacobian from the loop's sensitivities): m2 and g
    from its crank's and rocker's angles with 1e-3 noise (seeded), within 3 standard errors
    of the values the data were made with (measured: m2 1.7983 +- 0.0081, g 9.4995 +-
    0.0012 for 1.8 and 9.5)."""
    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    t = np.linspace(0.0, 2.0, 81)
    truth = {"m2": 1.8, "g": 9.5}
    made = model.simulate((0.0, 2.0), t_eval=t, params=truth, rtol=1e-12, atol=1e-13)
    rng = np.random.default_rng(3)
    data = {name: made.y[model.state_names.index(name)] + rng.normal(scale=1e-3, size=t.size)
            for name in ("q1", "q3")}
    found = nemc.fit(model, t, data, fit=["m2", "g"], observed=["q1", "q3"],
                     start={"m2": 1.5, "g": 9.81})
    for name, value in truth.items():
        assert abs(found.values[name] - value) < 3 * found.stderr[name], name
        assert found.stderr[name] < 0.01 * value  # the data pin it down


def test_an_inputs_column_equals_differences_of_runs(tmp_path: Path) -> None:
    """The slider-crank with an input u added to its motor's torque: d y / d u (a constant u)
    equals fourth-order differences of runs with u = +-h, +-2h to 1e-7 relative (measured:
    3.6e-10; h = 1e-3 left a truncation of 2.7e-6, the crank's speed being sensitive)."""
    text = (EXAMPLES / "slider_crank.yaml").read_text()
    text = text.replace("T0*(1 - dot(q1)/w0)", "T0*(1 - dot(q1)/w0) + u", 1)
    text = text.replace("gravity:", "inputs:\n  u: 0\ngravity:", 1)
    path = tmp_path / "slider_crank_input.yaml"
    path.write_text(text)
    model = nemc.compile(path)
    t_eval = np.linspace(0.0, 1.5, 16)
    res = model.simulate((0.0, 1.5), t_eval=t_eval, rtol=1e-12, atol=1e-13,
                         method="nemc.Vern9", sensitivities=["u"])
    assert res.success, res.message
    step = 1e-4
    runs = {k: model.simulate((0.0, 1.5), inputs={"u": k * step}, t_eval=t_eval, rtol=1e-13,
                              atol=1e-14, method="nemc.Vern9").y for k in (-2, -1, 1, 2)}
    expected = (8 * (runs[1] - runs[-1]) - (runs[2] - runs[-2])) / (12 * step)
    assert np.abs(expected).max() > 1e-3
    assert relative(res.sensitivities["u"], expected) < 1e-7
