"""Taylor-mode arithmetic of the accelerations' program, printed as C (nemc.Taylor).

Taylor's method integrates y' = f(t, y) by expanding the solution at each step into its Taylor
series y(t + h) = sum_k x[k] h^k, with x[k] = y^(k)(t) / k!. The coefficients come from automatic
differentiation in Taylor mode (Jorba & Zou 2005; heyoka, Biscani & Izzo 2021): every operation
of the program gets the recurrence that gives coefficient k of its result from coefficients
0..k of its operands (a product is a Cauchy sum, a quotient, sin and cos, exp, log and powers
have the classic recurrences), and the state's next coefficients follow from the equations of
motion, x_q[k + 1] = x_dq[k] / (k + 1) and x_dq[k + 1] = qdd[k] / (k + 1).

This module turns the program (nemc/program.py) into the body of one C function: parameter-only
values as scalars before the loop over k, one series (a row of coefficients) per
non-constant intermediate inside it. An operation without a recurrence here (abs, sign,
min/max, tan, atan...: non-smooth, or not worth a recurrence yet) on a value that changes in time
makes the program unsupported: TaylorUnsupported names it, and the model is built without
nemc.Taylor.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import sympy

from .program import Guard, Program, ProgramBuilder
from .tangent import NotLinear, jacobian_row, linear_form, tangent_program

# highest order the generated code supports: rows of TAYLOR_STRIDE = TAYLOR_MAX_ORDER + 1
TAYLOR_MAX_ORDER = 40


class TaylorUnsupported(ValueError):
    """The program uses an operation with no Taylor recurrence here."""


@dataclass(frozen=True)
class Dialect:
    """How the coefficient code is written: of one run (a coefficient is a double, the
    recurrences of templates/taylor.c.tmpl), or of SIMD lanes (a coefficient is a vector of
    runs, `lanes`, the recurrences of templates/batch.c.tmpl, which take the same arguments).
    The operations are the same; only the types, the helpers' names and what a failed guard
    does differ: one run returns its status, a lane records it in status[l] and the others go
    on. Lanes' parameter-only values are computed lane by lane, each with its own p (the
    constants are the scalar lines, in a loop over the lanes: see emit.taylor_c.lanes_section)."""

    value_type: str  # the type of a coefficient
    prefix: str  # the recurrences' prefix, for "series_"
    work_row: str  # the C macro of row j of the work array: work_row(work, j)

    @property
    def lanes(self) -> bool:
        return self.value_type != "double"

    @property
    def muladd(self) -> str:
        """The C macro of a Cauchy sum's multiply-add (fused where the build has FMA)."""
        return "LANES_MULADD" if self.lanes else "TAYLOR_MULADD"

    def helper(self, kind: str) -> str:
        """The C name of a recurrence ("product", "sincos_end"...) in this dialect."""
        return self.prefix + kind

    def broadcast(self, value: str) -> str:
        """A scalar's C as a coefficient (lanes: the same value in every lane)."""
        return f"LANES({value})" if self.lanes else value

    def argument(self, value: str) -> str:
        """A value handed to a recurrence (lanes: by address, as a one-vector array: a vector
        argument's ABI would depend on the -m flags)."""
        return f"(const lanes[1]){{{value}}}" if self.lanes else value

    def guard(self, test: str, status: str, loop: bool) -> list[str]:
        """A singular articulated inertia: in the loop at coefficient 0, or before it."""
        if self.lanes and loop:
            return ["if (k == 0)", f"    lanes_guard({self.argument(test)}, {status}, status);"]
        if self.lanes:  # in the loop over the lanes, with its p (emit.taylor_c.lanes_section)
            return [f"if (!({test} > 0.0) && !status[l])", f"    status[l] = {status};"]
        return [f"if ({'k == 0 && ' if loop else ''}!({test} > 0.0))", f"    return {status};"]


SCALAR = Dialect("double", "series_", "TAYLOR_ROW")
LANES = Dialect("lanes", "lanes_", "LANES_WORK_ROW")  # rows of the lanes' work (batch.c.tmpl)


@dataclass(frozen=True)
class Recurrence:
    """A line of the loop over the orders that calls a Taylor recurrence of
    templates/taylor.c.tmpl (series_<kind>, lanes_<kind> in batch.c.tmpl): coefficient k of
    `result` (None: the recurrence writes its rows itself, as sin-cos) from `operands`, rows read
    whole (their coefficients below k), then `scalars`, arguments that are no row."""

    kind: str
    result: str | None
    operands: tuple[str, ...]
    scalars: tuple[str, ...] = ()


@dataclass(frozen=True)
class Assignment:
    """A line of the loop over the orders that sets coefficient k of `target` to `value`, C
    that reads coefficient k of rows as name[k]."""

    target: str
    value: str


# a line of the loop over the orders: a recurrence, an assignment, or C as it is (a guard, the
# state's next coefficients)
LoopItem = Recurrence | Assignment | str


@dataclass(frozen=True)
class SeriesCode:
    """The C of the Taylor coefficients: declarations, scalar constants, the loop body."""

    n_series: int  # rows of the work array
    declarations: tuple[str, ...]  # `double *name = TAYLOR_ROW(work, j);`
    constants: tuple[str, ...]  # before the loop: parameter-only values, constant guards
    constant_names: tuple[str, ...]  # the names those lines define (scalars, in order)
    start: tuple[str, ...]  # before the loop: the time series
    loop: tuple[str, ...]  # inside `for (k = 0; k < order; ++k)`, its Cauchy sums in blocks
    program_lines: int  # the program's lines at order k (recurrences, assignments, guards)
    cost: float  # Cauchy sums per order (SERIES_WEIGHTS): what the program costs per order


class SeriesWriter:
    """Writes the coefficient-k code of expressions, naming series rows as it needs them."""

    def __init__(self, scalar: Callable[[sympy.Expr], str], state: dict[sympy.Symbol, str],
                 time: sympy.Symbol, dialect: Dialect = SCALAR):
        self.scalar = scalar  # prints a parameter-only expression as C
        self.dialect = dialect
        self.series: dict[sympy.Expr, str] = dict(state)  # expression -> its row's name
        self.varying: set[sympy.Symbol] = {*state, time}  # symbols that change with time
        self.time = time
        self.rows: list[str] = []  # the work array's rows, by name, in order
        self.constants: list[str] = []
        self.constant_names: list[str] = []
        self.loop: list[LoopItem] = []
        self.uses_time = False
        self.cost = 0.0  # Cauchy sums per order of the recurrences written (SERIES_WEIGHTS)
        self._scalars: dict[sympy.Expr, str] = {}  # parameter-only factor -> its constant

    def scalar_value(self, expr: sympy.Expr) -> str:
        """A parameter-only value as C: a number in place, anything else a named constant
        computed once, before the loop (so the loop reloads no parameter)."""
        if expr.is_Number:
            return self.scalar(expr)
        if expr not in self._scalars:
            name = f"c{len(self._scalars)}"
            self.constant(name, self.scalar(expr))
            self._scalars[expr] = name
        return self._scalars[expr]

    def constant(self, name: str, value: str) -> None:
        self.constants.append(f"const double {name} = {value};")
        self.constant_names.append(name)

    def at_order_zero(self, value: str) -> str:
        """C for coefficient k of a parameter-only value: the value at k = 0, else 0."""
        return f"(k == 0 ? {self.dialect.broadcast(value)} : {self.dialect.broadcast('0.0')})"

    def recurrence(self, kind: str, result: str | None, *operands: str,
                   scalars: tuple[str, ...] = ()) -> None:
        """A line of the loop that calls a Taylor recurrence (Recurrence)."""
        self.loop.append(Recurrence(kind, result, operands, scalars))
        self.cost += SERIES_WEIGHTS[kind]

    # -- rows -------------------------------------------------------------------------------

    def new_row(self, name: str) -> str:
        self.rows.append(name)
        return name

    def temporary(self) -> str:
        return self.new_row(f"s{len(self.rows)}")

    def row_of(self, expr: sympy.Expr) -> str:
        """The name of a row holding expr's series, computing it into a temporary if needed."""
        if expr in self.series:
            return self.series[expr]
        if expr == self.time:
            self.uses_time = True
            self.series[expr] = "tt"
            return "tt"
        coefficient = self.coefficient(expr)
        name = self.series.get(expr)  # a recurrence may have named it meanwhile
        if name is None:
            name = self.temporary()
            self.loop.append(Assignment(name, coefficient))
            self.series[expr] = name
        return name

    # -- coefficient k of an expression -------------------------------------------------------

    def is_constant(self, expr: sympy.Expr) -> bool:
        """Parameter-only: computed once per step, before the loop over the orders."""
        return not (expr.free_symbols & self.varying)

    def coefficient(self, expr: sympy.Expr) -> str:
        """C for coefficient k of a time-varying expr (its earlier coefficients computed)."""
        if expr in self.series or expr == self.time:
            return f"{self.row_of(expr)}[k]"
        if expr.is_Add:
            return self.add(expr.args)
        if expr.is_Mul:
            return self.product(expr.args)
        if expr.is_Pow:
            return f"{self.power(*expr.args)}[k]"
        if isinstance(expr, (sympy.sin, sympy.cos)):
            return f"{self.trigonometric(expr)}[k]"
        if isinstance(expr, (sympy.sinh, sympy.cosh)):
            return f"{self.hyperbolic(expr)}[k]"
        if isinstance(expr, sympy.exp):
            return f"{self.unary('exp', expr)}[k]"
        if isinstance(expr, sympy.log):
            return f"{self.unary('log', expr)}[k]"
        raise TaylorUnsupported(f"{type(expr).__name__.lower()} of a time-varying value")

    def add(self, args: Sequence[sympy.Expr]) -> str:
        varying = [a for a in args if not self.is_constant(a)]
        constant = sympy.Add(*[a for a in args if self.is_constant(a)])
        terms = [self.coefficient(a) for a in varying]
        if constant != 0:
            terms.append(self.at_order_zero(self.scalar_value(constant)))
        return "(" + " + ".join(terms) + ")"

    def product(self, args: Sequence[sympy.Expr]) -> str:
        factor = sympy.Mul(*[a for a in args if self.is_constant(a)])
        varying = [a for a in args if not self.is_constant(a)]
        numerator = [a for a in varying if not is_reciprocal(a)]
        denominator = [a.args[0] ** -a.args[1] for a in varying if is_reciprocal(a)]
        if len(numerator) == 1 and not denominator:
            row = None
            value = self.coefficient(numerator[0])
        else:
            row = self.quotient(numerator, denominator)
            value = f"{row}[k]"
        if factor == 1:
            return value
        if factor == -1:
            return f"-{value}"
        return f"{self.scalar_value(factor)} * {value}"

    def cauchy(self, factors: Sequence[sympy.Expr]) -> str:
        """The row of a product of time-varying factors (one Cauchy sum per extra factor)."""
        key = sympy.Mul(*factors)
        if key in self.series:
            return self.series[key]
        row = self.row_of(factors[0])
        for count in range(2, len(factors) + 1):
            partial = sympy.Mul(*factors[:count])
            if partial in self.series:
                row = self.series[partial]
                continue
            other = self.row_of(factors[count - 1])
            name = self.temporary()
            if other == row:
                self.recurrence("square", name, row)
            else:
                self.recurrence("product", name, row, other)
            self.series[partial] = row = name
        return row

    def quotient(self, numerator: Sequence[sympy.Expr],
                 denominator: Sequence[sympy.Expr]) -> str:
        top = self.cauchy(numerator) if numerator else None
        if not denominator:
            assert top is not None
            return top
        bottom = self.cauchy(denominator)
        name = self.temporary()
        if top is None:
            self.recurrence("reciprocal", name, bottom, name)
        else:
            self.recurrence("quotient", name, top, bottom, name)
        self.series[sympy.Mul(*numerator) / sympy.Mul(*denominator)] = name
        return name

    def power(self, base: sympy.Expr, exponent: sympy.Expr) -> str:
        expr = base**exponent
        if expr in self.series:
            return self.series[expr]
        if not self.is_constant(exponent):
            raise TaylorUnsupported("a power with a time-varying exponent")
        if exponent == -1:
            return self.quotient([], [base])
        if exponent.is_Integer and 2 <= exponent <= 8:
            return self.cauchy([base] * int(exponent))
        if exponent.is_Integer and exponent < 0:
            return self.quotient([], [base**-exponent])
        row = self.row_of(base)
        name = self.temporary()
        alpha = self.dialect.argument(self.dialect.broadcast(self.scalar_value(exponent)))
        self.recurrence("power", name, row, name, scalars=(alpha,))
        self.series[expr] = name
        return name

    def paired(self, expr: sympy.Expr, functions: tuple[type, type], kind: str) -> str:
        """sin and cos (or sinh and cosh) of one argument come together, from one recurrence."""
        argument = expr.args[0]
        first, second = (function(argument) for function in functions)
        if expr not in self.series:
            row = self.row_of(argument)
            derivative, a, b = self.temporary(), self.temporary(), self.temporary()
            self.recurrence(kind, None, row, derivative, a, b)
            self.series[first], self.series[second] = a, b
        return self.series[expr]

    def trigonometric(self, expr: sympy.Expr) -> str:
        return self.paired(expr, (sympy.sin, sympy.cos), "sincos")

    def hyperbolic(self, expr: sympy.Expr) -> str:
        return self.paired(expr, (sympy.sinh, sympy.cosh), "sinhcosh")

    def unary(self, kind: str, expr: sympy.Expr) -> str:
        if expr not in self.series:
            row = self.row_of(expr.args[0])
            derivative = [self.temporary()] if kind in DERIVATIVE_ROW else []
            name = self.temporary()
            self.recurrence(kind, name, row, *derivative, name)
            self.series[expr] = name
        return self.series[expr]


# recurrences whose C function keeps the row j a[j] of its argument (templates/taylor.c.tmpl)
DERIVATIVE_ROW = {"exp"}


SMOOTH_FUNCTIONS = (sympy.sin, sympy.cos, sympy.sinh, sympy.cosh, sympy.exp, sympy.log)


def unsupported_operation(expr: sympy.Expr, varying: set[sympy.Symbol]) -> str | None:
    """What in expr has no Taylor recurrence here when `varying` change with time (None: every
    operation has one): the operations SeriesWriter.coefficient takes, checked up front."""
    for node in sympy.preorder_traversal(expr):
        if not node.free_symbols & varying or node.is_Symbol or node.is_Add or node.is_Mul:
            continue
        if node.is_Pow:
            if node.exp.free_symbols & varying:
                return "a power with a time-varying exponent"
            continue
        if not isinstance(node, SMOOTH_FUNCTIONS):
            return f"{type(node).__name__.lower()} of a time-varying value"
    return None


def is_reciprocal(expr: sympy.Expr) -> bool:
    return bool(expr.is_Pow and expr.args[1].is_Integer and expr.args[1] < 0)


def series_code(program: Program, coordinates: Sequence[sympy.Symbol],
                speeds: Sequence[sympy.Symbol], rows: Mapping[sympy.Symbol, str],
                time: sympy.Symbol, scalar: Callable[[sympy.Expr], str],
                dialect: Dialect = SCALAR) -> SeriesCode:
    """The Taylor-coefficient code of the accelerations' program (one result per coordinate);
    rows: the name of each coordinate's and speed's row. Raises TaylorUnsupported."""
    writer = written_program(program, coordinates, speeds, rows, time, scalar, dialect)
    kept = rows_read_back(writer.rows, writer.loop)
    local = frozenset(writer.rows) - set(kept)
    start: tuple[str, ...] = ()
    if writer.uses_time:
        kept.append("tt")
        start = time_start(len(kept) - 1, dialect)
    return SeriesCode(len(kept), tuple(row_declaration(name, j, dialect)
                                       for j, name in enumerate(kept)),
                      tuple(writer.constants), tuple(writer.constant_names), start,
                      tuple(sums_in_blocks(writer.loop, local, dialect)), len(writer.loop),
                      writer.cost)


def written_program(program: Program, coordinates: Sequence[sympy.Symbol],
                    speeds: Sequence[sympy.Symbol], rows: Mapping[sympy.Symbol, str],
                    time: sympy.Symbol, scalar: Callable[[sympy.Expr], str],
                    dialect: Dialect = SCALAR) -> SeriesWriter:
    """The program's coefficient k, recorded by a SeriesWriter (its loop as values, its rows,
    constants and cost), with the state's next coefficients after it."""
    writer = SeriesWriter(scalar, dict(rows), time, dialect)
    written_steps(writer, program)
    next_coefficients(writer, [(rows[q], rows[dq]) for q, dq in zip(coordinates, speeds)],
                      program.results)
    return writer


def written_steps(writer: SeriesWriter, program: Program) -> None:
    """Coefficient k of the program's steps, recorded by the writer (its results apart)."""
    for step in program.steps:
        if isinstance(step, Guard):
            guard(writer, step)
            continue
        name, expr = step
        if writer.is_constant(expr):
            writer.constant(name.name, writer.scalar(expr))
            continue
        value = writer.coefficient(expr)
        same = re.fullmatch(r"(\w+)\[k\]", value)  # already a row (sin, a product...): alias it
        if same:
            writer.series[name] = same.group(1)
        else:
            writer.series[name] = writer.new_row(name.name)
            writer.loop.append(Assignment(name.name, value))
        writer.varying.add(name)


def next_coefficients(writer: SeriesWriter, pairs: Sequence[tuple[str, str]],
                      results: Sequence[sympy.Expr]) -> None:
    """The state's next coefficients from the results (its accelerations): for each pair of
    rows (a coordinate's, its rate's), x_q[k + 1] = x_dq[k] / (k + 1) and x_dq[k + 1] =
    result[k] / (k + 1)."""
    for (q_row, dq_row), result in zip(pairs, results):
        value = (writer.at_order_zero(writer.scalar_value(result)) if writer.is_constant(result)
                 else writer.coefficient(result))
        writer.loop.append(f"{q_row}[k + 1] = {dq_row}[k] * (1.0 / (k + 1));")
        writer.loop.append(f"{dq_row}[k + 1] = {value} * (1.0 / (k + 1));")


def time_start(j: int, dialect: Dialect) -> tuple[str, ...]:
    """The time's series in row j, filled before the loop over the orders (its row is declared
    for the loop's body too); lines are relative to the block they sit in: "    " marks one
    more level."""
    return ("{", "    " + row_declaration("tt", j, dialect), "    tt[0] = t;",
            "    for (int j = 1; j <= order; ++j)",
            f"        tt[j] = {dialect.broadcast('j == 1 ? 1.0 : 0.0')};", "}")


def row_declaration(name: str, j: int, dialect: Dialect) -> str:
    """The C that names row j of the work array."""
    return f"{dialect.value_type} *{name} = {dialect.work_row}(work, {j});"


def rows_read_back(rows: Sequence[str], loop: Sequence[LoopItem]) -> list[str]:
    """The work rows the loop over the orders reads back: the recurrences' operands, whose
    coefficients below k they read. Every other value is a local of its order (its
    Assignment or Recurrence declares it): a value whose earlier coefficients no recurrence
    reads (a product only added to others, a sum only scaled) needs coefficient k alone, at
    order k. Kept in a row, each order wrote it into a cache line of its own that it had not
    touched since the last expansion; a local stays in a register or the stack frame. Half
    the rows of an 8-link chain's articulated-body program are such values. The same
    operations in the same order: the same bits."""
    read = {name for item in loop if isinstance(item, Recurrence) for name in item.operands}
    return [name for name in rows if name in read]


AT_K = re.compile(r"\b(?P<name>[A-Za-z_]\w*)\[k\]")  # coefficient k of a row, in C


def at_order_k(text: str, local: frozenset[str]) -> str:
    """C reading coefficient k of rows (name[k]) with the locals read as themselves."""
    return AT_K.sub(lambda use: use["name"] if use["name"] in local else use[0], text)


def defined(target: str, value: str, local: frozenset[str], dialect: Dialect) -> str:
    """The line setting coefficient k of a row, or declaring a local."""
    if target in local:
        return f"const {dialect.value_type} {target} = {value};"
    return f"{target}[k] = {value};"


def written(item: LoopItem, local: frozenset[str], dialect: Dialect,
            olds: Sequence[str] = ()) -> str:
    """A line of the loop over the orders as C. olds: the accumulators of a recurrence's sums
    below k (sums_in_blocks), which its *_end helper finishes."""
    if isinstance(item, str):
        return at_order_k(item, local)
    if isinstance(item, Assignment):
        return defined(item.target, at_order_k(item.value, local), local, dialect)
    kind = f"{item.kind}_end" if olds else item.kind
    arguments = [*item.operands, *item.scalars, *(dialect.argument(old) for old in olds), "k"]
    call = f"{dialect.helper(kind)}({', '.join(arguments)})"
    return f"{call};" if item.result is None else defined(item.result, call, local, dialect)


@dataclass(frozen=True)
class CauchySums:
    """A recurrence's sums over j of terms of coefficients below k: each a[j] b[k - j], a and b
    formats of its operands ({0} the first), j = 1..last-1 (templates/taylor.c.tmpl)."""

    last: str
    terms: tuple[tuple[str, str], ...]
    results: tuple[int, ...]  # the operand naming each sum (old_<name>); -1: the result


FULL, HALF = "k", "(k + 1) / 2"
# the recurrences summed in blocks, by kind: each one's *_end helper finishes it (a power, whose
# exponent is a scalar argument, keeps its loop)
CAUCHY_SUMS = {
    "product": CauchySums(FULL, (("{0}", "{1}"),), (-1,)),
    "square": CauchySums(HALF, (("{0}", "{0}"),), (-1,)),
    "quotient": CauchySums(FULL, (("{1}", "{2}"),), (2,)),
    "reciprocal": CauchySums(FULL, (("{0}", "{1}"),), (1,)),
    "sincos": CauchySums(FULL, (("{1}", "{3}"), ("{1}", "{2}")), (2, 3)),
    "sinhcosh": CauchySums(FULL, (("{1}", "{3}"), ("{1}", "{2}")), (2, 3)),
    "exp": CauchySums(FULL, (("{1}", "{2}"),), (2,)),
    "log": CauchySums(FULL, (("(double)j * {1}", "{0}"),), (1,)),
}
# the Cauchy sums whose terms below k one loop over j adds (each its own accumulator, kept in a
# register: 16 vector registers without AVX-512). Measured: one run of a 3-link chain as fast
# with 8, 3-10% slower with 16 (spilled); 200 8-link chains in lanes as fast with 24, 1.14x
# slower with 6 (docs/decisions.md, "nemc.Taylor's values of one order as locals")
SUMS_PER_BLOCK = 12


@dataclass(frozen=True)
class Sum:
    """One sum of a recurrence's line: its accumulator and its term at j."""

    old: str
    term: str


def recurrence_sums(recurrence: Recurrence, dialect: Dialect) -> list[Sum]:
    """The sums of a recurrence, each into old_<the row or local it names>."""
    spec = CAUCHY_SUMS[recurrence.kind]
    operands = recurrence.operands
    names = [operands[i] if i >= 0 else recurrence.result for i in spec.results]
    sums = []
    for name, (a, b) in zip(names, spec.terms):
        old = f"old_{name}"
        a_j, b_k = a.format(*operands), b.format(*operands)
        sums.append(Sum(old, f"{old} = {dialect.muladd}({a_j}[j], {b_k}[k - j], {old});"))
    return sums


def sums_in_blocks(loop: Sequence[LoopItem], local: frozenset[str],
                   dialect: Dialect) -> list[str]:
    """The loop over the orders as C (local: the values that are locals of their order,
    rows_read_back), its Cauchy sums in blocks: the terms of coefficients below k of
    SUMS_PER_BLOCK sums, one loop over j adding a term to each, before the first of them, and
    each recurrence's line then finishing its sums with the terms of coefficient k
    (series_product_end...). Summed one after the other, every sum was a loop of its own whose
    length changes with k: its exit mispredicted once an order, and its multiply-adds were one
    chain; in a block, 12 chains run side by side, one exit a block. Every sum adds the same
    terms in the same order, from the same 0.0: the same bits."""
    sums = {index: recurrence_sums(item, dialect) for index, item in enumerate(loop)
            if isinstance(item, Recurrence) and item.kind in CAUCHY_SUMS}
    blocks: dict[int, list[str]] = {}
    for last in (FULL, HALF):
        in_turn = [(index, total) for index, totals in sums.items()
                   if CAUCHY_SUMS[loop[index].kind].last == last  # type: ignore[union-attr]
                   for total in totals]
        for start in range(0, len(in_turn), SUMS_PER_BLOCK):
            block = [total for _, total in in_turn[start:start + SUMS_PER_BLOCK]]
            blocks.setdefault(in_turn[start][0], []).extend(block_of_sums(block, last, dialect))
    lines: list[str] = []
    for index, item in enumerate(loop):
        lines += blocks.get(index, [])
        lines.append(written(item, local, dialect, [total.old for total in sums.get(index, [])]))
    return lines


def block_of_sums(block: Sequence[Sum], last: str, dialect: Dialect) -> list[str]:
    """The lines summing a block's terms below k (j = 1..last-1), each from 0.0."""
    zero = dialect.broadcast("0.0")
    starts = [", ".join(f"{total.old} = {zero}" for total in block[i:i + 4])
              for i in range(0, len(block), 4)]
    declaration = [f"{dialect.value_type} {starts[0]}"]
    declaration += [" " * (len(dialect.value_type) + 1) + line for line in starts[1:]]
    head = f"TAYLOR_LOOP(j, 1, {last}, "
    loop = [head + block[0].term] + [" " * len(head) + total.term for total in block[1:]]
    return ([f"/* the terms below k of the next {len(block)} sum{'s' * (len(block) > 1)} */"]
            + [line + "," for line in declaration[:-1]] + [declaration[-1] + ";"]
            + loop[:-1] + [loop[-1] + ");"])


# Cauchy sums per order of each recurrence: what a program costs nemc.Taylor (sums and constant
# factors cost next to nothing)
SERIES_WEIGHTS = {"product": 1, "square": 0.5, "quotient": 1, "reciprocal": 1, "sincos": 2,
                  "sinhcosh": 2, "exp": 1, "log": 1, "power": 1}


def series_cost(program: Program, coordinates: Sequence[sympy.Symbol],
                speeds: Sequence[sympy.Symbol], time: sympy.Symbol) -> float:
    """The Cauchy sums per order of the program's coefficients (inf: unsupported)."""
    rows = {s: f"x{i}" for i, s in enumerate((*coordinates, *speeds))}
    try:
        return written_program(program, coordinates, speeds, rows, time, str).cost
    except TaylorUnsupported:
        return float("inf")


def guard(writer: SeriesWriter, step: Guard) -> None:
    """A singular articulated inertia is checked at the expansion point (coefficient 0)."""
    if writer.is_constant(step.value):
        writer.constants += writer.dialect.guard(writer.scalar(step.value), step.status, False)
        return
    value = writer.coefficient(step.value)
    writer.loop += writer.dialect.guard(value, step.status, True)


# ---- the sensitivity columns' coefficients: the tangent of the state's series -------------------


def taylor_tangent(program: Program, seeds: Mapping[sympy.Symbol, sympy.Symbol]) -> Program:
    """The forward-mode derivative of nemc.Taylor's program along seeds (a state entry or a
    parameter -> its tangent's symbol): its results are the accelerations' tangent, J_y s +
    J_p e for a column s along the parameters' direction e. Written in Taylor arithmetic after
    the program (column_series_code), it gives the Taylor coefficients of ds/dt from the
    state's and the column's: the column's series is the tangent of the state's."""
    return tangent_program(program, seeds, "tds")


def taylor_jacobian(program: Program, seeds: Mapping[sympy.Symbol, sympy.Symbol]
                    ) -> tuple[Program, Program] | None:
    """The columns' derivative through the accelerations' Jacobian J = [J_y | J_p], whose
    entries are functions of the state alone, the same for every column: (the program with J's
    entries as more steps, reverse accumulation of its tangent as
    templates/sensitivities.c.tmpl's dense product does; the columns' program, no steps, each
    result the row sum J_i [s; e] of J's entries times the seeds). In Taylor arithmetic a
    column then costs a Cauchy sum per entry of J_y that is not constant (J_p's, times the
    column's constant direction, no sum), where the forward tangent (taylor_tangent) costs
    about two per product of the program. None where a tangent step is not linear in the
    seeds."""
    tangent = taylor_tangent(program, seeds)
    tangents = frozenset({*seeds.values(), *(name for name, _ in tangent.assignments())})
    try:
        steps = [(name, linear_form(expr, tangents)) for name, expr in tangent.assignments()]
        results = [linear_form(result, tangents) for result in tangent.results]
    except NotLinear:
        return None
    builder = ProgramBuilder("tj")
    rows = [jacobian_row(steps, result, builder.let) for result in results]
    entries = builder.finish([entry for row in rows for entry in row.values()])
    sums = tuple(sympy.Add(*(entry * seed for seed, entry in row.items())) for row in rows)
    return (Program(program.steps + entries.steps, program.results), Program((), sums))


@dataclass(frozen=True)
class ColumnSeriesCode:
    """nemc.Taylor's coefficients of the state with its sensitivity columns
    (templates/taylor_sensitivities.c.tmpl): the state's program (`state`, its rows kept where
    a column's recurrence reads them), then one column's code, run for every column at each
    order, its rows in the column's own work (`declarations`), its constants (which may read
    the column's direction seed_p) computed once per expansion and column, before the loop."""

    state: SeriesCode
    n_series: int  # rows of a column's work array
    declarations: tuple[str, ...]  # `double *name = TAYLOR_ROW(ws, j);`
    constants: tuple[str, ...]  # before the loop, once per column
    constant_names: tuple[str, ...]  # the names those lines define
    loop: tuple[str, ...]  # a column's lines at order k, after the state's
    program_lines: int
    cost: float  # a column's Cauchy sums per order


def column_series_code(program: Program, tangent: Program, coordinates: Sequence[sympy.Symbol],
                       speeds: Sequence[sympy.Symbol], rows: Mapping[sympy.Symbol, str],
                       column_rows: Mapping[sympy.Symbol, str], time: sympy.Symbol,
                       scalar: Callable[[sympy.Expr], str]) -> ColumnSeriesCode:
    """The Taylor-coefficient code of the program and of its TANGENT (taylor_tangent) for one
    column. rows: each coordinate's and speed's row; column_rows: each state seed's row of the
    column (in the order of coordinates, then speeds, as rows). One writer records both, so
    the tangent's recurrences read the state's rows and share its named products; the column's
    parameter-only values and its direction seed_p are its constants. Raises
    TaylorUnsupported."""
    writer = written_program(program, coordinates, speeds, rows, time, scalar)
    split_loop, split_rows = len(writer.loop), len(writer.rows)
    split_constants, state_cost = len(writer.constants), writer.cost
    split_names = len(writer.constant_names)
    writer.series.update(column_rows)
    writer.varying.update(column_rows)
    written_steps(writer, tangent)
    column = list(column_rows.values())
    n = len(coordinates)
    next_coefficients(writer, list(zip(column[:n], column[n:])), tangent.results)
    kept = rows_read_back(writer.rows, writer.loop)
    local = frozenset(writer.rows) - set(kept)
    own = set(writer.rows[:split_rows])
    state_kept = [name for name in kept if name in own]
    column_kept = [name for name in kept if name not in own]
    start: tuple[str, ...] = ()
    if writer.uses_time:
        state_kept.append("tt")
        start = time_start(len(state_kept) - 1, SCALAR)
    state_loop, column_loop = writer.loop[:split_loop], writer.loop[split_loop:]
    state = SeriesCode(
        len(state_kept), tuple(row_declaration(name, j, SCALAR)
                               for j, name in enumerate(state_kept)),
        tuple(writer.constants[:split_constants]), tuple(writer.constant_names[:split_names]),
        start, tuple(sums_in_blocks(state_loop, local, SCALAR)), len(state_loop), state_cost)
    return ColumnSeriesCode(
        state, len(column_kept), tuple(f"double *{name} = TAYLOR_ROW(ws, {j});"
                                for j, name in enumerate(column_kept)),
        tuple(writer.constants[split_constants:]), tuple(writer.constant_names[split_names:]),
        tuple(sums_in_blocks(column_loop, local, SCALAR)), len(column_loop),
        writer.cost - state_cost)
