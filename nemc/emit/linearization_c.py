"""The linearization's C, an optional part of a build (nemc/derive/linearization.py): a tree's
A, B, C and D at a state in one call (templates/linearization.c.tmpl), or a closed loop's
pieces (templates/loop_tangents.c.tmpl: the accelerations' program's every result and its
derivative per column) and its outputs' derivative along a direction
(templates/outputs_tangent.c.tmpl), from which the runtime assembles the reduced A, B, C, D.
Exact: the programs once, then their forward-mode derivatives once per column.
"""

from __future__ import annotations

import dataclasses

from ..derive.equations import Equations
from .c_text import SymbolTablePrinter
from .jacobian_c import jacobian_programs
from .optimize import Block
from .parts import Units
from .printing import STATE_INPUTS, Caller, program_body, template

SEEDS = (("const double *", "seed"), ("const double *", "seed_u"))
PRIMAL = Caller("linearization_primal", "The accelerations and drives, and what their "
                "derivative reads", STATE_INPUTS, ("QDD", "qdd"), "v")
TANGENT = Caller("linearization_tangent", "The derivative of the accelerations and drives "
                 "along seed and seed_u", (*STATE_INPUTS, *SEEDS, ("const double *", "v")),
                 ("DQDD", "dqdd"), "dv", indent=" " * 8)
LOOP_PRIMAL = dataclasses.replace(PRIMAL, function="loop_tangents_primal",
                                  what="The accelerations' program's results, and what their "
                                  "derivative reads", results=("ACC", "acc"))
LOOP_TANGENT = dataclasses.replace(TANGENT, function="loop_tangents_tangent",
                                   what="Their derivative along seed and seed_u",
                                   results=("DACC", "dacc_col"))


def linearization_section(eqs: Equations, block: Block, printer: SymbolTablePrinter,
                          prefix: str, chunk_steps: int, units: Units | None = None) -> str:
    """A tree's linearization, or a closed loop's pieces and outputs' derivative, and the
    functions saying what this build does not have."""
    absent = {name: template(f"{name}_absent.c.tmpl").substitute(prefix=prefix)
              for name in ("linearization", "loop_tangents", "outputs_tangent")}
    if eqs.linearization is None:
        return "".join(absent.values())
    programs = block.programs
    loop = eqs.loops is not None
    primal, tangent = jacobian_programs(
        eqs, printer, programs["dynamics"], programs["linearization"], chunk_steps, units,
        (LOOP_PRIMAL, LOOP_TANGENT) if loop else (PRIMAL, TANGENT))
    outputs, outputs_tangent = "", ""
    if "linearization_outputs" in programs:
        outputs = program_body(printer, programs["linearization_outputs"], ())
        outputs_tangent = program_body(printer.with_names({}, order="none"),
                                       programs["linearization_outputs_tangent"], "DOUT",
                                       "    " if loop else " " * 12)
    if not loop:
        return template("linearization.c.tmpl").substitute(
            prefix=prefix, linearization_parts=primal.functions + tangent.functions,
            primal=primal.body, tangent=tangent.body, outputs=outputs,
            outputs_tangent=outputs_tangent) + absent["loop_tangents"] + absent[
            "outputs_tangent"]
    return absent["linearization"] + template("loop_tangents.c.tmpl").substitute(
        prefix=prefix, linearization_parts=primal.functions + tangent.functions,
        primal=primal.body, tangent=tangent.body) + template(
        "outputs_tangent.c.tmpl").substitute(prefix=prefix, outputs=outputs,
                                             outputs_tangent=outputs_tangent)
