"""Runs with scipy's solve_ivp (SCIPY_METHODS): the compiled right-hand side, Jacobian and events
handed to it, under the same run settings and with the same messages as the native methods
(runs.simulate_scipy)."""

from __future__ import annotations

import math

import numpy as np

from ..vocabulary import IMPLICIT_METHODS
from . import runs
from .built import BuiltModel
from .failures import IntegrationFailure
from .inputs import RunInputs
from .outcome import RunSpec, ended_early, failed, failed_after, gave_up, lazy_outputs
from .results import SimulationResult
from .scipy_switches import SwitchingSegments


def simulate_scipy(model: BuiltModel, spec: RunSpec) -> SimulationResult:
    """simulate() with scipy's solve_ivp, under the run settings and the events."""
    from scipy.integrate import solve_ivp  # here: importing scipy costs more than a load

    method, p, rtol, atol, settings = spec.method, spec.p, spec.rtol, spec.atol, spec.settings
    if spec.inputs is None:
        rhs = model.compiled.integrator_rhs(p)
        model_events = model.compiled.model_events(p)
    else:  # inputs that vary (a table, a function): p at each (t, y)
        rhs = varying_rhs(model, spec.inputs)
        model_events = model.compiled.model_events(
            p, spec.inputs.at, spec.inputs.keep if model.friction.present else None)
    try:
        jac = integrator_jacobian(model, p) if method in IMPLICIT_METHODS else None
        options = {"rtol": rtol, "atol": atol, **({"jac": jac} if jac is not None else {})}
        with runs.interrupt_flag() as flag:
            outcome, control = runs.simulate_scipy(
                solve_ivp, rhs, method, spec.span, spec.state0,
                None if spec.times is None else np.asarray(spec.times, dtype=float), options,
                model_events, spec.user_events, settings, flag,
                SwitchingSegments if model.friction.present else None)
    except IntegrationFailure as failure:  # the Jacobian's, before the run
        return failed(failure, method, rtol, atol, model.parameters_at(p))
    status, message = outcome.status, outcome.message
    if control.failure is not None:  # the equations failed: the states before, kept
        return failed_after(model, spec, control.failure, outcome.t, outcome.y,
                            (outcome.nfev, outcome.njev, outcome.nlu), outcome.events,
                            (rtol, atol))
    if control.stop:  # the budget, the pace, the stiffness test or Ctrl-C ended it
        status = control.stop
        message = ended_early(model, runs.Ending(
            status, control.t, spec.span, control.steps, method, settings.max_steps,
            control.y, control.h_recent, control.stiff_from, control.stiffness), p)
    elif status == -1 and rhs.last[1] is not None:  # scipy gave up
        message = gave_up(model, message, *rhs.last, p)
    elif status == runs.REACHED_END and not math.isnan(control.stiff_from):
        message += runs.stiffness_note(control.stiff_from)
    return SimulationResult(
        t=outcome.t, y=outcome.y,
        outputs=lazy_outputs(model, outcome.t, outcome.y, p, spec.inputs),
        nfev=outcome.nfev, njev=outcome.njev, nlu=outcome.nlu, status=status,
        message=message, success=status >= 0, method=method, rtol=rtol, atol=atol,
        params=model.parameters_at(p), events=outcome.events,
    )


def varying_rhs(model: BuiltModel, inputs: RunInputs):
    """solve_ivp's fun where inputs vary: the C right-hand side at the parameter vector with
    the inputs' values at (t, y) (a table's segment, a function's value); its attribute `last`
    holds the latest [t, y], as integrator_rhs's."""
    compiled = model.compiled
    c_rhs, buffer, n, names = compiled.functions["rhs"], compiled.buffer, model.n_state, \
        model.state_names
    last: list = [0.0, None]

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        y = np.ascontiguousarray(y, dtype=np.float64)
        last[0], last[1] = t, y
        dy = np.empty(n)
        status = c_rhs(t, buffer(y), buffer(inputs.at(t, y)), buffer(dy))
        if status:
            raise IntegrationFailure(t, y, status, names, compiled.status_cause(status))
        return dy

    rhs.last = last  # type: ignore[attr-defined]
    return rhs


def integrator_jacobian(model: BuiltModel, p: np.ndarray):
    """solve_ivp's jac at parameters p: the analytic Jacobian of the model's build with it
    (compiled on first need), or None where there is none (a standalone package built
    without it: scipy then differences)."""
    source = model.compiled_with("jacobian")
    if not source.has_part("jacobian"):
        return None
    return source.compiled.integrator_jacobian(p)
