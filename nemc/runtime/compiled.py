"""One build's C, called through cffi: its entry points found once, numpy arrays handed over as
C buffers, the closures an integrator calls (right-hand side, Jacobian, events) and what a
status of the C means. It checks nothing of a caller's arguments (checks.py does): what reaches
it is already what the C takes.

For tools and tests as well as the runtime: `Model.compiled` is this object, whose `ffi` and
`lib` are the build's cffi module, `functions` its entry points by short name, `rhs_call` the
build's _rhs_call extension (or None) and `arm_interrupts` the callback a native run arms Ctrl-C
with (None: runs are watched from their start).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from . import runs
from .checks import checked_state, checked_states, checked_time, real_array, times_for
from .failures import IntegrationFailure, ModelError, status_cause

# the entry points every build (or a build with the part) has, by short name
ENTRY_POINTS = ("rhs", "rhs_many", "checks", "initial_state", "outputs", "jacobian",
                "inverse_mass_matrix", "integrate", "free_steps", "start_stiffness",
                "input_values", "linearization", "loop_tangents", "outputs_tangent",
                "sensitivity_rhs", "initial_state_tangent", "output_sensitivities")


def no_fast_call(t: Any, y: Any) -> None:
    """Model.rhs's first way where the build's _rhs_call cannot be imported: none."""
    return None


def arm_callback(ffi: Any) -> Any:
    """runs.arm_interrupts as a C function pointer for nemc_run.arm_interrupt (one per model,
    kept by it); None where cffi cannot make callbacks (runs are then watched from the start)."""
    try:
        return ffi.callback("int(int *)", runs.arm_interrupts, error=0,
                            onerror=runs.interrupted_while_arming)
    except (MemoryError, NotImplementedError, TypeError):  # no write+execute memory, ...
        return None


class Compiled:
    """The C functions of one build (METADATA: its model.json; FFI, LIB: its cffi module;
    RHS_CALL: its _rhs_call extension, or None)."""

    def __init__(self, metadata: Mapping[str, Any], ffi: Any, lib: Any, rhs_call: Any = None):
        self.metadata = metadata
        self.ffi, self.lib, self.rhs_call = ffi, lib, rhs_call
        self.prefix: str = metadata["c_prefix"]
        self.state_names: tuple[str, ...] = tuple(metadata["state_names"])
        self.n_state = len(self.state_names)
        self.output_names: tuple[str, ...] = tuple(metadata["output_names"])
        self.constraint_equations: tuple[str, ...] = tuple(
            metadata.get("constraint_equations", ()))
        # cffi's types, looked up once (a type named by a string is looked up in every call)
        self.double_array, self.double_pointer, self.int_pointer, self.run_pointer = (
            ffi.typeof("double[]"), ffi.typeof("double *"), ffi.typeof("int *"),
            ffi.typeof("nemc_run *"))
        self.functions: dict[str, Any] = {
            name: getattr(lib, self.prefix + name) for name in ENTRY_POINTS
            if hasattr(lib, self.prefix + name)}
        self.event_table: list[dict] = metadata.get("events") or []  # the scene's events
        self.arm_interrupts = arm_callback(ffi)  # nemc_run.arm_interrupt, or None
        self._kept_parameters: tuple[Any, Any] = (None, None)  # parameter_buffer's
        self._taylor_cpu: bool | None = None  # taylor_ready's answer
        self._method_ids: dict[str, int] = {}  # method_id's, looked up once
        self._native_entries: dict[str, tuple[Any, int]] = {}  # native_entry's

    # -- buffers and entry points -------------------------------------------------------------

    def buffer(self, array: np.ndarray) -> Any:
        """A float64 array as the C's double[] (no copy: C reads and writes the array)."""
        return self.ffi.from_buffer(self.double_array, array)

    def parameter_buffer(self, p: np.ndarray) -> Any:
        """buffer(p), kept for the latest parameter vector (never written to: a run with
        other parameters gets a new one) and handed out again while it is the same."""
        kept, buffer = self._kept_parameters
        if kept is not p:
            buffer = self.buffer(p)
            self._kept_parameters = (p, buffer)
        return buffer

    def function(self, name: str) -> Any:
        """The build's entry point <prefix>NAME, or None where the build has none."""
        return getattr(self.lib, self.prefix + name, None)

    def status_cause(self, status: int, program: str = "dynamics_program") -> str | None:
        """What a status of this build's C means where failure_cause cannot tell
        (failures.status_cause)."""
        return status_cause(self.metadata, self.constraint_equations, status, program)

    def call_many(self, function: str, ts: np.ndarray, ys: np.ndarray, p: np.ndarray,
                  out: np.ndarray) -> None:
        """Call a C loop over many states; refuse when any state cannot be evaluated."""
        buffer = self.buffer
        status = self.functions[function](len(ys), buffer(ts), buffer(ys), buffer(p),
                                          buffer(out))
        if status:
            raise ModelError(f"{function}: the equations cannot be evaluated at a state ({status})")

    def outputs_at(self, t: Any, y: Any, p: np.ndarray) -> dict[str, Any]:
        """The scene's outputs at the parameter vector p: floats for one state, arrays for y of
        shape (n_state, n_t) (Model.outputs, and a result's outputs when first read)."""
        array = real_array(y, "states")
        single = array.ndim == 1
        ys = checked_state(array, self.n_state).reshape(1, -1) if single else checked_states(
            array, self.n_state)
        ts = times_for(t, len(ys))
        out = np.empty((len(ys), len(self.output_names)))
        self.call_many("outputs", ts, ys, p, out)
        columns = {name: out[:, k] for k, name in enumerate(self.output_names)}
        return {k: float(v[0]) for k, v in columns.items()} if single else columns

    # -- the closures integrators call ---------------------------------------------------------

    def fast_rhs(self, p: np.ndarray) -> Callable[[Any, Any], np.ndarray | None]:
        """The right-hand side at parameters p through the build's _rhs_call (0.2-0.3 us a
        call where cffi's takes about 1: templates/rhs_call.c.tmpl): dy for a float t (finite)
        and a C-contiguous float64 array y, None for anything else and for any status but
        NEMC_OK, which the caller's cffi way then converts, refuses or raises. Without
        _rhs_call (CPython 3.10), always None (no_fast_call). p is kept, and never written."""
        if self.rhs_call is None:
            return no_fast_call
        address = self.ffi.cast("uintptr_t", self.ffi.addressof(self.lib, self.prefix + "rhs"))
        return self.rhs_call.make(int(address), p, np.ndarray, np.empty)

    def checked_rhs(self, p: np.ndarray) -> Callable[[Any, Any], np.ndarray]:
        """rhs(t, y) at parameters p through cffi, with Model.rhs's checks of its arguments."""
        c_rhs, buffer, n, names = self.functions["rhs"], self.buffer, self.n_state, \
            self.state_names
        p_buffer, cause = buffer(p), self.status_cause

        def rhs(t: Any, y: Any) -> np.ndarray:
            t, y = checked_time(t), checked_state(y, n)
            dy = np.empty(n)
            status = c_rhs(t, buffer(y), p_buffer, buffer(dy))
            if status:
                raise IntegrationFailure(t, y, status, names, cause(status))
            return dy

        return rhs

    def integrator_rhs(self, p: np.ndarray) -> Callable[[float, np.ndarray], np.ndarray]:
        """rhs(t, y) for integrators (solve_ivp's fun): fast_rhs's, else cffi's with buffers
        for p prepared once and the checks done in C. Its attribute `last` holds the latest
        [t, y]: where a solver that gave up stopped."""
        c_rhs, buffer, n, names = self.functions["rhs"], self.buffer, self.n_state, \
            self.state_names
        p_buffer, fast, cause = buffer(p), self.fast_rhs(p), self.status_cause
        last: list = [0.0, None]  # the latest (t, y): where a solver that gave up stopped

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            last[0], last[1] = t, y
            dy = fast(t, y)
            if dy is not None:
                return dy
            y = np.ascontiguousarray(y, dtype=np.float64)  # Radau/BDF may pass strided views
            last[1] = y
            dy = np.empty(n)
            status = c_rhs(t, buffer(y), p_buffer, buffer(dy))
            if status:
                raise IntegrationFailure(t, y, status, names, cause(status))
            return dy

        rhs.last = last  # type: ignore[attr-defined]
        return rhs

    def integrator_jacobian(self, p: np.ndarray) -> Callable[[float, np.ndarray], np.ndarray]:
        """d rhs/d y (t, y) for implicit integrators (solve_ivp's jac), from the build's
        analytic Jacobian (a build with the part "jacobian")."""
        c_jac, buffer, n, names = (self.functions["jacobian"], self.buffer, self.n_state,
                                   self.state_names)
        p_buffer, cause = buffer(p), self.status_cause

        def jacobian(t: float, y: np.ndarray) -> np.ndarray:
            y = np.ascontiguousarray(y, dtype=np.float64)
            jac = np.empty((n, n))
            status = c_jac(t, buffer(y), p_buffer, buffer(jac))
            if status:
                raise IntegrationFailure(t, y, status, names, cause(status))
            return jac

        return jacobian

    def model_events(self, p: np.ndarray,
                     p_at: Callable[[float, np.ndarray], np.ndarray] | None = None,
                     p_after: Callable[[np.ndarray], None] | None = None
                     ) -> runs.ModelEvents | None:
        """The scene's events for scipy's methods at parameters p (or p_at(t, y), where inputs
        vary): the compiled functions (every event's value at (t, y); an impact law's new
        state) and their table. P_AFTER, where inputs vary, is handed the parameter vector an
        impact law ran with: a friction switch writes its new mode there (the run keeps it)."""
        table = self.event_table
        if not table:
            return None
        buffer, names, cause = self.buffer, self.state_names, self.status_cause
        c_values, c_impact = self.function("events"), self.function("impact")
        p_buffer = buffer(p)

        def values(t: float, y: np.ndarray) -> np.ndarray:
            y = np.ascontiguousarray(y, dtype=np.float64)
            g = np.empty(len(table))
            at = p_buffer if p_at is None else buffer(p_at(t, y))
            status = c_values(t, buffer(y), at, buffer(g))
            if status:
                raise IntegrationFailure(t, y, status, names, cause(status))
            return g

        def impact(k: int, t: float, y: np.ndarray) -> np.ndarray:
            new = np.array(y, dtype=np.float64)
            p_now = None if p_at is None else p_at(t, new)
            status = c_impact(k, t, buffer(new), p_buffer if p_now is None else buffer(p_now))
            if status:
                raise IntegrationFailure(t, y, status, names, cause(status))
            if p_after is not None and p_now is not None:
                p_after(p_now)
            return new

        return runs.ModelEvents(tuple(e["name"] for e in table),
                                tuple(runs.DIRECTIONS[e["direction"]] for e in table),
                                tuple(e["action"] for e in table), values, impact)

    # -- the native integrators' entry points ---------------------------------------------------

    def taylor_ready(self) -> bool:
        """Whether this CPU runs the build's Taylor code (C taylor_ready: a build for FMA on a
        CPU without it does not)."""
        if self._taylor_cpu is None:  # asked once: the CPU does not change
            ready = self.function("taylor_ready")
            self._taylor_cpu = ready is None or bool(ready())
        return self._taylor_cpu

    def method_id(self, method: str) -> int:
        """The C enum nemc_method value of a native method ("nemc.Vern9" -> NEMC_VERN9)."""
        known = self._method_ids.get(method)
        if known is None:
            known = self._method_ids[method] = getattr(
                self.lib, "NEMC_" + method.removeprefix("nemc.").upper())
        return known

    def native_entry(self, method: str) -> tuple[Any, int]:
        """The native method's integrate entry point and its id (native, method_id), found
        once per method: simulate() looks them up on every call."""
        entry = self._native_entries.get(method)
        if entry is None:
            entry = self._native_entries[method] = (self.native(method),
                                                    self.method_id(method))
        return entry

    def native(self, method: str, function: str = "integrate") -> Any:
        """A native entry point of this build (integrate, integrate_many, free_steps, ...)."""
        entry = self.functions.get(function) or self.function(function)
        if entry is None:
            raise ModelError(f"{method}: this build has no native integrators (rebuild it)")
        return entry
