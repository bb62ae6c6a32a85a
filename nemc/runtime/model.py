"""The runtime's Model: a compiled mechanism, evaluated (built.py) and run: simulate (one run
of the scene: simulation.py, with native.py, scipy_run.py and auto.py) and simulate_many (an
ensemble: ensemble.py).

The runtime needs only numpy, scipy and the cffi module of a build: an exported standalone
package holds a copy of this folder. It must not import nemc's other stages or sympy.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

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
from . import ensemble, ensemble_sensitivities, fmu, plant, runs, simulation
from . import sensitivities as variational
from .auto import checked_auto_choice
from .built import DEFAULT_T_SPAN, BuiltModel  # noqa: F401 (re-exported)
from .failures import IntegrationFailure, ModelError  # noqa: F401 (re-exported)
from .linear import Linearization
from .results import EnsembleResult, SimulationResult, model_html
from .simulation import SOLVER_STEPS  # noqa: F401 (re-exported)

if TYPE_CHECKING:
    from . import regressor as regression


def read_metadata(path: Path) -> dict:
    """A build's model.json."""
    return json.loads(Path(path).read_text())


class Model(BuiltModel):
    """A compiled mechanism: names, defaults, rhs, jacobian, outputs and simulate."""

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
        inputs: Any = None,
        sensitivities: Sequence[str] | None = None,
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
        False and a message saying why (docs/decisions.md, "Runs that end").
        inputs: the YAML's inputs (input_names), each a number, a table (times, values: linear
        between samples, held beyond), nemc.feedback(K, y_ref, u_ref) (u = u_ref - K (y -
        y_ref)), all evaluated in C by every method, or a function f(t, y) (scipy's methods);
        or nemc.feedback(...) for every input at once. Those not given take the YAML's value
        (the scene's simulation.inputs, else the default).
        sensitivities: names of parameters, inputs (d/d a constant added to the input) and
        initial values (state names, or "y0" for all): the variational equations integrated
        with the run, exact (the part "sensitivities", compiled on first need), in the same
        error control; res.sensitivities[name] is d y(t) / d name, (n_state, n_t) ("y0":
        (n_state, n_state, n_t)), res.output_sensitivities[name][output] the outputs'. A
        closed loop's solved initial values (and "y0") have none: refused by name."""
        arguments = (t_span, y0, method, rtol, atol, params, events, max_step, tstops,
                     max_steps, inputs)  # as simulation.RUN_ARGUMENTS names them
        if sensitivities is not None:
            spec = simulation.run_spec(self, arguments, t_eval)
            result = variational.simulate_sensitivities(self, spec, sensitivities,
                                                        y0 is not None, y0)
        else:
            result = simulation.simulate(self, arguments, t_eval)
        result.model = self  # the result knows its model, and runs again at other times (a
        result.run_arguments = arguments  # run with sensitivities: without them)
        return result

    def _rerun(self, arguments: tuple, t_eval: Any) -> SimulationResult:
        """A result's run again, at the times t_eval (SimulationResult.rerun; arguments: its
        run_arguments)."""
        return simulation.simulate(self, arguments, t_eval)

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
        inputs: Any = None,
        sensitivities: Sequence[str] | None = None,
    ) -> EnsembleResult:
        """Integrate an ensemble with a native method, the loop over runs in C.

        y0s: (k, n_state) initial states, or None for the scene's initial state, or a dict of
        state values (a number, or k of them), each run's state as simulate's y0=dict makes it
        (a closed loop's assembled from the values given; a run whose values it cannot meet is
        refused by its number, as is a full state off the constraints). params: a dict
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
        always run one after the other.
        inputs: as simulate's, each input's value also run by run (an array of k numbers);
        tables and feedbacks shared; no Python functions (the runs are in C).
        sensitivities: as simulate's names; each run's variational equations integrated with
        its state in the same error control (nemc.DOP853, nemc.Vern9, nemc.Radau; default the
        scene's native method, nemc.Radau for an implicit scene, else nemc.Vern9 below rtol
        1e-4 and nemc.DOP853 above), the runs one after the other in C, never in lanes;
        res.sensitivities[name][r] is run r's d y(t) / d name, as its single run's (a closed
        loop's run from its own assembly). Refused: nemc.Taylor, friction and contacts."""
        call = ensemble.EnsembleCall(y0s, params, t_span, t_eval, method, rtol, atol, threads,
                                     max_step, tstops, max_steps, max_events, progress, lanes,
                                     inputs)
        if sensitivities is not None:
            return ensemble_sensitivities.simulate_many_sensitivities(self, call, sensitivities)
        return ensemble.simulate_many(self, call)

    def auto_method(self, span: Sequence[float], y0: Any, rtol: float,
                    params: Any = None, runs: int = 1) -> str:
        """The native method "auto" starts a run with (methods.auto_method): from the size,
        the tolerance, whether nemc.Taylor's code is at hand, and the stiff modes at y0.
        runs: an ensemble this large may build nemc.Taylor's code (AUTO_TAYLOR_BUILD_RUNS), and
        from AUTO_LANES_MIN_RUNS on, with nemc.Taylor's lanes at hand, takes nemc.Taylor up to
        AUTO_LANES_TAYLOR_MAX_COORDINATES."""
        return checked_auto_choice(self, span, y0, rtol, params, runs)

    def ensemble_method(self, span: Sequence[float], y0: Any = None, params: Any = None,
                        rtol: float | None = None, runs: int = 1) -> str:
        """simulate_many's (and nemc.sweep's) default for RUNS runs: the scene's native
        method; nemc.Radau for an implicit scene; else "auto"'s choice for a run from y0
        (default the scene's), without the switch to nemc.Radau a single run can make, and
        with nemc.Taylor's code built for it from AUTO_TAYLOR_BUILD_RUNS runs on. nemc.Taylor
        runs in SIMD lanes for ensembles of AUTO_LANES_MIN_RUNS runs or more (the lanes are
        a build of seconds), or when the build has them."""
        return ensemble.ensemble_method(self, span, y0, params, rtol, runs)

    # -- the model as a plant (plant.py) -------------------------------------------------------

    def linearize(self, y: Any = None, u: Any = None, *, t: float = 0.0,
                  params: Mapping[str, float] | None = None,
                  independent: Sequence[str] | None = None) -> Linearization:
        """The exact linearization about (t, y, u): dx/dt = A x + B u, out = C x + D u, from
        the derivation's forward-mode derivative in C (the part "linearization", compiled on
        first need; no finite differences). y: a state (array or dict; default the scene's
        initial state); u: the inputs' values (a mapping or a vector; default their YAML
        values at (t, y)). A closed loop's in independent coordinates (lin.state_names), the
        others following from the constraints: INDEPENDENT names them (default: those QR with
        column pivoting leaves, the dependent ones best conditioned). With driven joints A, B
        depend on t. lin.modes(), lin.to_scipy(), lin.to_control(), lin.feedback(K)."""
        return plant.linearize(self, y, u, t=t, params=params, independent=independent)

    def trim(self, y: Any = None, u: Any = None, *, fix: Mapping[str, float] | None = None,
             free: Sequence[str] | None = None, t: float = 0.0,
             params: Mapping[str, float] | None = None) -> plant.OperatingPoint:
        """An equilibrium, dy/dt = 0, by Newton with the exact Jacobian [A B] (scipy's
        least_squares): FREE names the state entries and inputs solved for (default every
        coordinate; a closed loop's independent ones), the rest held at y, u (default the
        scene's initial state at rest and the YAML's inputs) and FIX's values. An
        equilibrium not reached is an error naming the rate that stays away from 0; what the
        equations do not fix there is left at its start (op.undetermined), an error when
        named in FREE."""
        return plant.trim(self, y, u, fix=fix, free=free, t=t, params=params)

    def floquet(self, period: float, y: Any = None, *, t0: float = 0.0,
                params: Mapping[str, float] | None = None, u: Any = None,
                rtol: float = 1e-11, atol: float = 1e-13) -> plant.Floquet:
        """The Floquet multipliers of the motion from y (default the scene's initial state) at
        t0 over one PERIOD of a periodic drive: the monodromy matrix dy(t0 + T)/dy(t0) from
        the variational equations (the exact Jacobian), integrated with the motion."""
        return plant.floquet(self, period, y, t0=t0, params=params, u=u, rtol=rtol,
                             atol=atol)

    # -- the inverse dynamics linear in the inertial parameters (regression.py) ----------------

    def regressor(self, t: Any, q: Any, qd: Any, qdd: Any, *,
                  params: Mapping[str, float] | None = None, linear: Sequence[str] = ()
                  ) -> np.ndarray:
        """Y of tau = Y(q, qd, qdd) phi - Q: (rows, len(phi)) at one sample, (n_t, rows,
        len(phi)) for q, qd, qdd of shape (coordinates, n_t) (every joint's coordinate, a
        driven one's too: regressor_at(...).coordinate_names). phi: per body its mass, first
        moments and inertia about its origin, then the load coefficients named in LINEAR
        (regressor_at(...).names); a tree's rows are its coordinates, a closed loop's its
        drives. Exact: the derivation's expressions, evaluated with numpy (derived on first
        use; needs nemc's compiler)."""
        y, _ = self.regressor_at(params, linear).matrix(t, q, qd, qdd)
        return y[0] if np.ndim(q) == 1 else y

    def regressor_at(self, params: Mapping[str, float] | None = None,
                     linear: Sequence[str] = ()) -> regression.Regressor:
        """The regressor at these parameters: its names, phi's values, Y and the loads' Q over
        samples (regression.py)."""
        from . import regressor as regression  # scipy's linear algebra: only when asked

        return regression.Regressor(self._regressor_source(tuple(linear)),
                                   self.parameter_table.vector(params), self.parameter_names)

    def base_parameters(self, params: Mapping[str, float] | None = None,
                        linear: Sequence[str] = (), samples: int | None = None,
                        seed: int = 0) -> regression.BaseParameters:
        """The base parameters of a tree: the combinations of phi identifiable at all, from Y
        stacked at SAMPLES seeded random states (QR: regression.py; None: its default). A
        closed loop's depend on the motion: nemc.identify gives those of its data."""
        from . import regressor as regression

        reg = self.regressor_at(params, linear)
        if self.has_loops:
            raise ValueError("a closed loop's states are not free: its base parameters come "
                             "from data (nemc.identify)")
        count = regression.SAMPLES if samples is None else samples
        return reg.base(*regression.random_states(len(reg.coordinate_names), count, seed))

    def _regressor_source(self, linear: tuple[str, ...]) -> Any:
        """The regressor's code for LINEAR, derived once (the pipeline's regressor_maker)."""
        if linear not in self._regressor_code:
            if self.regressor_maker is None:
                raise ModelError("the regressor is derived by nemc's compiler: compile the "
                                 "mechanism with nemc.compile (a standalone package has none)")
            self._regressor_code[linear] = self.regressor_maker(linear)
        return self._regressor_code[linear]

    def export_fmu(self, path: str | Path, fmi: int = 2, kind: str = "me") -> Path:
        """This mechanism as an FMU at PATH (a .fmu file): FMI 2 or 3, model exchange ("me")
        or co-simulation ("cs"), from the same C with no Python in it; its build with the
        Jacobian and the linearization compiled first where the cache lacks it. A file at
        PATH is replaced only if nemc wrote it (docs/fmu.md)."""
        return fmu.export_fmu(self, path, fmi, kind)

    _repr_html_ = model_html  # IPython's display protocol: the model's names in a table
