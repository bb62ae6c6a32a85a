"""The variational equations' C, an optional part of a build (nemc/derive/sensitivities.py):
the sensitivity system's right-hand side (templates/sensitivities.c.tmpl), the initial state's
derivatives by the parameters, and the outputs' sensitivities at a point of a run
(templates/output_sensitivities.c.tmpl). Exact: the accelerations' program once, then (a
short program's) the Jacobian [J_y | J_p] of the accelerations by reverse accumulation of its
linear tangent, and each sensitivity column a small dense product; a long program's tangent
runs forward once per column. At the scene's events, the columns' jump and the event times'
sensitivities (templates/event_sensitivities.c.tmpl), from each event's partial derivatives.
A closed loop's system is templates/loop_sensitivities.c.tmpl (the same sensitivity_rhs
signature: its pieces' program once, their tangent's coefficients once (hoisted_tangent: its
many pieces would cost a reverse sweep each), then per column the tangent's forward sweep and
the index-1 equations' derivative solved), with loop_sensitivity_pieces for the runtime's
start columns.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import sympy

from ..derive.equations import Equations
from ..derive.program import Guard, Program
from ..derive.tangent import Linear, NotLinear, jacobian_row, linear_form
from .angles_c import angles_c
from .c_text import SymbolTablePrinter
from .jacobian_c import jacobian_programs
from .optimize import Block
from .parts import Units
from .printing import (
    STATE_INPUTS,
    Caller,
    Printed,
    body,
    comment_text,
    program_body,
    template,
)

SEEDS = (("const double *", "seed"), ("const double *", "seed_p"))
PRIMAL = Caller("sensitivity_primal", "The accelerations and drives, and what their "
                "derivative reads", STATE_INPUTS, ("QDD", "qdd"), "v")
TANGENT = Caller("sensitivity_tangent", "The derivative of the accelerations and drives "
                 "along seed and seed_p", (*STATE_INPUTS, *SEEDS, ("const double *", "v")),
                 ("DQDD", "dqdd"), "dv", indent=" " * 8)
LOOP_PRIMAL = dataclasses.replace(PRIMAL, function="loop_sensitivity_primal",
                                  what="A closed loop's pieces (the accelerations' program's "
                                  "results), and what their derivative reads",
                                  results=("ACC", "acc"))
LOOP_TANGENT = dataclasses.replace(TANGENT, function="loop_sensitivity_tangent",
                                   what="The pieces' derivative along seed and seed_p",
                                   results=("DACC", "dacc_col"))
OUTPUT_PRIMAL = dataclasses.replace(PRIMAL, function="output_sensitivity_primal")
OUTPUT_TANGENT = dataclasses.replace(TANGENT, function="output_sensitivity_tangent")


def sensitivities_section(eqs: Equations, block: Block, printer: SymbolTablePrinter,
                          prefix: str, chunk_steps: int, units: Units | None = None) -> str:
    """The sensitivity system's functions, or the functions saying this build has none."""
    absent = template("sensitivities_absent.c.tmpl").substitute(prefix=prefix)
    no_outputs = template("output_sensitivities_absent.c.tmpl").substitute(prefix=prefix)
    no_loop = template("loop_sensitivities_absent.c.tmpl").substitute(prefix=prefix)
    if eqs.sensitivities is None:
        return absent + no_outputs + event_sensitivities(eqs, block, printer, prefix) + no_loop
    if eqs.loops is not None:
        return loop_sensitivities(eqs, block, printer, prefix, chunk_steps, units)
    primal, coefficients, tangent = system_programs(eqs, block, printer, chunk_steps, units)
    rows = [(f"out[{i * len(eqs.parameters) + k}]", expr) for i in range(len(eqs.state))
            for k, expr in enumerate(block.groups["sensitivity_initial"][
                i * len(eqs.parameters): (i + 1) * len(eqs.parameters)])]
    system = no_loop + template("sensitivities.c.tmpl").substitute(
        prefix=prefix, sensitivity_parts=primal.functions + tangent.functions,
        primal=primal.body, coefficients=coefficients, tangent=tangent.body,
        initial=body(printer, block, rows))
    return (system + output_sensitivities(eqs, block, printer, prefix, chunk_steps, units)
            + event_sensitivities(eqs, block, printer, prefix))


def loop_sensitivities(eqs: Equations, block: Block, printer: SymbolTablePrinter, prefix: str,
                       chunk_steps: int, units: Units | None) -> str:
    """A closed loop's sensitivity system (templates/loop_sensitivities.c.tmpl): its pieces'
    program and their tangent along seed and seed_p, solved per column; the initial state's
    derivatives by the parameters; its outputs' sensitivities
    (templates/loop_output_sensitivities.c.tmpl). Its scene has no impacts (derive's
    loop_refusal)."""
    programs = block.programs
    primal, tangent = jacobian_programs(eqs, printer, programs["dynamics"],
                                        programs["sensitivities"], chunk_steps, units,
                                        (LOOP_PRIMAL, LOOP_TANGENT))
    dense = dense_programs(eqs, block, printer, chunk_steps, (LOOP_PRIMAL, LOOP_TANGENT),
                           hoisted_tangent)
    rhs_primal, coefficients, rhs_tangent = dense or (primal, "", tangent)
    system = template("loop_sensitivities.c.tmpl").substitute(
        prefix=prefix, loop_sensitivity_parts=primal.functions + tangent.functions,
        primal=primal.body, tangent=tangent.body, rhs_primal=rhs_primal.body,
        coefficients=coefficients, rhs_tangent=rhs_tangent.body,
        initial=body(printer, block, initial_rows(eqs, block)))
    if "sensitivity_outputs_tangent" not in programs:
        outputs = template("output_sensitivities_absent.c.tmpl").substitute(prefix=prefix)
    else:
        outputs = template("loop_output_sensitivities.c.tmpl").substitute(
            prefix=prefix, primal=primal.body, tangent=tangent.body,
            outputs=program_body(printer, programs["sensitivity_outputs"], ()),
            outputs_tangent=program_body(printer.with_names({}, order="none"),
                                         programs["sensitivity_outputs_tangent"], "DOUT",
                                         " " * 8))
    return system + outputs + event_sensitivities(eqs, block, printer, prefix)


def initial_rows(eqs: Equations, block: Block) -> list[tuple[str, sympy.Expr]]:
    """initial_state_tangent's assignments: out[i * N_PARAM + k] = d y0[i] / d p[k]."""
    return [(f"out[{i * len(eqs.parameters) + k}]", expr) for i in range(len(eqs.state))
            for k, expr in enumerate(block.groups["sensitivity_initial"][
                i * len(eqs.parameters): (i + 1) * len(eqs.parameters)])]


def event_sensitivities(eqs: Equations, block: Block, printer: SymbolTablePrinter,
                        prefix: str) -> str:
    """The columns' jump at an impact and the event times' sensitivities, or the functions
    saying the build has none."""
    if eqs.sensitivities is None or not eqs.sensitivities.events:
        return template("event_sensitivities_absent.c.tmpl").substitute(prefix=prefix)
    cases = "\n".join(event_partials_case(eqs, block, printer, k)
                      for k in range(len(eqs.sensitivities.events)))
    return template("event_sensitivities.c.tmpl").substitute(prefix=prefix, cases=cases)


def event_partials_case(eqs: Equations, block: Block, printer: SymbolTablePrinter, k: int
                        ) -> str:
    """Event k's partial derivatives as a case of event_partials: the arrays zeroed, then
    their entries that are not 0."""
    assert eqs.sensitivities is not None
    partials = eqs.sensitivities.events[k]
    n, n_param = len(eqs.state), len(eqs.parameters)
    names = [f"g_y[{i}]" for i in range(n)] + [f"g_p[{m}]" for m in range(n_param)] + ["*g_t"]
    zeroed = ["g_y", "g_p"]
    if partials.law:
        names += [f"G_y[{i}]" for i in range(n * n)] + [f"G_p[{i}]" for i in range(n * n_param)]
        names += [f"G_t[{i}]" for i in range(n)]
        zeroed += ["G_y", "G_p", "G_t"]
    exprs = block.groups[f"event_partials.{k}"]
    rows = [(name, expr) for name, expr in zip(names, exprs)
            if not (expr == 0 and name != "*g_t")]
    lines = [f"        memset({array}, 0, sizeof(double) * {size});" for array, size in
             zip(zeroed, ("N_STATE", "N_PARAM", "N_STATE * N_STATE", "N_STATE * N_PARAM",
                          "N_STATE"))]
    lines += ["    " + line for line in body(printer, block, rows).splitlines()]
    if partials.law:
        lines.append("        *law = 1;")
    name = comment_text(eqs.events[k].name)
    return "\n".join([f"    case {k}: {{ /* {name} */", *lines, "        break;", "    }"])


def system_programs(eqs: Equations, block: Block, printer: SymbolTablePrinter,
                    chunk_steps: int, units: Units | None) -> tuple[Printed, str, Printed]:
    """The system's primal, what is computed once before the columns and each column's steps:
    J formed once and a product per column (dense_programs) where the programs are short
    enough for one body, else the tangent as the Jacobian prints it (in parts), run forward
    for every column."""
    dense = dense_programs(eqs, block, printer, chunk_steps, (PRIMAL, TANGENT),
                           jacobian_tangent)
    if dense is not None:
        return dense
    programs = block.programs
    primal, columns = jacobian_programs(eqs, printer, programs["dynamics"],
                                        programs["sensitivities"], chunk_steps, units,
                                        (PRIMAL, TANGENT))
    return primal, "", columns


def dense_programs(eqs: Equations, block: Block, printer: SymbolTablePrinter,
                   chunk_steps: int, callers: tuple[Caller, Caller],
                   columns: Callable[..., tuple[str, str] | None]
                   ) -> tuple[Printed, str, Printed] | None:
    """The program's primal (written through CALLERS[0]'s macro), the lines computed once per
    call before the columns and each column's lines (through CALLERS[1]'s macro), as COLUMNS
    prints them from the linear tangent: J formed once and a dense product per column
    (jacobian_tangent: a tree's accelerations and drives), or the coefficients once and a
    forward sweep per column (hoisted_tangent: a closed loop's pieces). None where the
    programs are too long for one body or the tangent is not linear (linear_steps)."""
    programs = block.programs
    dynamics, tangent = programs["dynamics"], programs["sensitivities"]
    if max(dynamics.size, tangent.size) > chunk_steps:
        return None
    angles = angles_c(eqs, printer, dynamics, tangent)
    assert angles.reader is not None
    seeds = set(eqs.sensitivities.tangents.seeds.values()) if eqs.sensitivities else set()
    dense = columns(angles.printer.with_names({}, order="none"), angles.reader, seeds,
                    callers[1].results[0])
    if dense is None:
        return None
    primal = Printed("", angles.prologue + program_body(angles.printer, angles.program,
                                                        callers[0].writes))
    return primal, dense[0], Printed("", dense[1])


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


# ---- the columns' tangent as a small dense product, J formed once per call ----------------
# The tangent is linear in the seeds and in its own earlier steps: each step is a sum of
# coefficient x tangent, the coefficients functions of the primal values only, the same for
# every column. Read backwards at generation time (reverse accumulation), it gives each
# result's row of the Jacobian by every seed, J = [J_y | J_p] (the accelerations' and drives'
# rows), in one sweep per row, once per call; each column is then the dense product
# DQDD = J [s_j; e_j], a few multiply-adds a row, where the forward tangent ran the whole
# program again for every column (the double pendulum's 9 columns: 75 against 100 ns a call,
# benchmarks/sensitivities.py's breakdown). A closed loop's tangent has many results (its
# pieces: 21 on the four-bar), each row a reverse sweep: J cost more than the columns saved
# (the four-bar's call without columns 159 -> 257 ns, the slider-crank's 5 columns' call 523 ->
# 601 ns), so its steps' coefficients are named once and each column sweeps forward through
# them (hoisted_tangent: 59 -> 52 ns a column; benchmarks/loop_sensitivities.py).

class Constants:
    """The values computed once per call, before the loop over the columns: each named
    kj<k> and printed in the order named (a value names only earlier ones)."""

    def __init__(self, printer: SymbolTablePrinter):
        self.printer = printer
        self.symbols: dict[sympy.Expr, sympy.Symbol] = {}
        self.lines: list[str] = []

    def named(self, value: sympy.Expr) -> sympy.Expr:
        """VALUE itself where it is a number or a symbol, else the constant naming it."""
        if value.is_Number or value.is_Symbol:
            return value
        if -value in self.symbols:
            return -self.symbols[-value]
        if value not in self.symbols:
            text = self.names().doprint(value)
            self.symbols[value] = sympy.Dummy(f"kj{len(self.symbols)}", real=True)
            self.lines.append(f"    const double {self.symbols[value].name} = {text};")
        return self.symbols[value]

    def names(self) -> SymbolTablePrinter:
        """The printer of the constants named so far too."""
        return self.printer.with_names({s: s.name for s in self.symbols.values()},
                                       order="none")


def linear_steps(printer: SymbolTablePrinter, tangent: Program, seeds: set[sympy.Symbol]
                 ) -> tuple[Constants, list[tuple[sympy.Symbol, Linear]], list[Linear]] | None:
    """The tangent's steps and results as linear forms in the seeds and earlier steps, each
    step's coefficient named once (Constants), or None where a step is not linear or the
    program has guards (then printed as the Jacobian's tangent is, per column)."""
    if any(isinstance(step, Guard) for step in tangent.steps):
        return None
    tangents = frozenset(seeds | {name for name, _ in tangent.assignments()})
    try:
        steps = [(name, linear_form(expr, tangents)) for name, expr in tangent.assignments()]
        results = [linear_form(result, tangents) for result in tangent.results]
    except NotLinear:
        return None
    constants = Constants(printer)
    steps = [(name, {symbol: constants.named(coefficient) for symbol, coefficient in form.items()})
             for name, form in steps]  # each coefficient computed once, for every column
    return constants, steps, results


def jacobian_tangent(printer: SymbolTablePrinter, tangent: Program, seeds: set[sympy.Symbol],
                     target: str = "DQDD") -> tuple[str, str] | None:
    """The tangent as (the lines forming J before the loop over the columns; each column's
    product TARGET = J [seed; seed_p], TARGET the results' macro), or None (linear_steps)."""
    linear = linear_steps(printer, tangent, seeds)
    if linear is None:
        return None
    constants, steps, results = linear
    rows = [jacobian_row(steps, result, constants.named) for result in results]
    inner = constants.names()
    loop = [f"        {target}({i}) = "
            f"{inner.doprint(sympy.Add(*(entry * seed for seed, entry in row.items())))};"
            for i, row in enumerate(rows)]
    return "\n".join(constants.lines), "\n".join(loop)


def hoisted_tangent(printer: SymbolTablePrinter, tangent: Program, seeds: set[sympy.Symbol],
                    target: str = "DQDD") -> tuple[str, str] | None:
    """The tangent as (the lines naming each step's coefficients before the loop over the
    columns; each column's forward sweep, every step a sum of coefficient x tangent into
    TARGET), or None (linear_steps). Where the results are many (a closed loop's pieces) J's
    rows cost a reverse sweep each: the forward sweep per column is then the cheaper."""
    linear = linear_steps(printer, tangent, seeds)
    if linear is None:
        return None
    constants, steps, results = linear
    results = [{symbol: constants.named(c) for symbol, c in form.items()} for form in results]
    names = {name: f"dv{k}" for k, (name, _) in enumerate(steps)}
    inner = constants.names().with_names(names, order="none")

    def text(form: Linear) -> str:
        return inner.doprint(sympy.Add(*(c * symbol for symbol, c in form.items())))

    loop = [f"        const double {names[name]} = {text(form)};" for name, form in steps]
    loop += [f"        {target}({i}) = {text(form)};" for i, form in enumerate(results)]
    return "\n".join(constants.lines), "\n".join(loop)

