"""Forward sensitivities along a run (simulate(..., sensitivities=[...])): d y(t) / d p for named
parameters and inputs, and d y(t) / d y0, from the variational equations

    ds_j/dt = J_y(t, y, p) s_j + J_p(t, y, p) e_j

integrated with the state as one system, in the same error control (the build's part
"sensitivities": templates/sensitivities.c.tmpl evaluates the whole system's right-hand side in
one C call, the accelerations' program once and its exact forward-mode derivative once per
column). The columns' start: the unit vectors for initial values, d y0 / d p for a parameter
when the scene's initial state is used (its values may be expressions of parameters), else 0.

The system runs with nemc.DOP853, nemc.Vern9, nemc.Radau and nemc.Taylor (the drivers compiled
for the system's size once, kept in the cache: nemc/build/systems.py; the model's events
located on the state's entries) or with scipy's methods, the implicit ones with the
block-diagonal Jacobian diag(J_y, ..., J_y) (the Newton iteration's, the second derivatives
left out); nemc.Radau (the build then with the part "jacobian" as well) takes J_y as the
diagonal block of its Newton matrix and the columns' coupling by differences
(templates/radau.c.tmpl); nemc.Taylor (the build then with the part "taylor" as well) is the
model's own run of the system, handed to the drivers as a pointer: each column's Taylor
coefficients the tangent of the state's, one expansion of the whole system, its step size from
all of it (templates/taylor_sensitivities.c.tmpl). At the scene's impact events the
columns jump (the build's `sensitivity_impact`, applied where the run applies the law: by the
native drivers in C, by scipy's runs through the same C), and every event's time has its own
sensitivities (`event_time_sensitivities` at the states recorded before each event:
res.event_sensitivities). A closed loop's run starts from its assembled state with its
columns in the constraints' tangent space (loop_sensitivities.py); inputs given as Python
functions are refused by name, and so is nemc.Taylor where the model has none (a closed loop).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..vocabulary import (
    AUTO,
    AUTO_VERN9_BELOW_RTOL,
    IMPLICIT_METHODS,
    NATIVE_METHODS,
    SCIPY_METHODS,
)
from . import loop_sensitivities as closed
from . import native, runs
from .built import BuiltModel
from .checks import native_tolerances
from .compiled import arm_callback
from .failures import IntegrationFailure, ModelError
from .outcome import RunSpec, ended_early, gave_up, lazy_outputs
from .results import LazyOutputs, SimulationResult

INITIAL_VALUES = "y0"  # the name asking for d y(t) / d y0, every initial value at once
SCIPY_DEFAULT = "DOP853"  # "auto" where the native drivers cannot run (a standalone package,
#                           events= callables): scipy's DOP853
NATIVE_RADAU = "nemc.Radau"  # its Newton matrix's diagonal blocks: the build's J_y
NATIVE_TAYLOR = "nemc.Taylor"  # the build's own series of the system (its part "taylor")
ACTIONS = {"record": 0, "stop": 1, "impact": 2}  # enum nemc_event_action


@dataclass(frozen=True)
class Columns:
    """The sensitivity columns of a run: for each requested name its columns (a slice), each
    column's start s_j(t0) (n_state x k) and its direction in the parameters e_j (k x
    n_param)."""

    names: tuple[str, ...]
    slices: Mapping[str, slice]
    start: np.ndarray
    directions: np.ndarray

    @property
    def count(self) -> int:
        return self.directions.shape[0]

    def parameters(self, p: np.ndarray) -> np.ndarray:
        """The sensitivity system's parameter vector: p, the count, the directions."""
        return np.concatenate([p, [float(self.count)], self.directions.ravel()])


def requested(names: Any) -> tuple[str, ...]:
    """sensitivities=: a name or a sequence of names, each once."""
    listed = [names] if isinstance(names, str) else names
    try:
        listed = list(listed)
    except TypeError:
        raise ModelError(f"sensitivities must be a list of names (parameters, inputs, initial "
                         f"values or \"y0\"), got {names!r}") from None
    for name in listed:
        if not isinstance(name, str):
            raise ModelError(f"sensitivities: names are strings, got {name!r}")
    repeated = sorted({name for name in listed if listed.count(name) > 1})
    if repeated:
        raise ModelError(f"sensitivities: {repeated} asked for more than once")
    if not listed:
        raise ModelError("sensitivities: no name given (parameters, inputs, initial values "
                         "or \"y0\")")
    return tuple(listed)


def columns(model: BuiltModel, names: Sequence[str], p: np.ndarray,
            initial_tangent: np.ndarray | None) -> Columns:
    """The columns of NAMES: "y0" (every initial value), a state entry's name (its initial
    value), a parameter or an input (its constant term: d y / d u for a constant input).
    INITIAL_TANGENT: d y0 / d p (n_state x n_param) where the scene's initial state is used,
    else None (a given y0 does not move with the parameters)."""
    n, size = model.n_state, p.size
    starts: list[np.ndarray] = []
    directions: list[np.ndarray] = []
    slices: dict[str, slice] = {}
    for name in names:
        first = len(starts)
        if name == INITIAL_VALUES or name in model.state_names:
            entries = range(n) if name == INITIAL_VALUES else [model.state_names.index(name)]
            for i in entries:
                starts.append(np.eye(n)[i])
                directions.append(np.zeros(size))
        else:
            index = direction_index(model, name)
            direction = np.zeros(size)
            direction[index] = 1.0
            starts.append(np.zeros(n) if initial_tangent is None else initial_tangent[:, index])
            directions.append(direction)
        slices[name] = slice(first, len(starts))
    return Columns(tuple(names), slices, np.array(starts).T.copy(), np.array(directions))


def direction_index(model: BuiltModel, name: str) -> int:
    """Where in p the direction of NAME lies: a parameter's place, an input's constant term;
    a derived parameter or an unknown name refused."""
    if name in model.input_names:
        return model.input_layout.value_index(name)
    if name in model.parameter_names or name in model.derived_parameters:
        return model.parameter_table.index(name)  # a derived one: refused, with its formula
    import difflib

    known = [INITIAL_VALUES, *model.parameter_names, *model.input_names, *model.state_names]
    close = difflib.get_close_matches(name, known, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise ModelError(f"sensitivities: unknown name {name!r}{hint} (parameters "
                     f"{list(model.parameter_names)}, inputs {list(model.input_names)}, initial "
                     f"values {list(model.state_names)} or \"y0\")")


def sensitivity_build(model: BuiltModel) -> BuiltModel:
    """The build with the part "sensitivities" (compiled on first need), or a refusal saying
    why this model cannot have it."""
    why = model.metadata.get("sensitivities_unavailable")
    if why:
        raise ModelError(f"sensitivities: {why}")
    build = model.compiled_with("sensitivities")
    why = build.metadata.get("sensitivities_unavailable")
    if why:
        raise ModelError(f"sensitivities: {why}")
    if not build.has_part("sensitivities"):
        raise ModelError("sensitivities: this standalone package was built without its "
                         "variational equations: compile it with nemc (nemc compile "
                         "--sensitivities)")
    return build


def radau_build(build: BuiltModel) -> BuiltModel:
    """The sensitivity build with the part "jacobian" too (J_y, the exact Jacobian, the
    diagonal blocks of nemc.Radau's Newton matrix), compiled on first need."""
    variant = build.compiled_with("jacobian")
    if not (variant.has_part("jacobian") and variant.has_part("sensitivities")):
        raise ModelError(f"sensitivities with {NATIVE_RADAU} need the analytic Jacobian, and "
                         "this build has none: compile it with nemc (jacobian=True), or use "
                         "nemc.Vern9 or scipy's Radau")
    return variant


def taylor_build(model: BuiltModel, build: BuiltModel) -> BuiltModel:
    """The sensitivity build with the part "taylor" too (the series of the state and of its
    columns: templates/taylor_sensitivities.c.tmpl), compiled on first need, or a refusal
    saying why this model has no nemc.Taylor."""
    why = model.metadata.get("taylor_unavailable")
    if why:
        raise ModelError(f"sensitivities with {NATIVE_TAYLOR}: {why}")
    variant = build.compiled_with("taylor")
    why = variant.metadata.get("taylor_unavailable")
    if why:
        raise ModelError(f"sensitivities with {NATIVE_TAYLOR}: {why}")
    if not (variant.has_part("taylor") and variant.has_part("sensitivities")):
        raise ModelError(f"sensitivities with {NATIVE_TAYLOR} need its series, and this build "
                         "has none: compile it with nemc (taylor=True), or use nemc.Vern9")
    return variant


def checked_spec(model: BuiltModel, spec: RunSpec) -> RunSpec:
    """The run's plan with its method for sensitivities: scipy's (DOP853 for none or "auto");
    what cannot have sensitivities refused by name."""
    if spec.inputs is not None and spec.inputs.callables:
        raise ModelError("sensitivities: an input given as a Python function has no derivative "
                         "nemc can take; give it as a number, a table or nemc.feedback(...)")
    method = spec.method
    native_ok = model.system_drivers is not None and not spec.user_events
    if method == AUTO:
        if not native_ok:
            return spec.but(method=SCIPY_DEFAULT)
        return spec.but(method="nemc.Vern9" if spec.rtol < AUTO_VERN9_BELOW_RTOL
                        else "nemc.DOP853")
    if method in NATIVE_METHODS and spec.user_events:
        raise ModelError(f"events= callables need one of scipy's methods: {method} runs in C")
    if method in NATIVE_METHODS and model.system_drivers is None:
        raise ModelError(f"sensitivities with {method} need nemc to build the native "
                         "integrators for the sensitivity system: this standalone package "
                         f"runs them with scipy's methods ({', '.join(SCIPY_METHODS)})")
    return spec


def simulate_sensitivities(model: BuiltModel, spec: RunSpec, names: Any,
                           y0_given: bool, y0: Any = None) -> SimulationResult:
    """One run of SPEC with the sensitivities of NAMES (see Model.simulate). Y0_GIVEN: the
    caller gave y0 (then it does not move with the parameters), Y0 (a closed loop's: what it
    gives)."""
    names = requested(names)
    spec = checked_spec(model, spec)
    build = sensitivity_build(model)
    if model.compiled.event_table and build.compiled.function("sensitivity_impact") is None:
        raise ModelError("sensitivities: this standalone package was built by an nemc without "
                         "the sensitivities at events: compile it again (nemc compile "
                         "--sensitivities)")
    if spec.method == NATIVE_RADAU:
        build = radau_build(build)
    if spec.method == NATIVE_TAYLOR:
        build = taylor_build(model, build)
    tangent = None if y0_given else initial_tangent(build, spec.p)
    if model.has_loops:  # the start assembled, the columns in its tangent space
        spec, given = closed.assembled_spec(model, spec, y0)
        closed.refused_entries(model, names, given)
    cols = columns(model, names, spec.p, tangent)
    if model.has_loops:
        cols = dataclasses.replace(cols, start=closed.start_columns(
            build, spec, given, cols.start, cols.directions))
    if spec.span[0] == spec.span[1]:
        raise ModelError("sensitivities: t_span is empty (t0 == t1): nothing to integrate")
    return run_system(model, build, spec, cols)


def initial_tangent(build: BuiltModel, p: np.ndarray) -> np.ndarray:
    """d y0 / d p of the scene's initial state at p (n_state x n_param)."""
    out = np.empty((build.n_state, p.size))
    compiled = build.compiled
    compiled.functions["initial_state_tangent"](compiled.buffer(p), compiled.buffer(out))
    return out


def run_system(model: BuiltModel, build: BuiltModel, spec: RunSpec, cols: Columns
               ) -> SimulationResult:
    """The sensitivity system integrated with the run's method, split into the run's states
    and their sensitivities."""
    n = model.n_state
    z0 = np.concatenate([spec.state0, cols.start.T.ravel()])
    run = native_run if spec.method in NATIVE_METHODS else scipy_run
    try:
        outcome = run(model, build, spec, cols, z0)
    except IntegrationFailure as failure:
        return closed.singular_noted(model, failed_run(model, spec, cols, failure))
    t, z = outcome.t, outcome.z
    y = z[:n].copy()
    finite = bool(np.all(np.isfinite(z)))
    if model.has_loops and finite and t.size:  # as simulate's: the states on the constraints
        y = model.loops.projected(t, y, spec.p)
    result = SimulationResult(
        t, y, lazy_outputs(model, t, y, spec.p, spec.inputs), outcome.nfev, outcome.njev,
        outcome.nlu, outcome.status, outcome.message if finite else
        "the sensitivities are not finite: " + outcome.message,
        outcome.status >= 0 and finite, spec.method, outcome.rtol, outcome.atol,
        model.parameters_at(spec.p),
        {name: (times, states[:, :n]) for name, (times, states) in outcome.events.items()})
    result.sensitivities = split_columns(z[n:], cols, n)
    result.output_sensitivities = output_sensitivities(model, build, spec, cols, t, z)
    result.event_sensitivities = event_sensitivities(build, spec, cols, outcome.events)
    return result


def event_sensitivities(build: BuiltModel, spec: RunSpec, cols: Columns,
                        events: Mapping[str, tuple[np.ndarray, np.ndarray]]
                        ) -> dict[str, dict[str, np.ndarray]]:
    """Each scene event's times' sensitivities, from the system's states recorded just before
    each (C event_time_sensitivities): event -> name -> (k,) ("y0": (n_state, k))."""
    table = build.compiled.event_table
    call, buffer = build.compiled.function("event_time_sensitivities"), build.compiled.buffer
    found: dict[str, dict[str, np.ndarray]] = {}
    for index, event in enumerate(table):
        times, states = events.get(event["name"], (np.empty(0), np.empty((0, 0))))
        dtau = np.empty((len(times), cols.count))
        for r, (t, z) in enumerate(zip(times, states)):
            z = np.ascontiguousarray(z, dtype=np.float64)
            p = cols.parameters(spec.p if spec.inputs is None
                                else spec.inputs.at(float(t), z[:build.n_state]))
            status = call(index, float(t), buffer(z), buffer(p), buffer(dtau[r]))
            if status:
                raise IntegrationFailure(float(t), z[:build.n_state], status,
                                         build.state_names)
        found[event["name"]] = {name: (dtau[:, where].T.copy() if name == INITIAL_VALUES
                                       else dtau[:, where.start].copy())
                                for name, where in cols.slices.items()}
    return found


@dataclass
class SystemOutcome:
    """What a run of the system gives: its times and states z (N x n_t), status, message,
    counts, tolerances and events (their states z)."""

    t: np.ndarray
    z: np.ndarray
    status: int
    message: str
    nfev: int
    njev: int
    nlu: int
    rtol: float
    atol: float
    events: Mapping[str, tuple[np.ndarray, np.ndarray]]


def failed_run(model: BuiltModel, spec: RunSpec, cols: Columns,
               failure: IntegrationFailure) -> SimulationResult:
    """A run whose equations failed: where and why, its sensitivities NaN there."""
    from .outcome import failed

    result = failed(failure, spec.method, spec.rtol, spec.atol, model.parameters_at(spec.p))
    n = model.n_state
    result.sensitivities = split_columns(np.full((n * cols.count, 1), np.nan), cols, n)
    return result


def scipy_run(model: BuiltModel, build: BuiltModel, spec: RunSpec, cols: Columns,
              z0: np.ndarray) -> SystemOutcome:
    """The system by solve_ivp under the run settings, the scene's events and events=."""
    from scipy.integrate import solve_ivp

    n = model.n_state
    system = SystemRhs(build, spec, cols)
    jac = system_jacobian(model, spec, cols) if spec.method in IMPLICIT_METHODS else None
    options = {"rtol": spec.rtol, "atol": spec.atol, **({"jac": jac} if jac else {})}
    events = system_events(model, build, spec, cols)
    user_events = [state_event(event, n) for event in spec.user_events]
    with runs.interrupt_flag() as flag:
        outcome, control = runs.simulate_scipy(
            solve_ivp, system, spec.method, spec.span, z0,
            None if spec.times is None else np.asarray(spec.times, dtype=float), options,
            events, user_events, spec.settings, flag)
    status, message = outcome.status, outcome.message
    if control.stop:
        status = control.stop
        message = ended_early(model, runs.Ending(
            status, control.t, spec.span, control.steps, spec.method,
            spec.settings.max_steps, control.y[:n], control.h_recent, control.stiff_from,
            control.stiffness), spec.p)
    elif status == -1 and system.last[1] is not None:
        message = gave_up(model, message, system.last[0], system.last[1][:n], spec.p)
    return SystemOutcome(outcome.t, outcome.y, status, message, outcome.nfev, outcome.njev,
                         outcome.nlu, spec.rtol, spec.atol, outcome.events)


def system_events(model: BuiltModel, build: BuiltModel, spec: RunSpec, cols: Columns
                  ) -> runs.ModelEvents | None:
    """The scene's events for scipy's run of the system: their functions (their C reads the
    state's entries of z) and, at an impact, the law with the columns' jump (C
    sensitivity_impact)."""
    p_at = None if spec.inputs is None else spec.inputs.at
    events = model.compiled.model_events(spec.p, p_at)
    if events is None:
        return None
    compiled, n = build.compiled, model.n_state
    call, buffer = compiled.function("sensitivity_impact"), compiled.buffer
    fixed = buffer(cols.parameters(spec.p))

    def impact(k: int, t: float, z: np.ndarray) -> np.ndarray:
        new = np.array(z, dtype=np.float64)
        p = fixed if p_at is None else buffer(cols.parameters(p_at(t, new[:n])))
        status = call(k, t, buffer(new), p)
        if status:
            raise IntegrationFailure(t, new[:n], status, model.state_names,
                                     compiled.status_cause(status))
        return new

    return dataclasses.replace(events, impact=impact)


class SystemDrivers:
    """The cffi module of the native integrators for the system's size, as native.py's
    helpers take a build's (ffi, buffer, the run's types, Ctrl-C's callback)."""

    def __init__(self, module: Any):
        self.ffi, self.lib = module.ffi, module.lib
        self.run_pointer, self.int_pointer = (self.ffi.typeof("nemc_run *"),
                                              self.ffi.typeof("int *"))
        self.double_array = self.ffi.typeof("double[]")
        self.arm_interrupts = arm_callback(self.ffi)

    def buffer(self, array: np.ndarray) -> Any:
        return self.ffi.from_buffer(self.double_array, array)

    def function(self, build: BuiltModel, name: str, kind: str = "nemc_system_fn") -> Any:
        """The build's C function NAME as a pointer (of type KIND) these drivers call."""
        compiled = build.compiled
        address = compiled.ffi.cast("uintptr_t", compiled.ffi.addressof(
            compiled.lib, compiled.prefix + name))
        return self.ffi.cast(kind, int(address))


@functools.lru_cache(maxsize=16)
def system_drivers(maker: Callable[[int], Any], size: int) -> SystemDrivers:
    """The drivers for systems of SIZE states, loaded once per process (finding them in the
    cache prints and hashes their C: a few ms, a third of a small run, a fit's many runs)."""
    return SystemDrivers(maker(size))


def native_run(model: BuiltModel, build: BuiltModel, spec: RunSpec, cols: Columns,
               z0: np.ndarray) -> SystemOutcome:
    """The system by nemc.DOP853, nemc.Vern9 or nemc.Radau in C, the drivers compiled for its
    size."""
    assert model.system_drivers is not None
    size = z0.size
    drivers = system_drivers(model.system_drivers, size)
    rtol, atol = native_tolerances(spec.rtol, spec.atol)
    run, keep = native.new_run(drivers, spec.span, spec.times, rtol, atol, spec.settings)
    p = cols.parameters(spec.p)
    if spec.inputs is not None and spec.inputs.tables:
        keep.append(native.table_inputs(drivers, run, spec.inputs, p.size))
    n_eval = -1 if spec.times is None else len(spec.times)
    out = np.empty((max(n_eval, 0) + 1, size))
    run.y_eval = out_buffer = drivers.buffer(out)
    run.y_fail = out_buffer + max(n_eval, 0) * size
    table = model.compiled.event_table
    directions = np.array([runs.DIRECTIONS[e["direction"]] for e in table] or [0],
                          dtype=np.intc)
    actions = np.array([ACTIONS[e["action"]] for e in table] or [0], dtype=np.intc)
    ints = drivers.ffi.typeof("int[]")
    rhs, events, impact = (drivers.function(build, "sensitivity_rhs"),
                           drivers.function(build, "events") if table else drivers.ffi.NULL,
                           drivers.function(build, "sensitivity_impact",
                                            "nemc_system_impact_fn")
                           if table else drivers.ffi.NULL)
    jacobian, block = newton_block(drivers, build, spec)

    taylor = (drivers.function(build, "sensitivity_taylor", "nemc_system_taylor_fn")
              if spec.method == NATIVE_TAYLOR else drivers.ffi.NULL)

    def integrate(method: int, run: Any, y0: Any, p: Any) -> int:
        return drivers.lib.nemc_system_integrate(
            method, rhs, jacobian, block, taylor, len(table),
            drivers.ffi.from_buffer(ints, directions), drivers.ffi.from_buffer(ints, actions),
            events, impact, run, y0, p)

    method_id = getattr(drivers.lib, "NEMC_" + spec.method.split(".")[1].upper())
    try:
        status = native.run_in_c(drivers, integrate, method_id, run, drivers.buffer(z0),
                                 drivers.buffer(p))
        t, z = native_states(drivers, run, spec, out)
        found = native_events(drivers, run, table, size)
    finally:
        drivers.lib.nemc_system_free_steps(run)
    if status == drivers.lib.NEMC_RHS_FAILED:
        raise IntegrationFailure(run.t_fail, out[-1][:model.n_state], run.rhs_status,
                                 model.state_names, build.compiled.status_cause(run.rhs_status))
    message = native.native_message(model, spec, run, out[-1][:model.n_state])
    return SystemOutcome(t, z, status, message, run.nfev, run.njev, run.nlu, rtol, atol, found)


def newton_block(drivers: SystemDrivers, build: BuiltModel, spec: RunSpec
                 ) -> tuple[Any, int]:
    """nemc.Radau's Jacobian of the system as the drivers take it: the build's own J_y and its
    size, the diagonal block (NULL and 0 for the explicit methods)."""
    if spec.method != NATIVE_RADAU:
        return drivers.ffi.NULL, 0
    return drivers.function(build, "jacobian"), build.n_state


def native_states(drivers: SystemDrivers, run: Any, spec: RunSpec, out: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The run's times and states z: at t_eval (those reached), or at its steps."""
    size = out.shape[1]
    if spec.times is None:
        count = run.n_out
        t = np.frombuffer(drivers.ffi.buffer(run.steps_t, 8 * count), dtype=float).copy()
        z = np.frombuffer(drivers.ffi.buffer(run.steps_y, 8 * count * size), dtype=float)
        return t, z.reshape(count, size).T.copy()
    reached = run.n_out
    return np.asarray(spec.times)[:reached], out[:reached].T.copy()


def native_events(drivers: SystemDrivers, run: Any, table: list, size: int
                  ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The scene's events that fired, by name: (times, system states before)."""
    count = run.n_event_out
    if not table or not count:
        return {event["name"]: (np.empty(0), np.empty((0, size))) for event in table}
    ffi = drivers.ffi
    which = np.frombuffer(ffi.buffer(run.event_which, 4 * count), dtype=np.intc)
    times = np.frombuffer(ffi.buffer(run.event_t, 8 * count), dtype=float)
    states = np.frombuffer(ffi.buffer(run.event_y, 8 * count * size), dtype=float).reshape(
        count, size)
    return {event["name"]: (times[which == k].copy(), states[which == k].copy())
            for k, event in enumerate(table)}


def split_columns(s: np.ndarray, cols: Columns, n: int) -> dict[str, np.ndarray]:
    """The integrated columns (k n x n_t) by name: (n_state, n_t) each, "y0" (n_state,
    n_state, n_t) (d y_i(t) / d y0_j at [i, j])."""
    by_column = s.reshape(cols.count, n, -1)
    found = {}
    for name, where in cols.slices.items():
        block = by_column[where]
        found[name] = (np.ascontiguousarray(block.transpose(1, 0, 2))
                       if name == INITIAL_VALUES else block[0].copy())
    return found


class SystemRhs:
    """solve_ivp's fun of the sensitivity system: the build's sensitivity_rhs in one C call;
    `last` holds the latest [t, z] (where a solver that gave up stopped)."""

    def __init__(self, build: BuiltModel, spec: RunSpec, cols: Columns):
        compiled = build.compiled
        self.call, self.buffer = compiled.functions["sensitivity_rhs"], compiled.buffer
        self.cause, self.names = compiled.status_cause, build.state_names
        self.cols, self.inputs = cols, spec.inputs
        self.p = cols.parameters(spec.p)
        self.p_buffer = self.buffer(self.p)
        self.size = build.n_state * (1 + cols.count)
        self.last: list = [0.0, None]

    def __call__(self, t: float, z: np.ndarray) -> np.ndarray:
        z = np.ascontiguousarray(z, dtype=np.float64)
        self.last[0], self.last[1] = t, z
        p = self.p_buffer
        if self.inputs is not None:  # a table's segment at t
            p = self.buffer(self.cols.parameters(self.inputs.at(t, z[:len(self.names)])))
        dz = np.empty(self.size)
        status = self.call(t, self.buffer(z), p, self.buffer(dz))
        if status:
            n = len(self.names)
            raise IntegrationFailure(t, z[:n], status, self.names, self.cause(status))
        return dz


def system_jacobian(model: BuiltModel, spec: RunSpec, cols: Columns
                    ) -> Callable[[float, np.ndarray], np.ndarray] | None:
    """The implicit methods' Jacobian of the system: diag(J_y, ..., J_y) (the exact J_y of the
    build with the part "jacobian"; the terms of second derivatives left out: Newton's
    iteration converges on it), or None where the package has no Jacobian."""
    source = model.compiled_with("jacobian")
    if not source.has_part("jacobian") or spec.inputs is not None:
        return None
    jacobian = source.compiled.integrator_jacobian(spec.p)
    n, blocks = model.n_state, cols.count + 1

    def system(t: float, z: np.ndarray) -> np.ndarray:
        return np.kron(np.eye(blocks), jacobian(t, np.ascontiguousarray(z[:n])))

    return system


def state_event(event: Callable, n: int) -> Callable:
    """A simulate(events=...) callable event(t, y) called with the system's state z: y =
    z[:n], its terminal and direction kept."""
    def on_state(t: float, z: np.ndarray) -> float:
        return event(t, z[:n])

    for attribute in ("terminal", "direction"):
        if hasattr(event, attribute):
            setattr(on_state, attribute, getattr(event, attribute))
    on_state.__name__ = getattr(event, "__name__", "event")
    return on_state


def output_sensitivities(model: BuiltModel, build: BuiltModel, spec: RunSpec, cols: Columns,
                         t: np.ndarray, z: np.ndarray) -> Mapping[str, Any]:
    """The outputs' sensitivities along the run by the chain rule in C, computed when first
    read: name -> output -> (n_t,) ("y0": (n_state, n_t))."""
    if not model.output_names or not t.size:
        return {}
    return LazyOutputs(outputs_along, build, spec, cols, t, z)


def outputs_along(build: BuiltModel, spec: RunSpec, cols: Columns, t: np.ndarray,
                  z: np.ndarray) -> dict[str, Any]:
    compiled, n = build.compiled, build.n_state
    call, buffer = compiled.functions["output_sensitivities"], compiled.buffer
    n_out = len(build.output_names)
    out = np.empty((t.size, cols.count, n_out))
    p = cols.parameters(spec.p)
    for r in range(t.size):
        state = np.ascontiguousarray(z[:, r])
        if spec.inputs is not None:
            p = cols.parameters(spec.inputs.at(float(t[r]), state[:n]))
        status = call(float(t[r]), buffer(state), buffer(p), buffer(out[r]))
        if status:
            raise IntegrationFailure(float(t[r]), state[:n], status, build.state_names)
    found: dict[str, Any] = {}
    for name, where in cols.slices.items():
        block = out[:, where, :]  # n_t x columns x outputs
        found[name] = {output: (block[:, :, j].T.copy() if name == INITIAL_VALUES
                                else block[:, 0, j].copy())
                       for j, output in enumerate(build.output_names)}
    return found
