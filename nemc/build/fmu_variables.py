"""An FMU's variables: what each value reference is, in the order modelDescription.xml lists
them and the wrapper's C reads them (templates/fmi/fmu_core.c.tmpl's VR_* ranges).

    0                 time (the independent variable)
    states            the model's state y, named as model.json's state_names
    derivatives       der(name) of each state
    parameters        the runtime parameters, tunable
    inputs            the YAML's inputs: each sets its law's `value` (scale 0; decision 0031)
    outputs           the scene's outputs
    event indicators  event(name): each scene event's function
    settings          co-simulation: nemc.method, nemc.rtol, nemc.atol; model exchange of a
                      closed loop: nemc.projection_tolerance

The values an export needs from the model at run time (defaults the runtime computes: the
initial state, the inputs' start values, the native method) arrive as FmuDefaults.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..errors import BuildError

METHOD_IDS = {"nemc.DOP853": 0, "nemc.Radau": 1, "nemc.Vern9": 2, "nemc.Taylor": 3}  # enum
#                                                                  nemc_method (nemc_run.h)
KINDS = ("me", "cs")
VERSIONS = (2, 3)
# The smallest rtol the native methods take (runtime/checks.py's MIN_RTOL, scipy's 100 eps)
MIN_RTOL = 100 * 2.220446049250313e-16
DEFAULT_PROJECTION_TOLERANCE = 1e-10  # a closed loop's residual that starts a projection


@dataclass(frozen=True)
class FmuDefaults:
    """What the runtime knows of a model that an FMU starts from (nemc/runtime/fmu.py's
    fmu_facts): its experiment (the scene's t_span, output step, tolerances, run settings),
    the co-simulation's native method, the initial state (assembled, for closed loops), each
    input's value at the start by its YAML law, whether the drives leave no degree of freedom
    (a kinematic analysis), and the dependencies."""

    method: str
    rtol: float
    atol: float
    start_time: float
    stop_time: float
    output_step: float | None
    initial_state: tuple[float, ...]
    input_start: tuple[float, ...]
    kinematic: bool = False
    max_step: float = 0.0  # the scene's run settings (0: no max_step)
    max_steps: int = 0
    tstops: tuple[float, ...] = ()
    # each derivative's and output's (states, inputs) it depends on; None: all
    dependencies: Mapping[str, tuple] | None = None
    projection_tolerance: float = DEFAULT_PROJECTION_TOLERANCE


@dataclass(frozen=True)
class Variable:
    """One FMU variable: its value reference, role and attributes."""

    name: str
    vr: int
    role: str  # time, state, derivative, parameter, input, output, indicator, setting
    index: int  # its place among its role's variables
    start: float | int | None = None
    unit: str = ""
    description: str = ""
    integer: bool = False
    minimum: float | None = None
    maximum: float | None = None


@dataclass(frozen=True)
class Layout:
    """Every variable in value-reference order, and where each role's range starts."""

    variables: tuple[Variable, ...]
    first: Mapping[str, int] = field(default_factory=dict)

    def of(self, role: str) -> tuple[Variable, ...]:
        return tuple(v for v in self.variables if v.role == role)


ROLES = ("time", "state", "derivative", "parameter", "input", "output", "indicator", "setting")


def derivative_name(state: str) -> str:
    return f"der({state})"


def indicator_name(event: str) -> str:
    return f"event({event})"


def state_unit(meta: Mapping[str, Any], state: str) -> str:
    return meta.get("unit_labels", {}).get(state, "")


def derivative_unit(meta: Mapping[str, Any], state: str) -> str:
    """The unit of d state / dt: a coordinate's rate, a rate's acceleration."""
    labels = meta.get("unit_labels", {})
    if state.startswith("dot(") and state.endswith(")"):
        return labels.get(f"ddot({state[4:-1]})", "")
    return labels.get(f"dot({state})", "")


def setting_variables(kind: str, defaults: FmuDefaults, has_loops: bool,
                      has_taylor: bool) -> list[dict]:
    """The FMU's own settings: co-simulation's method and tolerances; model exchange's
    projection tolerance for a closed loop."""
    if kind == "cs":
        methods = [m for m in METHOD_IDS if m != "nemc.Taylor" or has_taylor]
        listed = ", ".join(f"{METHOD_IDS[m]} {m}" for m in methods)
        return [
            dict(name="nemc.method", start=METHOD_IDS[defaults.method], integer=True,
                 minimum=0, maximum=max(METHOD_IDS[m] for m in methods),
                 description=f"nemc's integrator inside fmi*DoStep: {listed}"),
            dict(name="nemc.rtol", start=defaults.rtol, minimum=MIN_RTOL, maximum=1.0,
                 description="the integrator's relative tolerance"),
            dict(name="nemc.atol", start=defaults.atol, minimum=0.0, maximum=1e300,
                 description="the integrator's absolute tolerance"),
        ]
    if has_loops:
        return [dict(name="nemc.projection_tolerance", start=defaults.projection_tolerance,
                     minimum=1e-300, maximum=1e300,
                     description="the largest constraint residual |Phi|, |dPhi/dt| a state "
                     "keeps: past it an event projects the state onto the constraints")]
    return []


def layout(meta: Mapping[str, Any], defaults: FmuDefaults, kind: str) -> Layout:
    """The FMU's variables for a model (its model.json META) and the export's DEFAULTS."""
    states = list(meta["state_names"])
    if len(defaults.initial_state) != len(states):
        raise BuildError("the FMU's initial state has the wrong length")
    parameters = list(meta["parameter_names"])
    inputs = list(meta["inputs"]["names"])
    outputs = list(meta["output_names"])
    events = [event["name"] for event in meta.get("events", ())]
    defaults_p = list(meta["parameter_defaults"])
    has_taylor = "taylor" in meta["generated"]
    rows: list[tuple[str, dict]] = [("time", dict(
        name="time", unit=meta.get("unit_labels", {}).get("t", ""),
        description="the independent variable"))]
    rows += [("state", dict(name=s, start=y0, unit=state_unit(meta, s)))
             for s, y0 in zip(states, defaults.initial_state)]
    rows += [("derivative", dict(name=derivative_name(s), unit=derivative_unit(meta, s)))
             for s in states]
    rows += [("parameter", dict(name=n, start=v)) for n, v in zip(parameters, defaults_p)]
    rows += [("input", dict(name=n, start=v, description="held over a step (its law's value)"))
             for n, v in zip(inputs, defaults.input_start)]
    rows += [("output", dict(name=n, unit=state_unit(meta, n))) for n in outputs]
    rows += [("indicator", dict(name=indicator_name(e), description=f"event {e}'s function: "
                                "it fires where this crosses zero")) for e in events]
    rows += [("setting", row) for row in setting_variables(
        kind, defaults, bool(meta.get("constraint_equations")), has_taylor)]
    variables, first, counts = [], {}, dict.fromkeys(ROLES, 0)
    for vr, (role, row) in enumerate(rows):
        first.setdefault(role, vr)
        variables.append(Variable(vr=vr, role=role, index=counts[role], **row))
        counts[role] += 1
    for role in ROLES:  # an empty range starts where the next one does
        first.setdefault(role, len(variables) if role == ROLES[-1] else -1)
    for position in range(len(ROLES) - 1, -1, -1):
        if first[ROLES[position]] < 0:
            first[ROLES[position]] = first[ROLES[position + 1]]
    check_unique(variables)
    return Layout(tuple(variables), first)


def check_unique(variables: Sequence[Variable]) -> None:
    """FMI requires distinct names: a YAML name equal to one the FMU makes is refused."""
    seen: set[str] = set()
    for variable in variables:
        if variable.name in seen:
            raise BuildError(f"the FMU would have two variables named {variable.name!r}: "
                             "rename it in the YAML")
        seen.add(variable.name)
