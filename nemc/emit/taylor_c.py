"""nemc.Taylor's C: the model's own Taylor coefficients (derive/taylor.py's series) with the
order and step rule (templates/taylor.c.tmpl), and its ensembles in SIMD lanes
(templates/batch.c.tmpl).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from typing import NamedTuple

import sympy

from ..derive.equations import Equations
from ..derive.taylor import (
    LANES,
    SCALAR,
    TAYLOR_MAX_ORDER,
    ColumnSeriesCode,
    Dialect,
    SeriesCode,
    TaylorUnsupported,
    column_series_code,
    series_code,
    taylor_jacobian,
    taylor_tangent,
)
from ..front import mechanism as m
from .c_text import SymbolTablePrinter
from .math_kernels import taylor_math
from .optimize import rewrite
from .parts import CHUNK_STEPS
from .printing import template

# Taylor loops of at most this many lines are also written out for order 0 alone, where the
# recurrences' k == 0 cases fold away (the double pendulum's steps: 3-5% faster); longer ones
# would double their compile time for that.
PEEL_MAX_LINES = 300


# nemc.Taylor's step rule (taylor_rule here and in templates/taylor.c.tmpl): a local error
# bound e^(-A p) = eps / e^(2 + TAYLOR_MARGIN) for a step h = rho / e^A of order p, met at the
# order and exponent that cost least per unit of time, c(p) e^A, under nemc's cost model of a
# step, c(p) = STEP_TERMS_PER_STATE n + L p + S p (p - 1) / 2 (a program of L lines and S
# Cauchy sums per order: StepCosts.terms). With A = 2 the bound is Jorba & Zou's,
# eps / e^2, as their order p = ceil(-ln(eps) / 2 + 1) rounds it up: half an order, e^1, on
# average. Their rule is this choice when the Cauchy sums are the whole cost; with a step's
# fixed work, longer steps of a higher order cost less (the double pendulum at 1e-6: order 11
# and A = 1.57 against order 8 and A = 2). TAYLOR_MARGIN keeps an rtol's error where Jorba &
# Zou's put it: without it, the bound met exactly, ensembles at rtol 1e-8 ended 4-5x less
# accurate than heyoka's at tol 1e-8. The exponent stays at least TAYLOR_MIN_EXPONENT: rho,
# from two coefficients, is an estimate, and at A = 1 the error fell by half an order of
# magnitude per order where A = 1.5 gave 1.8 (docs/decisions.md, "nemc.Taylor's order and step
# for nemc's cost"). STEP_TERMS_PER_STATE: a step's work beyond the coefficients (its step
# size, Horner's rule, the finiteness test), in terms, measured from the time per step against
# the order on the double pendulum, a free body and a 4-link chain.
TAYLOR_MIN_EXPONENT = 1.5
TAYLOR_MARGIN = 1.5
STEP_TERMS_PER_STATE = 120


class StepCosts(NamedTuple):
    """The cost model of a Taylor step of order p: step + line p + sums p (p - 1) / 2 terms."""

    step: float
    line: float
    sums: float

    def terms(self, order: int) -> float:
        """The program's terms at this order: line p + sums p (p - 1) / 2."""
        return self.line * order + self.sums * order * (order - 1) / 2


def step_costs(code: SeriesCode, n_state: int) -> StepCosts:
    return StepCosts(float(STEP_TERMS_PER_STATE * n_state), float(code.program_lines),
                     float(code.cost))


def step_cost_fields(costs: StepCosts) -> dict[str, str]:
    """templates/taylor.c.tmpl's cost model, as C doubles of the same values."""
    return dict(step_cost=repr(costs.step), line_cost=repr(costs.line), sum_cost=repr(costs.sums))


def taylor_rule(eps: float, costs: StepCosts) -> tuple[int, float]:
    """The order p and step exponent A for tolerance eps (the step is rho / e^A times Jorba &
    Zou's exp(-0.7 / (p - 1))), as templates/taylor.c.tmpl's taylor_rule: the same
    operations, so both choose the same order."""
    if not eps > 0:
        return TAYLOR_MAX_ORDER, 2.0
    bound = -math.log(eps) + 2 + TAYLOR_MARGIN  # A p at the local error bound
    first = math.ceil(bound / 2)  # the order where A = 2
    if first >= TAYLOR_MAX_ORDER:
        return TAYLOR_MAX_ORDER, 2.0
    best, best_exponent, best_cost = 0, 0.0, math.inf
    for order in range(max(first, 2), TAYLOR_MAX_ORDER + 1):
        exponent = min(max(bound / order, TAYLOR_MIN_EXPONENT), 2.0)
        work = costs.step + costs.terms(order)
        cost = math.log(work) + exponent + 0.7 / (order - 1)
        if cost < best_cost:
            best, best_exponent, best_cost = order, exponent, cost
        if exponent <= TAYLOR_MIN_EXPONENT:  # higher orders only cost more from here
            break
    return best, best_exponent


def taylor_rows(eqs: Equations) -> dict[sympy.Symbol, str]:
    """The row of Taylor coefficients of each state entry (declared by taylor_declarations)."""
    rows = {q: f"xq{i}" for i, q in enumerate(eqs.coordinates)}
    rows.update({u: f"xdq{i}" for i, u in enumerate(eqs.speeds)})
    return rows


def taylor_declarations(eqs: Equations, dialect: Dialect = SCALAR) -> list[str]:
    return [line for i in range(eqs.n) for line in (
        f"{dialect.value_type} *xq{i} = TAYLOR_ROW(x, STATE_Q({i}));",
        f"{dialect.value_type} *xdq{i} = TAYLOR_ROW(x, STATE_DQ({i}));")]


def block_lines(lines: Iterable[str], indent: str) -> str:
    return "\n".join(indent + line for line in lines)


def constants_read(code: SeriesCode) -> list[str]:
    """The parameter-only values the coefficients' loop reads, in the order they are defined."""
    read = set(re.findall(r"\b\w+\b", "\n".join(code.loop)))
    return [name for name in code.constant_names if name in read]


def coefficient_fields(eqs: Equations, code: SeriesCode, constants: list[str],
                       dialect: Dialect) -> dict[str, object]:
    """The fields of the coefficients' functions, shared by taylor.c.tmpl and batch.c.tmpl:
    the program at order k (declarations, its constants by name, the loop body) and the loop
    over the orders."""
    names = constants_read(code)
    return dict(
        n_series=max(code.n_series, 1),
        declarations=block_lines(taylor_declarations(eqs, dialect) + list(code.declarations),
                                 "    "),
        constant_names=block_lines(
            [f"const {dialect.value_type} {name} = constants[{j}];"
             for j, name in enumerate(names)], "    "),
        constants=block_lines(constants, "    "), start=block_lines(code.start, "    "),
        loop=block_lines(code.loop, "    "),
        orders=block_lines(order_loop(code, dialect), "    "),
    )


def order_loop(code: SeriesCode, dialect: Dialect) -> list[str]:
    """The loop over the orders (templates/taylor.c.tmpl's TAYLOR_LOOP), order 0 apart when
    the program is short (PEEL_MAX_LINES). A guard fails at order 0 only."""
    if dialect.lanes:
        call = "lanes_coefficient_k({k}, x, work, constants, status);"
        if code.program_lines > PEEL_MAX_LINES:
            return [f"TAYLOR_LOOP(k, 0, order, {call.format(k='k')});"]
        return [call.format(k=0) + " /* order 0 apart: its branches fold away */",
                f"TAYLOR_LOOP(k, 1, order, {call.format(k='k')});"]
    call = "taylor_coefficient_k({k}, x, work, constants)"
    if code.program_lines > PEEL_MAX_LINES:
        return [f"TAYLOR_LOOP(k, 0, order, const int status = {call.format(k='k')};",
                "                          if (status)",
                "                              return status;);"]
    return [f"const int status = {call.format(k=0)}; /* order 0 apart: its branches fold away */",
            "if (status)", "    return status;",
            f"TAYLOR_LOOP(k, 1, order, (void){call.format(k='k')};);"]


def series_printer(printer: SymbolTablePrinter) -> Callable[[sympy.Expr], str]:
    """C of the series' parameter-only values, small integer powers as products (as the
    other code's, optimize.rewrite)."""
    return lambda expr: printer.doprint(rewrite(expr))


class TaylorC(NamedTuple):
    """nemc.Taylor's C: its source ("" when the build has none), and why it cannot be built
    (None when it can)."""

    source: str
    unavailable: str | None = None


def taylor_section(eqs: Equations, printer: SymbolTablePrinter, fma: bool = False) -> TaylorC:
    """nemc.Taylor's C when the build asks for it. fma: its multiply-adds fused
    (templates/taylor.c.tmpl's TAYLOR_MULADD)."""
    if eqs.taylor_unavailable is not None:
        return TaylorC("", eqs.taylor_unavailable)
    if eqs.taylor is None:
        return TaylorC("")
    try:
        code = series_code(eqs.taylor, eqs.coordinates, eqs.speeds, taylor_rows(eqs), m.TIME,
                           series_printer(printer))
    except TaylorUnsupported as why:
        return TaylorC("", str(why))
    source = template("taylor.c.tmpl").substitute(
        max_order=TAYLOR_MAX_ORDER, fma=int(fma),
        taylor_math=taylor_math("math1_", "taylor_double1", "taylor_bits1", "one-element vectors"),
        constant_array=block_lines([scalar_constants(code)], "    "),
        min_exponent=repr(TAYLOR_MIN_EXPONENT), margin=repr(TAYLOR_MARGIN),
        **step_cost_fields(step_costs(code, 2 * eqs.n)),
        **coefficient_fields(eqs, code, list(code.constants), SCALAR))
    return TaylorC(source + sensitivity_section(eqs, printer), None)


def sensitivity_section(eqs: Equations, printer: SymbolTablePrinter) -> str:
    """nemc.Taylor's run of the sensitivity system (templates/taylor_sensitivities.c.tmpl) in
    builds with the variational equations too, else "" (the entry point then says
    NEMC_NO_TAYLOR: templates/integrators_entry.c.tmpl)."""
    if eqs.sensitivities is None or eqs.taylor is None or eqs.loops is not None:
        return ""
    return template("taylor_sensitivities.c.tmpl").substitute(
        **column_fields(eqs, column_code(eqs, printer)))


def column_code(eqs: Equations, printer: SymbolTablePrinter) -> ColumnSeriesCode:
    """The columns' coefficients by the cheaper of two derivatives of nemc.Taylor's program
    for as many columns as the state has entries and the model parameters: its forward tangent
    per column (taylor_tangent) or its Jacobian's entries once an order and their products
    with each column (taylor_jacobian, on programs of at most CHUNK_STEPS steps). The double
    pendulum's: the state's 13 Cauchy sums an order and 19.5 a column, or 56.5 (J's 18
    entries too) and 8 a column; with 9 columns 188.5 and 128.5, its runs 5.9 and 4.2 ms
    (benchmarks/sensitivities.py's case)."""
    assert eqs.sensitivities is not None and eqs.taylor is not None
    seeds = eqs.sensitivities.tangents.seeds  # state entry or parameter -> its tangent's symbol
    rows = taylor_rows(eqs)
    column_rows = {seeds[symbol]: "s" + rows[symbol]  # sxq<i>, sxdq<i>
                   for symbol in (*eqs.coordinates, *eqs.speeds)}
    names = {seeds[p]: f"seed_p[{k}]" for k, p in enumerate(eqs.parameters)}  # a direction
    candidates = [(eqs.taylor, taylor_tangent(eqs.taylor, seeds))]
    # J's reverse sweeps cost a row of results times the program's steps each, in sympy: on
    # programs short enough for one body, as the other methods' dense product (sensitivities_c)
    dense = taylor_jacobian(eqs.taylor, seeds) if eqs.taylor.size <= CHUNK_STEPS else None
    if dense is not None:
        candidates.append(dense)
    for program, tangent in candidates:
        names.update({name: name.name for name, _ in (*program.assignments(),
                                                      *tangent.assignments())})
    scalar = series_printer(printer.with_names(names))
    codes = [column_series_code(program, tangent, eqs.coordinates, eqs.speeds, rows,
                                column_rows, m.TIME, scalar) for program, tangent in candidates]
    count = len(eqs.state) + len(eqs.parameters)
    return min(codes, key=lambda code: code.state.cost + count * code.cost)


def column_fields(eqs: Equations, code: ColumnSeriesCode) -> dict[str, object]:
    """templates/taylor_sensitivities.c.tmpl's fields: the state's program at order k as
    taylor.c.tmpl's, the constants either loop reads, and a column's rows, constants and
    lines."""
    state = code.state
    read = set(re.findall(r"\b\w+\b", "\n".join(state.loop + code.loop)))
    names = [name for name in state.constant_names if name in read]
    column_read = set(re.findall(r"\b\w+\b", "\n".join(code.loop)))
    column_names = [name for name in code.constant_names if name in column_read]
    column_state = [line for i in range(eqs.n) for line in (
        f"double *sxq{i} = TAYLOR_ROW(xs, STATE_Q({i}));",
        f"double *sxdq{i} = TAYLOR_ROW(xs, STATE_DQ({i}));")]
    return dict(
        n_series=max(state.n_series, 1), n_column_series=max(code.n_series, 1),
        n_column_constants=max(len(column_names), 1),
        declarations=block_lines(taylor_declarations(eqs) + list(state.declarations), "    "),
        constant_names=block_lines([f"const double {name} = constants[{j}];"
                                    for j, name in enumerate(names)], "    "),
        loop=block_lines(state.loop, "    "),
        column_declarations=block_lines(column_state + list(code.declarations), " " * 8),
        column_constant_names=block_lines([f"const double {name} = cs[{j}];"
                                           for j, name in enumerate(column_names)], " " * 8),
        column_loop=block_lines(code.loop, " " * 8),
        constants=block_lines(state.constants, "    "),
        constant_array=block_lines([constant_array(names)], "    "),
        column_constants=block_lines(code.constants, " " * 8),
        column_store=block_lines([f"cs[{j}] = {name};" for j, name in enumerate(column_names)],
                                 " " * 8),
        start=block_lines(state.start, "    "))


def constant_array(names: list[str]) -> str:
    """The array of the parameter-only values NAMES a loop over the orders reads."""
    if not names:
        return "const double *constants = NULL;"
    return f"const double constants[{len(names)}] = {{{', '.join(names)}}};"


def scalar_constants(code: SeriesCode) -> str:
    """taylor_coefficients' array of the constants its loop reads (taylor_coefficient_k's)."""
    names = constants_read(code)
    if not names:
        return "const double *constants = NULL;"
    return f"const double constants[{len(names)}] = {{{', '.join(names)}}};"


# ---- ensembles in SIMD lanes ------------------------------------------------------------------


# The instruction set the lanes' functions are compiled for, by lane count (build.lane_count).
LANE_TARGETS = {4: "avx2,fma", 8: "avx512f"}  # AVX-512F implies FMA


def cpu_supports(target: str) -> str:
    """The C test that this CPU has every feature of a gcc target string ("avx2,fma")."""
    return " && ".join(f'__builtin_cpu_supports("{feature}")' for feature in target.split(","))


def lanes_section(eqs: Equations, printer: SymbolTablePrinter, prefix: str, count: int) -> str:
    """nemc.Taylor's ensembles in SIMD lanes (templates/batch.c.tmpl), COUNT per batch: the
    same coefficient code in the lanes dialect. Called only with Taylor's code built
    (taylor_section succeeded)."""
    assert eqs.taylor is not None
    if count not in LANE_TARGETS:
        raise ValueError(f"lanes per batch: one of {sorted(LANE_TARGETS)}, got {count!r}")
    code = series_code(eqs.taylor, eqs.coordinates, eqs.speeds, taylor_rows(eqs), m.TIME,
                       series_printer(printer), LANES)
    names = constants_read(code)
    return template("batch.c.tmpl").substitute(
        prefix=prefix, lanes=count, target=LANE_TARGETS[count],
        cpu_supports=cpu_supports(LANE_TARGETS[count]),
        taylor_math=taylor_math("lanes_math_", "lanes", "lane_bits", "NEMC_LANES lanes"),
        n_constants=max(len(names), 1),
        **coefficient_fields(eqs, code, lane_constants(code, names), LANES))


def lane_constants(code: SeriesCode, names: list[str]) -> list[str]:
    """The body of lanes_run_constants (templates/batch.c.tmpl): the parameter-only values of
    the run in lane l, with its p, by the scalar lines, into lane l of the values the loop
    reads (names: constants_read's, lanes_coefficient_k's constants)."""
    return [*code.constants, *(f"constants[{j}][l] = {name};" for j, name in enumerate(names))]
