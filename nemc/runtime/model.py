"""The runtime of a compiled mechanism: thin, checked wrappers over its C functions, and
integration with scipy's solve_ivp.

This module needs only numpy, scipy and the cffi module of a build: `nemc compile` copies it
verbatim into every standalone package as `_runtime.py`. It must not import nemc or sympy.
"""

from __future__ import annotations

import functools
import importlib
import json
import math
import os
import sys
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..vocabulary import (  # noqa: F401 (re-exported: the runtime's public names)
    AUTO,
    AUTO_LANES_MIN_RUNS,
    AUTO_LANES_TAYLOR_MAX_COORDINATES,
    AUTO_SPECTRUM_MAX_STATES,
    AUTO_STIFF_STEPS,
    AUTO_TAYLOR_BUILD_RUNS,
    AUTO_TAYLOR_MAX_COORDINATES,
    DEFAULT_ATOL,
    DEFAULT_METHOD,
    DEFAULT_RTOL,
    EXPLICIT_STABILITY,
    IMPLICIT_METHODS,
    METHODS,
    NATIVE_METHODS,
    SCIPY_METHODS,
    TAYLOR_METHODS,
    auto_method,
    auto_takes_taylor,
)
from . import runs
from .loops import LoopsMixin

DEFAULT_T_SPAN = (0.0, 10.0)
SERIES_NOT_FINITE = -3  # the model status NEMC_SERIES_NOT_FINITE (templates/model.h.tmpl)
OPTIONAL_PARTS = frozenset({"jacobian", "mass_matrix", "taylor", "lanes"})  # C built when asked
KINEMATIC_POINTS = 201  # the default times of a kinematic analysis over t_span
SOLVER_STEPS = "steps"  # simulate(t_eval="steps"): the solver's own steps, whatever the scene says


class ModelError(ValueError):
    """A call the model cannot honour: wrong shapes, unknown or invalid parameters."""


class IntegrationFailure(ArithmeticError):
    """The equations cannot be evaluated at a state (singular mass matrix, non-finite values)."""

    def __init__(self, t: float, y: np.ndarray, status: int, state_names: Sequence[str],
                 cause: str | None = None):
        self.t, self.y, self.status = t, np.array(y), status
        state = ", ".join(f"{n}={v:.6g}" for n, v in zip(state_names, self.y))
        cause = failure_cause(self.y, status, state_names, cause)
        super().__init__(f"at t={t:.9g}: {cause}; state: {state}")


def failure_cause(y: np.ndarray, status: int, state_names: Sequence[str],
                  known: str | None = None) -> str:
    """What a failed evaluation of the equations most likely means, for a user: a state that
    is not finite first, then KNOWN (what the model knows of its status), else by the status."""
    if not np.all(np.isfinite(y)):
        return ("the state is not finite: the solution blew up before this step "
                "(or the initial state holds inf or nan)")
    if known:
        return known
    if status == SERIES_NOT_FINITE:
        return ("nemc.Taylor's series overflows here (a Taylor coefficient, or the series' value "
                "at the step's end, is not finite): the solution blows up, or it moves too fast "
                "for the series at this tolerance (try nemc.Vern9 or nemc.DOP853)")
    if status > 0:
        return (f"the articulated inertia through joint {status} (counting from 1 in file "
                "order) is not positive: the mass matrix is singular or not positive definite "
                "here, likely a mass or inertia near zero or a configuration where the "
                "coordinates lose a degree of freedom")
    return ("the accelerations are not finite: a load or parameter gives inf or nan here "
            "(e.g. a division by zero in a load expression)")


class LazyOutputs(Mapping[str, np.ndarray]):
    """The scene's outputs along a result, computed from its t and y on first access: a caller
    that never reads them (a sweep, a benchmark) does not pay for them."""

    __slots__ = ("_compute", "_arguments", "_values")

    def __init__(self, compute: Callable[..., dict[str, np.ndarray]], *arguments: Any):
        self._compute: Callable[..., dict[str, np.ndarray]] | None = compute
        self._arguments = arguments  # compute's (no closure made per result: issue 19)
        self._values: dict[str, np.ndarray] = {}

    def _get(self) -> dict[str, np.ndarray]:
        if self._compute is not None:
            self._values, self._compute = self._compute(*self._arguments), None
            self._arguments = ()
        return self._values

    def __getitem__(self, name: str) -> np.ndarray:
        return self._get()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())

    def __repr__(self) -> str:
        return repr(self._get())


NO_OUTPUTS = LazyOutputs(dict)  # the outputs of a result without any (nothing to compute)


@dataclass
class SimulationResult:
    """As scipy's OdeResult, plus the scene's outputs at every returned time (computed when
    first read)."""

    t: np.ndarray
    y: np.ndarray
    outputs: Mapping[str, np.ndarray]
    nfev: int
    njev: int
    nlu: int
    status: int
    message: str
    success: bool
    method: str
    rtol: float
    atol: float
    params: dict[str, float] = field(default_factory=dict)
    # name -> (times, states just before each, shape (k, n_state)): the scene's events that
    # fired, then simulate(events=...)'s callables by their __name__
    events: Mapping[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    @property
    def t_events(self) -> list[np.ndarray]:
        """As solve_ivp's: each event's times, in res.events' order."""
        return [times for times, _ in self.events.values()]

    @property
    def y_events(self) -> list[np.ndarray]:
        """As solve_ivp's: each event's states, (k, n_state) each."""
        return [states for _, states in self.events.values()]

    # the model that ran it, and its simulate() call's arguments (rerun)
    model: Any = field(default=None, repr=False, compare=False)
    run_arguments: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def rerun(self) -> Callable[[Any], SimulationResult] | None:
        """The same run at other times: rerun(t_eval) (dense curves for figures); None for a
        result that simulate() did not return. Made when asked for: simulate() only keeps
        its arguments (0.2 us less per call, issue 19)."""
        if self.model is None or self.run_arguments is None:
            return None
        return functools.partial(self.model._rerun, self.run_arguments)

    # -- the user's view: tables, figures, animation, notebooks (issue 20) ------------------

    def columns(self) -> dict[str, np.ndarray]:
        """t, the state and the outputs by name, in the table's order."""
        names = self.model.state_names if self.model is not None else [
            f"y{i}" for i in range(len(self.y))]
        return {"t": self.t, **dict(zip(names, self.y)), **self.outputs}

    def to_pandas(self) -> Any:
        """A pandas DataFrame indexed by t, a column per state and output (pandas is optional:
        imported here); the unit of each column, where the YAML declares units, in
        df.attrs["units"]."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("to_pandas() needs pandas: pip install pandas") from None
        columns = self.columns()
        frame = pd.DataFrame({k: v for k, v in columns.items() if k != "t"},
                             index=pd.Index(columns["t"], name="t"))
        labels = self.model.metadata.get("unit_labels", {}) if self.model is not None else {}
        frame.attrs["units"] = {name: labels.get(name, "") for name in columns}
        frame.attrs["method"] = self.method
        return frame

    def plot(self, path: str | os.PathLike | None = None, **options: Any) -> Any:
        """The report figure of this run (nemc.figures: state as in the book, outputs grouped
        by kind, units from the YAML); written to PATH when given. Returns the figure."""
        return _user_view("figures", "plot()").plot_result(self, path, **options)

    def animate(self, path: str | os.PathLike | None = None, **options: Any) -> Any:
        """The mechanism moving (nemc.animate): written to PATH (.gif, .mp4, .html) when
        given, else returned for display (inline in a notebook)."""
        return _user_view("animate", "animate()").animate_result(self, path, **options)

    def _repr_html_(self) -> str:
        import html  # here, as difflib and concurrent.futures: a cached load imports neither

        name = self.model.name if self.model is not None else "simulation"
        status = "success" if self.success else "failed"
        head = (f"<p><b>{html.escape(name)}</b>: {html.escape(self.method)}, rtol {self.rtol:g},"
                f" atol {self.atol:g}, {self.nfev} RHS calls, {len(self.t)} times, {status}: "
                f"{html.escape(self.message)}</p>")
        return head + _html_table(self.columns(), rows=_preview_rows(len(self.t)))


def _no_fast_call(t: Any, y: Any) -> None:
    """Model.rhs's first way where the build's _rhs_call cannot be imported: none."""
    return None


def _real_array(value: Any, what: str) -> np.ndarray:
    """VALUE as a numpy array of real numbers (bool, int, float); anything else is refused."""
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as error:  # e.g. ragged nested lists
        raise ModelError(f"{what} must be an array of real numbers ({error})") from None
    if array.dtype.kind not in "biuf":
        raise ModelError(f"{what} must be real numbers, got dtype {array.dtype}")
    return array


def _all_finite(array: np.ndarray) -> bool:
    """Whether every entry is finite. A small array's sum as Python floats (no warning on an
    overflow) says so in 0.2 us where numpy's isfinite().all() takes 1 us: a nan or inf makes
    the sum nan or inf; only then (or after an overflow) each entry is looked at."""
    if array.size <= 64 and math.isfinite(sum(
            array.tolist() if array.ndim == 1 else array.ravel().tolist())):
        return True
    return bool(np.isfinite(array).all())


def _arm_callback(ffi: Any) -> Any:
    """runs.arm_interrupts as a C function pointer for nemc_run.arm_interrupt (one per model,
    kept by it); None where cffi cannot make callbacks (runs are then watched from the start)."""
    try:
        return ffi.callback("int(int *)", runs.arm_interrupts, error=0,
                            onerror=runs.interrupted_while_arming)
    except (MemoryError, NotImplementedError, TypeError):  # no write+execute memory, ...
        return None


def read_metadata(path: Path) -> dict:
    return json.loads(Path(path).read_text())


def _user_view(module: str, what: str) -> Any:
    """nemc's module for figures or animation; a standalone package without nemc says what to
    install instead of failing deep inside."""
    try:
        return importlib.import_module(f"nemc.tools.{module}")
    except ImportError as error:
        raise ImportError(f"{what} needs nemc and matplotlib installed (pip install nemc, or "
                          f"use the nemc checkout): {error}") from None


def _preview_rows(count: int, head: int = 5) -> list[int]:
    return list(range(count)) if count <= 2 * head else [
        *range(head), -1, *range(count - head, count)]


def _html_table(columns: Mapping[str, np.ndarray], rows: list[int]) -> str:
    """An HTML table of the columns at these rows (-1: an ellipsis row)."""
    import html

    names = list(columns)
    head = "".join(f"<th>{html.escape(n)}</th>" for n in names)
    body = []
    for row in rows:
        cells = ["&hellip;"] * len(names) if row < 0 else [
            f"{float(columns[n][row]):.6g}" for n in names]
        body.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


class Model(LoopsMixin):
    """A compiled mechanism: names, defaults, rhs, jacobian, outputs and simulate."""

    _model_error = ModelError  # what LoopsMixin raises

    def __init__(self, metadata: dict, ffi: Any, lib: Any, rhs_call: Any = None):
        self.metadata = metadata
        self.name: str = metadata["name"]
        self.state_names: tuple[str, ...] = tuple(metadata["state_names"])
        self.coordinate_names: tuple[str, ...] = tuple(metadata["coordinate_names"])
        self.parameter_names: tuple[str, ...] = tuple(metadata["parameter_names"])
        self.derived_parameters: dict[str, str] = dict(metadata["derived_parameters"])
        self.output_names: tuple[str, ...] = tuple(metadata["output_names"])
        self.scene: dict = metadata["scene"]
        self.n_state = len(self.state_names)
        self._ffi, self._lib = ffi, lib
        # cffi's types, looked up once (a type named by a string is looked up in every call)
        self._double_array, self._double_pointer, self._int_pointer, self._run_pointer = (
            ffi.typeof("double[]"), ffi.typeof("double *"), ffi.typeof("int *"),
            ffi.typeof("nemc_run *"))
        prefix = metadata["c_prefix"]
        self._c = {
            name: getattr(lib, prefix + name)
            for name in (
                "rhs", "rhs_many", "checks", "initial_state", "outputs", "jacobian",
                "inverse_mass_matrix", "integrate", "free_steps", "start_stiffness",
            )
            if hasattr(lib, prefix + name)
        }
        self._default_p = np.array(metadata["parameter_defaults"], dtype=float)
        # Compiles this mechanism with more parts (set by nemc's pipeline; None in a
        # standalone package, which has only the parts it was built with): see compiled_with.
        self.part_compiler: Callable[[frozenset[str]], Model] | None = None
        self._variants: dict[str, Model] = {}
        self._checked: tuple[tuple, np.ndarray] = ((), self._default_p)
        self._rhs_cache: tuple[Any, Any] = (None, None)  # rhs(): (p, its closure)
        self._default_rhs: Callable[[Any, Any], np.ndarray] | None = None  # rhs(t, y)
        # rhs(t, y)'s C call through the build's _rhs_call (None: not made yet), and that module
        self._fast_rhs: Callable[[Any, Any], np.ndarray | None] | None = None
        self._rhs_call = rhs_call
        self._method_ids: dict[str, int] = {}  # _method_id's, looked up once
        self._native_entries: dict[str, tuple[Any, int]] = {}  # _native_entry's
        self._native_models: dict[str, Model] = {}  # _native_model's, found once
        self._look: tuple[int, Model | None] = (-1, None)  # _look_model's (variants, model)
        self._taylor_cpu: bool | None = None  # _taylor_ready's answer
        self._kept_parameters: tuple[Any, Any] = (None, None)  # _parameter_buffer's
        self._event_table: list[dict] = metadata.get("events") or []  # the scene's events
        self._arm_interrupts = _arm_callback(ffi)  # nemc_run.arm_interrupt, or None
        # parameters_at(the defaults), copied for each result: never handed out itself
        self._default_params = dict(zip(self.parameter_names, self._default_p.tolist()))

    @property
    def parameters(self) -> dict[str, float]:
        """The parameters settable at run time, with their default values."""
        return dict(zip(self.parameter_names, self._default_p.tolist()))

    def __repr__(self) -> str:
        return f"<nemc model {self.name}: state {list(self.state_names)}>"

    # -- arguments --------------------------------------------------------------------------

    def _buffer(self, array: np.ndarray) -> Any:
        return self._ffi.from_buffer(self._double_array, array)

    def _parameter_buffer(self, p: np.ndarray) -> Any:
        """_buffer(p), kept for the latest parameter vector (never written to: a run with
        other parameters gets a new one) and handed out again while it is the same."""
        kept, buffer = self._kept_parameters
        if kept is not p:
            buffer = self._buffer(p)
            self._kept_parameters = (p, buffer)
        return buffer

    def parameter_vector(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The C parameter array for these overrides, checked (finite, masses positive)."""
        if params is None and not self._checked[0]:  # the defaults, as last time
            return self._checked[1]
        overrides = self._overrides(params)
        key = tuple(sorted(overrides.items()))
        if key == self._checked[0]:
            return self._checked[1]
        p = self._default_p.copy()
        for name, value in overrides.items():
            p[self._parameter_index(name)] = value
        self._check_masses(p)
        self._checked = (key, p)
        return p

    def _overrides(self, params: Any) -> dict[str, float]:
        """``params`` as name -> finite float; anything but a mapping of names is refused."""
        if params is None:
            return {}
        if not isinstance(params, Mapping):
            raise ModelError(f"params must be a mapping name -> value, got {type(params).__name__}")
        for name in params:
            if not isinstance(name, str):
                raise ModelError(f"parameter names are strings, got {name!r}")
        return {name: self._finite(name, value) for name, value in params.items()}

    def _parameter_index(self, name: str) -> int:
        if name in self.parameter_names:
            return self.parameter_names.index(name)
        if name in self.derived_parameters:
            raise ModelError(
                f"parameter {name!r} is derived ({name} = {self.derived_parameters[name]}):"
                " set its inputs instead"
            )
        import difflib

        close = difflib.get_close_matches(name, self.parameter_names, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ModelError(f"unknown parameter {name!r}{hint} (known: {list(self.parameter_names)})")

    @staticmethod
    def _finite(name: str, value: Any, what: str = "parameter") -> float:
        if isinstance(value, (str, bytes)) or np.iscomplexobj(value):
            raise ModelError(f"{what} {name!r}: expected a real number, got {value!r}")
        try:
            number = float(value)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"{what} {name!r}: expected a number, got {value!r}") from None
        if not math.isfinite(number):
            raise ModelError(f"{what} {name!r}: must be finite, got {number}")
        return number

    def _check_masses(self, p: np.ndarray) -> None:
        names = self.metadata["check_names"]
        values = np.empty(len(names))
        self._c["checks"](self._buffer(p), self._buffer(values))
        for key, value in zip(names, values):
            if not value > 0:
                raise ModelError(f"{key} must be > 0 and finite, got {value:g} at these parameters")

    def _state(self, y: Any) -> np.ndarray:
        """One state as a new-or-checked contiguous float64 array of shape (n_state,)."""
        if (type(y) is np.ndarray and y.dtype is FLOAT64 and y.shape == (self.n_state,)
                and y.flags.c_contiguous):  # already what C takes
            return y
        array = _real_array(y, "state")
        if array.shape != (self.n_state,):
            raise ModelError(f"state must have shape ({self.n_state},), got {array.shape}")
        return np.ascontiguousarray(array, dtype=np.float64)

    @staticmethod
    def _time(t: Any) -> float:
        """One time: a real scalar."""
        if type(t) is float and math.isfinite(t):
            return t
        array = _real_array(t, "time t")
        if array.ndim != 0:
            raise ModelError(f"time t must be a scalar, got shape {array.shape}")
        if not np.isfinite(array):
            raise ModelError(f"time t must be finite, got {float(array)}")
        return float(array)

    @staticmethod
    def _times_for(t: Any, count: int) -> np.ndarray:
        """Times for COUNT states: a real scalar or an array of shape (COUNT,)."""
        array = _real_array(t, "times t")
        if array.ndim != 0 and array.shape != (count,):
            raise ModelError(f"times t must be a scalar or have shape ({count},), "
                             f"got {array.shape}")
        if not np.isfinite(array).all():
            raise ModelError("times t must be finite")
        return np.ascontiguousarray(np.broadcast_to(array.astype(np.float64), (count,)))

    def initial_state(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The scene's initial state (unlisted values 0) at these parameters; a closed loop's
        assembled from its given values and its guess (at the scene's start time)."""
        p = self.parameter_vector(params)
        y0 = np.empty(self.n_state)
        self._c["initial_state"](self._buffer(p), self._buffer(y0))
        if self.has_loops:
            t0 = (self.scene["t_span"] or DEFAULT_T_SPAN)[0]
            y0 = self._assembled(t0, y0, self._given_mask(None), p)[0]
        return y0

    def state_vector(self, y0: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """A state from an array, or from a dict of coordinate / dot(q) values (others 0)."""
        if y0 is None:
            return self.initial_state(params)
        # a dict of values (closed loops: the others start from the scene's guess)
        if type(y0) is not np.ndarray and isinstance(y0, Mapping):
            state = self.initial_state(params) if self.has_loops else np.zeros(self.n_state)
            for name, value in y0.items():
                if name not in self.state_names:
                    import difflib

                    close = difflib.get_close_matches(str(name), self.state_names, n=1)
                    hint = f"; did you mean {close[0]!r}?" if close else ""
                    raise ModelError(f"unknown state name {name!r}{hint}")
                state[self.state_names.index(name)] = self._finite(name, value, "state value")
            return state
        return self._state(y0).copy()

    # -- evaluation -------------------------------------------------------------------------

    def rhs(self, t: float, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """dy/dt at (t, y)."""
        if params is None:  # the default parameters (checked when compiled): no lookup
            fast = self._fast_rhs or self._prepare_default_rhs()
            dy = fast(t, y)  # a float t and a float64 array y: the C call, else None
            return dy if dy is not None else self._default_rhs(t, y)  # type: ignore[misc]
        p = self.parameter_vector(params)
        if self._rhs_cache[0] is not p:  # the closure of the latest parameters, kept
            self._rhs_cache = (p, self._rhs_function(p))
        return self._rhs_cache[1](self._time(t), self._state(y))

    def _prepare_default_rhs(self) -> Callable[[Any, Any], np.ndarray | None]:
        """rhs(t, y)'s two ways at the default parameters: _fast_call's, and _checked_rhs's,
        which converts or refuses the arguments and raises the failure."""
        self._default_rhs = self._checked_rhs(self._default_p)
        self._fast_rhs = self._fast_call(self._default_p)
        return self._fast_rhs

    def _fast_call(self, p: np.ndarray) -> Callable[[Any, Any], np.ndarray | None]:
        """The right-hand side at parameters p through the build's _rhs_call (0.2-0.3 us a
        call where cffi's takes about 1: templates/rhs_call.c.tmpl): dy for a float t (finite)
        and a C-contiguous float64 array y, None for anything else and for any status but
        NEMC_OK, which the caller's cffi way then converts, refuses or raises. Without
        _rhs_call (CPython 3.10), always None. p is kept, and never written."""
        if self._rhs_call is None:
            return _no_fast_call
        address = self._ffi.cast("uintptr_t", self._ffi.addressof(
            self._lib, self.metadata["c_prefix"] + "rhs"))
        return self._rhs_call.make(int(address), p, np.ndarray, np.empty)

    def _checked_rhs(self, p: np.ndarray) -> Callable[[Any, Any], np.ndarray]:
        """rhs(t, y) at parameters p through cffi, with Model.rhs's checks of its arguments."""
        c_rhs, buffer, n, names = self._c["rhs"], self._buffer, self.n_state, self.state_names
        p_buffer, time_of, state_of = buffer(p), self._time, self._state

        def rhs(t: Any, y: Any) -> np.ndarray:
            t, y = time_of(t), state_of(y)
            dy = np.empty(n)
            status = c_rhs(t, buffer(y), p_buffer, buffer(dy))
            if status:
                raise IntegrationFailure(t, y, status, names, self._status_cause(status))
            return dy

        return rhs

    def _rhs_function(self, p: np.ndarray):
        """A fast closure for integrators: _fast_call's, else cffi's with buffers for p
        prepared once and the checks done in C."""
        c_rhs, buffer, n, names = self._c["rhs"], self._buffer, self.n_state, self.state_names
        p_buffer, fast = buffer(p), self._fast_call(p)
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
                raise IntegrationFailure(t, y, status, names, self._status_cause(status))
            return dy

        rhs.last = last  # type: ignore[attr-defined]
        return rhs

    def rhs_many(self, t: Any, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """dy/dt at many states in one C call: y of shape (n_state, n), t scalar or (n,)."""
        ys = self._states(y)
        ts = self._times_for(t, len(ys))
        dys = np.empty_like(ys)
        self._many("rhs_many", ts, ys, self.parameter_vector(params), dys)
        return dys.T

    def _many(self, function: str, ts, ys, p, out) -> None:
        """Call a C loop over many states; refuse when any state cannot be evaluated."""
        buffer = self._buffer
        status = self._c[function](len(ys), buffer(ts), buffer(ys), buffer(p), buffer(out))
        if status:
            raise ModelError(f"{function}: the equations cannot be evaluated at a state ({status})")

    def _states(self, y: Any) -> np.ndarray:
        """(n_state, n) -> contiguous (n, n_state) rows for the C loops."""
        array = _real_array(y, "states")
        if array.ndim != 2 or array.shape[0] != self.n_state:
            expected = f"({self.n_state}, n)"
            raise ModelError(f"states must be real with shape {expected}, got {array.shape}")
        return np.ascontiguousarray(array.T, dtype=np.float64)

    def jacobian(self, t: float, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """d rhs / d y, (n_state, n_state): analytic, from C (built on first need); central
        differences of the compiled RHS only in a standalone package built without it."""
        function = self._jacobian_function(self.parameter_vector(params))
        if function is not None:
            return function(self._time(t), self._state(y))
        return self._finite_difference_jacobian(self._time(t), self._state(y), params)

    def has_part(self, part: str) -> bool:
        """Whether this build has the optional part "jacobian", "mass_matrix", "taylor" or
        "lanes" (a query only)."""
        return part in self.metadata["generated"]

    def compiled_with(self, part: str) -> Model:
        """This mechanism's model with the optional part "jacobian" (the exact Jacobian, also
        needed by nemc.Radau), "mass_matrix" (M^-1, for Model.mass_matrix), "taylor"
        (nemc.Taylor's coefficients) or "lanes" (nemc.Taylor's coefficients also in SIMD
        lanes, for simulate_many): this model when its build has it; otherwise the build that
        adds it to this one's parts, compiled now (sympy and the C compiler: seconds) or loaded
        from the cache, and kept for later calls. A standalone package compiles nothing: it
        returns itself."""
        if self.has_part(part) or self.part_compiler is None:
            return self
        if f"{part}_unavailable" in self.metadata:  # this mechanism cannot have it
            return self
        if part not in self._variants:
            have = {name for model in (self, *self._variants.values())
                    for name in model.metadata["generated"]}
            variant = self.part_compiler(frozenset(have & OPTIONAL_PARTS | {part}))
            variant._share_defaults(self)
            self._variants[part] = variant
        return self._variants[part]

    def _share_defaults(self, model: Model) -> None:
        """Take the default parameter vector of MODEL, the same mechanism: a run that MODEL
        hands to this variant then finds its defaults by identity (parameters_at)."""
        if np.array_equal(self._default_p, model._default_p):
            self._default_p = model._default_p
            self._checked = ((), model._default_p)

    def _jacobian_function(self, p: np.ndarray):
        """A fast closure d rhs/d y for implicit integrators, or None without a C Jacobian."""
        source = self.compiled_with("jacobian")
        if not source.has_part("jacobian"):
            return None
        c_jac, buffer, n, names = (source._c["jacobian"], source._buffer, self.n_state,
                                   self.state_names)
        p_buffer = buffer(p)

        def jacobian(t: float, y: np.ndarray) -> np.ndarray:
            y = np.ascontiguousarray(y, dtype=np.float64)
            jac = np.empty((n, n))
            status = c_jac(t, buffer(y), p_buffer, buffer(jac))
            if status:
                raise IntegrationFailure(t, y, status, names, self._status_cause(status))
            return jac

        return jacobian

    def _finite_difference_jacobian(self, t: float, y: np.ndarray, params) -> np.ndarray:
        f = self._rhs_function(self.parameter_vector(params))
        jac = np.empty((self.n_state, self.n_state))
        for j in range(self.n_state):
            h = 6e-6 * max(1.0, abs(y[j]))
            up, down = y.copy(), y.copy()
            up[j] += h
            down[j] -= h
            jac[:, j] = (f(t, up) - f(t, down)) / (2 * h)
        return jac

    def mass_matrix(self, y: Any, params: Mapping[str, float] | None = None,
                    t: float = 0.0) -> np.ndarray:
        """The mass matrix M(q) of M qdd = f at state y (and time t, where driven joints move
        the bodies), (n_coord, n_coord), for diagnostics: the inverse of M^-1, whose columns the
        C code computes (built on first need)."""
        n = len(self.coordinate_names)
        inverse = np.empty((n, n))
        p, state = self.parameter_vector(params), self._state(y)
        source = self.compiled_with("mass_matrix")
        if not source.has_part("mass_matrix"):
            raise ModelError("this standalone package was built without the mass matrix "
                             "(nemc compile --jacobian builds it)")
        buffer = source._buffer
        status = source._c["inverse_mass_matrix"](self._time(t), buffer(state), buffer(p),
                                                  buffer(inverse))
        if status:
            raise IntegrationFailure(float(t), state, status, self.state_names)
        return np.linalg.inv(inverse)

    def outputs(
        self, t: Any, y: Any, params: Mapping[str, float] | None = None
    ) -> dict[str, Any]:
        """The scene's outputs: floats for one state, arrays for y of shape (n_state, n_t)."""
        if not self.output_names:
            return {}
        return self._outputs_at(t, y, self.parameter_vector(params))

    def _outputs_at(self, t: Any, y: Any, p: np.ndarray) -> dict[str, Any]:
        """outputs() at the parameter vector p."""
        array = _real_array(y, "states")
        single = array.ndim == 1
        ys = self._state(array).reshape(1, -1) if single else self._states(array)
        ts = self._times_for(t, len(ys))
        out = np.empty((len(ys), len(self.output_names)))
        self._many("outputs", ts, ys, p, out)
        columns = {name: out[:, k] for k, name in enumerate(self.output_names)}
        return {k: float(v[0]) for k, v in columns.items()} if single else columns

    # -- integration ------------------------------------------------------------------------

    def simulate(
        self,
        t_span: Sequence[float] | None = None,
        y0: Any = None,
        *,
        method: str | None = None,
        t_eval: Sequence[float] | None = None,
        rtol: float | None = None,
        atol: float | None = None,
        params: Mapping[str, float] | None = None,
        events: Any = None,
        max_step: float | None = None,
        tstops: Sequence[float] | None = None,
        max_steps: int | None = None,
    ) -> SimulationResult:
        """Integrate the scene. Arguments left None take the YAML scene's values, then defaults
        (t_span (0, 10), method "auto", rtol 1e-6, atol 1e-9, t_eval: the solver's steps).
        Methods: scipy's solve_ivp methods (SCIPY_METHODS), nemc's own (NATIVE_METHODS), and
        "auto": nemc chooses one of its own from the size, the stiffness at the start and the
        tolerance, and goes on with nemc.Radau if the problem turns stiff (methods.py's rules;
        res.method names what ran, e.g. "nemc.DOP853 then nemc.Radau").

        The scene's events are located by every method (res.events); events: more, as
        solve_ivp's callables event(t, y) with .terminal and .direction (scipy's methods only).
        max_step: the largest step; tstops: times the steps land on exactly (where a load
        switches); max_steps: the step budget (default 1,000,000 accepted steps; 0: none).
        A run that ends early (budget, stiffness, Ctrl-C, ...) returns what it has, success
        False and a message saying why (docs/decisions.md, "Runs that end")."""
        result = self._simulate(t_span, y0, method, t_eval, rtol, atol, params, events,
                                max_step, tstops, max_steps)
        result.model = self  # the result knows its model, and runs again at other times
        result.run_arguments = (t_span, y0, method, rtol, atol, params, events, max_step,
                                tstops, max_steps)
        return result

    def _rerun(self, arguments: tuple, t_eval: Any) -> SimulationResult:
        """A result's run again, at the times t_eval (SimulationResult.rerun; arguments: its
        run_arguments)."""
        t_span, y0, method, rtol, atol, params, events, max_step, tstops, max_steps = arguments
        return self._simulate(t_span, y0, method, t_eval, rtol, atol, params, events, max_step,
                              tstops, max_steps)

    def _simulate(self, t_span: Any, y0: Any, method: Any, t_eval: Any, rtol: Any, atol: Any,
                  params: Mapping[str, float] | None, events: Any, max_step: Any, tstops: Any,
                  max_steps: Any) -> SimulationResult:
        """simulate()'s run, its arguments in order (positional: a call costs less)."""
        p = self.parameter_vector(params)
        span = checked_span(self.scene["t_span"] or DEFAULT_T_SPAN if t_span is None else t_span)
        method = checked_method(self.scene["method"] or DEFAULT_METHOD if method is None
                                else method, METHODS)
        rtol, atol = self._tolerances(rtol, atol)
        times = self._times(span, t_eval)
        state0 = self._initial(y0, params)
        settings = self._run_settings(span, max_step, tstops, max_steps)
        user_events = self._user_events(events)
        if self.has_loops:
            state0, freedom = self._assembled(span[0], state0, self._given_mask(y0), p)
            if freedom == 0:
                return self._kinematic_run(span, state0, times, rtol, atol, p)
            result = self._integrate(method, span, state0, times, rtol, atol, p, settings,
                                     user_events)
            result.y = self._projected(result.t, result.y, p)
            return result
        return self._integrate(method, span, state0, times, rtol, atol, p, settings, user_events)

    def _integrate(self, method: str, span: tuple[float, ...], state0: np.ndarray, times: Any,
                   rtol: float, atol: float, p: np.ndarray, settings: runs.RunSettings,
                   user_events: list[Callable]) -> SimulationResult:
        """One run from state0 with the method: nemc's own, or scipy's solve_ivp."""
        if method == AUTO:
            return self._integrate_auto(span, state0, times, rtol, atol, p, settings,
                                        user_events)
        if method in NATIVE_METHODS:
            if user_events:
                raise ModelError(
                    f"events= callables need one of scipy's methods ({', '.join(SCIPY_METHODS)})"
                    f": {method} runs in C and locates only the scene's events "
                    "(simulation.events in the YAML, compiled into the model)")
            model = self._native_model(method)
            return model._simulate_native(method, span, state0, times, rtol, atol, p, settings)
        if span[0] == span[1]:  # solve_ivp returns nothing; the native methods return y0
            return self._at_start(method, span, state0, times, rtol, atol, p)
        return self._simulate_scipy(method, span, state0, times, rtol, atol, p, settings,
                                    user_events)

    # -- method "auto" (methods.py's rules) --------------------------------------------------

    def _integrate_auto(self, span: tuple[float, ...], state0: np.ndarray, times: Any,
                        rtol: float, atol: float, p: np.ndarray, settings: runs.RunSettings,
                        user_events: list[Callable]) -> SimulationResult:
        """The method "auto" chooses; an explicit start that turns stiff goes on with
        nemc.Radau from where the stiffness test stopped it (as LSODA switches)."""
        if user_events:  # callables run in Python: scipy's LSODA switches by itself
            return self._integrate("LSODA", span, state0, times, rtol, atol, p, settings,
                                   user_events)
        method = self._auto_choice(span, state0, rtol, p)
        if method not in ("nemc.DOP853", "nemc.Vern9"):
            return self._integrate(method, span, state0, times, rtol, atol, p, settings, [])
        switch = AUTO_SWITCH_SETTINGS if settings is runs.DEFAULT_SETTINGS else replace(
            settings, stiff_switch=AUTO_STIFF_STEPS)
        ending: list = []
        first = self._simulate_native(method, span, state0, times, rtol, atol, p, switch,
                                      ending)
        if first.status != self._lib.NEMC_STIFF or span[0] == span[1]:
            return first
        t_switch, y_switch, steps, stiff_from = ending[0]
        rest_settings = replace(
            settings, max_steps=max(settings.max_steps - steps, 1) if settings.max_steps else 0)
        rest = self._integrate("nemc.Radau", (t_switch, span[1]), y_switch,
                               self._times_after(times, t_switch, span), rtol, atol, p,
                               rest_settings, [])
        return self._joined_runs(first, rest, t_switch, stiff_from, p)

    def _joined_runs(self, first: SimulationResult, rest: SimulationResult, t_switch: float,
                     stiff_from: float, p: np.ndarray) -> SimulationResult:
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
            t=t, y=y, outputs=self._lazy_outputs(t, y, p), nfev=first.nfev + rest.nfev,
            njev=first.njev + rest.njev, nlu=first.nlu + rest.nlu, status=rest.status,
            message=rest.message + note, success=rest.success,
            method=f"{first.method} then {rest.method}", rtol=first.rtol, atol=first.atol,
            params=first.params, events=events)

    def auto_method(self, span: Sequence[float], y0: Any, rtol: float,
                    params: Any = None, runs: int = 1) -> str:
        """The native method "auto" starts a run with (methods.auto_method): from the size,
        the tolerance, whether nemc.Taylor's code is at hand, and the stiff modes at y0.
        runs: an ensemble this large may build nemc.Taylor's code (AUTO_TAYLOR_BUILD_RUNS), and
        from AUTO_LANES_MIN_RUNS on, with nemc.Taylor's lanes at hand, takes nemc.Taylor up to
        AUTO_LANES_TAYLOR_MAX_COORDINATES."""
        p = params if isinstance(params, np.ndarray) else self.parameter_vector(params)
        return self._auto_choice(tuple(span), self._state(y0), rtol, p, runs)

    def _auto_choice(self, span: tuple[float, ...], y0: np.ndarray, rtol: float,
                     p: np.ndarray, runs: int = 1) -> str:
        """auto_method with its arguments checked already (simulate's own call)."""
        lanes = self._lanes_at_hand() if runs >= AUTO_LANES_MIN_RUNS else 0
        taylor_max = max(AUTO_TAYLOR_MAX_COORDINATES,
                         AUTO_LANES_TAYLOR_MAX_COORDINATES.get(lanes, 0))
        return auto_method(len(self.coordinate_names), rtol,
                           bool(lanes) or (self._taylor_at_hand(runs)
                                           and self._taylor_cheap(rtol)),
                           self._start_stiffness(span, y0, p), taylor_max)

    def _taylor_cheap(self, rtol: float) -> bool:
        """Whether the build's nemc.Taylor program is cheap enough against its right-hand side
        for "auto" to give it a run at rtol (methods.auto_takes_taylor; a build without Taylor's
        code, built later for an ensemble, counts as cheap, as before)."""
        return auto_takes_taylor(self.metadata.get("taylor_cost_ratio", 0.0), rtol)

    def _lanes_at_hand(self) -> int:
        """The lanes per batch of a build at hand with nemc.Taylor's lanes (this one, or the
        variant compiled_with("lanes") already gave), else 0: nothing is built to find out."""
        for model in (self, *self._variants.values()):
            if model.has_part("lanes") and model._taylor_ready():
                return int(model.metadata.get("lane_count", 0))
        return 0

    def _taylor_at_hand(self, runs: int) -> bool:
        """nemc.Taylor's code is in the build, or worth building for this many runs."""
        if self.has_loops or "taylor_unavailable" in self.metadata:
            return False
        if self.has_part("taylor"):
            return self._taylor_ready()
        return runs >= AUTO_TAYLOR_BUILD_RUNS and self.part_compiler is not None

    def _start_stiffness(self, span: tuple[float, ...], y0: np.ndarray, p: np.ndarray) -> float:
        """The steps an explicit method would need over the span for stability alone: the stiff
        rate of the Jacobian's eigenvalues at y0 x the span / EXPLICIT_STABILITY, in one C call
        (<model>_start_stiffness, templates/spectrum.c.tmpl), with the exact Jacobian of a build
        at hand that has it, else forward differences of the RHS (nothing is built to look).
        The eigenvalues are computed only when the dissipation (minus the trace: the decay
        rates' sum) is large enough to make AUTO_STIFF_STEPS; else it is returned, an estimate
        that a stiffness it misses is still caught by the run's test.
        0 when not computed (loops, large systems, a start the RHS cannot evaluate)."""
        if self.has_loops or self.n_state > AUTO_SPECTRUM_MAX_STATES:
            return 0.0
        model = self._look_model()
        steps = model._ffi.new(model._double_pointer)
        if model._c["start_stiffness"](float(span[0]), model._buffer(y0),
                                       model._parameter_buffer(p),
                                       abs(span[1] - span[0]) / EXPLICIT_STABILITY,
                                       AUTO_STIFF_STEPS, steps):
            return 0.0  # the run itself will say why
        return steps[0]

    def _look_model(self) -> Model:
        """The build _start_stiffness looks with: the first at hand with the exact Jacobian
        (this one or a variant), else this one; found again only when a variant was added."""
        count, model = self._look
        if count != len(self._variants):
            model = next((model for model in (self, *self._variants.values())
                          if model.has_part("jacobian")), self)
            self._look = (len(self._variants), model)
        return model

    @staticmethod
    def _times_after(times: Any, t_switch: float, span: tuple[float, ...]) -> Any:
        """The requested times still ahead after a switch at t_switch."""
        if times is None:
            return None
        times = np.asarray(times, dtype=float)
        ahead = times > t_switch if span[1] >= span[0] else times < t_switch
        return times[ahead]

    def _run_settings(self, span: tuple[float, ...], max_step: Any, tstops: Any,
                      max_steps: Any) -> runs.RunSettings:
        try:
            return runs.run_settings(self.scene, span, max_step, tstops, max_steps)
        except runs.SettingsError as error:
            raise ModelError(str(error)) from None

    @staticmethod
    def _user_events(events: Any) -> list[Callable]:
        """simulate's events=: None, one callable or a sequence of them (as solve_ivp)."""
        if events is None:
            return []
        listed = [events] if callable(events) else list(events)
        for event in listed:
            if not callable(event):
                raise ModelError(f"events must be callables event(t, y), got {event!r}")
        return listed

    def _model_events(self, p: np.ndarray) -> runs.ModelEvents | None:
        """The scene's events for scipy's methods at parameters p: the compiled functions
        (every event's value at (t, y); an impact law's new state) and their table."""
        table = self.metadata.get("events") or []
        if not table:
            return None
        prefix, buffer, names = self.metadata["c_prefix"], self._buffer, self.state_names
        c_values = getattr(self._lib, prefix + "events")
        c_impact = getattr(self._lib, prefix + "impact")
        p_buffer = buffer(p)

        def values(t: float, y: np.ndarray) -> np.ndarray:
            y = np.ascontiguousarray(y, dtype=np.float64)
            g = np.empty(len(table))
            status = c_values(t, buffer(y), p_buffer, buffer(g))
            if status:
                raise IntegrationFailure(t, y, status, names, self._status_cause(status))
            return g

        def impact(k: int, t: float, y: np.ndarray) -> np.ndarray:
            new = np.array(y, dtype=np.float64)
            status = c_impact(k, t, buffer(new), p_buffer)
            if status:
                raise IntegrationFailure(t, y, status, names, self._status_cause(status))
            return new

        return runs.ModelEvents(tuple(e["name"] for e in table),
                                tuple(runs.DIRECTIONS[e["direction"]] for e in table),
                                tuple(e["action"] for e in table), values, impact)

    def _simulate_scipy(
        self, method: str, span: tuple[float, ...], state0: np.ndarray, times: Any,
        rtol: float, atol: float, p: np.ndarray, settings: runs.RunSettings,
        user_events: list[Callable],
    ) -> SimulationResult:
        """simulate() with scipy's solve_ivp, under the run settings and the events."""
        from scipy.integrate import solve_ivp  # here: importing scipy costs more than a load

        rhs = self._rhs_function(p)
        model_events = self._model_events(p)
        try:
            jac = self._jacobian_function(p) if method in IMPLICIT_METHODS else None
            options = {"rtol": rtol, "atol": atol, **({"jac": jac} if jac is not None else {})}
            with runs.interrupt_flag() as flag:
                outcome, control = runs.simulate_scipy(
                    solve_ivp, rhs, method, span, state0,
                    None if times is None else np.asarray(times, dtype=float), options,
                    model_events, user_events, settings, flag)
        except IntegrationFailure as failure:
            return self._failed(failure, method, rtol, atol, self.parameters_at(p))
        status, message = outcome.status, outcome.message
        if control.stop:  # the budget, the pace, the stiffness test or Ctrl-C ended it
            status = control.stop
            message = runs.ending_message(runs.Ending(
                status, control.t, span, control.steps, method, settings.max_steps,
                control.y, control.h_recent, control.stiff_from, control.stiffness)
            ) + self._singularity_note(control.t, control.y, p)
        elif status == -1 and rhs.last[1] is not None:  # scipy gave up
            message = self._gave_up(message, *rhs.last, p)
        elif status == runs.REACHED_END and not math.isnan(control.stiff_from):
            message += runs.stiffness_note(control.stiff_from)
        return SimulationResult(
            t=outcome.t, y=outcome.y, outputs=self._lazy_outputs(outcome.t, outcome.y, p),
            nfev=outcome.nfev, njev=outcome.njev, nlu=outcome.nlu, status=status,
            message=message, success=status >= 0, method=method, rtol=rtol, atol=atol,
            params=self.parameters_at(p), events=outcome.events,
        )

    def _kinematic_run(self, span: tuple[float, ...], state0: np.ndarray, times: Any,
                       rtol: float, atol: float, p: np.ndarray) -> SimulationResult:
        """A mechanism its drives leave without a degree of freedom: no integration, its
        states computed from the constraints at each time of t_eval (default: 201 over
        t_span), the outputs (drives, reactions) there."""
        times = np.linspace(*span, KINEMATIC_POINTS) if times is None else np.asarray(times)
        t, y, failure = self._kinematic_states(times.astype(float), state0, p)
        return SimulationResult(
            t=t, y=y, outputs=self._lazy_outputs(t, y, p), nfev=0, njev=0, nlu=0,
            status=0 if failure is None else -1, success=failure is None,
            message=failure or "Kinematic analysis: no degree of freedom left by the drives; "
            "the states come from the constraints at each time.",
            method="kinematic", rtol=rtol, atol=atol, params=self.parameters_at(p))

    def _times(self, span: tuple[float, ...], t_eval: Sequence[float] | None) -> Any:
        """The checked times of the returned states: t_eval, else the scene's (its step from
        t0 towards t1, or its list within t_span, in the span's direction), else None."""
        if isinstance(t_eval, str) and t_eval == SOLVER_STEPS:  # the solver's own steps
            return None
        if t_eval is not None:
            return checked_times(_real_array(t_eval, "t_eval"), span)
        if self.scene["t_eval_step"]:
            return step_times(span, float(self.scene["t_eval_step"]))
        if self.scene["t_eval"] is not None:
            times = np.asarray(self.scene["t_eval"], dtype=float)
            inside = times[(times >= min(span)) & (times <= max(span))]
            if not inside.size:
                raise ModelError(f"none of the scene's t_eval times lies in t_span {list(span)}:"
                                 " pass t_eval")
            return inside if span[1] >= span[0] else inside[::-1].copy()
        return None

    def _tolerances(self, rtol: Any, atol: Any) -> tuple[float, float]:
        """rtol and atol, or the scene's, or the defaults; checked (see checked_tolerances)."""
        return checked_tolerances(
            rtol if rtol is not None else self.scene["rtol"] or DEFAULT_RTOL,
            atol if atol is not None else self.scene["atol"] or DEFAULT_ATOL)

    def _initial(self, y0: Any, params: Mapping[str, float] | None) -> np.ndarray:
        """The initial state of a run: finite, whatever gave it (y0, the scene, parameters)."""
        state = self.state_vector(y0, params)
        if not _all_finite(state):
            values = ", ".join(f"{n}={v:g}" for n, v in zip(self.state_names, state))
            raise ModelError(f"the initial state must be finite, got {values}")
        return state

    def _at_start(
        self, method: str, span: tuple[float, ...], y0: np.ndarray, times: np.ndarray | None,
        rtol: float, atol: float, p: np.ndarray,
    ) -> SimulationResult:
        """A run over an empty interval (t1 == t0), as the native methods give it: y0 at t0."""
        t = np.array([span[0]]) if times is None else times
        y = np.repeat(y0.reshape(-1, 1), t.size, axis=1)
        return SimulationResult(
            t=t, y=y, outputs=self._lazy_outputs(t, y, p), nfev=0, njev=0, nlu=0, status=0,
            message=SUCCESS_MESSAGE, success=True, method=method, rtol=rtol, atol=atol,
            params=self.parameters_at(p),
        )

    def _gave_up(self, message: str, t: float, y: np.ndarray, p: np.ndarray) -> str:
        state = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.state_names, y))
        singular = self._singularity_note(t, y, p)
        cause = singular or (" Likely cause: the solution grows without bound (a finite-time "
                             "blow-up, a singular configuration or an unstable load); `nemc "
                             "stress` measures the scene")
        return f"integration stopped near t={t:.9g}: {message} State: {state}.{cause}"

    def _failed(
        self, failure: IntegrationFailure, method: str, rtol: float, atol: float,
        params: Mapping[str, float] | None,
    ) -> SimulationResult:
        """A result that says where and why the equations could not be evaluated."""
        return SimulationResult(
            t=np.array([failure.t]), y=failure.y.reshape(-1, 1), outputs={}, nfev=0, njev=0,
            nlu=0, status=-1, message=f"integration failed: {failure}", success=False,
            method=method, rtol=rtol, atol=atol, params=dict(params or {}),
        )

    # -- native integration: integrators in the model's C (NATIVE_METHODS) -------------------

    def _native_model(self, method: str) -> Model:
        """The model whose build has what the native method needs: nemc.Radau the Jacobian,
        nemc.Taylor its coefficients (compiled now when this build lacks them); the same
        from then on, kept (1 us less a run)."""
        model = self._native_models.get(method)
        if model is None:
            model = self._native_models[method] = self._find_native_model(method)
        return model

    def _find_native_model(self, method: str) -> Model:
        if method in IMPLICIT_METHODS:
            model = self.compiled_with("jacobian")
            if not model.has_part("jacobian"):
                raise ModelError(f"{method} needs the analytic Jacobian, and this build has"
                                 " none: compile it with jacobian=True (or a scene method that"
                                 " is implicit)")
            return model
        if method in TAYLOR_METHODS:
            model = self.compiled_with("taylor")
            if not model.has_part("taylor"):
                why = model.metadata.get("taylor_unavailable")
                raise ModelError(f"{method} is not available for {self.name}: " + (
                    f"{why}; use nemc.Vern9 or nemc.DOP853" if why else "this build has no"
                    " Taylor code (compile it with taylor=True, or name nemc.Taylor as the"
                    " scene's method)"))
            if not model._taylor_ready():
                raise ModelError(
                    f"{method}: this build's Taylor code was compiled for a CPU with FMA "
                    "instructions, which this CPU lacks (a package copied from another "
                    "machine): compile the mechanism again on this machine, or use nemc.Vern9")
            return model
        return self

    def _taylor_ready(self) -> bool:
        """Whether this CPU runs the build's Taylor code (C taylor_ready: a build for FMA on a
        CPU without it does not)."""
        if self._taylor_cpu is None:  # asked once: the CPU does not change
            ready = getattr(self._lib, self.metadata["c_prefix"] + "taylor_ready", None)
            self._taylor_cpu = ready is None or bool(ready())
        return self._taylor_cpu

    def _method_id(self, method: str) -> int:
        """The C enum nemc_method value of a native method ("nemc.Vern9" -> NEMC_VERN9)."""
        known = self._method_ids.get(method)
        if known is None:
            known = self._method_ids[method] = getattr(
                self._lib, "NEMC_" + method.removeprefix("nemc.").upper())
        return known

    def _native_entry(self, method: str) -> tuple[Any, int]:
        """The native method's integrate entry point and its id (_native, _method_id), found
        once per method: simulate() looks them up on every call."""
        entry = self._native_entries.get(method)
        if entry is None:
            entry = self._native_entries[method] = (self._native(method),
                                                    self._method_id(method))
        return entry

    def _native(self, method: str, function: str = "integrate") -> Any:
        """A native entry point of this model's compiled module."""
        entry = self._c.get(function) or getattr(self._lib, self.metadata["c_prefix"] + function,
                                                 None)
        if entry is None:
            raise ModelError(f"{method}: this build has no native integrators (rebuild it)")
        return entry

    def _native_run(
        self, span: tuple[float, ...], times: np.ndarray | None, rtol: float, atol: float,
        settings: runs.RunSettings = runs.DEFAULT_SETTINGS,
    ) -> tuple[Any, list]:
        """A nemc_run with the settings of one integration, and the buffers it points into.
        times: a contiguous float array, checked already (checked_times), or None for the
        solver's own steps; rtol, atol: as native_tolerances returns them."""
        run = self._ffi.new(self._run_pointer)
        run.t0, run.t_end = span
        run.rtol, run.atol = rtol, atol
        keep: list = []
        if times is None:
            run.n_eval = -1
        else:
            run.n_eval, run.t_eval = len(times), self._buffer(times)
            keep.append(times)
        if settings is not runs.DEFAULT_SETTINGS:  # the usual case: no max_step, no tstops
            run.max_step = settings.max_step if math.isfinite(settings.max_step) else 0.0
            run.stiff_switch = settings.stiff_switch
            if settings.tstops.size:
                run.n_tstops, run.tstops = settings.tstops.size, self._buffer(settings.tstops)
                keep.append(settings.tstops)
        run.max_steps = settings.max_steps
        return run, keep

    def _simulate_native(
        self, method: str, span: tuple[float, ...], y0: np.ndarray, times: Any,
        rtol: float, atol: float, p: np.ndarray,
        settings: runs.RunSettings = runs.DEFAULT_SETTINGS, ending: list | None = None,
    ) -> SimulationResult:
        """simulate() with a native method: the same result as scipy's solve_ivp would give.
        ending: a list that gets (t, state, accepted steps, stiff_from) where a run that turned
        stiff (NEMC_STIFF, under settings.stiff_switch) ended.
        Every step here counts towards simulate()'s fixed cost (benchmarks/overhead.py)."""
        integrate, method_id = self._native_entry(method)
        rtol, atol = native_tolerances(rtol, atol)
        run, keep = self._native_run(span, times, rtol, atol, settings)
        n, n_eval, buffer = self.n_state, -1 if times is None else len(times), self._buffer
        # the states at t_eval, then the state where a run failed: one buffer
        out = np.empty((max(n_eval, 0) + 1, n))
        run.y_eval = out_buffer = buffer(out)
        run.y_fail = out_buffer + max(n_eval, 0) * n
        try:
            status = self._run_in_c(integrate, method_id, run, buffer(y0),
                                    self._parameter_buffer(p))
            n_out = run.n_out
            if n_eval < 0:
                t, y = self._take_steps(run)
            elif n_out == n_eval:
                t, y = keep[0], out[:-1].T
            else:
                t, y = keep[0][:n_out], out[:n_out].T
            events = self._take_events(run) if self._event_table else {}
        finally:
            if n_eval < 0 or self._event_table:  # else the run malloc'ed nothing
                self._native(method, "free_steps")(run)
        if ending is not None and status == self._lib.NEMC_STIFF:  # method "auto" goes on
            ending.append((float(run.t_fail), out[-1].copy(), int(run.n_steps),
                           float(run.stiff_from)))
        lib = self._lib
        if status == lib.NEMC_REACHED_END and math.isnan(run.stiff_from):
            message = SUCCESS_MESSAGE  # the usual case
        elif status == lib.NEMC_RHS_FAILED:
            cause = self._status_cause(run.rhs_status, "taylor_program" if method in
                                       TAYLOR_METHODS else "dynamics_program")
            failure = IntegrationFailure(run.t_fail, out[-1], run.rhs_status, self.state_names,
                                         cause)
            return self._failed(failure, method, rtol, atol, self.parameters_at(p))
        else:
            message = self._native_message(method, run, span, settings, out[-1], p)
        # positional, in the fields' order: keywords cost 0.4 us more (issue 19)
        return SimulationResult(
            t, y, self._lazy_outputs(t, y, p), run.nfev, run.njev, run.nlu, status, message,
            status >= 0, method, rtol, atol, self.parameters_at(p), events)

    def _run_in_c(self, integrate: Any, method_id: int, run: Any, y0: Any, p: Any) -> int:
        """One native run, Ctrl-C watched for once it lasts (runs.arm_interrupts), or from its
        start where cffi cannot make the callback."""
        run.interrupt = flag = self._ffi.new(self._int_pointer)
        if self._arm_interrupts is None:
            with runs.interrupt_flag(flag):
                return integrate(method_id, run, y0, p)
        run.arm_interrupt = self._arm_interrupts
        try:
            return integrate(method_id, run, y0, p)
        finally:
            runs.after_run(flag)

    def _native_message(self, method: str, run: Any, span: tuple[float, ...],
                        settings: runs.RunSettings, y_fail: np.ndarray, p: np.ndarray) -> str:
        """scipy's messages for the outcomes scipy has; nemc's for the others (runs.py)."""
        lib, status = self._lib, run.status
        if status == lib.NEMC_REACHED_END:
            note = "" if math.isnan(run.stiff_from) else runs.stiffness_note(run.stiff_from)
            return SUCCESS_MESSAGE + note
        if status == lib.NEMC_STEP_TOO_SMALL:
            return self._gave_up("Required step size is less than spacing between numbers.",
                                 run.t_fail, y_fail, p)
        if status not in (lib.NEMC_STOPPED_BY_EVENT, lib.NEMC_STEP_BUDGET, lib.NEMC_TOO_SLOW,
                          lib.NEMC_STIFF, lib.NEMC_CHATTERING, lib.NEMC_INTERRUPTED):
            raise RuntimeError(f"{method}: the native integrator failed (status {status})")
        events = self.metadata.get("events") or []
        event = events[run.event_stop]["name"] if 0 <= run.event_stop < len(events) else None
        return runs.ending_message(runs.Ending(
            status, run.t_fail, tuple(span), int(run.n_steps), method, settings.max_steps,
            y_fail, run.h_recent, run.stiff_from, run.stiffness, event, run.h_recent)
        ) + self._singularity_note(run.t_fail, y_fail, p)

    def _status_cause(self, status: int, program: str = "dynamics_program") -> str | None:
        """What a status of the C means where failure_cause cannot tell: a loop's, or a positive
        one when the PROGRAM ("dynamics_program" or "taylor_program" in model.json) is the
        mass-matrix form (mass_form.py: pivot k of M's LDL^T), not the articulated-body one."""
        form = self.metadata.get(program) or ""
        if status <= 0 or not form.startswith("mass matrix"):
            return self._loop_failure(status)
        series = ", in nemc.Taylor's series," if program == "taylor_program" else ""
        return (f"the mass matrix is singular or not positive definite here (pivot {status} of"
                f" its LDL^T factorization{series} is not positive): likely a mass or inertia "
                "near zero or a configuration where the coordinates lose a degree of freedom")

    def _take_events(self, run: Any) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """The scene's events that fired in a single run, by name: (times, states before)."""
        table = self._event_table
        if not table:
            return {}
        count, ffi, n = run.n_event_out, self._ffi, self.n_state
        which = np.frombuffer(ffi.buffer(run.event_which, 4 * count), dtype=np.intc) \
            if count else np.empty(0, dtype=np.intc)
        times = np.frombuffer(ffi.buffer(run.event_t, 8 * count), dtype=float) \
            if count else np.empty(0)
        states = np.frombuffer(ffi.buffer(run.event_y, 8 * count * n), dtype=float).reshape(
            count, n) if count else np.empty((0, n))
        return {event["name"]: (times[which == k].copy(), states[which == k].copy())
                for k, event in enumerate(table)}

    def _lazy_outputs(self, t: np.ndarray, y: np.ndarray, p: np.ndarray) -> LazyOutputs:
        """The outputs along (t, y) at parameter vector p, computed when first read."""
        if not t.size or not self.output_names:
            return NO_OUTPUTS
        return LazyOutputs(self._outputs_at, t, y, p)  # p: never written to

    def parameters_at(self, p: np.ndarray) -> dict[str, float]:
        if p is self._default_p:  # never written to (parameter_vector copies it)
            return self._default_params.copy()
        return dict(zip(self.parameter_names, p.tolist()))

    def _take_steps(self, run: Any) -> tuple[np.ndarray, np.ndarray]:
        """Copy the step record that C malloc'ed (n_eval -1); free_steps releases it."""
        count, ffi = run.n_out, self._ffi
        t = np.frombuffer(ffi.buffer(run.steps_t, 8 * count), dtype=float).copy()
        y = np.frombuffer(ffi.buffer(run.steps_y, 8 * count * self.n_state), dtype=float)
        return t, y.reshape(count, self.n_state).T.copy()

    def simulate_many(
        self,
        y0s: Any = None,
        *,
        params: Mapping[str, Any] | None = None,
        t_span: Sequence[float] | None = None,
        t_eval: Sequence[float] | None = None,
        method: str | None = None,
        rtol: float | None = None,
        atol: float | None = None,
        threads: int | None = None,
        max_step: float | None = None,
        tstops: Sequence[float] | None = None,
        max_steps: int | None = None,
        max_events: int = runs.DEFAULT_MAX_EVENTS,
        progress: bool | None = None,
        lanes: bool = True,
    ) -> EnsembleResult:
        """Integrate an ensemble with a native method, the loop over runs in C.

        y0s: (k, n_state) initial states, or None for the scene's initial state. params: a dict
        of overrides whose values are numbers (shared) or arrays of length k (one per run).
        t_eval: the times of the returned states, default the scene's, else (t0, t_end).
        method: a native method; default the scene's when native, nemc.Radau when the scene's
        method is implicit, else nemc.DOP853. threads: how many threads share the runs
        (default: the machine's cores); each run is independent and deterministic.
        max_step, tstops, max_steps: as simulate's. The scene's events are located in every
        run; the first max_events of each run are kept (event_t, event_which; event_count
        counts them all). progress: a line on stderr while it runs (None: only when stderr
        is a terminal and the runs take over half a second). Ctrl-C stops every run between
        steps: each then has the status interrupted and its states so far.
        lanes: nemc.Taylor integrates NEMC_LANES runs at once in SIMD lanes (the part "lanes",
        compiled on first use; templates/batch.c.tmpl), with every setting above and the same
        results to the last bit as one run after the other (lanes=False); the other methods
        always run one after the other."""
        span = checked_span(self.scene["t_span"] or DEFAULT_T_SPAN if t_span is None else t_span)
        inputs = None  # (parameters, starts), made once
        if method is None or (isinstance(method, str) and method == AUTO):
            inputs = ps, starts = self._ensemble_inputs(y0s, params)
            method = self.ensemble_method(span, starts[0], ps[0], rtol, len(starts))
            lanes = lanes and (len(starts) >= AUTO_LANES_MIN_RUNS or self.has_part("lanes"))
        if not isinstance(method, str) or method not in NATIVE_METHODS:
            raise ModelError(f"simulate_many: method must be one of {', '.join(NATIVE_METHODS)}"
                             f" or auto, got {method!r}")
        in_lanes = method in TAYLOR_METHODS and bool(lanes)
        model = self.compiled_with("lanes") if in_lanes else self
        in_lanes = in_lanes and model.has_part("lanes")
        if not in_lanes:  # (a lanes build that could not have them says why Taylor cannot)
            model = model._native_model(method)
        if model is not self:  # a build with the method's part: it runs the ensemble
            return model.simulate_many(y0s, params=params, t_span=t_span, t_eval=t_eval,
                                       method=method, rtol=rtol, atol=atol, threads=threads,
                                       max_step=max_step, tstops=tstops, max_steps=max_steps,
                                       max_events=max_events, progress=progress, lanes=lanes)
        rtol, atol = self._tolerances(rtol, atol)
        threads = checked_threads(threads)
        times = self._times(span, t_eval)
        times = np.array(sorted(set(span), reverse=span[1] < span[0]) if times is None else times,
                         dtype=float)
        given = self._given_mask(y0s)
        ps, y0s = inputs or self._ensemble_inputs(y0s, params)
        if self.has_loops:  # each run from its assembled state
            y0s = self._assembled_runs(span[0], y0s, given, ps)
        settings = self._run_settings(span, max_step, tstops, max_steps)
        capacity = checked_max_events(max_events)
        integrate_many = self._native(method, "integrate_lanes" if in_lanes else "integrate_many")
        method_id = self._method_id(method)
        rtol, atol = native_tolerances(rtol, atol)
        run, keep = self._native_run(span, times, rtol, atol, settings)
        run.event_capacity = capacity
        k, n = len(y0s), self.n_state
        y = np.empty((k, len(times), n))
        statuses = np.empty(k, dtype=np.intc)
        counts = np.empty((k, 4), dtype=np.int_)
        event_t = np.full((k, max(capacity, 1)), np.nan)
        event_which = np.full((k, max(capacity, 1)), -1, dtype=np.intc)
        event_counts = np.zeros(k, dtype=np.int_)
        p_stride = ps.shape[1] if ps.shape[0] > 1 else 0

        f = self._ffi.from_buffer
        arguments = (method_id, run, k, f("double[]", y0s), f("double[]", ps), p_stride,
                     f("double[]", y), f("int[]", statuses), f("long[]", counts),
                     f("double[]", event_t), f("int[]", event_which), f("long[]", event_counts))
        run.next_run = next_run = self._ffi.new("long *")  # the runs' counter the threads share
        lanes_each = self.metadata.get("lane_count", 1) if in_lanes else 1
        workers = max(1, min(threads or os.cpu_count() or 1, -(-k // lanes_each)))
        with runs.interrupt_flag(self._ffi.new(self._int_pointer)) as flag:
            run.interrupt = flag
            run_threads(lambda: integrate_many(*arguments), workers, lambda: next_run[0], k,
                        runs.Progress(f"{self.name}: runs", k) if progress is not False else None,
                        progress)
        if self.has_loops:
            y = self._projected_runs(keep[0], y, ps)
        return EnsembleResult(
            t=keep[0], y=y.transpose(0, 2, 1), status=statuses.astype(int),
            success=statuses >= 0, nfev=counts[:, 0].copy(), njev=counts[:, 1].copy(),
            nlu=counts[:, 2].copy(), method=method, rtol=rtol, atol=atol,
            event_names=tuple(e["name"] for e in self.metadata.get("events") or []),
            event_t=event_t[:, :capacity], event_which=event_which[:, :capacity],
            event_count=event_counts,
        )

    def ensemble_method(self, span: Sequence[float], y0: Any = None, params: Any = None,
                        rtol: float | None = None, runs: int = 1) -> str:
        """simulate_many's (and nemc.sweep's) default for RUNS runs: the scene's native
        method; nemc.Radau for an implicit scene; else "auto"'s choice for a run from y0
        (default the scene's), without the switch to nemc.Radau a single run can make, and
        with nemc.Taylor's code built for it from AUTO_TAYLOR_BUILD_RUNS runs on. nemc.Taylor
        runs in SIMD lanes for ensembles of AUTO_LANES_MIN_RUNS runs or more (the lanes are
        a build of seconds), or when the build has them."""
        scene = self.scene["method"]
        if scene in NATIVE_METHODS:
            return scene
        if scene in IMPLICIT_METHODS:
            return "nemc.Radau"
        p = params if isinstance(params, np.ndarray) else self.parameter_vector(params)
        y0 = self._initial(None, params if isinstance(params, Mapping) else None) \
            if y0 is None else y0
        return self.auto_method(span, y0, self._tolerances(rtol, None)[0], p, runs)

    def _ensemble_inputs(self, y0s: Any, params: Mapping[str, Any] | None):
        """(parameter vectors (k or 1, n_p), initial states (k, n_state)), checked."""
        columns = ensemble_columns(params)
        sizes = {len(v) for v in columns.values() if len(v) != 1}
        if y0s is not None:
            y0s = _real_array(y0s, "y0s").astype(float)
            if y0s.ndim != 2 or y0s.shape[1] != self.n_state or not len(y0s):
                raise ModelError(f"y0s must have shape (k, {self.n_state}), got {y0s.shape}")
            sizes.add(len(y0s))
        if len(sizes) > 1:
            raise ModelError(f"simulate_many: y0s and params disagree on the number of runs:"
                             f" {sorted(sizes)}")
        k = sizes.pop() if sizes else 1
        if k == 0:
            raise ModelError("simulate_many: no runs (params hold empty arrays)")
        sets = [{name: v[i % len(v)] for name, v in columns.items()} for i in
                range(k if any(len(v) > 1 for v in columns.values()) else 1)]
        ps = np.array([self.parameter_vector(s) for s in sets])
        if y0s is None:
            y0s = np.array([self.initial_state(s) for s in sets])
            y0s = np.broadcast_to(y0s, (k, self.n_state))
        if not np.all(np.isfinite(y0s)):
            raise ModelError("y0s must be finite")
        return np.ascontiguousarray(ps), np.ascontiguousarray(y0s, dtype=float)

    # -- the user's view: the drawing's positions, notebook display (issue 20) --------------

    def positions(self, t: Any, y: Any, params: Mapping[str, float] | None = None
                  ) -> dict[str, np.ndarray]:
        """Ground-frame positions of the points a drawing needs (bodies' origins, mass
        centres and named points, joints, spring ends; metadata["drawing"]), computed by the
        compiled model: name -> [x, y] for one state, [xs, ys] of shape (2, n_t) for y of
        shape (n_state, n_t)."""
        array = _real_array(y, "states")
        single = array.ndim == 1
        xy = self.positions_array(t, array.reshape(-1, 1) if single else array, params)
        names = self.metadata["drawing"]["points"]
        return {name: xy[0, k].copy() if single else xy[:, k].T.copy()
                for k, name in enumerate(names)}

    def positions_array(self, t: Any, y: Any, params: Mapping[str, float] | None = None
                        ) -> np.ndarray:
        """As positions(), as one array (n_t, n_points, 2) for y of shape (n_state, n_t)."""
        function = getattr(self._lib, self.metadata["c_prefix"] + "positions", None)
        if function is None or "drawing" not in self.metadata:
            raise ModelError(f"the build of {self.name} has no positions function: rebuild it"
                             " with this version of nemc")
        ys = self._states(y)
        ts = self._times_for(t, len(ys))
        out = np.empty((len(ys), len(self.metadata["drawing"]["points"]), 2))
        buffer = self._buffer
        function(len(ys), buffer(ts), buffer(ys), buffer(self.parameter_vector(params)),
                 buffer(out))
        return out

    def _repr_html_(self) -> str:
        import html

        labels = self.metadata.get("unit_labels", {})

        def row(name: str, value: str = "") -> str:
            unit = labels.get(name, "")
            return (f"<tr><td>{html.escape(name)}</td><td>{html.escape(value)}</td>"
                    f"<td>{html.escape(unit)}</td></tr>")

        sections = [("state", [row(n) for n in self.state_names]),
                    ("parameters", [row(n, f"{v:g}") for n, v in self.parameters.items()]),
                    ("outputs", [row(n) for n in self.output_names])]
        body = "".join(f"<tr><th colspan='3'>{title}</th></tr>" + "".join(rows)
                       for title, rows in sections if rows)
        description = html.escape(self.metadata.get("description", ""))
        return (f"<p><b>nemc model {html.escape(self.name)}</b>: {description}</p>"
                f"<table><thead><tr><th>name</th><th>default</th><th>unit</th></tr></thead>"
                f"<tbody>{body}</tbody></table>")


@dataclass
class EnsembleResult:
    """simulate_many's results: y[r] is run r's states at t (NaN after a run stopped)."""

    t: np.ndarray
    y: np.ndarray  # (k, n_state, n_t)
    status: np.ndarray  # (k,): as SimulationResult.status (0 the end, 1 a stop event, < 0 not)
    success: np.ndarray
    nfev: np.ndarray
    njev: np.ndarray
    nlu: np.ndarray
    method: str
    rtol: float
    atol: float
    event_names: tuple[str, ...] = ()  # the scene's events, in the order event_which counts
    event_t: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))  # (k, max_events)
    event_which: np.ndarray = field(default_factory=lambda: np.empty((0, 0), dtype=np.intc))
    event_count: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=int))  # (k,)

    def event_times(self, name: str) -> list[np.ndarray]:
        """Each run's times of event NAME (the first max_events events of each run)."""
        if name not in self.event_names:
            raise ModelError(f"no event {name!r}; the scene's events: {list(self.event_names)}")
        k = self.event_names.index(name)
        return [times[which == k] for times, which in zip(self.event_t, self.event_which)]


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


def checked_max_events(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ModelError(f"max_events must be a whole number >= 0, got {value!r}")
    return int(value)


# enum nemc_method and enum nemc_status in templates/integrators.h.tmpl
SUCCESS_MESSAGE = "The solver successfully reached the end of the integration interval."
EPS = float(np.finfo(float).eps)
# method "auto"'s explicit start under the default settings: it ends once the run turns stiff
AUTO_SWITCH_SETTINGS = replace(runs.DEFAULT_SETTINGS, stiff_switch=AUTO_STIFF_STEPS)
MIN_RTOL = 100 * EPS  # as scipy's solve_ivp: a smaller rtol is raised to this
FLOAT64 = np.dtype(np.float64)  # native float64's dtype, one object: checked with `is`


def native_tolerances(rtol: float, atol: float) -> tuple[float, float]:
    """rtol and atol checked as scipy's validate_tol (rtol raised to 100 eps, with a warning
    that names the user's line)."""
    if rtol < MIN_RTOL:
        warnings.warn(f"At least one element of `rtol` is too small. Setting"
                      f" `rtol = np.maximum(rtol, {MIN_RTOL})`.", stacklevel=_user_stacklevel())
        rtol = MIN_RTOL
    if not (atol >= 0 and math.isfinite(atol) and math.isfinite(rtol)):
        raise ModelError(f"atol must be finite and >= 0, rtol finite; got {atol}, {rtol}")
    return rtol, atol


def _user_stacklevel() -> int:
    """warnings.warn's stacklevel, called here, that names the first frame outside nemc: the
    user's line, however deep in nemc the warning is made."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").partition(".")[0] == "nemc":
        frame, level = frame.f_back, level + 1
    return level


def checked_times(times: np.ndarray, span: tuple[float, ...]) -> np.ndarray:
    """t_eval checked, as a contiguous float array: 1-d, not empty, finite, within t_span, in
    the span's direction. (solve_ivp silently drops NaN times and fails on an empty t_eval.)"""
    times = np.asarray(times, dtype=float)
    t0, tf = span
    if times.ndim != 1 or not times.size:
        raise ModelError(f"t_eval must be a 1-d list of at least one time (or None: the "
                         f"solver's own steps), got shape {times.shape}")
    if times.size == 1:  # the usual short case: no numpy reduction (0.15 us less)
        low = high = times.item()
    else:
        low, high = times.min(), times.max()  # a nan or inf shows in min or max
    first, last = (t0, tf) if t0 <= tf else (tf, t0)
    if not (first <= low and high <= last):  # the span is finite: so are the times, if within
        if not (math.isfinite(low) and math.isfinite(high)):
            raise ModelError("Values in `t_eval` are not within `t_span`: "
                             f"{times[~np.isfinite(times)][0]} is not finite")
        raise ModelError(f"Values in `t_eval` are not within `t_span` {list(span)}")
    if times.size > 1:
        d = np.diff(times)
        if not ((tf > t0 and d.min() > 0) or (tf < t0 and d.max() < 0)):
            direction = "increasing" if tf > t0 else "decreasing"
            raise ModelError(f"Values in `t_eval` are not properly sorted: they must be strictly "
                             f"{direction}, as t_span {list(span)}")
    return np.ascontiguousarray(times)


MAX_STEP_TIMES = 1_000_000  # times a scene's t_eval {step} may give (memory: n_state doubles each)


def checked_span(t_span: Any) -> tuple[float, float]:
    """t_span as two finite times. t1 < t0 integrates backwards (every method can); t1 == t0
    returns the initial state."""
    if type(t_span) in (tuple, list) and len(t_span) == 2 and type(t_span[0]) is float \
            and type(t_span[1]) is float:  # the usual case: no array needed
        t0, t1 = t_span
    else:
        array = _real_array(t_span, "t_span")
        if array.shape != (2,):
            got = f"{array.size} value(s)" if array.ndim == 1 else f"shape {array.shape}"
            raise ModelError(f"t_span must be two times [t0, t1], got {got}")
        t0, t1 = (float(v) for v in array)
    if not (math.isfinite(t0) and math.isfinite(t1) and math.isfinite(t1 - t0)):
        raise ModelError(f"t_span must be two finite times [t0, t1] (and t1 - t0 finite), "
                         f"got [{t0}, {t1}]")
    return t0, t1


def checked_method(method: Any, methods: Sequence[str]) -> str:
    if not isinstance(method, str) or method not in methods:
        raise ModelError(f"unknown method {method!r}; choose one of {', '.join(methods)}")
    return method


def checked_tolerances(rtol: Any, atol: Any) -> tuple[float, float]:
    """rtol in (0, 1) and atol >= 0, each one finite number (scipy would take rtol 1e10, and a
    native method then returned 1e54 with success). rtol below 100 eps is raised to it with a
    warning, by scipy and native_tolerances alike."""
    if type(rtol) is float and type(atol) is float and 0 < rtol < 1 and 0 <= atol < math.inf:
        return rtol, atol  # the usual case (a nan fails every comparison)
    rtol, atol = _tolerance(rtol, "rtol"), _tolerance(atol, "atol")
    if not 0 < rtol < 1:
        raise ModelError(f"rtol must be > 0 and < 1 (a relative error), got {rtol:g}")
    if not atol >= 0:
        raise ModelError(f"atol must be >= 0, got {atol:g}")
    return rtol, atol


def _tolerance(value: Any, name: str) -> float:
    if type(value) is float:  # the usual case (checked finite below)
        return _finite_tolerance(value, name)
    if isinstance(value, (bool, np.bool_)):
        raise ModelError(f"{name} must be a number, got {value!r}")
    array = _real_array(value, name)
    if array.ndim != 0:
        raise ModelError(f"{name} must be one number (tolerances per state entry are not "
                         f"supported), got an array of shape {array.shape}")
    return _finite_tolerance(float(array), name)


def _finite_tolerance(number: float, name: str) -> float:
    if not math.isfinite(number):
        raise ModelError(f"{name} must be finite, got {number}")
    return number


def checked_threads(threads: Any) -> int | None:
    if threads is None:
        return None
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)) \
            or threads < 1:
        raise ModelError(f"threads must be a whole number >= 1 (or None: every core), "
                         f"got {threads!r}")
    return int(threads)


def step_times(span: tuple[float, ...], step: float) -> np.ndarray:
    """t0, t0 + step, ... up to t1 (down to t1 when t1 < t0), at most MAX_STEP_TIMES of them."""
    ratio = abs(span[1] - span[0]) / step
    if not ratio < MAX_STEP_TIMES:
        raise ModelError(f"t_eval {{step: {step:g}}} over t_span {list(span)} gives more than "
                         f"{MAX_STEP_TIMES} times: use a larger step or a shorter span")
    count = int(math.floor(ratio * (1 + 1e-12))) + 1
    return span[0] + math.copysign(step, span[1] - span[0]) * np.arange(count)


def ensemble_columns(params: Any) -> dict[str, np.ndarray]:
    """simulate_many's params: name -> 1-d float array (one value, or one per run)."""
    if params is None:
        return {}
    if not isinstance(params, Mapping):
        raise ModelError(f"params must be a mapping name -> value(s), got {type(params).__name__}")
    columns = {}
    for name, value in params.items():
        array = _real_array(value, f"parameter {name!r}")
        if array.ndim > 1:
            raise ModelError(f"parameter {name!r}: expected a number or a 1-d array of one value"
                             f" per run, got shape {array.shape}")
        columns[name] = np.atleast_1d(array.astype(float))
    return columns


