"""The runtime of a compiled mechanism: thin, checked wrappers over its C functions, and
integration with scipy's solve_ivp.

This module needs only numpy, scipy and the cffi module of a build: `nemc compile` copies it
verbatim into every standalone package as `_runtime.py`. It must not import nemc or sympy.
"""

from __future__ import annotations

import difflib
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

SCIPY_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
IMPLICIT_METHODS = ("Radau", "BDF", "LSODA")  # these get the analytic Jacobian
DEFAULT_T_SPAN = (0.0, 10.0)
DEFAULT_METHOD = "RK45"
DEFAULT_RTOL = 1e-6
DEFAULT_ATOL = 1e-9


class ModelError(ValueError):
    """A call the model cannot honour: wrong shapes, unknown or invalid parameters."""


class IntegrationFailure(ArithmeticError):
    """The equations cannot be evaluated at a state (singular mass matrix, non-finite values)."""

    def __init__(self, t: float, y: np.ndarray, status: int, state_names: Sequence[str]):
        self.t, self.y, self.status = t, np.array(y), status
        state = ", ".join(f"{n}={v:.6g}" for n, v in zip(state_names, self.y))
        if status > 0:
            cause = (
                f"the mass matrix is singular or not positive definite (at joint {status},"
                " counting from 1 in file order)"
            )
        else:
            cause = "the accelerations are not finite (a load or parameter gives inf or nan)"
        super().__init__(f"at t={t:.9g}: {cause}; state: {state}")


@dataclass
class SimulationResult:
    """As scipy's OdeResult, plus the scene's outputs at every returned time."""

    t: np.ndarray
    y: np.ndarray
    outputs: dict[str, np.ndarray]
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


def read_metadata(path: Path) -> dict:
    return json.loads(Path(path).read_text())


class Model:
    """A compiled mechanism: names, defaults, rhs, jacobian, outputs and simulate."""

    def __init__(self, metadata: dict, ffi: Any, lib: Any):
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
        prefix = metadata["c_prefix"]
        self._c = {
            name: getattr(lib, prefix + name)
            for name in (
                "rhs", "rhs_many", "checks", "initial_state", "outputs", "jacobian",
                "inverse_mass_matrix",
            )
            if hasattr(lib, prefix + name)
        }
        self._default_p = np.array(metadata["parameter_defaults"], dtype=float)
        # Builds the variant with the C Jacobian on first need (set by nemc; None standalone).
        self.jacobian_provider: Callable[[], Model] | None = None
        self._checked: tuple[tuple, np.ndarray] = ((), self._default_p)

    @property
    def parameters(self) -> dict[str, float]:
        """The parameters settable at run time, with their default values."""
        return dict(zip(self.parameter_names, self._default_p.tolist()))

    def __repr__(self) -> str:
        return f"<nemc model {self.name}: state {list(self.state_names)}>"

    # -- arguments --------------------------------------------------------------------------

    def _buffer(self, array: np.ndarray) -> Any:
        return self._ffi.from_buffer("double[]", array)

    def parameter_vector(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The C parameter array for these overrides, checked (finite, masses positive)."""
        key = tuple(sorted(params.items())) if params else ()
        if key == self._checked[0]:
            return self._checked[1]
        p = self._default_p.copy()
        for name, value in (params or {}).items():
            p[self._parameter_index(name)] = self._finite(name, value)
        self._check_masses(p)
        self._checked = (key, p)
        return p

    def _parameter_index(self, name: str) -> int:
        if name in self.parameter_names:
            return self.parameter_names.index(name)
        if name in self.derived_parameters:
            raise ModelError(
                f"parameter {name!r} is derived ({name} = {self.derived_parameters[name]}):"
                " set its inputs instead"
            )
        close = difflib.get_close_matches(name, self.parameter_names, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ModelError(f"unknown parameter {name!r}{hint} (known: {list(self.parameter_names)})")

    @staticmethod
    def _finite(name: str, value: Any) -> float:
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise ModelError(f"parameter {name!r}: expected a number, got {value!r}") from None
        if not math.isfinite(number):
            raise ModelError(f"parameter {name!r}: must be finite, got {number}")
        return number

    def _check_masses(self, p: np.ndarray) -> None:
        names = self.metadata["check_names"]
        values = np.empty(len(names))
        self._c["checks"](self._buffer(p), self._buffer(values))
        for key, value in zip(names, values):
            if not value > 0:
                raise ModelError(f"{key} must be > 0 and finite, got {value:g} at these parameters")

    def _state(self, y: Any) -> np.ndarray:
        array = np.asarray(y)
        if np.iscomplexobj(array) or array.dtype.kind not in "fiub":
            raise ModelError(f"state must be real numbers, got dtype {array.dtype}")
        if array.shape != (self.n_state,):
            raise ModelError(f"state must have shape ({self.n_state},), got {array.shape}")
        return np.ascontiguousarray(array, dtype=np.float64)

    def initial_state(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The scene's initial state (unlisted values 0) at these parameters."""
        y0 = np.empty(self.n_state)
        self._c["initial_state"](self._buffer(self.parameter_vector(params)), self._buffer(y0))
        return y0

    def state_vector(self, y0: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """A state from an array, or from a dict of coordinate / dot(q) values (others 0)."""
        if y0 is None:
            return self.initial_state(params)
        if isinstance(y0, Mapping):
            state = np.zeros(self.n_state)
            for name, value in y0.items():
                if name not in self.state_names:
                    close = difflib.get_close_matches(str(name), self.state_names, n=1)
                    hint = f"; did you mean {close[0]!r}?" if close else ""
                    raise ModelError(f"unknown state name {name!r}{hint}")
                state[self.state_names.index(name)] = self._finite(name, value)
            return state
        return self._state(y0).copy()

    # -- evaluation -------------------------------------------------------------------------

    def rhs(self, t: float, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """dy/dt at (t, y)."""
        return self._rhs_function(self.parameter_vector(params))(float(t), self._state(y))

    def _rhs_function(self, p: np.ndarray):
        """A fast closure for integrators: buffers for p prepared once, checks done in C."""
        c_rhs, buffer, n, names = self._c["rhs"], self._buffer, self.n_state, self.state_names
        p_buffer = buffer(p)

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            y = np.ascontiguousarray(y, dtype=np.float64)  # Radau/BDF may pass strided views
            dy = np.empty(n)
            status = c_rhs(t, buffer(y), p_buffer, buffer(dy))
            if status:
                raise IntegrationFailure(t, y, status, names)
            return dy

        return rhs

    def rhs_many(self, t: Any, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """dy/dt at many states in one C call: y of shape (n_state, n), t scalar or (n,)."""
        ys = self._states(y)
        ts = np.ascontiguousarray(np.broadcast_to(np.asarray(t, dtype=float), ys.shape[:1]))
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
        array = np.asarray(y)
        if array.ndim != 2 or array.shape[0] != self.n_state or array.dtype.kind not in "fiu":
            expected = f"({self.n_state}, n)"
            raise ModelError(f"states must be real with shape {expected}, got {array.shape}")
        return np.ascontiguousarray(array.T, dtype=np.float64)

    def jacobian(self, t: float, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """d rhs / d y, (n_state, n_state): analytic, from C (built on first need); central
        differences of the compiled RHS only in a standalone package built without it."""
        function = self._jacobian_function(self.parameter_vector(params))
        if function is not None:
            return function(float(t), self._state(y))
        return self._finite_difference_jacobian(float(t), self._state(y), params)

    def _has_jacobian(self) -> bool:
        if "jacobian" not in self._c and self.jacobian_provider is not None:
            upgraded = self.jacobian_provider()
            self._c, self._lib, self._ffi = upgraded._c, upgraded._lib, upgraded._ffi
            self.jacobian_provider = None
        return "jacobian" in self._c

    def _jacobian_function(self, p: np.ndarray):
        """A fast closure d rhs/d y for implicit integrators, or None without a C Jacobian."""
        if not self._has_jacobian():
            return None
        c_jac, buffer, n, names = self._c["jacobian"], self._buffer, self.n_state, self.state_names
        p_buffer = buffer(p)

        def jacobian(t: float, y: np.ndarray) -> np.ndarray:
            y = np.ascontiguousarray(y, dtype=np.float64)
            jac = np.empty((n, n))
            status = c_jac(t, buffer(y), p_buffer, buffer(jac))
            if status:
                raise IntegrationFailure(t, y, status, names)
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

    def mass_matrix(self, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The mass matrix M(q) of M qdd = f at state y, (n_coord, n_coord), for diagnostics:
        the inverse of M^-1, whose columns the C code computes (built on first need)."""
        n = len(self.coordinate_names)
        inverse = np.empty((n, n))
        p, state = self.parameter_vector(params), self._state(y)
        if not self._has_jacobian():
            raise ModelError("this standalone package was built without the mass matrix")
        buffer = self._buffer
        status = self._c["inverse_mass_matrix"](buffer(state), buffer(p), buffer(inverse))
        if status:
            raise IntegrationFailure(0.0, state, status, self.state_names)
        return np.linalg.inv(inverse)

    def outputs(
        self, t: Any, y: Any, params: Mapping[str, float] | None = None
    ) -> dict[str, Any]:
        """The scene's outputs: floats for one state, arrays for y of shape (n_state, n_t)."""
        if not self.output_names:
            return {}
        single = np.ndim(y) == 1
        ys = self._states(np.asarray(y).reshape(self.n_state, -1) if single else y)
        ts = np.ascontiguousarray(np.broadcast_to(np.asarray(t, dtype=float), ys.shape[:1]))
        out = np.empty((len(ys), len(self.output_names)))
        self._many("outputs", ts, ys, self.parameter_vector(params), out)
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
    ) -> SimulationResult:
        """Integrate the scene. Arguments left None take the YAML scene's values, then defaults
        (t_span (0, 10), method RK45, rtol 1e-6, atol 1e-9, t_eval: the solver's steps)."""
        p = self.parameter_vector(params)
        span = tuple(float(v) for v in (t_span or self.scene["t_span"] or DEFAULT_T_SPAN))
        method = method or self.scene["method"] or DEFAULT_METHOD
        if method not in SCIPY_METHODS:
            raise ModelError(f"unknown method {method!r}; choose one of {', '.join(SCIPY_METHODS)}")
        rtol = float(rtol if rtol is not None else self.scene["rtol"] or DEFAULT_RTOL)
        atol = float(atol if atol is not None else self.scene["atol"] or DEFAULT_ATOL)
        times = self._times(span, t_eval)
        state0 = self.state_vector(y0, params)
        from scipy.integrate import solve_ivp  # here: importing scipy costs more than a load

        try:
            jac = self._jacobian_function(p) if method in IMPLICIT_METHODS else None
            extra = {"jac": jac} if jac is not None else {}
            sol = solve_ivp(
                self._rhs_function(p), span, state0, method=method, t_eval=times,
                rtol=rtol, atol=atol, **extra,
            )
        except IntegrationFailure as failure:
            return self._failed(failure, method, rtol, atol, params)
        outputs = self.outputs(sol.t, sol.y, params) if sol.t.size else {}
        return SimulationResult(
            t=sol.t, y=sol.y, outputs=outputs, nfev=int(sol.nfev), njev=int(sol.njev),
            nlu=int(sol.nlu), status=int(sol.status), message=str(sol.message),
            success=bool(sol.success), method=method, rtol=rtol, atol=atol,
            params=dict(zip(self.parameter_names, p.tolist())),
        )

    def _times(self, span: tuple[float, ...], t_eval: Sequence[float] | None) -> Any:
        if t_eval is not None:
            return np.asarray(t_eval, dtype=float)
        if self.scene["t_eval_step"]:
            step = float(self.scene["t_eval_step"])
            count = int(math.floor((span[1] - span[0]) / step * (1 + 1e-12))) + 1
            return span[0] + step * np.arange(count)
        if self.scene["t_eval"] is not None:
            times = np.asarray(self.scene["t_eval"], dtype=float)
            return times[(times >= span[0]) & (times <= span[1])]
        return None

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
