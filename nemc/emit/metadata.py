"""model.json's metadata: what the runtime knows of a model besides its compiled functions
(names, defaults, the parts built, the scene, the events).
"""

from __future__ import annotations

from ..derive.equations import Equations
from ..front import mechanism as m
from ..vocabulary import NEMC_VERSION as __version__
from .jacobian_c import has_jacobian


def metadata(eqs: Equations, prefix: str) -> dict:
    mech, sim = eqs.mechanism, eqs.mechanism.simulation
    starts = eqs.loops.starts if eqs.loops is not None else ()
    # the parameters, then the inputs' laws, then the offsets of constraints "as at the start",
    # then the friction items' forces and modes
    settable = len(eqs.parameters) - len(eqs.inputs.coefficients) - len(starts) - 2 * (
        eqs.friction.count if eqs.friction is not None else 0)
    return {
        "name": mech.name,
        "description": mech.description,
        "source": mech.source,
        "source_hash": mech.source_hash,
        "nemc_version": __version__,
        "c_prefix": prefix,
        "coordinate_names": list(mech.coordinates),
        "coordinate_kinds": coordinate_kinds(mech),
        "state_names": list(mech.state_names),
        "parameter_names": [s.name for s in eqs.parameters[:settable]],
        "parameter_defaults": list(eqs.parameter_defaults[:settable]),
        "inputs": {"names": list(eqs.inputs.names), "offset": settable,
                   "stride": eqs.inputs.stride,
                   "defaults": list(eqs.parameter_defaults[
                       settable: settable + len(eqs.inputs.coefficients)])},
        "derived_parameters": {name: str(expr) for name, expr in eqs.derived_parameters},
        "check_names": [key for key, _ in eqs.checks],
        "check_strict": list(eqs.check_strict),
        "output_names": [name for name, _ in eqs.outputs],
        "generated": generated_functions(eqs),
        "dynamics_program": eqs.dynamics_form,
        "drive_names": [joint.name for joint in mech.driven],
        "load_outputs": load_outputs(mech),
        "friction": list(eqs.friction.names) if eqs.friction is not None else [],
        "friction_laws": list(eqs.friction.laws) if eqs.friction is not None else [],
        "friction_rates": [2 * i + 1 for i in eqs.friction.rates]
        if eqs.friction is not None else [],  # the state entries of their joints' rates
        "constraint_equations": list(eqs.loops.owners) if eqs.loops is not None else [],
        "constraint_starts": [[k, eqs.parameters.index(offset)] for k, offset in starts],
        "constraint_on_velocities": list(eqs.loops.on_velocities) if eqs.loops is not None
        else [],
        "initial_given": [name for name in mech.state_names if name in sim.initial],
        "scene": {
            "t_span": list(sim.t_span) if sim.t_span else None,
            "t_eval": list(sim.t_eval) if sim.t_eval is not None else None,
            "t_eval_step": sim.t_eval_step,
            "method": sim.method,
            "rtol": sim.rtol,
            "atol": sim.atol,
            "max_step": sim.max_step,
            "tstops": list(sim.tstops),
            "max_steps": sim.max_steps,
        },
        "events": event_metadata(eqs),
    }


def generated_functions(eqs: Equations) -> list[str]:
    """The parts a model's build has: outputs, jacobian and mass_matrix only when needed (the
    header declares every function; those of a part not built return NEMC_NOT_BUILT)."""
    jacobian = ["jacobian"] if has_jacobian(eqs) else []
    mass_matrix = ["mass_matrix"] if eqs.inverse_mass is not None else []
    outputs = ["outputs"] if eqs.outputs else []
    linear = ["linearization"] if eqs.linearization is not None else []
    sensitivities = ["sensitivities"] if eqs.sensitivities is not None else []
    return (["rhs", "rhs_many", "checks", "initial_state"] + outputs + jacobian + mass_matrix
            + linear + sensitivities)


def load_outputs(mech: m.Mechanism) -> list[str]:
    """The outputs the named loads report (figures draw them in their own panels)."""
    kinds = {q: kind for joint in mech.joints
             for q, kind in zip(joint.coordinates, joint.coordinate_kinds)}
    joint_kind = {joint.name: kinds.get(joint.coordinates[0], "angle") if joint.coordinates
                  else "angle" for joint in mech.joints}
    return [name + suffix for name, index in mech.load_names
            for suffix, _ in mech.loads[index].reported_kinds(joint_kind.__getitem__)]


def coordinate_kinds(mech: m.Mechanism) -> list[str]:
    """"angle" or "length" for each coordinate (plots show angles in degrees)."""
    return [kind for joint in mech.joints for kind in joint.coordinate_kinds]


def event_metadata(eqs: Equations) -> list[dict]:
    """Each event's name, direction, action and the states its impact law sets (model.json)."""
    return [{"name": event.name, "direction": event.direction, "action": event.action,
             "sets": [name for name, _ in event.law]} for event in eqs.events]
