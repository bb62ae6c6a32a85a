"""Runs with nemc's own integrators, in the model's C (NATIVE_METHODS): the build a method needs,
the nemc_run that carries a run's settings to C and its outcome back, and the SimulationResult
made of it (the same result as scipy's solve_ivp would give). Every step here counts towards
simulate()'s fixed cost (benchmarks/overhead.py)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..vocabulary import IMPLICIT_METHODS, TAYLOR_METHODS
from . import runs
from .built import BuiltModel
from .checks import native_tolerances
from .compiled import Compiled
from .failures import IntegrationFailure, ModelError
from .inputs import RunInputs
from .outcome import RunSpec, ended_early, failed_after, gave_up, lazy_outputs
from .results import SUCCESS_MESSAGE, SimulationResult, with_outputs


def native_build(model: BuiltModel, method: str) -> BuiltModel:
    """The build that has what the native method needs: nemc.Radau the Jacobian, nemc.Taylor
    its coefficients (compiled now when this build lacks them); the same from then on, kept
    on the model (1 us less a run)."""
    kept = model._native_builds.get(method)
    if kept is None:
        kept = model._native_builds[method] = find_native_build(model, method)
    return kept


def find_native_build(model: BuiltModel, method: str) -> BuiltModel:
    """native_build's answer, found: the model itself, or its build with the part the method
    needs; refused where there can be none."""
    if method in IMPLICIT_METHODS:
        variant = model.compiled_with("jacobian")
        if not variant.has_part("jacobian"):
            raise ModelError(f"{method} needs the analytic Jacobian, and this build has"
                             " none: compile it with jacobian=True (or a scene method that"
                             " is implicit)")
        return variant
    if method in TAYLOR_METHODS:
        variant = model.compiled_with("taylor")
        if not variant.has_part("taylor"):
            why = variant.metadata.get("taylor_unavailable")
            raise ModelError(f"{method} is not available for {model.name}: " + (
                f"{why}; use nemc.Vern9 or nemc.DOP853" if why else "this build has no"
                " Taylor code (compile it with taylor=True, or name nemc.Taylor as the"
                " scene's method)"))
        if not variant.compiled.taylor_ready():
            raise ModelError(
                f"{method}: this build's Taylor code was compiled for a CPU with FMA "
                "instructions, which this CPU lacks (a package copied from another "
                "machine): compile the mechanism again on this machine, or use nemc.Vern9")
        return variant
    return model


def new_run(compiled: Compiled, span: tuple[float, ...], times: np.ndarray | None, rtol: float,
            atol: float, settings: runs.RunSettings = runs.DEFAULT_SETTINGS) -> tuple[Any, list]:
    """A nemc_run with the settings of one integration, and the buffers it points into.
    times: a contiguous float array, checked already (checked_times), or None for the
    solver's own steps; rtol, atol: as native_tolerances returns them."""
    run = compiled.ffi.new(compiled.run_pointer)
    run.t0, run.t_end = span
    run.rtol, run.atol = rtol, atol
    keep: list = []
    if times is None:
        run.n_eval = -1
    else:
        run.n_eval, run.t_eval = len(times), compiled.buffer(times)
        keep.append(times)
    if settings is not runs.DEFAULT_SETTINGS:  # the usual case: no max_step, no tstops
        run.max_step = settings.max_step if math.isfinite(settings.max_step) else 0.0
        run.stiff_switch = settings.stiff_switch
        if settings.tstops.size:
            run.n_tstops, run.tstops = settings.tstops.size, compiled.buffer(settings.tstops)
            keep.append(settings.tstops)
    run.max_steps = settings.max_steps
    return run, keep


def simulate_native(model: BuiltModel, spec: RunSpec, ending: list | None = None
                    ) -> SimulationResult:
    """A run of MODEL (the build native_build gave) with spec's native method.
    ending: a list that gets (t, state, accepted steps, stiff_from) where a run that turned
    stiff (NEMC_STIFF, under spec.settings.stiff_switch) ended."""
    compiled, method, p = model.compiled, spec.method, spec.p
    integrate, method_id = compiled.native_entry(method)
    rtol, atol = native_tolerances(spec.rtol, spec.atol)
    run, keep = new_run(compiled, spec.span, spec.times, rtol, atol, spec.settings)
    if spec.inputs is not None and spec.inputs.tables:
        keep.append(table_inputs(compiled, run, spec.inputs, p.size))
    n, buffer, times = model.n_state, compiled.buffer, spec.times
    n_eval = -1 if times is None else len(times)
    # the states at t_eval, then the state where a run failed: one buffer
    out = np.empty((max(n_eval, 0) + 1, n))
    run.y_eval = out_buffer = buffer(out)
    run.y_fail = out_buffer + max(n_eval, 0) * n
    work = account_buffer(model, run, n_eval)
    has_events = bool(compiled.event_table)
    try:
        status = run_in_c(compiled, integrate, method_id, run, buffer(spec.state0),
                          compiled.parameter_buffer(p))
        n_out = run.n_out
        if n_eval < 0:
            t, y = taken_steps(compiled, run)
            work = taken_work(compiled, run) if work is not None else None
        elif n_out == n_eval:
            t, y = keep[0], out[:-1].T
        else:
            t, y = keep[0][:n_out], out[:n_out].T
        if work is not None:
            work = work[:n_out]
        events = taken_events(compiled, run) if has_events else {}
    finally:
        if n_eval < 0 or has_events:  # else the run malloc'ed nothing
            compiled.native(method, "free_steps")(run)
    lib = compiled.lib
    if ending is not None and status == lib.NEMC_STIFF:  # method "auto" goes on
        ending.append((float(run.t_fail), out[-1].copy(), int(run.n_steps),
                       float(run.stiff_from)))
    if status == lib.NEMC_REACHED_END and math.isnan(run.stiff_from):
        message = SUCCESS_MESSAGE  # the usual case
    elif status == lib.NEMC_RHS_FAILED:
        cause = compiled.status_cause(run.rhs_status, "taylor_program" if method in
                                      TAYLOR_METHODS else "dynamics_program")
        failure = IntegrationFailure(run.t_fail, out[-1], run.rhs_status, model.state_names,
                                     cause)
        return failed_after(model, spec, failure, t, y, (run.nfev, run.njev, run.nlu),
                            events, (rtol, atol))
    else:
        message = native_message(model, spec, run, out[-1])
    outputs = lazy_outputs(model, t, y, p, spec.inputs)
    if work is not None and t.size:
        outputs = with_outputs(outputs, model.friction.account_outputs(work))
    # positional, in the fields' order: keywords cost 0.4 us more (issue 19)
    return SimulationResult(
        t, y, outputs, run.nfev, run.njev, run.nlu, status,
        message,
        status >= 0, method, rtol, atol, model.parameters_at(p), events)


def account_buffer(model: BuiltModel, run: Any, n_eval: int) -> np.ndarray | None:
    """The work account's buffer (n_eval x items) set in RUN for a model with Coulomb
    friction or contacts (templates/run_control.c.tmpl keeps each item's work at every
    t_eval point; with n_eval -1 at every step, malloc'ed by the run), else None."""
    if not model.friction.present:
        return None
    run.n_work = len(model.friction.items)
    work = np.zeros((max(n_eval, 0), run.n_work))
    if n_eval > 0:
        run.work_eval = model.compiled.buffer(work)
    return work


def taken_work(compiled: Compiled, run: Any) -> np.ndarray:
    """Copy the work account C malloc'ed with the step record (n_out x items)."""
    count, m = run.n_out, run.n_work
    if not count or not m or run.steps_work == compiled.ffi.NULL:
        return np.zeros((count, m))
    return np.frombuffer(compiled.ffi.buffer(run.steps_work, 8 * count * m),
                         dtype=float).reshape(count, m).copy()


def table_inputs(compiled: Compiled, run: Any, inputs: RunInputs, n_parameters: int
                 ) -> tuple[np.ndarray, ...]:
    """The inputs given as tables into RUN (its laws' places in p, the samples; the C moves
    each law from segment to segment: templates/run_control.c.tmpl), and the arrays it points
    into, to keep while it runs."""
    laws = np.array([index for index, _ in inputs.tables], dtype=np.intc)
    sizes = np.array([table.times.size for _, table in inputs.tables], dtype=np.intc)
    times = np.ascontiguousarray(np.concatenate([t.times for _, t in inputs.tables]))
    values = np.ascontiguousarray(np.concatenate([t.values for _, t in inputs.tables]))
    ints = compiled.ffi.typeof("int[]")
    run.n_tables, run.n_parameters = len(laws), n_parameters
    run.table_law = compiled.ffi.from_buffer(ints, laws)
    run.table_size = compiled.ffi.from_buffer(ints, sizes)
    run.table_t, run.table_u = compiled.buffer(times), compiled.buffer(values)
    return laws, sizes, times, values


def run_in_c(compiled: Compiled, integrate: Any, method_id: int, run: Any, y0: Any,
             p: Any) -> int:
    """One native run, Ctrl-C watched for once it lasts (runs.arm_interrupts), or from its
    start where cffi cannot make the callback."""
    run.interrupt = flag = compiled.ffi.new(compiled.int_pointer)
    if compiled.arm_interrupts is None:
        with runs.interrupt_flag(flag):
            return integrate(method_id, run, y0, p)
    run.arm_interrupt = compiled.arm_interrupts
    try:
        return integrate(method_id, run, y0, p)
    finally:
        runs.after_run(flag)


def native_message(model: BuiltModel, spec: RunSpec, run: Any, y_fail: np.ndarray) -> str:
    """scipy's messages for the outcomes scipy has; nemc's for the others (runs.py)."""
    lib, status = model.compiled.lib, run.status
    if status == lib.NEMC_REACHED_END:
        note = "" if math.isnan(run.stiff_from) else runs.stiffness_note(run.stiff_from)
        return SUCCESS_MESSAGE + note
    if status == lib.NEMC_STEP_TOO_SMALL:
        return gave_up(model, "Required step size is less than spacing between numbers.",
                       run.t_fail, y_fail, spec.p)
    if status not in (lib.NEMC_STOPPED_BY_EVENT, lib.NEMC_STEP_BUDGET, lib.NEMC_TOO_SLOW,
                      lib.NEMC_STIFF, lib.NEMC_CHATTERING, lib.NEMC_INTERRUPTED):
        raise RuntimeError(f"{spec.method}: the native integrator failed (status {status})")
    events = model.compiled.event_table
    event = events[run.event_stop]["name"] if 0 <= run.event_stop < len(events) else None
    return ended_early(model, runs.Ending(
        status, run.t_fail, tuple(spec.span), int(run.n_steps), spec.method,
        spec.settings.max_steps, y_fail, run.h_recent, run.stiff_from, run.stiffness, event,
        run.h_recent), spec.p)


def taken_events(compiled: Compiled, run: Any) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The scene's events that fired in a single run, by name: (times, states before)."""
    table = compiled.event_table
    if not table:
        return {}
    count, ffi, n = run.n_event_out, compiled.ffi, compiled.n_state
    which = np.frombuffer(ffi.buffer(run.event_which, 4 * count), dtype=np.intc) \
        if count else np.empty(0, dtype=np.intc)
    times = np.frombuffer(ffi.buffer(run.event_t, 8 * count), dtype=float) \
        if count else np.empty(0)
    states = np.frombuffer(ffi.buffer(run.event_y, 8 * count * n), dtype=float).reshape(
        count, n) if count else np.empty((0, n))
    return {event["name"]: (times[which == k].copy(), states[which == k].copy())
            for k, event in enumerate(table)}


def taken_steps(compiled: Compiled, run: Any) -> tuple[np.ndarray, np.ndarray]:
    """Copy the step record that C malloc'ed (n_eval -1); free_steps releases it."""
    count, ffi, n = run.n_out, compiled.ffi, compiled.n_state
    t = np.frombuffer(ffi.buffer(run.steps_t, 8 * count), dtype=float).copy()
    y = np.frombuffer(ffi.buffer(run.steps_y, 8 * count * n), dtype=float)
    return t, y.reshape(count, n).T.copy()
