"""Multiple shooting for nemc.fit (shots=K): each experiment's time cut into K shots at its data
times, every shot but the first started from a state of its own that the fit estimates with
the parameters, the shots tied together by continuity defects (the state a shot reaches at the
next one's start minus that start, weighted) as further residuals.

One shot follows a chaotic mechanism only from a start very close to the answer: the residuals
of a long run are folded over the parameters into many local minima. Short shots see only a
little of the divergence, so the linearization the fit steps on holds much farther, and the
defects close as the fit converges (Bock's boundary-value approach to parameter estimation).

The Jacobian is exact, from each shot's sensitivities: the parameters' columns as in a single
run (a shot's start given, its parameter columns start at 0), a shot's start's columns its
"y0" sensitivities, and -1 for the start a defect compares against. The shots' starts begin
where the data observe them, else from one run at the fit's start values.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .failures import FitError, IntegrationFailure, ModelError
from .sensitivities import INITIAL_VALUES

DEFECT_WEIGHT = 1e3  # a defect's weight at the estimate: this x the experiment's largest data
#                      weight (a state jump of sigma / 1000 costs as much as a datum off by
#                      sigma): the shots then join into one run within the data's noise
LOOSE_WEIGHT = 1.0  # ... and in the fit's first pass, from the start: a defect costs as much as
#                     a datum off by as much (heavier, the trust region shrinks to the defects'
#                     curvature while the parameters are still far off)


@dataclass(frozen=True)
class Cut:
    """One experiment's shots: the data row where each starts (the first 0, then ascending),
    and the defects' weight."""

    starts: tuple[int, ...]
    data_weight: float  # the experiment's largest data weight
    scale: float = LOOSE_WEIGHT  # the defects' weight, x data_weight

    @property
    def weight(self) -> float:
        return self.scale * self.data_weight

    @property
    def count(self) -> int:
        return len(self.starts)

    def rows(self, shot: int, n_t: int) -> slice:
        """The data rows of SHOT, and its next shot's first (the defect's time) but for the
        last shot."""
        end = self.starts[shot + 1] + 1 if shot + 1 < self.count else n_t
        return slice(self.starts[shot], end)


def cut(t: np.ndarray, weights: np.ndarray, shots: int, where: str) -> Cut:
    """T's data rows cut into SHOTS shots of (nearly) equal counts, two rows at least each."""
    if shots > t.size // 2:
        raise FitError(f"fit: {where}shots={shots} for {t.size} times: each shot needs two "
                         f"measurements at least (shots <= {t.size // 2})")
    starts = tuple(int(k) for k in np.linspace(0, t.size, shots + 1)[:-1].round())
    largest = float(weights.max()) if weights.size else 1.0
    return Cut(starts, largest if largest > 0 else 1.0)


def checked_shots(shots: Any) -> int:
    """shots=: an integer >= 1 (1: single shooting)."""
    if isinstance(shots, bool) or not isinstance(shots, (int, np.integer)) or shots < 1:
        raise FitError(f"fit: shots must be an integer >= 1 (1: one run per experiment), "
                         f"got {shots!r}")
    return int(shots)


@dataclass
class ShotRows:
    """What one experiment's shots give at x: its data residuals and their Jacobian rows, its
    defects and theirs, its shots' runs."""

    data: np.ndarray
    data_jacobian: np.ndarray
    defects: np.ndarray
    defect_jacobian: np.ndarray
    runs: list


def node_count(problem: Any, cuts: Sequence[Cut]) -> int:
    """The unknowns the shots' starts add: n_state for each shot but an experiment's first."""
    return sum(c.count - 1 for c in cuts) * problem.model.n_state


def starting_nodes(problem: Any, cuts: Sequence[Cut], x0: np.ndarray) -> np.ndarray:
    """The shots' starts where the fit begins: the observed state entries from the data at
    each shot's first time, the rates of observed coordinates from their data's differences
    there, the rest from one run per experiment at the start values X0 (which a chaotic
    mechanism's wrong parameters soon take far)."""
    model, nodes = problem.model, []
    for experiment, c in zip(problem.experiments, cuts):
        if c.count == 1:
            continue
        params, inputs, y0 = problem.settings_at(x0, experiment)
        try:
            res = model.simulate((experiment.t0, experiment.t[-1]), y0, t_eval=experiment.t,
                                 params=params, inputs=inputs or None, **problem.run)
            states = res.y
        except (IntegrationFailure, ModelError):
            states = np.empty((model.n_state, 0))
        for row in c.starts[1:]:
            reached = states[:, min(row, states.shape[1] - 1)] if states.shape[1] else \
                model.state_vector(None, params)
            nodes.append(observed_start(problem, experiment, row, reached))
    return np.concatenate(nodes) if nodes else np.empty(0)


def observed_start(problem: Any, experiment: Any, row: int, reached: np.ndarray
                   ) -> np.ndarray:
    """A shot's start at data row ROW: REACHED (a run's state), its observed entries the
    data's, the rate of an observed coordinate whose rate is not observed the derivative of
    the parabola through its data at rows ROW - 1, ROW, ROW + 1."""
    names, start = problem.model.state_names, np.array(reached, dtype=float)
    for j, name in enumerate(problem.observed):
        if name not in names:
            continue
        i = names.index(name)
        start[i] = experiment.data[row, j]
        rate = i + 1 if i % 2 == 0 else None  # y: each coordinate followed by its rate
        if rate is not None and names[rate] not in problem.observed:
            start[rate] = data_rate(experiment.t, experiment.data[:, j], row)
    return start


def data_rate(t: np.ndarray, values: np.ndarray, row: int) -> float:
    """The derivative at t[ROW] of the parabola through the data at ROW and its neighbours
    (one-sided at the data's last row)."""
    rows = slice(row - 1, row + 2) if row + 1 < t.size else slice(row - 2, row + 1)
    coefficients = np.polyfit(t[rows] - t[row], values[rows], 2)
    return float(coefficients[1])


def experiment_rows(problem: Any, x: np.ndarray, k: int, c: Cut, first_node: int
                    ) -> ShotRows:
    """Experiment K's shots at x (its starts at x[FIRST_NODE:], n_state each): the weighted
    data residuals and defects, and their exact Jacobian rows over all of x."""
    experiment, n = problem.experiments[k], problem.model.n_state
    settings = problem.settings_at(x, experiment)
    data, data_jac, defects, defect_jac, runs = [], [], [], [], []
    for shot in range(c.count):
        rows = c.rows(shot, experiment.t.size)
        column = first_node + (shot - 1) * n  # this shot's start in x (shot 0: none, the
        #                                        next one's then at first_node)
        res = shot_run(problem, x, experiment, settings, shot, experiment.t[rows], column)
        runs.append(res)
        last = shot + 1 == c.count
        # the data rows this shot answers for: not the next shot's first (the defect's time)
        kept = rows.stop - rows.start - (0 if last else 1)
        predicted, sensitivity = observed_along(problem, res, shot, column, x.size)
        weights = experiment.weights[rows][:kept]
        data.append((weights * (predicted[:kept] - experiment.data[rows][:kept])).ravel())
        data_jac.append((weights[..., None] * sensitivity[:kept]).reshape(-1, x.size))
        if not last:
            defect, jac = defect_rows(problem, res, shot, column, x)
            defects.append(c.weight * defect)
            defect_jac.append(c.weight * jac)
    return ShotRows(np.concatenate(data), np.vstack(data_jac),
                    np.concatenate(defects) if defects else np.empty(0),
                    np.vstack(defect_jac) if defect_jac else np.empty((0, x.size)), runs)


def shot_run(problem: Any, x: np.ndarray, experiment: Any, settings: tuple, shot: int,
             times: np.ndarray, column: int) -> Any:
    """One shot's run over TIMES with its sensitivities: the first from the experiment's
    start (the fitted names'), a later one from its start x[COLUMN:] (the parameters' and
    inputs', and "y0"). A run that fails or stops early is a ModelError."""
    params, inputs, y0 = settings
    if shot == 0:
        span, start, names = (experiment.t0, times[-1]), y0, list(problem.names)
    else:
        span, start = (times[0], times[-1]), x[column:column + problem.model.n_state]
        names = [name for name, kind in zip(problem.names, problem.kinds) if kind != "initial"]
        names.append(INITIAL_VALUES)
    res = problem.model.simulate(span, start, t_eval=times, params=params,
                                 inputs=inputs or None, sensitivities=names, **problem.run)
    if not res.success or res.t.size != times.size:
        raise ModelError(f"shot {shot}: {res.message}")
    return res


def observed_along(problem: Any, res: Any, shot: int, column: int, size: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The observed values along a shot (n_t x observed) and their derivatives by all of x
    (n_t x observed x size): the fitted names' columns, and a later shot's start's."""
    model = problem.model
    n, n_t = model.n_state, res.t.size
    predicted = np.empty((n_t, len(problem.observed)))
    sensitivity = np.zeros((n_t, len(problem.observed), size))
    for j, name in enumerate(problem.observed):
        if name in model.state_names:
            i = model.state_names.index(name)
            predicted[:, j] = res.y[i]
            by = {key: value[i] for key, value in res.sensitivities.items()}
        else:
            predicted[:, j] = res.outputs[name]
            by = {key: value[name] for key, value in res.output_sensitivities.items()}
        for m, fitted in enumerate(problem.names):
            if fitted in by and (shot == 0 or problem.kinds[m] != "initial"):
                sensitivity[:, j, m] = by[fitted]
        if shot > 0:
            sensitivity[:, j, column:column + n] = by[INITIAL_VALUES].T
    return predicted, sensitivity


def defect_rows(problem: Any, res: Any, shot: int, column: int, x: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The continuity defect at the next shot's start: the state this shot reaches minus that
    start (unweighted), and its derivatives by all of x."""
    n = problem.model.n_state
    following = column + n  # the next shot's start in x
    defect = res.y[:, -1] - x[following:following + n]
    jac = np.zeros((n, x.size))
    for m, fitted in enumerate(problem.names):
        if fitted in res.sensitivities and (shot == 0 or problem.kinds[m] != "initial"):
            jac[:, m] = res.sensitivities[fitted][:, -1]
    if shot > 0:
        jac[:, column:column + n] = res.sensitivities[INITIAL_VALUES][:, :, -1]
    jac[:, following:following + n] -= np.eye(n)
    return defect, jac
