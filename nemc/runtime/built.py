"""One build of a mechanism, evaluated: its names and defaults, its state and parameter
vectors, and the C functions at a state (rhs, jacobian, mass matrix, outputs, positions), each a
thin checked wrapper over the build's C (compiled.py). Its builds with more parts (the
Jacobian, nemc.Taylor's code, ...) are compiled on first need and kept (compiled_with).
runtime.Model adds the runs to it (model.py)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .checks import (
    checked_state,
    checked_states,
    checked_time,
    finite_number,
    real_array,
    times_for,
)
from .compiled import Compiled
from .failures import IntegrationFailure, ModelError
from .friction import Friction
from .inputs import InputLayout
from .loops import Loops
from .parameters import Parameters

DEFAULT_T_SPAN = (0.0, 10.0)
OPTIONAL_PARTS = frozenset({"jacobian", "mass_matrix", "taylor", "lanes",  # C built when asked
                            "linearization", "sensitivities"})


class BuiltModel:
    """A compiled mechanism's names, defaults and evaluation. Its collaborators, public for
    tools and tests: `compiled` (the build's C: compiled.Compiled), `parameter_table`
    (parameters.Parameters) and `loops` (loops.Loops)."""

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
        self.compiled = Compiled(metadata, ffi, lib, rhs_call)
        self.parameter_table = Parameters(metadata, self.compiled)
        self.loops = Loops(metadata, self.compiled)
        self.input_layout = InputLayout(metadata, self.state_names)
        self.input_names: tuple[str, ...] = self.input_layout.names
        self.constraint_equations: tuple[str, ...] = self.loops.constraint_equations
        self.has_loops: bool = self.loops.has_loops
        self.friction = Friction(metadata, self.compiled)
        # Compiles this mechanism with more parts (set by nemc's pipeline; None in a
        # standalone package, which has only the parts it was built with): see compiled_with.
        self.part_compiler: Callable[[frozenset[str]], BuiltModel] | None = None
        # Writes this mechanism's FMU (set by nemc's pipeline; None in a standalone package):
        # Model.export_fmu, nemc/runtime/fmu.py.
        self.fmu_exporter: Callable[..., Any] | None = None
        # The native integrators for a system of n states given by a function pointer (the
        # sensitivity system: sensitivities.py), their cffi module (set by nemc's pipeline, which
        # builds them once per size; None in a standalone package).
        self.system_drivers: Callable[[int], Any] | None = None
        # The regressor's code for the linear coefficients named (set by nemc's pipeline,
        # which derives it; None in a standalone package): Model.regressor, regressor.py.
        self.regressor_maker: Callable[[tuple[str, ...]], Any] | None = None
        self._regressor_code: dict[tuple[str, ...], Any] = {}  # regressor_maker's, by names
        self._variants: dict[str, BuiltModel] = {}  # compiled_with's, by the part asked for
        # the seconds its compile took when the pipeline built it now rather than loaded it
        # from the cache, until a BuildNotice reported them (None: nothing to report)
        self.fresh_build_seconds: float | None = None
        self._native_builds: dict[str, BuiltModel] = {}  # native.native_build's, by method
        self._stiffness_build: tuple[int, BuiltModel | None] = (-1, None)  # auto.stiffness_build's
        self._rhs_cache: tuple[Any, Any, Any] = (None, None, None)  # rhs(): (p, its ways)
        # rhs(t, y) at the default parameters: through the build's _rhs_call (None: not made
        # yet), else through cffi with the checks (Compiled.fast_rhs, checked_rhs)
        self._fast_rhs: Callable[[Any, Any], np.ndarray | None] | None = None
        self._default_rhs: Callable[[Any, Any], np.ndarray] | None = None

    @property
    def parameters(self) -> dict[str, float]:
        """The parameters settable at run time, with their default values."""
        return dict(zip(self.parameter_names, self.parameter_table.defaults.tolist()))

    def __repr__(self) -> str:
        return f"<nemc model {self.name}: state {list(self.state_names)}>"

    # -- parameters and states --------------------------------------------------------------

    def parameter_vector(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The C parameter array for these overrides, checked (finite, masses positive)."""
        return self.parameter_table.vector(params)

    def parameters_at(self, p: np.ndarray) -> dict[str, float]:
        """The parameter vector p as name -> value."""
        return self.parameter_table.at(p)

    def initial_state(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The scene's initial state (unlisted values 0) at these parameters; a closed loop's
        assembled from its given values and its guess (at the scene's start time)."""
        p = self.parameter_vector(params)
        y0 = self.scene_values(p)
        if self.has_loops:
            t0 = (self.scene["t_span"] or DEFAULT_T_SPAN)[0]
            p = self.loops.started(t0, y0, p)
            y0 = self.loops.assembled(t0, y0, self.loops.given_mask(None), p)[0]
        return y0

    def scene_values(self, p: np.ndarray) -> np.ndarray:
        """The scene's `initial` values at the parameter vector p, the others 0 (a closed loop's:
        its `guess`), not assembled."""
        y0 = np.empty(self.n_state)
        buffer = self.compiled.buffer
        self.compiled.functions["initial_state"](buffer(p), buffer(y0))
        return y0

    def guess_state(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """Where a closed loop's assembly from given values starts (simulate's y0=dict,
        simulate_many's and a sweep's columns, `--initial`): the scene's initial state, or,
        where the scene's values cannot close at these parameters, its values and guess as they
        are (the values given then decide whether the loop closes)."""
        if not self.has_loops:
            return self.initial_state(params)
        p = self.parameter_vector(params)  # refused parameters: their own error
        try:
            return self.initial_state(params)
        except ModelError:
            return self.scene_values(p)

    def state_vector(self, y0: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """A state from an array, or from a dict of coordinate / dot(q) values (others 0)."""
        if y0 is None:
            return self.initial_state(params)
        # a dict of values (closed loops: the others start from the scene's guess)
        if type(y0) is not np.ndarray and isinstance(y0, Mapping):
            state = self.guess_state(params) if self.has_loops else np.zeros(self.n_state)
            for name, value in y0.items():
                if name not in self.state_names:
                    import difflib

                    close = difflib.get_close_matches(str(name), self.state_names, n=1)
                    hint = f"; did you mean {close[0]!r}?" if close else ""
                    raise ModelError(f"unknown state name {name!r}{hint}")
                state[self.state_names.index(name)] = finite_number(name, value, "state value")
            return state
        return checked_state(y0, self.n_state).copy()

    # -- evaluation -------------------------------------------------------------------------

    def rhs(self, t: float, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """dy/dt at (t, y) (equations that hold "as at the start", a gear pair's, hold as at y)."""
        if self.loops.starts:
            p = self._started(t, y, self.parameter_vector(params))
            return self.compiled.integrator_rhs(p)(checked_time(t), checked_state(y, self.n_state))
        if params is None:  # the default parameters (checked when compiled): no lookup
            fast = self._fast_rhs or self._prepare_default_rhs()
            dy = fast(t, y)  # a float t and a float64 array y: the C call, else None
            return dy if dy is not None else self._default_rhs(t, y)  # type: ignore[misc]
        p = self.parameter_vector(params)
        if p is self.parameter_table.defaults:
            return self.rhs(t, y)
        kept = self._rhs_cache
        if kept[0] is not p:  # the two ways at the latest parameters, kept
            kept = self._rhs_cache = (p, self.compiled.fast_rhs(p),
                                      self.compiled.checked_rhs(p))
        dy = kept[1](t, y)  # as at the defaults: the C call, else None
        return dy if dy is not None else kept[2](t, y)

    def _prepare_default_rhs(self) -> Callable[[Any, Any], np.ndarray | None]:
        """rhs(t, y)'s two ways at the default parameters: the build's _rhs_call, and cffi's,
        which converts or refuses the arguments and raises the failure."""
        defaults = self.parameter_table.defaults
        self._default_rhs = self.compiled.checked_rhs(defaults)
        self._fast_rhs = self.compiled.fast_rhs(defaults)
        return self._fast_rhs

    def rhs_many(self, t: Any, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """dy/dt at many states in one C call: y of shape (n_state, n), t scalar or (n,)."""
        ys = checked_states(y, self.n_state)
        ts = times_for(t, len(ys))
        dys = np.empty_like(ys)
        p = self.parameter_vector(params)
        if self.loops.starts:  # each state its own start
            for k in range(len(ys)):
                self.compiled.call_many("rhs_many", ts[k:k + 1], ys[k:k + 1],
                                        self._started(ts[k], ys[k], p), dys[k:k + 1])
            return dys.T
        self.compiled.call_many("rhs_many", ts, ys, p, dys)
        return dys.T

    def jacobian(self, t: float, y: Any, params: Mapping[str, float] | None = None) -> np.ndarray:
        """d rhs / d y, (n_state, n_state): analytic, from C (built on first need); central
        differences of the compiled RHS only in a standalone package built without it."""
        p = self._started(t, y, self.parameter_vector(params))
        source = self.compiled_with("jacobian")
        if source.has_part("jacobian"):
            function = source.compiled.integrator_jacobian(p)
            return function(checked_time(t), checked_state(y, self.n_state))
        return self._finite_difference_jacobian(checked_time(t), checked_state(y, self.n_state),
                                                params)

    def _finite_difference_jacobian(self, t: float, y: np.ndarray, params) -> np.ndarray:
        f = self.compiled.integrator_rhs(self._started(t, y, self.parameter_vector(params)))
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
        p, state = self.parameter_vector(params), checked_state(y, self.n_state)
        source = self.compiled_with("mass_matrix")
        if not source.has_part("mass_matrix"):
            raise ModelError("this standalone package was built without the mass matrix "
                             "(nemc compile --jacobian builds it)")
        buffer = source.compiled.buffer
        status = source.compiled.functions["inverse_mass_matrix"](
            checked_time(t), buffer(state), buffer(p), buffer(inverse))
        if status:
            raise IntegrationFailure(float(t), state, status, self.state_names)
        return np.linalg.inv(inverse)

    def outputs(
        self, t: Any, y: Any, params: Mapping[str, float] | None = None
    ) -> dict[str, Any]:
        """The scene's outputs: floats for one state, arrays for y of shape (n_state, n_t)."""
        if not self.output_names:
            return {}
        p = self.parameter_vector(params)
        array = real_array(y, "states")
        if not self.loops.starts or array.ndim == 1:
            return self.compiled.outputs_at(t, array, self._started(t, array, p))
        ts = times_for(t, array.shape[-1])
        columns = [self.compiled.outputs_at(ts[k], column, self._started(ts[k], column, p))
                   for k, column in enumerate(array.T)]  # each state its own start
        return {name: np.array([c[name] for c in columns]) for name in self.output_names}

    def positions(self, t: Any, y: Any, params: Mapping[str, float] | None = None
                  ) -> dict[str, np.ndarray]:
        """Ground-frame positions of the points a drawing needs (bodies' origins, mass
        centres and named points, joints, spring ends; metadata["drawing"]), computed by the
        compiled model: name -> [x, y] for one state, [xs, ys] of shape (2, n_t) for y of
        shape (n_state, n_t)."""
        array = real_array(y, "states")
        single = array.ndim == 1
        xy = self.positions_array(t, array.reshape(-1, 1) if single else array, params)
        names = self.metadata["drawing"]["points"]
        return {name: xy[0, k].copy() if single else xy[:, k].T.copy()
                for k, name in enumerate(names)}

    def positions_array(self, t: Any, y: Any, params: Mapping[str, float] | None = None
                        ) -> np.ndarray:
        """As positions(), as one array (n_t, n_points, 2) for y of shape (n_state, n_t)."""
        function = self.compiled.function("positions")
        if function is None or "drawing" not in self.metadata:
            raise ModelError(f"the build of {self.name} has no positions function: rebuild it"
                             " with this version of nemc")
        ys = checked_states(y, self.n_state)
        ts = times_for(t, len(ys))
        out = np.empty((len(ys), len(self.metadata["drawing"]["points"]), 2))
        buffer, p = self.compiled.buffer, self.parameter_vector(params)
        for rows in [slice(k, k + 1) for k in range(len(ys))] if self.loops.starts else [
                slice(None)]:  # a state its own start where equations hold "as at the start"
            p_rows = self._started(ts[rows][0], ys[rows][0], p) if self.loops.starts else p
            function(len(ys[rows]), buffer(np.ascontiguousarray(ts[rows])),
                     buffer(np.ascontiguousarray(ys[rows])), buffer(p_rows),
                     buffer(out[rows]))
        return out

    def constraint_residual(self, y: Any, t: Any = 0.0,
                            params: Mapping[str, float] | None = None,
                            start: Any = None) -> np.ndarray:
        """|Phi(q, t)| and |Phi_q q' + Phi_t| (the largest entry of each) at a state, or for y of
        shape (n_state, n_t) at each state (shape (2, n_t)). Zeros for a mechanism without
        loops. Equations that hold "as at the start" (a gear pair's) are measured from the
        state `start` at time t_span[0] (default: the scene's initial state)."""
        array = np.asarray(y, dtype=float)
        single = array.ndim == 1
        ys = checked_states(array.reshape(-1, 1) if single else array, self.n_state)
        if not self.has_loops:
            return np.zeros(2) if single else np.zeros((2, len(ys)))
        p = self.parameter_vector(params)
        if self.loops.starts:
            first = (self.scene["t_span"] or DEFAULT_T_SPAN)[0]
            p = self.loops.started(first, self.initial_state(params) if start is None
                                   else self.state_vector(start, params), p)
        out = self.loops.residual(times_for(t, len(ys)), ys, p)
        return out[0] if single else out.T

    def _started(self, t: Any, y: Any, p: np.ndarray) -> np.ndarray:
        """p with the offsets of equations that hold "as at the start" taken at (t, y): outside
        a run, a state is its own start (p itself for a mechanism without such equations)."""
        if not self.loops.starts:
            return p
        return self.loops.started(checked_time(float(np.asarray(t).reshape(-1)[0])),
                                  checked_state(y, self.n_state), p)

    # -- the builds with more parts ------------------------------------------------------------

    def has_part(self, part: str) -> bool:
        """Whether this build has the optional part "jacobian", "mass_matrix", "taylor" or
        "lanes" (a query only)."""
        return part in self.metadata["generated"]

    def compiled_with(self, part: str) -> BuiltModel:
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
            have = {name for model in self._builds_at_hand()
                    for name in model.metadata["generated"]}
            variant = self.part_compiler(frozenset(have & OPTIONAL_PARTS | {part}))
            variant.parameter_table.share_defaults(self.parameter_table)
            self._variants[part] = variant
        return self._variants[part]

    def _builds_at_hand(self) -> tuple[BuiltModel, ...]:
        """This build and the variants compiled_with gave already (nothing is built)."""
        return (self, *self._variants.values())
