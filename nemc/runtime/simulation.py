"""One run of the scene (Model.simulate): its arguments resolved against the scene's and checked
into a RunSpec, the method run (nemc's own, scipy's, or "auto": its choice, and the switch to
nemc.Radau of a run that turns stiff), a closed loop's states kept on its constraints, and a
mechanism without a degree of freedom analysed instead of integrated."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from ..vocabulary import (
    AUTO,
    AUTO_STIFF_STEPS,
    AUTO_SWITCHES_FROM,
    DEFAULT_ATOL,
    DEFAULT_METHOD,
    DEFAULT_RTOL,
    METHODS,
    NATIVE_METHODS,
    SCIPY_METHODS,
)
from . import runs
from .auto import auto_choice
from .built import DEFAULT_T_SPAN, BuiltModel
from .checks import (
    all_finite,
    checked_method,
    checked_span,
    checked_times,
    checked_tolerances,
    real_array,
    step_times,
    within_budget,
)
from .failures import ModelError
from .friction import FRICTION_METHOD
from .inputs import RunInputs
from .kinematic import Passage
from .native import native_build, simulate_native
from .outcome import RunSpec, at_start, lazy_outputs
from .passages import passages_message
from .results import LazyOutputs, SimulationResult
from .scipy_run import simulate_scipy

KINEMATIC_POINTS = 201  # the default times of a kinematic analysis over t_span
KINEMATIC_MESSAGE = ("Kinematic analysis: no degree of freedom left by the drives; the states "
                     "come from the constraints at each time.")
SOLVER_STEPS = "steps"  # simulate(t_eval="steps"): the solver's own steps, whatever the scene says
# method "auto"'s explicit start under the default settings: it ends once the run turns stiff
AUTO_SWITCH_SETTINGS = replace(runs.DEFAULT_SETTINGS, stiff_switch=AUTO_STIFF_STEPS)
# simulate()'s arguments but t_eval, in the order of the tuple a result keeps of them
# (SimulationResult.run_arguments: a plain tuple, 0.3 us less a run than a named one)
RUN_ARGUMENTS = ("t_span", "y0", "method", "rtol", "atol", "params", "events", "max_step",
                 "tstops", "max_steps", "inputs")


def simulate(model: BuiltModel, arguments: tuple, t_eval: Any) -> SimulationResult:
    """The run of simulate()'s ARGUMENTS (as RUN_ARGUMENTS names them) at the times T_EVAL:
    each resolved against the scene, then the defaults, and checked, in this order."""
    spec = run_spec(model, arguments, t_eval)
    if not model.state_names:  # every coordinate driven: nothing to integrate
        return kinematic_run(model, spec)
    if not model.has_loops:
        return integrate(model, spec)
    y0 = arguments[1]
    p = model.loops.started(spec.span[0], spec.state0, spec.p)  # a gear pair's offset
    state0, freedom = model.loops.assembled(spec.span[0], spec.state0,
                                            model.loops.given_mask(y0), p)
    spec = RunSpec(spec.method, spec.span, state0, spec.times, spec.rtol, spec.atol, p,
                   spec.settings, spec.user_events, spec.inputs)
    if freedom == 0:
        return kinematic_run(model, spec)
    result = integrate(model, spec)
    result.y = model.friction.held(result.y, model.loops.projected(result.t, result.y, spec.p))
    result.message += passages_message(model.loops.passages(result.t, result.y, spec.p))
    return result


def run_spec(model: BuiltModel, arguments: tuple, t_eval: Any) -> RunSpec:
    """simulate()'s ARGUMENTS resolved against the scene, then the defaults, and checked, in
    this order, into one run's plan (a closed loop's state not yet assembled)."""
    t_span, y0, method, rtol, atol, params, events, max_step, tstops, max_steps, inputs = \
        arguments
    p = model.parameter_table.vector(params)  # Model.parameter_vector's, one call less
    varying = None
    if inputs is not None:  # the inputs' laws set in a copy of p (inputs.py)
        given = model.input_layout.resolve(p, inputs)
        p, varying = given.p, given if given.tables or given.callables else None
    scene = model.scene
    span = checked_span(scene["t_span"] or DEFAULT_T_SPAN if t_span is None else t_span)
    method = checked_method(scene["method"] or DEFAULT_METHOD if method is None else method,
                            METHODS)
    rtol, atol = tolerances(scene, rtol, atol)
    times = run_times(scene, span, t_eval, per_time=model.n_state + 1)
    state0 = initial_state(model, y0, params)
    settings = checked_settings(scene, span, max_step, tstops, max_steps)
    if varying is not None and varying.tables:  # every step lands on the tables' samples
        settings = with_tstops(settings, varying.tstops, span)
    return RunSpec(method, span, state0, times, rtol, atol, p, settings,
                   checked_events(events), varying)


def integrate(model: BuiltModel, spec: RunSpec) -> SimulationResult:
    """One run from spec.state0 with spec.method: nemc's own, scipy's solve_ivp, or "auto"."""
    method = spec.method
    if method == AUTO:
        return integrate_auto(model, spec)
    model.friction.check_method(method)
    if model.friction.present:  # the run's own parameters: its modes, which switches write
        state0, p = model.friction.started(spec.span[0], spec.state0, spec.p)
        inputs = spec.inputs if spec.inputs is None else replace(spec.inputs, p=p)
        spec = RunSpec(method, spec.span, state0, spec.times, spec.rtol, spec.atol, p,
                       spec.settings, spec.user_events, inputs)
    if method in NATIVE_METHODS and spec.inputs is not None and spec.inputs.callables:
        raise ModelError(f"an input given as a Python function runs with scipy's methods "
                         f"({', '.join(SCIPY_METHODS)}): {method} runs in C, where inputs are "
                         "numbers, tables (times, values) or nemc.feedback(K, y_ref, u_ref)")
    if method in NATIVE_METHODS:
        if spec.user_events:
            raise ModelError(
                f"events= callables need one of scipy's methods ({', '.join(SCIPY_METHODS)})"
                f": {method} runs in C and locates only the scene's events "
                "(simulation.events in the YAML, compiled into the model)")
        return simulate_native(native_build(model, method), spec)
    if spec.span[0] == spec.span[1]:  # solve_ivp returns nothing; the native methods return y0
        return at_start(model, spec)
    return simulate_scipy(model, spec)


def integrate_auto(model: BuiltModel, spec: RunSpec) -> SimulationResult:
    """The method "auto" chooses (auto.auto_choice); an explicit start that turns stiff goes
    on with nemc.Radau from where the stiffness test stopped it (as LSODA switches)."""
    python_in_loop = spec.user_events or spec.inputs is not None and spec.inputs.callables
    if model.friction.present:
        return integrate(model, spec.but(method=FRICTION_METHOD))
    if python_in_loop:
        return integrate(model, spec.but(method="LSODA"))  # Python in the loop: scipy's
        #                                                    LSODA switches by itself
    span, settings = spec.span, spec.settings
    method = auto_choice(model, span, spec.state0, spec.rtol, spec.p)
    if method not in AUTO_SWITCHES_FROM:
        return integrate(model, spec.but(method=method))
    switch = AUTO_SWITCH_SETTINGS if settings is runs.DEFAULT_SETTINGS else replace(
        settings, stiff_switch=AUTO_STIFF_STEPS)
    ending: list = []
    first = simulate_native(native_build(model, method),
                            spec.but(method=method, settings=switch), ending)
    if first.status != model.compiled.lib.NEMC_STIFF or span[0] == span[1]:
        return first
    t_switch, y_switch, steps, stiff_from = ending[0]
    rest_settings = replace(
        settings, max_steps=max(settings.max_steps - steps, 1) if settings.max_steps else 0)
    rest = integrate(model, RunSpec("nemc.Radau", (t_switch, span[1]), y_switch,
                                    times_after(spec.times, t_switch, span), spec.rtol,
                                    spec.atol, spec.p, rest_settings, [], spec.inputs))
    return joined_runs(model, first, rest, t_switch, stiff_from, spec.p, spec.inputs)


def joined_runs(model: BuiltModel, first: SimulationResult, rest: SimulationResult,
                t_switch: float, stiff_from: float, p: np.ndarray,
                inputs: RunInputs | None = None) -> SimulationResult:
    """One result of a run that switched method at t_switch: first's states before it,
    rest's from it (the switch's state once), their events and counts together."""
    t_rest, y_rest = rest.t, rest.y
    if first.t.size and t_rest.size and t_rest[0] == first.t[-1]:
        t_rest, y_rest = t_rest[1:], y_rest[:, 1:]
    t, y = np.concatenate([first.t, t_rest]), np.concatenate([first.y, y_rest], axis=1)
    events = {name: tuple(np.concatenate([part.events[name][k] for part in (first, rest)
                                          if name in part.events]) for k in (0, 1))
              for name in {**first.events, **rest.events}}
    note = (f" {first.method} ran until t = {t_switch:.6g}, where the problem had turned"
            f" stiff (Hairer's test held from t = {stiff_from:.6g}); {rest.method} went on"
            " from there.")
    return SimulationResult(
        t=t, y=y, outputs=lazy_outputs(model, t, y, p, inputs), nfev=first.nfev + rest.nfev,
        njev=first.njev + rest.njev, nlu=first.nlu + rest.nlu, status=rest.status,
        message=rest.message + note, success=rest.success,
        method=f"{first.method} then {rest.method}", rtol=first.rtol, atol=first.atol,
        params=first.params, events=events)


def times_after(times: Any, t_switch: float, span: tuple[float, ...]) -> Any:
    """The requested times still ahead after a switch at t_switch."""
    if times is None:
        return None
    times = np.asarray(times, dtype=float)
    ahead = times > t_switch if span[1] >= span[0] else times < t_switch
    return times[ahead]


def kinematic_run(model: BuiltModel, spec: RunSpec) -> SimulationResult:
    """A mechanism its drives leave without a degree of freedom: no integration, its
    states computed from the constraints at each time of t_eval (default: 201 over
    t_span) on the branch it starts on, the outputs (drives, reactions) there."""
    times = np.linspace(*spec.span, KINEMATIC_POINTS) if spec.times is None else np.asarray(
        spec.times)
    passages: list[Passage] = []
    if model.has_loops:
        found = model.loops.kinematic_states(spec.span[0], times.astype(float), spec.state0,
                                             spec.p)
        t, y, failure, passages = found.t, found.y, found.failure, found.passages
    else:  # a tree whose every coordinate is driven: its state is empty
        t, y, failure = times.astype(float), np.empty((0, len(times))), None
    outputs = lazy_outputs(model, t, y, spec.p, spec.inputs)
    if passages and model.output_names:
        outputs = LazyOutputs(passed_outputs, model, t, y, spec.p, spec.inputs, passages)
    message = failure or KINEMATIC_MESSAGE + passages_note(t, passages)
    return SimulationResult(
        t=t, y=y, outputs=outputs, nfev=0, njev=0, nlu=0,
        status=0 if failure is None else -1, success=failure is None,
        message=message if failure is None else f"Kinematic analysis stopped {message}"
        + passages_note(t, passages),
        method="kinematic", rtol=spec.rtol, atol=spec.atol, params=model.parameters_at(spec.p))


def passages_note(t: np.ndarray, passages: list[Passage]) -> str:
    """What a kinematic analysis's message says of the singular configurations it passed (a run
    of consecutive times near one counted once, at its middle time)."""
    if not passages:
        return ""
    runs: list[list[int]] = []
    for passage in passages:
        if runs and passage.index == runs[-1][-1] + 1:
            runs[-1].append(passage.index)
        else:
            runs.append([passage.index])
    at = ", ".join(f"{t[run[len(run) // 2]]:.6g}" for run in runs[:5])
    more = f" and {len(runs) - 5} more" if len(runs) > 5 else ""
    return (f" It passed {len(runs)} singular configuration{'s' if len(runs) > 1 else ''} on "
            f"its branch (near t = {at}{more}; the state and outputs at the {len(passages)} "
            "times near them interpolated from times on either side, decision 0036).")


def passed_outputs(model: BuiltModel, t: np.ndarray, y: np.ndarray, p: np.ndarray,
                   inputs: RunInputs | None, passages: list[Passage]) -> dict[str, np.ndarray]:
    """The outputs along a kinematic analysis, those at its passages of singular configurations
    interpolated from the times on either side (kinematic.Passage) as their states were."""
    outputs = {name: np.array(values, dtype=float)
               for name, values in lazy_outputs(model, t, y, p, inputs).items()}
    for passage in passages:
        shifted = lazy_outputs(model, passage.times, passage.states.T, p, inputs)
        for name, values in outputs.items():
            values[passage.index] = passage.weights @ np.asarray(shifted[name], dtype=float)
    return outputs


# -- the arguments, resolved and checked -------------------------------------------------------

def run_times(scene: Mapping[str, Any], span: tuple[float, ...],
              t_eval: Sequence[float] | str | None, per_time: int = 1) -> np.ndarray | None:
    """The checked times of the returned states: t_eval, else the scene's (its step from
    t0 towards t1, or its list within t_span, in the span's direction), else None (the
    solver's steps; also for t_eval SOLVER_STEPS). The results hold PER_TIME numbers a time:
    within the budget (checks.within_budget), checked before anything is allocated."""
    if isinstance(t_eval, str) and t_eval == SOLVER_STEPS:  # the solver's own steps
        return None
    if t_eval is not None:
        within_budget(f"t_eval of {np.size(t_eval)} times", np.size(t_eval) * per_time)
        return checked_times(real_array(t_eval, "t_eval"), span)
    if scene["t_eval_step"]:
        times = step_times(span, float(scene["t_eval_step"]))
        within_budget(f"t_eval of {times.size} times", times.size * per_time)
        return times
    if scene["t_eval"] is not None:
        times = np.asarray(scene["t_eval"], dtype=float)
        inside = times[(times >= min(span)) & (times <= max(span))]
        if not inside.size:
            raise ModelError(f"none of the scene's t_eval times lies in t_span {list(span)}:"
                             " pass t_eval")
        return inside if span[1] >= span[0] else inside[::-1].copy()
    return None


def tolerances(scene: Mapping[str, Any], rtol: Any, atol: Any) -> tuple[float, float]:
    """rtol and atol, or the scene's, or the defaults; checked (see checked_tolerances)."""
    return checked_tolerances(
        rtol if rtol is not None else scene["rtol"] or DEFAULT_RTOL,
        atol if atol is not None else scene["atol"] or DEFAULT_ATOL)


def initial_state(model: BuiltModel, y0: Any, params: Mapping[str, float] | None) -> np.ndarray:
    """The initial state of a run: finite, whatever gave it (y0, the scene, parameters)."""
    state = model.state_vector(y0, params)
    if not all_finite(state):
        values = ", ".join(f"{n}={v:g}" for n, v in zip(model.state_names, state))
        raise ModelError(f"the initial state must be finite, got {values}")
    return state


def checked_settings(scene: Mapping[str, Any], span: tuple[float, ...], max_step: Any,
                     tstops: Any, max_steps: Any) -> runs.RunSettings:
    """max_step, tstops and max_steps, or the scene's, checked (runs.run_settings)."""
    try:
        return runs.run_settings(scene, span, max_step, tstops, max_steps)
    except runs.SettingsError as error:
        raise ModelError(str(error)) from None


def with_tstops(settings: runs.RunSettings, times: np.ndarray, span: tuple[float, ...]
                ) -> runs.RunSettings:
    """SETTINGS with TIMES among its tstops (those inside the span, in its direction)."""
    inside = times[(times > min(span)) & (times < max(span))]
    merged = np.unique(np.concatenate([settings.tstops, inside]))
    return replace(settings, tstops=merged if span[1] >= span[0] else merged[::-1].copy())


def checked_events(events: Any) -> list[Callable]:
    """simulate's events=: None, one callable or a sequence of them (as solve_ivp)."""
    if events is None:
        return []
    listed = [events] if callable(events) else list(events)
    for event in listed:
        if not callable(event):
            raise ModelError(f"events must be callables event(t, y), got {event!r}")
    return listed
