"""A mechanism fitted to measured data (nemc.fit): weighted least squares over named parameters,
inputs (constant ones) and initial values, by scipy's least_squares (trust-region reflective,
bounds allowed) with the exact Jacobian from the run's sensitivities (sensitivities.py), over
one or several experiments sharing the parameters.

Estimates come with standard errors and their correlation from the Jacobian at the solution:
cov = s^2 (J^T J)^-1, s^2 the residuals' variance (absolute_sigma=False, as scipy's curve_fit),
or (J^T J)^-1 with weights = 1 / sigma taken as known (absolute_sigma=True). A parameter the
data cannot determine is refused by name before anything is returned: the rank of the
sensitivity matrix (columns scaled to unit length) falls short, and the names are those its
null space holds.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import shooting
from .built import BuiltModel
from .failures import FitError, IntegrationFailure, ModelError
from .results import user_view
from .sensitivities import INITIAL_VALUES

RANK_TOLERANCE = 1e-7  # singular values of the scaled sensitivity matrix below this x the
#                        largest count as zero: sensitivities at rtol 1e-10 are good to ~1e-9


@dataclass(frozen=True)
class Experiment:
    """One run's measurements: times T (increasing), DATA (n_t x len(observed), or a mapping
    observed name -> n_t values), its own initial state Y0 (None: the scene's), INPUTS
    (simulate's), WEIGHTS (1 / sigma: a number, one per observed, or DATA's shape) and T0, the
    run's start (None: T's first time)."""

    t: Any
    data: Any
    y0: Any = None
    inputs: Mapping[str, Any] | None = None
    weights: Any = None
    t0: float | None = None


@dataclass(frozen=True)
class Checked:
    """An Experiment checked: arrays of the right shapes, finite."""

    t: np.ndarray
    data: np.ndarray  # n_t x n_observed
    weights: np.ndarray  # the same shape
    y0: Any
    inputs: Mapping[str, Any] | None
    t0: float


@dataclass(frozen=True)
class FitResult:
    """The estimates (values) with their standard errors, covariance and correlation (in
    names' order), the weighted residuals at the estimate (data order: experiment by
    experiment, time by time, observed by observed), their root mean square, and the runs
    at the estimate (one per experiment)."""

    names: tuple[str, ...]
    values: dict[str, float]
    stderr: dict[str, float]
    covariance: np.ndarray
    correlation: np.ndarray
    residual: np.ndarray
    success: bool
    message: str
    nfev: int
    rank: int
    dof: int
    rms: float
    runs: list = field(default_factory=list, repr=False)  # with shots: every shot's, in order
    defects: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)  # shots'
    # continuity defects at the estimate (state units; experiment by experiment, shot by shot)
    observed: tuple[str, ...] = ()  # the data's columns, in their order
    experiments: tuple[Checked, ...] = field(default=(), repr=False)  # the data fitted

    def plot(self, path: str | os.PathLike | None = None, **options: Any) -> Any:
        """The fit's figure (nemc.tools.fit_figures): each observed signal's data with the
        fitted model's curve, its residuals below; written to PATH when given (PNG, PDF,
        SVG); TITLE and SIZE (inches) as a run's plot(). Returns the figure (a notebook
        shows it)."""
        return user_view("fit_figures", "plot()").plot_fit(self, path, **options)

    def __repr__(self) -> str:
        rows = [f"{'name':>16}  {'value':>14}  {'stderr':>11}"]
        rows += [f"{name:>16}  {self.values[name]:>14.8g}  {self.stderr[name]:>11.3g}"
                 for name in self.names]
        rows.append(f"rms residual {self.rms:.4g} ({self.dof} degrees of freedom); "
                    f"{self.message}")
        return "\n".join(rows)


@dataclass(frozen=True)
class Problem:
    """What is fitted to what: the model, the names (their kind: "parameter", "input" or
    "initial"), the observed names (a state entry or an output), the experiments, the run's
    settings."""

    model: BuiltModel
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    observed: tuple[str, ...]
    experiments: tuple[Checked, ...]
    params: Mapping[str, float]
    run: Mapping[str, Any]

    def run_at(self, x: np.ndarray, experiment: Checked) -> Any:
        """The experiment's run with the fitted values X, and their sensitivities."""
        params, inputs, y0 = self.settings_at(x, experiment)
        return self.model.simulate((experiment.t0, experiment.t[-1]), y0, t_eval=experiment.t,
                                   params=params, inputs=inputs or None,
                                   sensitivities=list(self.names), **self.run)

    def settings_at(self, x: np.ndarray, experiment: Checked
                    ) -> tuple[dict[str, float], dict[str, Any], np.ndarray | None]:
        """The experiment's parameters, inputs and initial state (None: the scene's) with the
        fitted values X (the names' first len(names) entries)."""
        params = dict(self.params)
        inputs = dict(experiment.inputs or {})
        y0 = None if experiment.y0 is None else self.model.state_vector(
            experiment.y0, params).copy()
        for name, kind, value in zip(self.names, self.kinds, x[:len(self.names)].tolist()):
            if kind == "parameter":
                params[name] = value
            elif kind == "input":
                inputs[name] = value
        initial = [(name, value) for name, kind, value in zip(self.names, self.kinds, x)
                   if kind == "initial"]
        if initial:
            y0 = self.model.state_vector(None, params).copy() if y0 is None else y0
            for name, value in initial:
                y0[self.model.state_names.index(name)] = value
        return params, inputs, y0


def fit(model: BuiltModel, t: Any = None, data: Any = None, fit: Sequence[str] = (),
        observed: Sequence[str] = (), y0: Any = None, weights: Any = None, *,
        experiments: Sequence[Experiment] | None = None,
        bounds: Mapping[str, tuple[float, float]] | None = None,
        start: Mapping[str, float] | None = None, params: Mapping[str, float] | None = None,
        inputs: Mapping[str, Any] | None = None, method: str = "auto",
        rtol: float = 1e-10, atol: float = 1e-12, absolute_sigma: bool = False,
        max_nfev: int = 100, shots: int = 1) -> FitResult:
    """See nemc.fit."""
    from scipy.optimize import least_squares

    problem = checked_problem(model, t, data, fit, observed, y0, weights, experiments, params,
                              inputs, method, rtol, atol)
    x0 = start_values(problem, start)
    lower, upper = bound_arrays(problem.names, bounds, x0)
    cache = evaluations(problem, shooting.checked_shots(shots))
    x0, lower, upper = cache.unknowns(x0, lower, upper)
    residual0, jacobian0 = cache.at(x0, first=True)
    refuse_unidentifiable(problem, jacobian0, "at the start", cache.column_names())
    found = least_squares(cache.residual, x0, jac=cache.jacobian, bounds=(lower, upper),
                          method="trf", x_scale="jac", max_nfev=max_nfev, xtol=1e-12,
                          ftol=1e-12, gtol=1e-12)
    if cache.tighten():  # shots: the defects weighed loosely first, then closed
        nfev = found.nfev
        found = least_squares(cache.residual, found.x, jac=cache.jacobian,
                              bounds=(lower, upper), method="trf", x_scale="jac",
                              max_nfev=max_nfev, xtol=1e-12, ftol=1e-12, gtol=1e-12)
        found.nfev += nfev
    if found.status <= 0 or not np.all(np.isfinite(found.fun)):
        last = dict(zip(problem.names, found.x.tolist()))
        raise FitError(f"the fit did not converge ({found.message}) after {found.nfev} runs; "
                       f"last values {last}: start closer, bound the parameters (bounds=), "
                       "fit fewer of them or cut the runs into shots (shots=)")
    residual, jacobian = cache.at(found.x)
    rank = refuse_unidentifiable(problem, jacobian, "at the estimate", cache.column_names())
    return fit_result(problem, found, residual, jacobian, rank, absolute_sigma,
                      cache.runs_at(found.x), cache.defects(residual))


# ---- the problem, checked --------------------------------------------------------------------


def checked_problem(model: BuiltModel, t: Any, data: Any, names: Sequence[str],
                    observed: Sequence[str], y0: Any, weights: Any,
                    experiments: Sequence[Experiment] | None, params: Any, inputs: Any,
                    method: str, rtol: float, atol: float) -> Problem:
    names = fitted_names(model, names)
    observed = observed_names(model, observed)
    if experiments is None:
        if t is None or data is None:
            raise FitError("fit: give the measurements' times t and data (or experiments=)")
        experiments = [Experiment(t, data, y0, inputs, weights)]
    elif t is not None or data is not None:
        raise FitError("fit: give t and data, or experiments=, not both")
    checked = tuple(checked_experiment(e, observed, k) for k, e in enumerate(experiments))
    kinds = tuple(kind_of(model, name) for name in names)
    if "initial" in kinds and len(checked) > 1:
        raise FitError("fit: initial values are each experiment's own: fit them with one "
                       "experiment at a time (or give each experiment its y0)")
    overrides = model.parameter_table.overrides(params)
    run = {"method": method, "rtol": rtol, "atol": atol}
    return Problem(model, names, kinds, observed, checked, overrides, run)


def fitted_names(model: BuiltModel, names: Any) -> tuple[str, ...]:
    listed = [names] if isinstance(names, str) else list(names)
    expanded = [entry for name in listed for entry in
                (model.state_names if name == INITIAL_VALUES else [name])]
    if not expanded:
        raise FitError("fit: name what to fit (fit=[...]: parameters, inputs, initial values)")
    for name in expanded:
        if not isinstance(name, str):
            raise FitError(f"fit: names are strings, got {name!r}")
    repeated = sorted({name for name in expanded if expanded.count(name) > 1})
    if repeated:
        raise FitError(f"fit: {repeated} named more than once")
    for name in expanded:
        kind_of(model, name)
    return tuple(expanded)


def kind_of(model: BuiltModel, name: str) -> str:
    """"parameter", "input" or "initial"; a derived parameter or unknown name refused."""
    if name in model.parameter_names:
        return "parameter"
    if name in model.input_names:
        return "input"
    if name in model.state_names:
        return "initial"
    if name in model.derived_parameters:
        raise FitError(f"fit: parameter {name!r} is derived ({name} = "
                       f"{model.derived_parameters[name]}): fit what it is made of")
    raise FitError(f"fit: unknown name {name!r}{close_name(name, model)} (parameters "
                   f"{list(model.parameter_names)}, inputs {list(model.input_names)}, initial "
                   f"values {list(model.state_names)})")


def close_name(name: str, model: BuiltModel) -> str:
    import difflib

    known = [*model.parameter_names, *model.input_names, *model.state_names,
             *model.output_names]
    close = difflib.get_close_matches(name, known, n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def observed_names(model: BuiltModel, observed: Any) -> tuple[str, ...]:
    listed = [observed] if isinstance(observed, str) else list(observed)
    if not listed:
        raise FitError("fit: name what the data measure (observed=[...]: state entries or "
                       "outputs)")
    for name in listed:
        if name not in model.state_names and name not in model.output_names:
            raise FitError(f"fit: observed {name!r} is neither a state entry "
                           f"{list(model.state_names)} nor an output{close_name(name, model)}")
    return tuple(listed)


def checked_experiment(experiment: Experiment, observed: tuple[str, ...], k: int) -> Checked:
    where = f"experiment {k}: " if k else ""
    t = np.asarray(experiment.t, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise FitError(f"fit: {where}t must be at least two finite, increasing times")
    data = data_array(experiment.data, observed, t.size, where)
    weights = weight_array(experiment.weights, data.shape, where)
    t0 = float(t[0] if experiment.t0 is None else experiment.t0)
    if not t0 <= t[0]:
        raise FitError(f"fit: {where}t0 = {t0} is after the first measurement {t[0]}")
    return Checked(t, data, weights, experiment.y0, experiment.inputs, t0)


def data_array(data: Any, observed: tuple[str, ...], n_t: int, where: str) -> np.ndarray:
    """DATA as n_t x len(observed), checked: a mapping by observed name, or an array."""
    if isinstance(data, Mapping):
        missing = [name for name in observed if name not in data]
        if missing:
            raise FitError(f"fit: {where}data has no column for observed {missing} "
                           f"(columns: {list(data)})")
        data = np.column_stack([np.asarray(data[name], dtype=float) for name in observed])
    array = np.asarray(data, dtype=float)
    if array.ndim == 1 and len(observed) == 1:
        array = array.reshape(-1, 1)
    if array.shape != (n_t, len(observed)):
        raise FitError(f"fit: {where}data must be {n_t} times x {len(observed)} observed "
                       f"{list(observed)}, got shape {array.shape}")
    bad = np.argwhere(~np.isfinite(array))
    if bad.size:
        row, col = bad[0]
        raise FitError(f"fit: {where}data holds {len(bad)} values that are not finite (NaN or "
                       f"inf), the first at row {row}, observed {observed[col]!r}: remove "
                       "those times or give them weight 0 with a finite value")
    return array


def weight_array(weights: Any, shape: tuple[int, int], where: str) -> np.ndarray:
    if weights is None:
        return np.ones(shape)
    array = np.asarray(weights, dtype=float)
    try:
        array = np.broadcast_to(array, shape).copy()
    except ValueError:
        raise FitError(f"fit: {where}weights must be a number, one per observed or the data's "
                       f"shape {shape}, got shape {array.shape}") from None
    if not np.all(np.isfinite(array)) or np.any(array < 0):
        raise FitError(f"fit: {where}weights must be finite and >= 0 (1 / sigma)")
    return array


def start_values(problem: Problem, start: Mapping[str, float] | None) -> np.ndarray:
    """Where the fit starts: START's values, else the parameters' (params=, else defaults),
    the inputs' and the initial values' of the first experiment."""
    start = dict(start or {})
    unknown = [name for name in start if name not in problem.names]
    if unknown:
        raise FitError(f"fit: start names {unknown}, which are not fitted {list(problem.names)}")
    model, first = problem.model, problem.experiments[0]
    values = {**model.parameters, **problem.params}
    state = model.state_vector(first.y0, problem.params)
    x0 = []
    for name, kind in zip(problem.names, problem.kinds):
        if name in start:
            x0.append(float(start[name]))
        elif kind == "parameter":
            x0.append(values[name])
        elif kind == "initial":
            x0.append(float(state[model.state_names.index(name)]))
        else:
            x0.append(input_start(model, name, first))
    x = np.array(x0)
    if not np.all(np.isfinite(x)):
        raise FitError(f"fit: the start values {dict(zip(problem.names, x0))} must be finite")
    return x


def input_start(model: BuiltModel, name: str, experiment: Checked) -> float:
    given = (experiment.inputs or {}).get(name)
    if given is None:
        raise FitError(f"fit: input {name!r} needs a start value (start={{{name!r}: ...}})")
    try:
        return float(given)
    except (TypeError, ValueError):
        raise FitError(f"fit: input {name!r} is fitted as a constant: its start is a "
                       f"number, got {given!r}") from None


def bound_arrays(names: tuple[str, ...], bounds: Mapping[str, Any] | None, x0: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    lower, upper = np.full(len(names), -np.inf), np.full(len(names), np.inf)
    for name, pair in (bounds or {}).items():
        if name not in names:
            raise FitError(f"fit: bounds name {name!r}, which is not fitted {list(names)}")
        low, high = (float(v) for v in pair)
        if not low < high:
            raise FitError(f"fit: bounds of {name!r} must be (low, high) with low < high")
        k = names.index(name)
        lower[k], upper[k] = low, high
        if not low < x0[k] < high:
            raise FitError(f"fit: {name!r} starts at {x0[k]:g}, outside its bounds "
                           f"({low:g}, {high:g}): give start=")
    return lower, upper


# ---- residuals and their Jacobian -------------------------------------------------------------


class Evaluations:
    """The weighted residuals and their exact Jacobian at x, from one run per experiment with
    its sensitivities (kept for the latest x: least_squares asks for both there). A run that
    fails, or values the model refuses (a negative mass), give residuals NaN (the trust region
    then shrinks), refused at the start."""

    def __init__(self, problem: Problem):
        self.problem = problem
        self.kept: tuple[bytes, np.ndarray, np.ndarray, list] | None = None

    def at(self, x: np.ndarray, first: bool = False) -> tuple[np.ndarray, np.ndarray]:
        key = np.asarray(x, dtype=float).tobytes()
        if self.kept is None or self.kept[0] != key:
            self.kept = (key, *self.evaluate(np.asarray(x, dtype=float), first))
        return self.kept[1], self.kept[2]

    def residual(self, x: np.ndarray) -> np.ndarray:
        return self.at(x)[0]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        return self.at(x)[1]

    def runs_at(self, x: np.ndarray) -> list:
        self.at(x)
        assert self.kept is not None
        return self.kept[3]

    def unknowns(self, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The fit's unknowns where it starts, and their bounds: the fitted names'."""
        return x0, lower, upper

    def column_names(self) -> tuple[str, ...]:
        """What each unknown (a column of the Jacobian) is."""
        return self.problem.names

    def tighten(self) -> bool:
        """Weigh the defects fully for the fit's second pass; False: there is none."""
        return False

    def defects(self, residual: np.ndarray) -> np.ndarray:
        """The continuity defects in RESIDUAL, unweighted (none in one run per experiment)."""
        return np.empty(0)

    def evaluate(self, x: np.ndarray, first: bool) -> tuple[np.ndarray, np.ndarray, list]:
        problem = self.problem
        rows, blocks, runs = [], [], []
        for k, experiment in enumerate(problem.experiments):
            try:
                res = problem.run_at(x, experiment)
                failure = None if res.success and res.t.size == experiment.t.size else \
                    res.message
            except (IntegrationFailure, ModelError) as error:  # ModelError: values the
                failure = str(error)  # model refuses (a negative inertia), a step too far
            if failure is not None:
                if first:
                    raise FitError(f"fit: the run of experiment {k} at the start values "
                                   f"{dict(zip(problem.names, x.tolist()))} failed: {failure}")
                size = sum(e.data.size for e in problem.experiments)
                return np.full(size, np.nan), np.full((size, x.size), np.nan), []
            predicted, sensitivity = predictions(problem, res)
            rows.append((experiment.weights * (predicted - experiment.data)).ravel())
            blocks.append((experiment.weights[..., None] * sensitivity).reshape(
                experiment.data.size, x.size))
            runs.append(res)
        return np.concatenate(rows), np.vstack(blocks), runs


def evaluations(problem: Problem, shots: int) -> Evaluations:
    """The residuals' evaluations: one run per experiment, or its time cut into SHOTS."""
    if shots == 1:
        return Evaluations(problem)
    return ShotEvaluations(problem, shots)


class ShotEvaluations(Evaluations):
    """Multiple shooting (shooting.py): x = [the fitted names | every experiment's later
    shots' starts]; the residuals the data's (data order) then the continuity defects."""

    def __init__(self, problem: Problem, shots: int):
        super().__init__(problem)
        self.cuts = tuple(shooting.cut(e.t, e.weights, shots, f"experiment {k}: " if k else "")
                          for k, e in enumerate(problem.experiments))
        self.n_data = sum(e.data.size for e in problem.experiments)

    def unknowns(self, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        nodes = shooting.starting_nodes(self.problem, self.cuts, x0)
        free = np.full(nodes.size, np.inf)
        return (np.concatenate([x0, nodes]), np.concatenate([lower, -free]),
                np.concatenate([upper, free]))

    def column_names(self) -> tuple[str, ...]:
        names = list(self.problem.names)
        for k, c in enumerate(self.cuts):
            where = f"experiment {k} " if len(self.cuts) > 1 else ""
            names += [f"{where}shot {shot}'s {state}" for shot in range(1, c.count)
                      for state in self.problem.model.state_names]
        return tuple(names)

    def tighten(self) -> bool:
        self.cuts = tuple(dataclasses.replace(c, scale=shooting.DEFECT_WEIGHT)
                          for c in self.cuts)
        self.kept = None
        return True

    def defects(self, residual: np.ndarray) -> np.ndarray:
        n, tail, found, start = self.problem.model.n_state, residual[self.n_data:], [], 0
        for c in self.cuts:
            size = (c.count - 1) * n
            found.append(tail[start:start + size] / c.weight)
            start += size
        return np.concatenate(found)

    def evaluate(self, x: np.ndarray, first: bool) -> tuple[np.ndarray, np.ndarray, list]:
        problem, n = self.problem, self.problem.model.n_state
        data, defects, runs, first_node = [], [], [], len(problem.names)
        for k, c in enumerate(self.cuts):
            try:
                rows = shooting.experiment_rows(problem, x, k, c, first_node)
            except (IntegrationFailure, ModelError) as error:
                if first:
                    raise FitError(f"fit: a shot of experiment {k} at the start values "
                                   f"{dict(zip(problem.names, x.tolist()))} failed: "
                                   f"{error}") from None
                size = self.n_data + sum((c.count - 1) * n for c in self.cuts)
                return np.full(size, np.nan), np.full((size, x.size), np.nan), []
            data.append((rows.data, rows.data_jacobian))
            defects.append((rows.defects, rows.defect_jacobian))
            runs.extend(rows.runs)
            first_node += (c.count - 1) * n
        parts = data + defects
        return (np.concatenate([r for r, _ in parts]), np.vstack([j for _, j in parts]), runs)


def predictions(problem: Problem, res: Any) -> tuple[np.ndarray, np.ndarray]:
    """The observed values along a run (n_t x observed) and their derivatives by the fitted
    names (n_t x observed x names)."""
    model = problem.model
    predicted, sensitivity = [], []
    for name in problem.observed:
        if name in model.state_names:
            i = model.state_names.index(name)
            predicted.append(res.y[i])
            sensitivity.append([res.sensitivities[fitted][i] for fitted in problem.names])
        else:
            predicted.append(res.outputs[name])
            sensitivity.append([res.output_sensitivities[fitted][name]
                                for fitted in problem.names])
    return np.array(predicted).T, np.array(sensitivity).transpose(2, 0, 1)


# ---- identifiability and the estimate's errors -------------------------------------------------


def refuse_unidentifiable(problem: Problem, jacobian: np.ndarray, where: str,
                          names: tuple[str, ...]) -> int:
    """The rank of the sensitivity matrix (columns scaled to unit length, NAMES theirs); a
    shortfall is a FitError naming what the data do not determine."""
    norms = np.linalg.norm(jacobian, axis=0)
    silent = [name for name, norm in zip(names, norms) if not norm > 0]
    if silent:
        raise FitError(f"fit: the data cannot identify {silent}: the observed "
                       f"{list(problem.observed)} do not depend on them {where}")
    _, singular, vt = np.linalg.svd(jacobian / norms, full_matrices=False)
    rank = int(np.sum(singular > RANK_TOLERANCE * singular[0]))
    if rank < len(names):
        null = vt[rank:]
        involved = [name for k, name in enumerate(names) if np.abs(null[:, k]).max() > 0.1]
        raise FitError(f"fit: the data cannot identify {involved} separately: the sensitivity "
                       f"matrix has rank {rank} of {len(names)} {where} (their effects on the "
                       f"observed {list(problem.observed)} cancel: only a combination is "
                       "determined; fix all but one of them)")
    return rank


def fit_result(problem: Problem, found: Any, residual: np.ndarray, jacobian: np.ndarray,
               rank: int, absolute_sigma: bool, runs: list, defects: np.ndarray) -> FitResult:
    """The estimates and their errors from the Jacobian of every unknown (with shots, the
    shots' starts too: the names' block of the covariance is theirs); the residuals and their
    rms are the data's, the shots' DEFECTS apart."""
    names, unknowns = problem.names, found.x.size
    dof = residual.size - unknowns
    if dof <= 0:
        raise FitError(f"fit: {residual.size} data for {unknowns} unknowns: no degree of "
                       "freedom left for the errors (measure more)")
    variance = 1.0 if absolute_sigma else float(residual @ residual) / dof
    covariance = (np.linalg.inv(jacobian.T @ jacobian) * variance)[:len(names), :len(names)]
    stderr = np.sqrt(np.diag(covariance))
    correlation = covariance / np.outer(stderr, stderr)
    values = dict(zip(names, found.x[:len(names)].tolist()))
    data = residual[:residual.size - defects.size]
    return FitResult(names, values, dict(zip(names, stderr.tolist())), covariance, correlation,
                     data, True, found.message, int(found.nfev), rank, dof,
                     float(np.sqrt(data @ data / data.size)), runs, defects,
                     problem.observed, problem.experiments)
