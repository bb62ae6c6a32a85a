"""Ensembles (Model.simulate_many): many runs of a native method, the loop over runs in C,
shared by threads; nemc.Taylor's runs NEMC_LANES at a time in SIMD lanes (templates/batch.c.tmpl)
with the same results to the last bit as one after the other."""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..vocabulary import (
    AUTO,
    AUTO_LANES_MIN_RUNS,
    IMPLICIT_METHODS,
    NATIVE_METHODS,
    TAYLOR_METHODS,
)
from . import runs
from .auto import checked_auto_choice
from .built import DEFAULT_T_SPAN, BuiltModel
from .checks import (
    _user_stacklevel,
    checked_max_events,
    checked_span,
    checked_threads,
    ensemble_columns,
    native_tolerances,
    real_array,
    within_budget,
)
from .failures import BuildNotice, ModelError
from .friction import FRICTION_METHOD, FRICTION_METHODS
from .inputs import RunInputs
from .native import native_build, new_run, table_inputs
from .results import EnsembleResult
from .simulation import checked_settings, initial_state, run_times, tolerances, with_tstops


@dataclass(frozen=True)
class EnsembleCall:
    """simulate_many's arguments, as the caller gave them (Model.simulate_many says what each
    means)."""

    y0s: Any = None
    params: Mapping[str, Any] | None = None
    t_span: Sequence[float] | None = None
    t_eval: Sequence[float] | None = None
    method: str | None = None
    rtol: float | None = None
    atol: float | None = None
    threads: int | None = None
    max_step: float | None = None
    tstops: Sequence[float] | None = None
    max_steps: int | None = None
    max_events: int = runs.DEFAULT_MAX_EVENTS
    progress: bool | None = None
    lanes: bool = True
    inputs: Any = None


def simulate_many(model: BuiltModel, call: EnsembleCall) -> EnsembleResult:
    """The ensemble of CALL: its method chosen ("auto", or None: ensemble_method's), then run
    by the build that has what the method needs (its lanes, its Jacobian, ...)."""
    if not model.state_names:  # every coordinate driven: as a closed loop without freedom
        raise ModelError("simulate_many: this mechanism has no degree of freedom left by its "
                         "drives (a kinematic analysis): use simulate")
    span = checked_span(model.scene["t_span"] or DEFAULT_T_SPAN if call.t_span is None
                        else call.t_span)
    method, lanes = call.method, call.lanes
    at_hand = model._builds_at_hand()  # a build made after this, this call made
    inputs = None  # (parameters, starts, tables), made once
    if method is None or (isinstance(method, str) and method == AUTO):
        inputs = ps, starts, _ = ensemble_inputs(model, call.y0s, call.params, call.inputs)
        method = FRICTION_METHOD if model.friction.present else \
            ensemble_method(model, span, starts[0], ps[0], call.rtol, len(starts))
        lanes = lanes and (len(starts) >= AUTO_LANES_MIN_RUNS or model.has_part("lanes"))
    if not isinstance(method, str) or method not in NATIVE_METHODS:
        got = repr(method) if isinstance(method, str) else type(method).__name__
        raise ModelError(f"simulate_many: method must be one of {', '.join(NATIVE_METHODS)}"
                         f" or auto, got {got}")
    model.friction.check_method(method)
    in_lanes = method in TAYLOR_METHODS and bool(lanes) and not has_tables(call.inputs)
    build = model.compiled_with("lanes") if in_lanes else model
    in_lanes = in_lanes and build.has_part("lanes")
    if not in_lanes:  # (a lanes build that could not have them says why Taylor cannot)
        build = native_build(build, method)
    if build is not model:  # a build with the method's part: it runs the ensemble
        if all(build is not other for other in at_hand):
            note_build(build, method + (" in SIMD lanes" if in_lanes else ""))
        return simulate_many(build, replace(call, method=method, lanes=lanes))
    return run_ensemble(model, call, span, method, in_lanes, inputs)


def note_build(build: BuiltModel, method: str) -> None:
    """A BuildNotice, once, when the ensemble's build was compiled by this call for METHOD
    (not loaded from the cache): the user sees why the first call took seconds, and that later
    ones will not."""
    seconds, build.fresh_build_seconds = build.fresh_build_seconds, None
    if seconds is not None:
        warnings.warn(BuildNotice(
            f"simulate_many built {build.name}'s code for {method} in {seconds:.1f} s, once: "
            "later calls and sessions load it from nemc's cache"), stacklevel=_user_stacklevel())


def run_ensemble(model: BuiltModel, call: EnsembleCall, span: tuple[float, float],
                 method: str, in_lanes: bool, inputs: tuple | None) -> EnsembleResult:
    """The ensemble in the model's C: its inputs checked, every run's buffers made, the runs
    shared by threads (run_threads), a closed loop's states brought onto its constraints."""
    rtol, atol = tolerances(model.scene, call.rtol, call.atol)
    threads = checked_threads(call.threads)
    times = run_times(model.scene, span, call.t_eval)
    times = np.array(sorted(set(span), reverse=span[1] < span[0]) if times is None else times,
                     dtype=float)
    given = model.loops.given_mask(call.y0s)
    ps, y0s, tables = inputs or ensemble_inputs(model, call.y0s, call.params, call.inputs)
    within_budget(f"simulate_many of {len(y0s)} runs at {len(times)} times",
                  len(y0s) * len(times) * model.n_state)
    if model.has_loops:  # each run from its assembled state
        ps = np.ascontiguousarray(model.loops.started_runs(span[0], y0s, ps))
        y0s = model.loops.assembled_runs(span[0], y0s, given, ps)
    if model.friction.present:  # each run its own parameter row: its modes
        y0s, ps = model.friction.started_runs(span[0], y0s, ps)
    settings = checked_settings(model.scene, span, call.max_step, call.tstops, call.max_steps)
    if tables is not None:  # every step lands on the tables' samples
        settings = with_tstops(settings, tables.tstops, span)
    capacity = checked_max_events(call.max_events)
    compiled = model.compiled
    integrate_many = compiled.native(method, "integrate_lanes" if in_lanes else "integrate_many")
    method_id = compiled.method_id(method)
    rtol, atol = native_tolerances(rtol, atol)
    run, keep = new_run(compiled, span, times, rtol, atol, settings)
    if tables is not None:
        keep.append(table_inputs(compiled, run, tables, ps.shape[1]))
    run.event_capacity = capacity
    k, n = len(y0s), model.n_state
    y = np.empty((k, len(times), n))
    statuses = np.empty(k, dtype=np.intc)
    counts = np.empty((k, 4), dtype=np.int_)
    event_t = np.full((k, max(capacity, 1)), np.nan)
    event_which = np.full((k, max(capacity, 1)), -1, dtype=np.intc)
    event_counts = np.zeros(k, dtype=np.int_)
    p_stride = ps.shape[1] if ps.shape[0] > 1 else 0

    ffi = compiled.ffi
    f = ffi.from_buffer
    arguments = (method_id, run, k, f("double[]", y0s), f("double[]", ps), p_stride,
                 f("double[]", y), f("int[]", statuses), f("long[]", counts),
                 f("double[]", event_t), f("int[]", event_which), f("long[]", event_counts))
    run.next_run = next_run = ffi.new("long *")  # the runs' counter the threads share
    lanes_each = model.metadata.get("lane_count", 1) if in_lanes else 1
    workers = max(1, min(threads or os.cpu_count() or 1, -(-k // lanes_each)))
    with runs.interrupt_flag(ffi.new(compiled.int_pointer)) as flag:
        run.interrupt = flag
        run_threads(lambda: integrate_many(*arguments), workers, lambda: next_run[0], k,
                    runs.Progress(f"{model.name}: runs", k) if call.progress is not False
                    else None, call.progress)
    if model.has_loops:
        y = model.friction.held(y, model.loops.projected_runs(keep[0], y, ps))
    return EnsembleResult(
        t=keep[0], y=y.transpose(0, 2, 1), status=statuses.astype(int),
        success=statuses >= 0, nfev=counts[:, 0].copy(), njev=counts[:, 1].copy(),
        nlu=counts[:, 2].copy(), method=method, rtol=rtol, atol=atol,
        event_names=tuple(e["name"] for e in model.metadata.get("events") or []),
        event_t=event_t[:, :capacity], event_which=event_which[:, :capacity],
        event_count=event_counts,
    )


def ensemble_method(model: BuiltModel, span: Sequence[float], y0: Any = None,
                    params: Any = None, rtol: float | None = None, runs: int = 1) -> str:
    """Model.ensemble_method: the scene's native method; nemc.Radau for an implicit scene;
    else "auto"'s choice for a run from y0 (default the scene's) for RUNS runs."""
    scene = model.scene["method"]
    if model.friction.present:  # its explicit native methods only (runtime/friction.py)
        return scene if scene in FRICTION_METHODS else FRICTION_METHOD
    if scene in NATIVE_METHODS:
        return scene
    if scene in IMPLICIT_METHODS:
        return "nemc.Radau"
    p = params if isinstance(params, np.ndarray) else model.parameter_vector(params)
    y0 = initial_state(model, None, params if isinstance(params, Mapping) else None) \
        if y0 is None else y0
    return checked_auto_choice(model, span, y0, tolerances(model.scene, rtol, None)[0], p, runs)


def has_tables(inputs: Any) -> bool:
    """Whether simulate_many's inputs hold a table (runs one after the other: not in lanes)."""
    return isinstance(inputs, Mapping) and any(
        isinstance(v, tuple | list) and len(v) == 2 and not np.isscalar(v[0])
        for v in inputs.values())


def per_run(value: Any) -> bool:
    """An input's value given run by run: a 1-D array of numbers (a table is a pair of
    arrays, a feedback an object)."""
    return isinstance(value, np.ndarray | list) and np.ndim(value) == 1 and all(
        np.isscalar(v) for v in value)


def ensemble_inputs(model: BuiltModel, y0s: Any, params: Mapping[str, Any] | None,
                    inputs: Any = None) -> tuple[np.ndarray, np.ndarray, RunInputs | None]:
    """(parameter vectors (k or 1, n_p) with the inputs' laws, initial states (k, n_state),
    the tables the runs share or None), checked. An input's value may be given run by run (an
    array of k numbers), else shared: a number, a table, nemc.feedback(...)."""
    columns = ensemble_columns(params)
    sizes = {len(v) for v in columns.values() if len(v) != 1}
    if isinstance(inputs, Mapping):
        sizes |= {len(v) for v in inputs.values() if per_run(v) and len(v) != 1}
    y0s, values = checked_y0s(model, y0s)
    if values is not None:
        sizes |= {len(v) for v in values.values() if len(v) != 1}
    elif y0s is not None:
        sizes.add(len(y0s))
    if len(sizes) > 1:
        raise ModelError(f"simulate_many: y0s and params disagree on the number of runs:"
                         f" {sorted(sizes)}")
    k = sizes.pop() if sizes else 1
    if k == 0:
        raise ModelError("simulate_many: no runs (params hold empty arrays)")
    within_budget(f"simulate_many of {k} runs", k * (model.n_state + len(model.parameter_names)))
    sets = [{name: v[i % len(v)] for name, v in columns.items()} for i in
            range(k if any(len(v) > 1 for v in columns.values()) else 1)]
    ps = np.array([model.parameter_vector(s) for s in sets])
    tables = None
    if inputs is not None:
        ps, tables = with_run_inputs(model, ps, inputs, k)
    if values is not None:
        y0s = given_states(model, values, sets, k)
    elif y0s is None:
        y0s = np.broadcast_to(scene_starts(model, sets), (k, model.n_state))
    if not np.all(np.isfinite(y0s)):
        raise ModelError("y0s must be finite")
    return np.ascontiguousarray(ps), np.ascontiguousarray(y0s, dtype=float), tables


def scene_starts(model: BuiltModel, sets: Sequence[Mapping[str, float]]) -> np.ndarray:
    """The scene's initial state at each parameter set; one a closed loop cannot assemble
    refused by its run's number (where the runs' parameters differ)."""
    states = []
    for run, params in enumerate(sets):
        try:
            states.append(model.initial_state(params))
        except ModelError as error:
            if len(sets) == 1:
                raise
            raise ModelError(f"simulate_many: run {run} of {len(sets)}: {error}") from None
    return np.array(states)


def checked_y0s(model: BuiltModel, y0s: Any
                ) -> tuple[np.ndarray | None, dict[str, np.ndarray] | None]:
    """simulate_many's y0s checked: (the states (k, n_state), None), or (None, a dict's
    columns: state name -> one value or one per run), or (None, None) for the scene's."""
    if isinstance(y0s, Mapping):
        return None, state_columns(model, y0s)
    if y0s is None:
        return None, None
    y0s = real_array(y0s, "y0s")
    within_budget(f"y0s of shape {y0s.shape}", y0s.size)
    y0s = y0s.astype(float)
    if y0s.ndim != 2 or y0s.shape[1] != model.n_state or not len(y0s):
        raise ModelError(f"y0s must have shape (k, {model.n_state}) or be a dict of state "
                         f"values, got {y0s.shape}")
    return y0s, None


def state_columns(model: BuiltModel, y0s: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """A dict y0s checked: state name -> its value (1,) or one per run (k,)."""
    columns = ensemble_columns(y0s, "state value", "y0s")
    for name in columns:
        if name not in model.state_names:
            raise ModelError(f"y0s: unknown state name {name!r} (the state: "
                             f"{', '.join(model.state_names)})")
    return columns


def given_states(model: BuiltModel, values: Mapping[str, np.ndarray],
                 sets: Sequence[Mapping[str, float]], k: int) -> np.ndarray:
    """The K runs' states from a dict y0s, each as simulate's y0=dict makes it at the run's
    parameters SETS[i]: the values given, the others 0 (a tree) or, for a closed loop, the
    model.guess_state's, from which the others are solved (run_ensemble, with the given mask
    of the dict's names)."""
    bases = np.array([model.guess_state(s) if model.has_loops else np.zeros(model.n_state)
                      for s in sets])
    states = np.array(bases[np.arange(k) % len(bases)])
    for name, column in values.items():
        states[:, model.state_names.index(name)] = column if len(column) > 1 else column[0]
    return states


def with_run_inputs(model: BuiltModel, ps: np.ndarray, inputs: Any, k: int
                    ) -> tuple[np.ndarray, RunInputs | None]:
    """The parameter vectors with each run's inputs' laws set (k rows where an input or a
    parameter varies by run), and the tables they share."""
    varying = isinstance(inputs, Mapping) and any(per_run(v) and len(v) > 1
                                                  for v in inputs.values())
    rows = k if varying or len(ps) > 1 else 1
    laid, last = [], None
    for i in range(rows):
        given = {name: (v[i % len(v)] if per_run(v) else v) for name, v in inputs.items()} \
            if isinstance(inputs, Mapping) else inputs
        last = model.input_layout.resolve(ps[i % len(ps)], given)
        if last.callables:
            raise ModelError("simulate_many runs in C: inputs are numbers (per run or "
                             "shared), tables (times, values) or nemc.feedback(...), not "
                             "Python functions")
        laid.append(last.p)
    return np.array(laid), last if last is not None and last.tables else None


def run_threads(work: Callable[[], None], workers: int, taken: Callable[[], int], total: int,
                progress: runs.Progress | None, show: bool | None) -> None:
    """WORK on WORKERS threads at once: each call takes the ensemble's runs one by one from the
    counter they share (nemc_run's next_run) until none is left, so that no thread idles while
    runs remain, and none of them ends a slice of runs with its SIMD lanes part-empty (cffi
    releases the GIL during the C calls). taken: the counter's value (the runs begun: the
    progress shown); results do not depend on which thread runs which run."""
    from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait

    if progress is not None and show:
        progress.delay = 0.0
    with ThreadPoolExecutor(workers) as pool:
        futures = [pool.submit(work) for _ in range(workers)]
        try:
            pending = futures
            while pending:
                finished, pending = wait(pending, timeout=0.1, return_when=FIRST_EXCEPTION)
                for future in finished:
                    future.result()  # a worker's error, raised here
                if progress is not None:
                    progress.update(min(taken(), total))
        finally:
            if progress is not None:
                progress.close()
