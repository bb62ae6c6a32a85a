"""The Jacobian's C (exact: the primal run once and its tangent once per column; by differences
for a closed loop's projected right-hand side) and M^-1's, each an optional part of a build.
"""

from __future__ import annotations

from ..derive.equations import Equations
from ..derive.program import Program
from .angles_c import angles_c
from .c_text import SymbolTablePrinter
from .optimize import Block
from .parts import Units, in_parts, print_program
from .printing import STATE_INPUTS, Caller, Printed, program_body, symbols_used, template

INVERSE_MASS = Caller("inverse_mass_times", "M^-1 force",
                      (("double", "t"), ("const double *", "y"), ("const double *", "p"),
                       ("const double *", "force")), ("QDD", "qdd"), "v")
PRIMAL = Caller("jacobian_primal", "The accelerations and what their derivative reads",
                STATE_INPUTS, ("QDD", "qdd"), "v")
TANGENT = Caller("jacobian_tangent", "The derivative of the accelerations along seed",
                 (*STATE_INPUTS, ("const double *", "seed"), ("const double *", "v")),
                 ("DQDD", "dqdd"), "dv", indent=" " * 8)


def jacobian_programs(
    eqs: Equations, printer: SymbolTablePrinter, primal: Program, tangent: Program,
    chunk_steps: int, units: Units | None = None,
    callers: tuple[Caller, Caller] = (PRIMAL, TANGENT),
) -> tuple[Printed, Printed]:
    """The primal (run once) and its tangent (once per column): in parts when either is long,
    the primal then also passing on every value the tangent reads. The tangent's sums are
    printed in sympy's canonical order of their terms (order "none"), not sorted for print,
    more than half of printing's time; the primal, as the RHS, keeps the sorted order and its
    bits (docs/decisions.md, "Printing order")."""
    primal_caller, tangent_caller = callers
    angles = angles_c(eqs, printer, primal, tangent)
    assert angles.reader is not None
    tangent = angles.reader
    if max(primal.size, tangent.size) <= chunk_steps:
        return (Printed("", angles.prologue + program_body(angles.printer, angles.program,
                                                           primal_caller.writes)),
                Printed("", program_body(angles.printer.with_names({}, order="none"), tangent,
                                         tangent_caller.writes, tangent_caller.indent)))
    primal_code, passed = in_parts(angles.printer, angles.program, angles.caller(primal_caller),
                                   chunk_steps, symbols_used(tangent), units)
    tangent_printer = angles.printer.with_names(passed, order="none")
    return (Printed(primal_code.functions, angles.prologue + primal_code.body),
            in_parts(tangent_printer, tangent, angles.caller(tangent_caller), chunk_steps,
                     units=units)[0])


def shares_primal(eqs: Equations, block: Block, chunk_steps: int) -> bool:
    """Whether a tree's accelerations run the part functions of its Jacobian's primal: when
    the Jacobian is exact and the accelerations' program long enough to be printed in parts,
    the same program is compiled once rather than twice (a sixth of a 1000-body chain's
    compiler time). The primal's parts also keep what the derivative reads, a few stores
    more per call, with the same operations and so the same numbers."""
    programs = block.programs
    return (eqs.jacobian is not None and "primal" not in programs
            and (eqs.layout is None or not eqs.layout.augmented)
            and max(programs["dynamics"].size, programs["jacobian"].size) > chunk_steps)


def jacobian_section(
    eqs: Equations, block: Block, printer: SymbolTablePrinter, prefix: str, chunk_steps: int,
    units: Units | None = None, printed: tuple[Printed, Printed] | None = None,
) -> str:
    """The Jacobian (exact; by differences for a closed loop's projected right-hand side) and
    M^-1, each an optional part, or the function saying this build has none. PRINTED: the
    primal and tangent, printed already, the primal's functions going with the accelerations
    (shares_primal)."""
    mass_matrix = mass_matrix_section(block, printer, prefix, chunk_steps, units)
    if not has_jacobian(eqs):
        return template("jacobian_absent.c.tmpl").substitute(prefix=prefix) + mass_matrix
    if eqs.jacobian is None:
        return template("jacobian_differences.c.tmpl").substitute(prefix=prefix) + mass_matrix
    programs = block.programs
    if printed is None:
        primal, tangent = jacobian_programs(
            eqs, printer, programs.get("primal", programs["dynamics"]), programs["jacobian"],
            chunk_steps, units)
        functions = primal.functions + tangent.functions
    else:
        (primal, tangent), functions = printed, printed[1].functions
    return template("jacobian.c.tmpl").substitute(
        prefix=prefix,
        jacobian_parts=functions,
        primal=primal.body,
        tangent=tangent.body,
    ) + mass_matrix


def mass_matrix_section(block: Block, printer: SymbolTablePrinter, prefix: str,
                        chunk_steps: int, units: Units | None = None) -> str:
    """M^-1 column by column (Model.mass_matrix), or the function saying this build has none."""
    if "inverse_mass" not in block.programs:
        return template("mass_matrix_absent.c.tmpl").substitute(prefix=prefix)
    inverse_mass = print_program(printer, block.programs["inverse_mass"], INVERSE_MASS,
                                 chunk_steps, units)
    return template("inverse_mass.c.tmpl").substitute(
        prefix=prefix, inverse_mass_parts=inverse_mass.functions, inverse_mass=inverse_mass.body)


def has_jacobian(eqs: Equations) -> bool:
    """Whether the build has the Jacobian (exact, or differences for loops)."""
    return eqs.jacobian is not None or eqs.jacobian_by_differences


def jacobian_function(eqs: Equations, prefix: str) -> str:
    """The C of the Jacobian function a driver is given: the build's, or NULL without it."""
    return f"{prefix}jacobian" if has_jacobian(eqs) else "NULL"
