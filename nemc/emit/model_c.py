"""<name>.c's model functions (templates/model.c.tmpl): the right-hand side, checks, initial
state, outputs, Jacobian and M^-1, and the events' functions and impact laws.
"""

from __future__ import annotations

import sympy

from ..derive.equations import Equations
from ..derive.mass_form import rhs_solve_text
from ..front import mechanism as m
from ..vocabulary import NEMC_VERSION as __version__
from .angles_c import angles_kernel
from .c_text import SymbolTablePrinter
from .dynamics_c import DYNAMICS_FORMS, dynamics_section
from .jacobian_c import jacobian_programs, jacobian_section, shares_primal
from .linearization_c import linearization_section
from .optimize import Block
from .parts import Units
from .printing import body, comment_text, indexed, needed, symbol_table, template
from .resources import read_template
from .sensitivities_c import sensitivities_section


def c_source(eqs: Equations, block: Block, prefix: str, chunk_steps: int,
             units: Units | None = None) -> str:
    """<name>.c's model functions (templates/model.c.tmpl) and the events' (events_section)."""
    mech, printer = eqs.mechanism, SymbolTablePrinter(symbol_table(eqs, block))
    shared = (jacobian_programs(eqs, printer, block.programs["dynamics"],
                                block.programs["jacobian"], chunk_steps, units)
              if shares_primal(eqs, block, chunk_steps) else None)
    dynamics = dynamics_section(eqs, block, printer, prefix, chunk_steps, units,
                                shared and shared[0])
    jacobian = jacobian_section(eqs, block, printer, prefix, chunk_steps, units, shared)
    jacobian += linearization_section(eqs, block, printer, prefix, chunk_steps, units)
    jacobian += sensitivities_section(eqs, block, printer, prefix, chunk_steps, units)
    return template("model.c.tmpl").substitute(
        name=mech.name,
        version=__version__,
        source=comment_text(mech.source),
        source_hash=mech.source_hash,
        description=comment_text(mech.description),
        state_names=comment_text(", ".join(mech.state_names)),
        parameter_names=comment_text(", ".join(s.name for s in eqs.parameters)),
        dynamics_description=DYNAMICS_FORMS[eqs.dynamics_form].account.replace(
            "{solve}", rhs_solve_text(eqs.n)),
        prefix=prefix,
        dynamics_section=angles_kernel(dynamics + jacobian) + dynamics,
        check_names=comment_text(", ".join(key for key, _ in eqs.checks)),
        checks=body(printer, block, indexed("out", block.groups["checks"])),
        initial=body(printer, block, indexed("y0", block.groups["initial"])),
        outputs_section=outputs_section(eqs, block, printer, prefix)
        + template("input_values.c.tmpl").substitute(
            prefix=prefix, input_names=comment_text(", ".join(eqs.inputs.names)),
            values=body(printer, block, indexed("u", block.groups["inputs"]))),
        jacobian_section=jacobian,
        loops_absent="" if eqs.loops is not None else
        template("loops_absent.c.tmpl").substitute(prefix=prefix),
    ) + events_section(eqs, block, printer, prefix) + (
        "" if eqs.friction is not None else
        template("friction_absent.c.tmpl").substitute(prefix=prefix))


def outputs_section(eqs: Equations, block: Block, printer: SymbolTablePrinter, prefix: str) -> str:
    """The scene's outputs, or the function saying the scene asks for none. A model with drives
    or loops computes them at its state brought onto the constraints, with its accelerations,
    multipliers and drives."""
    if not eqs.outputs:
        return template("outputs_absent.c.tmpl").substitute(prefix=prefix)
    exprs = block.groups["outputs"]
    given_p = "p"
    if eqs.friction is not None:  # the accelerations and p with the friction forces solved
        state, before, given_p = "given", read_template("friction_outputs.c.tmpl"), "p_given"
    elif eqs.layout is not None and eqs.layout.augmented:
        state, before = "given", read_template("consistent_dynamics.c.tmpl")
    else:
        uses_qdd = any(s in eqs.accelerations for e in exprs for s in _all_symbols(block, e))
        state, before = "y", read_template("accelerations.c.tmpl") if uses_qdd else ""
    return template("outputs.c.tmpl").substitute(
        prefix=prefix, state=state, p=given_p,
        output_names=comment_text(", ".join(name for name, _ in eqs.outputs)),
        accelerations=before,
        outputs=body(printer, block, indexed("out", exprs)),
    )


def _all_symbols(block: Block, expr: sympy.Expr) -> set[sympy.Symbol]:
    found = set(sympy.sympify(expr).free_symbols)
    for _, temp in needed(block, (expr,)):
        found |= temp.free_symbols
    return found


# ---- events (format v2, simulation.events) ----------------------------------------------------


EVENT_DIRECTIONS = {"falling": "NEMC_FALLING", "both": "NEMC_BOTH", "rising": "NEMC_RISING"}
EVENT_ACTIONS = {"record": "NEMC_RECORD", "stop": "NEMC_STOP", "impact": "NEMC_IMPACT",
                 "switch": "NEMC_SWITCH"}


def impact_case(eqs: Equations, block: Block, printer: SymbolTablePrinter, k: int) -> str:
    """Event k's impact law as a case of the impact function: every new value computed from the
    state before the event, checked, then written through the layout macros."""
    event = eqs.events[k]
    writes = "\n".join(
        f"        {printer.doprint(m.symbol(name))} = value[{i}]; /* {comment_text(name)} */"
        for i, (name, _) in enumerate(event.law))
    values = body(printer, block, indexed("value", block.groups[f"impact.{k}"]))
    given = "\n".join(f"        given[{eqs.state.index(m.symbol(name))}] = 1;"
                      for name, _ in event.law)
    return template("impact_case.c.tmpl").substitute(
        k=k, name=comment_text(event.name), count=len(event.law), given=given,
        values="\n".join("    " + line for line in values.splitlines()), writes=writes)


def events_section(eqs: Equations, block: Block, printer: SymbolTablePrinter, prefix: str) -> str:
    """The events' functions and impact laws (or the functions saying the scene has none), and
    the table of directions and actions the integrators read."""
    if not eqs.events:
        return template("events_absent.c.tmpl").substitute(prefix=prefix)
    return template("events.c.tmpl").substitute(
        prefix=prefix,
        event_names=comment_text(", ".join(event.name for event in eqs.events)),
        directions=", ".join(EVENT_DIRECTIONS[event.direction] for event in eqs.events),
        actions=", ".join(EVENT_ACTIONS[event.action] for event in eqs.events),
        values=body(printer, block, indexed("g", block.groups["events"])),
        cases="\n".join(impact_case(eqs, block, printer, k)
                        for k, event in enumerate(eqs.events) if event.law),
        **friction_events_c(eqs),
    )


def friction_events_c(eqs: Equations) -> dict[str, str]:
    """The friction items' switching events (the last N_FRICTION): their values and laws are
    templates/friction.c.tmpl's."""
    count = eqs.friction.count if eqs.friction is not None else 0
    first = len(eqs.events) - count
    if not count:
        return {"friction_values": "", "friction_cases": ""}
    values = (f"    {{\n        int status = friction_event_values(t, y, p, g + {first});\n"
              "        if (status)\n            return status;\n    }")
    cases = "\n".join(f"    case {first + k}: /* {comment_text(name)}.stick_slip */\n"
                       f"        return friction_switch({k}, t, y, p);"
                       for k, name in enumerate(eqs.friction.names))
    return {"friction_values": values, "friction_cases": cases}
