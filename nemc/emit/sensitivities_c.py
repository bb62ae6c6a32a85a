"""The variational equations' C, an optional part of a build (nemc/derive/sensitivities.py):
the sensitivity system's right-hand side (templates/sensitivities.c.tmpl), the initial state's
derivatives by the parameters, and the outputs' sensitivities at a point of a run
(templates/output_sensitivities.c.tmpl). Exact: the accelerations' program once, then its
forward-mode derivative once per sensitivity column.
"""

from __future__ import annotations

import dataclasses

from ..derive.equations import Equations
from .c_text import SymbolTablePrinter
from .jacobian_c import jacobian_programs
from .optimize import Block
from .parts import Units
from .printing import STATE_INPUTS, Caller, body, program_body, template

SEEDS = (("const double *", "seed"), ("const double *", "seed_p"))
PRIMAL = Caller("sensitivity_primal", "The accelerations and drives, and what their "
                "derivative reads", STATE_INPUTS, ("QDD", "qdd"), "v")
TANGENT = Caller("sensitivity_tangent", "The derivative of the accelerations and drives "
                 "along seed and seed_p", (*STATE_INPUTS, *SEEDS, ("const double *", "v")),
                 ("DQDD", "dqdd"), "dv", indent=" " * 8)
OUTPUT_PRIMAL = dataclasses.replace(PRIMAL, function="output_sensitivity_primal")
OUTPUT_TANGENT = dataclasses.replace(TANGENT, function="output_sensitivity_tangent")


def sensitivities_section(eqs: Equations, block: Block, printer: SymbolTablePrinter,
                          prefix: str, chunk_steps: int, units: Units | None = None) -> str:
    """The sensitivity system's functions, or the functions saying this build has none."""
    absent = template("sensitivities_absent.c.tmpl").substitute(prefix=prefix)
    no_outputs = template("output_sensitivities_absent.c.tmpl").substitute(prefix=prefix)
    if eqs.sensitivities is None:
        return absent + no_outputs
    programs = block.programs
    primal, tangent = jacobian_programs(eqs, printer, programs["dynamics"],
                                        programs["sensitivities"], chunk_steps, units,
                                        (PRIMAL, TANGENT))
    rows = [(f"out[{i * len(eqs.parameters) + k}]", expr) for i in range(len(eqs.state))
            for k, expr in enumerate(block.groups["sensitivity_initial"][
                i * len(eqs.parameters): (i + 1) * len(eqs.parameters)])]
    system = template("sensitivities.c.tmpl").substitute(
        prefix=prefix, sensitivity_parts=primal.functions + tangent.functions,
        primal=primal.body, tangent=tangent.body, initial=body(printer, block, rows))
    return system + output_sensitivities(eqs, block, printer, prefix, chunk_steps, units)


def output_sensitivities(eqs: Equations, block: Block, printer: SymbolTablePrinter,
                         prefix: str, chunk_steps: int, units: Units | None = None) -> str:
    """The outputs' sensitivities at a point, or the function saying the scene has none."""
    programs = block.programs
    if "sensitivity_outputs_tangent" not in programs:
        return template("output_sensitivities_absent.c.tmpl").substitute(prefix=prefix)
    primal, tangent = jacobian_programs(eqs, printer, programs["dynamics"],
                                        programs["sensitivities"], chunk_steps, units,
                                        (OUTPUT_PRIMAL, OUTPUT_TANGENT))
    outputs = program_body(printer, programs["sensitivity_outputs"], ())
    outputs_tangent = program_body(printer.with_names({}, order="none"),
                                   programs["sensitivity_outputs_tangent"], "DOUT", " " * 8)
    return template("output_sensitivities.c.tmpl").substitute(
        prefix=prefix, output_parts=primal.functions + tangent.functions, primal=primal.body,
        tangent=tangent.body, outputs=outputs, outputs_tangent=outputs_tangent)
