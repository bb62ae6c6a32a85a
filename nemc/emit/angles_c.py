"""The C of a program's sines and cosines computed together (angles.py finds them): the
prologue computing them before the program's first step, in one call of the branch-free kernel
(templates/angles.c.tmpl), and the kernel, in a C file that calls it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..derive.equations import Equations
from ..derive.program import Program, prune
from ..front import mechanism as m
from .angles import angle_calls
from .c_text import SymbolTablePrinter
from .math_kernels import sincos_kernel
from .printing import Caller, Parameter, symbols_used, template


@dataclass(frozen=True)
class AnglesC:
    """A program whose sines and cosines of its angles are computed first, together
    (angles.py): the program reading them, its printer, the lines that compute them."""

    program: Program
    printer: SymbolTablePrinter
    prologue: str  # "" when the program has no such angle
    reader: Program | None = None  # the program reading its steps, reading its angles too

    def caller(self, caller: Caller) -> Caller:
        """CALLER whose part functions also read the arrays sine and cosine."""
        if not self.prologue:
            return caller
        return dataclasses.replace(caller, inputs=(*caller.inputs, *ANGLE_INPUTS))


ANGLE_INPUTS: tuple[Parameter, ...] = (("const double *", "sine"), ("const double *", "cosine"))
ANGLES_CALL = "angles_sincos("  # the prologue's call: a C file that has it gets the kernel


def angles_c(eqs: Equations, printer: SymbolTablePrinter, program: Program,
             reader: Program | None = None) -> AnglesC:
    """PROGRAM with its angles' sines and cosines as sine[k] and cosine[k], computed before its
    first step by one call (templates/angles.c.tmpl), and READER, a program that reads its
    steps (the Jacobian's tangent reads its primal's), reading them too. The steps that only
    computed an angle go, unless the reader reads them."""
    inputs = frozenset((*eqs.coordinates, *eqs.speeds, *eqs.parameters, m.TIME))
    calls = angle_calls(program, inputs)
    if not calls.angles:
        return AnglesC(program, printer, "", reader)
    count = len(calls.angles)
    ahead = printer.with_names({name: f"angle_{printer.names[name]}" for name, _ in calls.ahead})
    angles = ", ".join(ahead.doprint(angle) for angle in calls.angles)
    prologue = "".join(
        ["    /* the sines and cosines of the angles, together (angles_sincos) */\n",
         *(f"    const double {ahead.doprint(name)} = {ahead.doprint(expr)};\n"
           for name, expr in calls.ahead),
         f"    const double angle[{count}] = {{{angles}}};\n"
         f"    double sine[{count}], cosine[{count}];\n"
         f"    {ANGLES_CALL}{count}, angle, sine, cosine);\n"])
    printer = printer.with_names({**{s: f"sine[{k}]" for k, s in enumerate(calls.sines)},
                                  **{c: f"cosine[{k}]" for k, c in enumerate(calls.cosines)}})
    reader = calls.names_in(reader) if reader is not None else None
    read = symbols_used(reader) if reader is not None else set()
    kept = prune(list(calls.program.steps), (*calls.program.results, *read))
    return AnglesC(Program(kept, calls.program.results), printer, prologue, reader)


def angles_kernel(c_text: str) -> str:
    """The angles' kernel (templates/angles.c.tmpl) for a C file that calls it, else ""."""
    if ANGLES_CALL not in c_text:
        return ""
    return template("angles.c.tmpl").substitute(angles_math=sincos_kernel(
        "angles_math_", "angles_double2", "angles_bits2", "two-element vectors (the RHS's angles)"))
