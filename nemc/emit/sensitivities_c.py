"""The variational equations' C, an optional part of a build (nemc/derive/sensitivities.py):
the sensitivity system's right-hand side (templates/sensitivities.c.tmpl), the initial state's
derivatives by the parameters, and the outputs' sensitivities at a point of a run
(templates/output_sensitivities.c.tmpl). Exact: the accelerations' program once, then its
forward-mode derivative once per sensitivity column. At the scene's events, the columns' jump
and the event times' sensitivities (templates/event_sensitivities.c.tmpl), from each event's
partial derivatives. A closed loop's system is templates/loop_sensitivities.c.tmpl (the same
sensitivity_rhs signature: its pieces' program once, their tangent per column, the index-1
equations' derivative solved), with loop_sensitivity_pieces for the runtime's start columns.
"""

from __future__ import annotations

import dataclasses

import sympy

from ..derive.equations import Equations
from ..derive.program import Guard, Program
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
    system = template("loop_sensitivities.c.tmpl").substitute(
        prefix=prefix, loop_sensitivity_parts=primal.functions + tangent.functions,
        primal=primal.body, tangent=tangent.body,
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
    """The system's primal, the tangent's coefficients (computed once) and its columns' steps:
    hoisted (hoisted_tangent) where the programs are short enough for one body, else the
    tangent as the Jacobian prints it (in parts), every column computing its coefficients."""
    programs = block.programs
    dynamics, tangent = programs["dynamics"], programs["sensitivities"]
    if max(dynamics.size, tangent.size) <= chunk_steps:
        angles = angles_c(eqs, printer, dynamics, tangent)
        assert angles.reader is not None
        seeds = set(eqs.sensitivities.tangents.seeds.values()) if eqs.sensitivities else set()
        hoisted = hoisted_tangent(angles.printer.with_names({}, order="none"), angles.reader,
                                  seeds)
        if hoisted is not None:
            primal = Printed("", angles.prologue + program_body(angles.printer, angles.program,
                                                                PRIMAL.writes))
            return primal, hoisted[0], Printed("", hoisted[1])
    primal, columns = jacobian_programs(eqs, printer, dynamics, tangent, chunk_steps, units,
                                        (PRIMAL, TANGENT))
    return primal, "", columns


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


# ---- the columns' tangent with its coefficients hoisted out of the loop over columns ---------
# The tangent is linear in the seeds and in its own earlier steps: each step is a sum of
# coefficient x tangent, the coefficients functions of the primal values only. They are the
# same for every column, so they are computed once, before the loop, and each column's steps
# are then short sums of products.

Linear = dict[sympy.Symbol, sympy.Expr]  # tangent symbol -> its coefficient


class NotLinear(Exception):
    """A tangent step that is not a sum of coefficient x tangent (then printed as it is)."""


def linear_form(expr: sympy.Expr, tangents: frozenset[sympy.Symbol]) -> Linear:
    """EXPR as {tangent: coefficient}, the coefficients free of TANGENTS."""
    expr = sympy.sympify(expr)
    if expr in tangents:
        return {expr: sympy.S.One}
    if not (expr.free_symbols & tangents):
        if expr == 0:
            return {}
        raise NotLinear(expr)
    if expr.is_Add:
        total: Linear = {}
        for term in expr.args:
            for symbol, coefficient in linear_form(term, tangents).items():
                total[symbol] = total.get(symbol, sympy.S.Zero) + coefficient
        return total
    if expr.is_Mul:
        varying = [f for f in expr.args if f.free_symbols & tangents]
        if len(varying) != 1:
            raise NotLinear(expr)
        scale = sympy.Mul(*(f for f in expr.args if f is not varying[0]))
        return {symbol: scale * coefficient
                for symbol, coefficient in linear_form(varying[0], tangents).items()}
    raise NotLinear(expr)


def hoisted_tangent(printer: SymbolTablePrinter, tangent: Program, seeds: set[sympy.Symbol]
                    ) -> tuple[str, str] | None:
    """The tangent as (the coefficients' lines, before the loop over columns; each column's
    steps and results), or None where a step is not linear or the program has guards."""
    if any(isinstance(step, Guard) for step in tangent.steps):
        return None
    tangents = frozenset(seeds | {name for name, _ in tangent.assignments()})
    coefficients: dict[sympy.Expr, sympy.Symbol] = {}

    def named(coefficient: sympy.Expr) -> sympy.Expr:
        if coefficient.is_Number or coefficient.is_Symbol:
            return coefficient
        if -coefficient in coefficients:
            return -coefficients[-coefficient]
        if coefficient not in coefficients:
            coefficients[coefficient] = sympy.Dummy(f"kc{len(coefficients)}", real=True)
        return coefficients[coefficient]

    try:
        steps = [(name, linear_form(expr, tangents)) for name, expr in tangent.assignments()]
        results = [linear_form(result, tangents) for result in tangent.results]
    except NotLinear:
        return None
    sums = [(name, sympy.Add(*(named(c) * t for t, c in form.items())))
            for name, form in steps]
    result_sums = [sympy.Add(*(named(c) * t for t, c in form.items())) for form in results]
    inner = printer.with_names({s: s.name for s in coefficients.values()}, order="none")
    before = "\n".join(f"    const double {symbol.name} = {printer.doprint(expr)};"
                       for expr, symbol in coefficients.items())
    indent = " " * 8
    loop = [f"{indent}const double {name.name} = {inner.doprint(expr)};" for name, expr in sums]
    loop += [f"{indent}DQDD({i}) = {inner.doprint(expr)};" for i, expr in enumerate(result_sums)]
    return before, "\n".join(loop)
