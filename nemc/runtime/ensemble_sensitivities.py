"""Sensitivities in ensembles (simulate_many(..., sensitivities=[...])): each member's
variational equations integrated with its state as one system in the same error control, as a
single run's (sensitivities.py), the members one after the other in one C call of the system's
drivers (templates/system.c.tmpl's nemc_system_integrate_many: runs taken as nemc_drivers.c's
ensembles take them, at the system's size, threads sharing the counter), no Python per member
while they run; after, the event times' sensitivities from the states kept before each event.

nemc.Taylor's members too run one after the other, each its single run's series of the system
(templates/taylor_sensitivities.c.tmpl), not in its SIMD lanes: the lanes' code
(templates/batch.c.tmpl) has no columns' series and runs N_STATE entries a lane (decision 0035's
amendment "Ensembles"). Each member's columns start as its single run's:
unit vectors for initial values, d y0 / d p at its own parameters where the scene's initial
state is used, a closed loop's in its own assembled state's tangent space
(loop_sensitivities.py). Refused by name: Coulomb friction and contacts (the
build's own refusal), what a closed loop's single run refuses, inputs as Python functions
(ensembles run in C)."""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import numpy as np

from ..vocabulary import (
    AUTO,
    AUTO_VERN9_BELOW_RTOL,
    IMPLICIT_METHODS,
    NATIVE_METHODS,
)
from . import loop_sensitivities as closed
from . import runs
from . import sensitivities as variational
from .built import DEFAULT_T_SPAN, BuiltModel
from .checks import (
    checked_max_events,
    checked_span,
    checked_threads,
    native_tolerances,
    within_budget,
)
from .ensemble import EnsembleCall, ensemble_inputs, run_threads
from .failures import ModelError
from .inputs import segment_law
from .native import new_run, table_inputs
from .results import EnsembleResult
from .simulation import checked_settings, run_times, tolerances, with_tstops

PREFIX = "simulate_many with sensitivities"

# the system drivers' methods an ensemble runs one member after the other (nemc.Taylor's with
# the build's series of the system, not in its SIMD lanes, which have no columns)
ENSEMBLE_METHODS = ("nemc.DOP853", "nemc.Vern9", "nemc.Radau", variational.NATIVE_TAYLOR)


def simulate_many_sensitivities(model: BuiltModel, call: EnsembleCall, names: Any
                                ) -> EnsembleResult:
    """The ensemble of CALL with the sensitivities of NAMES: res.sensitivities[name][r] is
    member r's d y(t) / d name, as its single run's res.sensitivities[name]."""
    names = variational.requested(names)
    refuse_unsupported(model, call)
    span = checked_span(model.scene["t_span"] or DEFAULT_T_SPAN if call.t_span is None
                        else call.t_span)
    rtol, atol = tolerances(model.scene, call.rtol, call.atol)
    method = system_method(model, call.method, rtol)
    build = variational.sensitivity_build(model)
    if method == variational.NATIVE_RADAU:
        build = variational.radau_build(build)
    if method == variational.NATIVE_TAYLOR:
        build = variational.taylor_build(model, build)
    if span[0] == span[1]:
        raise ModelError(f"{PREFIX}: t_span is empty (t0 == t1): nothing to integrate")
    ps, y0s, tables = ensemble_inputs(model, call.y0s, call.params, call.inputs)
    k = len(y0s)
    ps = np.ascontiguousarray(np.broadcast_to(ps, (k, ps.shape[1])))
    loop = None
    if model.has_loops:  # each run from its assembled state, its columns in its tangent space
        y0s, loop = assembled_runs(model, names, call.y0s, span[0], y0s, ps)
    starts, system_ps, cols = member_columns(model, build, names, (ps, y0s),
                                             call.y0s is not None, (span[0], loop))
    return run_members(model, build, call, span, method, (rtol, atol),
                       (starts, system_ps, tables), cols)


def refuse_unsupported(model: BuiltModel, call: EnsembleCall) -> None:
    """What an ensemble's sensitivities cannot do, refused by name before anything is built."""
    if not model.state_names:
        raise ModelError(f"{PREFIX}: this mechanism has no degree of freedom left by its "
                         "drives (a kinematic analysis)")
    if model.system_drivers is None:
        raise ModelError(f"{PREFIX} need nemc to build the native integrators for the "
                         "sensitivity system: this standalone package has none (use "
                         "simulate(..., sensitivities=...) with scipy's methods)")


def system_method(model: BuiltModel, method: Any, rtol: float) -> str:
    """The native method that runs the members' systems: the one asked for (one of the
    system's drivers'); for None the scene's native method (simulate_many's default),
    nemc.Radau for an implicit scene, else as "auto": nemc.Vern9 below rtol 1e-4 and
    nemc.DOP853 above (a single run's "auto" with sensitivities)."""
    if method is None:
        scene = model.scene["method"]
        method = scene if scene in NATIVE_METHODS else \
            variational.NATIVE_RADAU if scene in IMPLICIT_METHODS else AUTO
    if isinstance(method, str) and method == AUTO:
        return "nemc.Vern9" if rtol < AUTO_VERN9_BELOW_RTOL else "nemc.DOP853"
    if not isinstance(method, str) or method not in ENSEMBLE_METHODS:
        got = repr(method) if isinstance(method, str) else type(method).__name__
        raise ModelError(f"{PREFIX}: method must be one of "
                         f"{', '.join(ENSEMBLE_METHODS)} or auto, got {got}")
    return method


def assembled_runs(model: BuiltModel, names: tuple[str, ...], given_y0s: Any, t0: float,
                   y0s: np.ndarray, ps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A closed loop's runs' initial states assembled as simulate_many assembles them, and the
    mask of the entries given (the others solved: no column, refused by name as simulate
    refuses them)."""
    given = model.loops.given_mask(given_y0s)
    closed.refused_entries(model, names, given)
    return model.loops.assembled_runs(t0, y0s, given, ps), given


def member_columns(model: BuiltModel, build: BuiltModel, names: tuple[str, ...],
                   runs_at: tuple[np.ndarray, np.ndarray], given: bool,
                   loop: tuple[float, np.ndarray | None]
                   ) -> tuple[np.ndarray, np.ndarray, variational.Columns]:
    """Each member's system start [y0 | s_0(t0) | ...] (k x n_state (1 + columns)) and
    parameters [p | count | directions] (k rows), and the columns' layout (the first
    member's: the directions and slices are the same for all). RUNS_AT: the parameter rows and
    initial states. GIVEN: y0s were given (they do not move with the parameters), else each
    member's columns start at d y0 / d p at its own parameters. LOOP: t0 and a closed loop's
    given mask (None for a tree): the columns then start in each run's tangent space."""
    ps, y0s = runs_at
    t0, loop_given = loop
    within_budget(f"{PREFIX} of {len(y0s)} runs", len(y0s) * model.n_state * (
        1 + len(names) * max(model.n_state, 1)))
    starts, system_ps, first = [], [], None
    for y0, p in zip(y0s, ps):
        tangent = None if given else variational.initial_tangent(build, p)
        cols = variational.columns(model, names, p, tangent)
        if loop_given is not None:
            cols = dataclasses.replace(cols, start=closed.start_columns_at(
                build, (t0, y0, p), loop_given, cols.start, cols.directions))
        first = first or cols
        starts.append(np.concatenate([y0, cols.start.T.ravel()]))
        system_ps.append(cols.parameters(p))
    assert first is not None
    return (np.ascontiguousarray(starts, dtype=float),
            np.ascontiguousarray(system_ps, dtype=float), first)


def run_members(model: BuiltModel, build: BuiltModel, call: EnsembleCall,
                span: tuple[float, float], method: str, tols: tuple[float, float],
                members: tuple[np.ndarray, np.ndarray, Any],
                cols: variational.Columns) -> EnsembleResult:
    """The members' systems in one C call per thread (nemc_system_integrate_many), split into
    the states and the columns."""
    starts, system_ps, tables = members
    k, size = len(starts), starts.shape[1]
    drivers = variational.system_drivers(model.system_drivers, size)
    run, keep = members_run(model, drivers, call, span, tols, (k, size, system_ps.shape[1]),
                            tables)
    out = MemberArrays(k, len(keep[0]), size, int(run.event_capacity))
    out.parameters = system_ps
    integrate = members_call(model, build, drivers, method)
    f = drivers.ffi.from_buffer
    arguments = (run, k, f("double[]", starts), f("double[]", system_ps), system_ps.shape[1],
                 *out.buffers(f))
    run.next_run = next_run = drivers.ffi.new("long *")
    threads = checked_threads(call.threads)
    workers = max(1, min(threads or os.cpu_count() or 1, k))
    with runs.interrupt_flag(drivers.ffi.new(drivers.int_pointer)) as flag:
        run.interrupt = flag
        run_threads(lambda: integrate(*arguments), workers, lambda: next_run[0], k,
                    runs.Progress(f"{model.name}: runs", k) if call.progress is not False
                    else None, call.progress)
    result = ensemble_result(model, keep[0], out, method, (run.rtol, run.atol), cols)
    result.event_sensitivities = member_event_sensitivities(build, out, cols, tables)
    return result


def members_run(model: BuiltModel, drivers: Any, call: EnsembleCall, span: tuple[float, float],
                tols: tuple[float, float], sizes: tuple[int, int, int], tables: Any
                ) -> tuple[Any, list]:
    """The settings every member runs with (a nemc_run: times, tolerances, max_step, tstops,
    budget, the input tables, the events kept) and the arrays it points into (the times
    first). SIZES: the members, the system's states and its parameters."""
    k, size, n_parameters = sizes
    times = run_times(model.scene, span, call.t_eval, size)
    times = np.array(sorted(set(span), reverse=span[1] < span[0]) if times is None else times,
                     dtype=float)
    within_budget(f"{PREFIX} of {k} runs at {len(times)} times", k * len(times) * size)
    settings = checked_settings(model.scene, span, call.max_step, call.tstops, call.max_steps)
    if tables is not None:  # every step lands on the tables' samples
        settings = with_tstops(settings, tables.tstops, span)
    rtol, atol = native_tolerances(*tols)
    run, keep = new_run(drivers, span, times, rtol, atol, settings)
    if tables is not None:
        keep.append(table_inputs(drivers, run, tables, n_parameters))
    run.event_capacity = checked_max_events(call.max_events)
    return run, keep


class MemberArrays:
    """The ensemble's output arrays, as nemc_integrate_many fills them: the systems' states at
    t_eval (k x n_t x size), statuses, counts (k x 4), the events kept (k x capacity)."""

    def __init__(self, k: int, n_t: int, size: int, capacity: int):
        self.z = np.empty((k, n_t, size))
        self.statuses = np.empty(k, dtype=np.intc)
        self.counts = np.zeros((k, 4), dtype=np.int_)
        self.event_t = np.full((k, max(capacity, 1)), np.nan)
        self.event_which = np.full((k, max(capacity, 1)), -1, dtype=np.intc)
        self.event_y = np.full((k, max(capacity, 1), size), np.nan)  # the states before
        self.event_counts = np.zeros(k, dtype=np.int_)
        self.capacity = capacity
        self.parameters = np.empty((k, 0))  # the members' system parameters

    def buffers(self, f: Any) -> tuple:
        return (f("double[]", self.z), f("int[]", self.statuses), f("long[]", self.counts),
                f("double[]", self.event_t), f("int[]", self.event_which),
                f("double[]", self.event_y),
                f("long[]", self.event_counts))


def members_call(model: BuiltModel, build: BuiltModel, drivers: Any, method: str) -> Any:
    """nemc_system_integrate_many bound to the build's system and events (and nemc.Taylor's
    series of the system): a function of the run's settings, the members and the output
    arrays."""
    table = model.compiled.event_table
    ints = drivers.ffi.typeof("int[]")
    directions = np.array([runs.DIRECTIONS[e["direction"]] for e in table] or [0],
                          dtype=np.intc)
    actions = np.array([variational.ACTIONS[e["action"]] for e in table] or [0],
                       dtype=np.intc)
    null = drivers.ffi.NULL
    rhs = drivers.function(build, "sensitivity_rhs")
    events = drivers.function(build, "events") if table else null
    impact = drivers.function(build, "sensitivity_impact", "nemc_system_impact_fn") \
        if table else null
    jacobian, block = (drivers.function(build, "jacobian"), build.n_state) \
        if method == variational.NATIVE_RADAU else (null, 0)
    taylor = drivers.function(build, "sensitivity_taylor", "nemc_system_taylor_fn") \
        if method == variational.NATIVE_TAYLOR else null
    method_id = getattr(drivers.lib, "NEMC_" + method.split(".")[1].upper())
    kept = (drivers.ffi.from_buffer(ints, directions), drivers.ffi.from_buffer(ints, actions))

    def integrate(*arguments: Any) -> int:
        return drivers.lib.nemc_system_integrate_many(
            method_id, rhs, jacobian, block, taylor, len(table), *kept, events, impact, *arguments)

    return integrate


def ensemble_result(model: BuiltModel, t: np.ndarray, out: MemberArrays, method: str,
                    tols: tuple[float, float], cols: variational.Columns) -> EnsembleResult:
    """The EnsembleResult of the members' states, with res.sensitivities[name]: (k, n_state,
    n_t) ("y0": (k, n_state, n_state, n_t)), NaN after a member stopped."""
    n = model.n_state
    if model.has_loops:  # as simulate_many's: the states brought onto the constraints
        ps = out.parameters[:, :cols.directions.shape[1]]
        out.z[:, :, :n] = model.loops.projected_runs(t, out.z[:, :, :n], ps)
    z = out.z.transpose(0, 2, 1)  # k x size x n_t
    by_column = z[:, n:].reshape(len(z), cols.count, n, -1)  # k x columns x n_state x n_t
    sensitivities = {name: np.ascontiguousarray(
        by_column[:, where].transpose(0, 2, 1, 3) if name == variational.INITIAL_VALUES
        else by_column[:, where.start]) for name, where in cols.slices.items()}
    capacity = out.capacity
    return EnsembleResult(
        t=t, y=np.ascontiguousarray(z[:, :n]), status=out.statuses.astype(int),
        success=out.statuses >= 0, nfev=out.counts[:, 0].copy(),
        njev=out.counts[:, 1].copy(), nlu=out.counts[:, 2].copy(), method=method,
        rtol=tols[0], atol=tols[1],
        event_names=tuple(e["name"] for e in model.metadata.get("events") or []),
        event_t=out.event_t[:, :capacity], event_which=out.event_which[:, :capacity],
        event_count=out.event_counts, sensitivities=sensitivities)


def member_event_sensitivities(build: BuiltModel, out: MemberArrays, cols: variational.Columns,
                               tables: Any) -> dict[str, dict[str, list[np.ndarray]]]:
    """Each scene event's times' sensitivities in each member (its events kept: the first
    max_events), from the system's states recorded before each (C event_time_sensitivities,
    as a single run's): event -> name -> k arrays, (count,) ("y0": (n_state, count)); NaN where
    the C refuses a state."""
    table = build.compiled.event_table
    call, buffer = build.compiled.function("event_time_sensitivities"), build.compiled.buffer
    found: dict[str, dict[str, list[np.ndarray]]] = {
        event["name"]: {name: [] for name in cols.slices} for event in table}
    for r in range(len(out.z)) if table else ():
        kept = min(int(out.event_counts[r]), out.capacity)
        dtau = np.empty((kept, cols.count))
        for i in range(kept):
            t = float(out.event_t[r, i])
            p = member_parameters(out.parameters[r], tables, t)
            if call(int(out.event_which[r, i]), t, buffer(out.event_y[r, i]), buffer(p),
                    buffer(dtau[i])):
                dtau[i] = np.nan
        which = out.event_which[r, :kept]
        for index, event in enumerate(table):
            rows = dtau[which == index]
            for name, where in cols.slices.items():
                found[event["name"]][name].append(
                    rows[:, where].T.copy() if name == variational.INITIAL_VALUES
                    else rows[:, where.start].copy())
    return found


def member_parameters(system_p: np.ndarray, tables: Any, t: float) -> np.ndarray:
    """A member's system parameters at t: with the input tables' laws for the segment from t
    (as RunInputs.at sets them in a single run's)."""
    if tables is None:
        return system_p
    p = system_p.copy()
    for index, table in tables.tables:
        p[index: index + 3] = segment_law(table, t)
    return p
