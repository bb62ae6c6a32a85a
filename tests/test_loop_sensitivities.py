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
tangent space along the run. simulate(sensitivities=) still refuses closed loops
(tests/test_sensitivities.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import nemc
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
