"""What the runtime raises or warns of, and what a status of the model's C means in words: the
caller's mistakes (ModelError), equations that cannot be evaluated at a state
(IntegrationFailure), whose message says the likely cause, a closed loop's constraint by name
included, and a call's compile of seconds (BuildNotice)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

SERIES_NOT_FINITE = -3  # the model status NEMC_SERIES_NOT_FINITE (templates/nemc_run.h.tmpl)
EVENT_NOT_FINITE = -4  # NEMC_EVENT_NOT_FINITE: an event's function
LAW_NOT_FINITE = -5  # NEMC_LAW_NOT_FINITE: an impact law's new value
FRICTION_UNSOLVABLE = -6  # NEMC_FRICTION_UNSOLVABLE: Painleve's paradox
STATUS_CAUSES = {  # what these statuses mean, whatever the state (the state is checked first)
    SERIES_NOT_FINITE: "nemc.Taylor's series overflows here (a Taylor coefficient, or the "
                       "series' value at the step's end, is not finite): the solution blows up, "
                       "or it moves too fast for the series at this tolerance (try nemc.Vern9 "
                       "or nemc.DOP853)",
    EVENT_NOT_FINITE: "an event's function (simulation.events, `when`) is not finite here: it "
                      "gives inf or nan at this state (e.g. sqrt or log of a negative number, "
                      "a division by zero)",
    LAW_NOT_FINITE: "an impact law (simulation.events, `action`) gives a new value that is "
                    "not finite at this state (e.g. a division by zero)",
    FRICTION_UNSOLVABLE: "Painleve's paradox: the friction forces and the normal forces they "
                         "depend on have no unique solution at this state (a friction "
                         "coefficient too large for this configuration: the sliding joint "
                         "would jam or be thrown; friction section)",
}


class ModelError(ValueError):
    """A call the model cannot honour: wrong shapes, unknown or invalid parameters."""


class FitError(ModelError):
    """A fit that cannot be made or did not converge (nemc.fit): what, and which names."""


class BuildNotice(UserWarning):
    """A call compiled a build of its own now (sympy and the C compiler: seconds, once; later
    calls and sessions load it from the cache): what it built and how long that took."""


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
    if status in STATUS_CAUSES:
        return STATUS_CAUSES[status]
    if status > 0:
        return (f"the articulated inertia through joint {status} (counting from 1 in file "
                "order) is not positive: the mass matrix is singular or not positive definite "
                "here, likely a mass or inertia near zero or a configuration where the "
                "coordinates lose a degree of freedom")
    return ("the accelerations are not finite: a load or parameter gives inf or nan here "
            "(e.g. a division by zero in a load expression)")


def status_cause(metadata: Mapping[str, Any], equations: Sequence[str], status: int,
                 program: str = "dynamics_program") -> str | None:
    """What a status of the C means where failure_cause cannot tell: a loop's (EQUATIONS: the
    constraint owning each constraint equation), or a positive one when the PROGRAM
    ("dynamics_program" or "taylor_program" in model.json) is the mass-matrix form
    (mass_form.py: pivot k of M's LDL^T), not the articulated-body one."""
    form = metadata.get(program) or ""
    if status <= 0 or not form.startswith("mass matrix"):
        return loop_failure(equations, status)
    series = ", in nemc.Taylor's series," if program == "taylor_program" else ""
    return (f"the mass matrix is singular or not positive definite here (pivot {status} of"
            f" its LDL^T factorization{series} is not positive): likely a mass or inertia "
            "near zero or a configuration where the coordinates lose a degree of freedom")


def loop_equation(equations: Sequence[str], status: int) -> str:
    """The constraint of the equation a NEMC_PROJECTION_FAILED / NEMC_LOOP_SINGULAR status
    names."""
    index = (-status) % 1000
    return equations[index] if index < len(equations) else f"equation {index}"


def loop_failure(equations: Sequence[str], status: int) -> str | None:
    """What a loop status of the model's C means, or None for other statuses."""
    if -2000 < status <= -1000:
        return (f"the state cannot be brought onto constraint {loop_equation(equations, status)!r}"
                " (the loop cannot close here: a configuration the mechanism cannot reach, "
                "or the motion left the branch it was on)")
    if -3000 < status <= -2000:
        return (f"constraint {loop_equation(equations, status)!r} loses rank here and the "
                "motion does not carry the mechanism out of it: a singular (locked) "
                "configuration of the loop, at rest in it or moving within it (which branch it "
                "would leave on is not determined)")
    return None
