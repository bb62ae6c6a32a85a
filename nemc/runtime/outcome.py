"""One run's plan and what it returns: RunSpec, the checked settings of a run (what simulate()
resolved from its arguments and the scene), and the pieces of a SimulationResult every way of
running shares (the outputs, computed when read; a run that could not start or failed; why a
solver gave up)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from . import runs
from .built import BuiltModel
from .failures import IntegrationFailure
from .inputs import RunInputs
from .results import NO_OUTPUTS, SUCCESS_MESSAGE, LazyOutputs, SimulationResult


@dataclass(slots=True)  # not frozen (1.2 us more a run: a frozen dataclass sets each field
class RunSpec:          # through object.__setattr__); never changed: dataclasses.replace
    """One run's settings, checked: the method (a name of METHODS), the span (t0, t1), the
    initial state, the times of the returned states (None: the solver's steps), the
    tolerances, the parameter vector (with the inputs' laws), the run settings,
    simulate(events=)'s callables and the inputs that vary along the run."""

    method: str
    span: tuple[float, float]
    state0: np.ndarray
    times: np.ndarray | None
    rtol: float
    atol: float
    p: np.ndarray
    settings: runs.RunSettings
    user_events: Sequence[Callable]
    inputs: RunInputs | None = None  # inputs that vary along the run (tables, functions)

    def but(self, method: str, settings: runs.RunSettings | None = None) -> RunSpec:
        """This run with another method (and settings): a new RunSpec (positional, 1 us less
        than dataclasses.replace)."""
        return RunSpec(method, self.span, self.state0, self.times, self.rtol, self.atol, self.p,
                       self.settings if settings is None else settings, self.user_events,
                       self.inputs)


def lazy_outputs(model: BuiltModel, t: np.ndarray, y: np.ndarray, p: np.ndarray,
                 inputs: RunInputs | None = None) -> LazyOutputs:
    """The outputs along (t, y) at parameter vector p (with inputs that vary: at each point's
    values), computed when first read."""
    if not t.size or not model.output_names:
        return NO_OUTPUTS
    p = model.friction.inferring(p)  # each point's friction mode from its state
    if inputs is not None:
        inputs = replace(inputs, p=model.friction.inferring(inputs.p))
        return LazyOutputs(outputs_along, model, t, y, inputs)
    return LazyOutputs(model.compiled.outputs_at, t, y, p)  # p: never written to


def outputs_along(model: BuiltModel, t: np.ndarray, y: np.ndarray, inputs: RunInputs
                  ) -> dict[str, np.ndarray]:
    """The outputs at each (t, y), each at its inputs' values (a table's segment, a function's
    value)."""
    rows = [model.compiled.outputs_at(t[k], y[:, k], inputs.at(float(t[k]), y[:, k]))
            for k in range(t.size)]
    return {name: np.array([row[name] for row in rows]) for name in model.output_names}


def at_start(model: BuiltModel, spec: RunSpec) -> SimulationResult:
    """A run over an empty interval (t1 == t0), as the native methods give it: y0 at t0."""
    t = np.array([spec.span[0]]) if spec.times is None else spec.times
    y = np.repeat(spec.state0.reshape(-1, 1), t.size, axis=1)
    return SimulationResult(
        t=t, y=y, outputs=lazy_outputs(model, t, y, spec.p), nfev=0, njev=0, nlu=0, status=0,
        message=SUCCESS_MESSAGE, success=True, method=spec.method, rtol=spec.rtol,
        atol=spec.atol, params=model.parameters_at(spec.p),
    )


def failed(failure: IntegrationFailure, method: str, rtol: float, atol: float,
           params: dict[str, float] | None) -> SimulationResult:
    """A result that says where and why the equations could not be evaluated, with no state
    computed before (a run that could not start)."""
    return SimulationResult(
        t=np.array([failure.t]), y=failure.y.reshape(-1, 1), outputs={}, nfev=0, njev=0,
        nlu=0, status=runs.EQUATIONS_FAILED, message=f"integration failed: {failure}",
        success=False, method=method, rtol=rtol, atol=atol, params=dict(params or {}),
    )


def failed_after(model: BuiltModel, spec: RunSpec, failure: IntegrationFailure,
                 t: np.ndarray, y: np.ndarray, counts: tuple[int, int, int],
                 events: dict[str, tuple[np.ndarray, np.ndarray]],
                 tolerances: tuple[float, float]) -> SimulationResult:
    """A run whose equations (an event's function, an impact law) failed mid-run: the states
    (t, y) and events it computed before, their outputs, status EQUATIONS_FAILED, and where
    and why it failed (tolerances: the run's, as its method used them). A run that failed
    before its first state returns the failing one, as `failed`."""
    if not t.size:
        return replace(failed(failure, spec.method, *tolerances, model.parameters_at(spec.p)),
                       nfev=counts[0], njev=counts[1], nlu=counts[2], events=events)
    return SimulationResult(
        t, y, lazy_outputs(model, t, y, spec.p, spec.inputs), *counts, runs.EQUATIONS_FAILED,
        f"integration failed: {failure}", False, spec.method, *tolerances,
        model.parameters_at(spec.p), events)


def gave_up(model: BuiltModel, message: str, t: float, y: np.ndarray, p: np.ndarray) -> str:
    """The message of a run whose solver gave up at (t, y): where, the state, the likely
    cause."""
    state = ", ".join(f"{n}={v:.6g}" for n, v in zip(model.state_names, y))
    singular = model.loops.singularity_note(t, y, p)
    cause = singular or (" Likely cause: the solution grows without bound (a finite-time "
                         "blow-up, a singular configuration or an unstable load); `nemc "
                         "stress` measures the scene")
    return f"integration stopped near t={t:.9g}: {message} State: {state}.{cause}"


def ended_early(model: BuiltModel, ending: runs.Ending, p: np.ndarray) -> str:
    """The message of a run that ended early (runs.ending_message), with where a closed loop
    turned singular."""
    return runs.ending_message(ending) + model.loops.singularity_note(ending.t, ending.y, p)

