"""Emission: C source, its header (which is also the cffi declarations) and the runtime metadata,
from the templates.

The templates own the C: signatures, loops, memory layout. templates/model.h.tmpl is the one
description of the model's C interface: its functions, enums and run structure, and the layout
macros (Q(i), DQ(i), P(k), QDD(i), ...) through which printed code reads and writes its arrays;
its declarations are cut out verbatim as the cffi cdef. This module prints only straight-line
bodies of statements, through an explicit symbol table (coordinates -> Q(i), parameters -> P(k),
temporaries -> x<k>, ...), so no name from the YAML ever reaches C code; names appear only inside
comments, sanitized.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from string import Template
from typing import NamedTuple

import sympy

from ..derive.c_cost import estimated_ns
from ..derive.equations import (
    ADDITION_FORMULAS,
    ARTICULATED,
    LINEARIZED,
    MASS_MATRIX,
    DynamicsLayout,
    Equations,
    taylor_cost_ratio,
)
from ..derive.mass_form import rhs_solve_text
from ..derive.program import Guard, Program, prune
from ..derive.taylor import (
    LANES,
    SCALAR,
    TAYLOR_MAX_ORDER,
    Dialect,
    SeriesCode,
    TaylorUnsupported,
    series_code,
)
from ..front import mechanism as m
from ..vocabulary import AUTO_SPECTRUM_MAX_STATES
from ..vocabulary import NEMC_VERSION as __version__
from .angles import angle_calls
from .c_text import SymbolTablePrinter
from .optimize import Block, rewrite
from .resources import read_template
from .units import unit_metadata


@dataclass(frozen=True)
class Emitted:
    """The generated code of one model: C source and header, cffi declarations, metadata."""

    name: str
    c_source: str
    header: str
    cdef: str
    package_init: str
    metadata: dict
    spectrum: str  # the C of <name>_spectrum.c (method auto's look at the start)
    units: tuple[str, ...] = ()  # the C of <name>_unit<k>.c, k = 1, 2, ... (long programs' parts)
    rhs_call: str = ""  # the C of _rhs_call.c: Model.rhs's extension (templates/rhs_call.c.tmpl)
    drivers: str = ""  # the C of nemc_drivers.c: the native integrators (the same at one size)
    # the headers every model shares, by file name: nemc_run.h (in the cdef), nemc_drivers.h
    shared_headers: tuple[tuple[str, str], ...] = ()


def template(name: str) -> Template:
    return Template(read_template(name))


def comment_text(text: str) -> str:
    """Text safe inside a C block comment: printable ASCII, no comment terminator."""
    text = re.sub(r"[^\x20-\x7e]", "?", text)
    return text.replace("*/", "* /").replace("/*", "/ *")


def symbol_table(eqs: Equations, block: Block) -> dict[sympy.Symbol, str]:
    """Every symbol the printed code may meet -> its C: a layout macro of the header
    (templates/model.h.tmpl) for the arrays, its own name for a temporary."""
    names: dict[sympy.Symbol, str] = {m.TIME: "t"}
    for i, (q, u) in enumerate(zip(eqs.coordinates, eqs.speeds)):
        names[q], names[u] = f"Q({i})", f"DQ({i})"
    names.update({a: f"QDD({i})" for i, a in enumerate(eqs.accelerations)})
    names.update({s: f"P({k})" for k, s in enumerate(eqs.parameters)})
    names.update({s: f"FORCE({k})" for k, s in enumerate(eqs.generalized_forces)})
    names.update({s: f"DRIVE({j})" for j, s in enumerate(eqs.drives)})
    names.update({s: f"LAMBDA({k})" for k, s in enumerate(eqs.multipliers)})

    if eqs.seeds:
        for i, (q, u) in enumerate(zip(eqs.coordinates, eqs.speeds)):
            names[eqs.seeds[q]], names[eqs.seeds[u]] = f"SEED_Q({i})", f"SEED_DQ({i})"
    names.update({s: s.name for s, _ in block.temporaries})
    for program in (*block.programs.values(), eqs.taylor):
        if program is not None:
            names.update({s: s.name for s, _ in program.assignments()})
    return names


# ---- straight-line bodies --------------------------------------------------------------------


def needed(block: Block, exprs: tuple[sympy.Expr, ...]) -> list[tuple[sympy.Symbol, sympy.Expr]]:
    """The temporaries these expressions use, directly or through other temporaries, in order."""
    wanted = set().union(*(sympy.sympify(e).free_symbols for e in exprs)) if exprs else set()
    for sym, expr in reversed(block.temporaries):
        if sym in wanted:
            wanted |= expr.free_symbols
    return [(s, e) for s, e in block.temporaries if s in wanted]


def body(
    printer: SymbolTablePrinter, block: Block, targets: list[tuple[str, sympy.Expr]]
) -> str:
    """Straight-line C: the temporaries the targets need, then `target = expression;`."""
    lines = [
        f"    const double {printer.doprint(s)} = {printer.doprint(e)};"
        for s, e in needed(block, tuple(e for _, e in targets))
    ]
    lines += [f"    {target} = {printer.doprint(expr)};" for target, expr in targets]
    return "\n".join(lines)


def program_body(
    printer: SymbolTablePrinter, program: Program, results: str | Sequence[str],
    indent: str = "    ", passed: dict[sympy.Symbol, str] | None = None,
) -> str:
    """Straight-line C of a program: its named steps, its guards, then `results(i) = ...;`
    (results: a layout macro), or `results[i] = ...;` (results: a target per result).
    passed: the names to hand on to other functions, each copied there right after its step."""
    targets = ([f"{results}({i})" for i in range(len(program.results))]
               if isinstance(results, str) else list(results))
    passed = passed or {}
    lines = []
    for step in program.steps:
        if isinstance(step, Guard):
            lines.append(f"{indent}if (!({printer.doprint(step.value)} > 0.0))")
            lines.append(f"{indent}    return {step.status};")
        else:
            lines.append(f"{indent}const double {step[0].name} = {printer.doprint(step[1])};")
            if step[0] in passed:
                lines.append(f"{indent}{passed[step[0]]} = {step[0].name};")
    lines += [f"{indent}{target} = {printer.doprint(expr)};"
              for target, expr in zip(targets, program.results)]
    return "\n".join(lines)


def indexed(array: str, exprs: tuple[sympy.Expr, ...]) -> list[tuple[str, sympy.Expr]]:
    return [(f"{array}[{k}]", expr) for k, expr in enumerate(exprs)]


# ---- long programs in parts (issue 5) ------------------------------------------------------
# gcc's register allocation is superlinear in a function's size: a program longer than
# CHUNK_STEPS steps is printed as consecutive part functions (templates/part.c.tmpl) of at most
# that many steps, which its caller runs in order. A value one part defines and a later part (or
# the results) uses travels through an array on the caller's stack; the operations are the
# same, so are the numbers. gcc CPU seconds for the model's C of a 32/64-body chain with the
# Jacobian: 11.8/33.8 in one body each, 3.6-3.9/6.1-7.0 with parts of 100 to 300 steps, 4.4/7.3
# with 400; the RHS costs the same or less (docs/decisions.md).

CHUNK_STEPS = 300

Parameter = tuple[str, str]  # (C type, name) of a function parameter


@dataclass(frozen=True)
class Printed:
    """A program printed as C: the functions that go before its caller, the caller's body."""

    functions: str
    body: str


@dataclass(frozen=True)
class Caller:
    """Where a program is printed: the function running it, its inputs, where results go."""

    function: str  # the part functions are <function>_part<k>
    what: str  # what the program computes, for the parts' comments
    inputs: tuple[Parameter, ...]  # the parameters the program's expressions may read
    results: tuple[str, str]  # (layout macro the results are written through, its array)
    array: str  # the array passing values from part to part
    indent: str = "    "
    targets: tuple[str, ...] = ()  # where each result goes, when not results[0](i)

    @property
    def writes(self) -> str | tuple[str, ...]:
        return self.targets or self.results[0]


def split_steps(program: Program, chunk_steps: int) -> list[Program]:
    """Consecutive parts of at most chunk_steps steps, of near-equal size; the last part
    carries the results."""
    count = -(-program.size // chunk_steps)
    size = -(-program.size // count)
    steps = [program.steps[start : start + size] for start in range(0, program.size, size)]
    return [Program(part, ()) for part in steps[:-1]] + [Program(steps[-1], program.results)]


def symbols_used(program: Program) -> set[sympy.Symbol]:
    used: set[sympy.Symbol] = set()
    for step in program.steps:
        used |= (step.value if isinstance(step, Guard) else step[1]).free_symbols
    for result in program.results:
        used |= sympy.sympify(result).free_symbols
    return used


def passed_values(
    parts: list[Program], used_elsewhere: set[sympy.Symbol]
) -> list[sympy.Symbol]:
    """The values a part defines that a later part, or the code in used_elsewhere, reads."""
    read_later, passed = set(used_elsewhere), set()
    for part in reversed(parts):
        passed |= {name for name, _ in part.assignments() if name in read_later}
        read_later |= symbols_used(part)
    return [name for part in parts for name, _ in part.assignments() if name in passed]


def has_guard(program: Program) -> bool:
    return any(isinstance(step, Guard) for step in program.steps)


class PartNames(Mapping[sympy.Symbol, str]):
    """The C names a part function reads its values by: a value another part defined is read
    from the array it was passed through, every other one by the table's name (a view, not a
    copy: each of a 1000-body chain's 400 parts copied a table of 115,000 names)."""

    def __init__(self, table: Mapping[sympy.Symbol, str], passed: Mapping[sympy.Symbol, str],
                 defined_here: frozenset[sympy.Symbol]):
        self.table, self.passed, self.defined_here = table, passed, defined_here

    def __getitem__(self, symbol: sympy.Symbol) -> str:
        found = self.passed.get(symbol)
        if found is not None and symbol not in self.defined_here:
            return found
        return self.table[symbol]

    def __iter__(self) -> Iterator[sympy.Symbol]:
        return iter({**self.table, **self.passed})

    def __len__(self) -> int:
        return len({**self.table, **self.passed})


def part_function(
    printer: SymbolTablePrinter, part: Program, caller: Caller, number: int, count: int,
    passed: dict[sympy.Symbol, str], storage: str = "static ",
) -> str:
    """One part as a function (static, unless it goes to a unit file of its own: storage "");
    it returns a guard's status when it has guards."""
    names = [name for name, _ in part.assignments()]
    part_printer = printer.with_table(PartNames(printer.names, passed, frozenset(names)))
    mine = {name: passed[name] for name in names if name in passed}
    text = program_body(part_printer, part, caller.writes if part.results else caller.results[0],
                        passed=mine)
    parameters = part_parameters(part, caller)
    guarded = has_guard(part)
    return template("part.c.tmpl").substitute(
        what=caller.what, number=number, count=count,
        steps=f"{names[0].name} to {names[-1].name}" if names else "no named steps",
        storage=storage, signature=part_signature(part, caller, number),
        unused=" ".join(f"(void){name};" for _, name in parameters),
        body=text, finish="\n    return 0;" if guarded else "",
    )


def part_parameters(part: Program, caller: Caller) -> list[Parameter]:
    parameters = [*caller.inputs, ("double *", caller.array)]
    return parameters + [("double *", caller.results[1])] if part.results else parameters


def part_signature(part: Program, caller: Caller, number: int) -> str:
    """`int accelerations_part3(double t, ...)`: what a part function returns, its name and its
    parameters."""
    parameters = ", ".join(f"{ctype}{'' if ctype.endswith('*') else ' '}{name}"
                           for ctype, name in part_parameters(part, caller))
    return_type = "int" if has_guard(part) else "void"
    return f"{return_type} {caller.function}_part{number}({parameters})"


def part_calls(parts: list[Program], caller: Caller, n_passed: int) -> str:
    """The caller's body: the array, then each part in order, returning a non-zero status."""
    arguments = ", ".join([*(name for _, name in caller.inputs), caller.array])
    indent = caller.indent
    lines = [f"{indent}double {caller.array}[{max(n_passed, 1)}];"
             " /* intermediates passed between the parts */"]
    if any(has_guard(part) for part in parts):
        lines.append(f"{indent}int status;")
    for number, part in enumerate(parts, start=1):
        last = f", {caller.results[1]}" if number == len(parts) else ""
        call = f"{caller.function}_part{number}({arguments}{last});"
        if has_guard(part):
            lines += [f"{indent}status = {call}", f"{indent}if (status)",
                      f"{indent}    return status;"]
        else:
            lines.append(f"{indent}{call}")
    return "\n".join(lines)


def in_parts(
    printer: SymbolTablePrinter, program: Program, caller: Caller, chunk_steps: int,
    used_elsewhere: set[sympy.Symbol] | None = None, units: Units | None = None,
) -> tuple[Printed, dict[sympy.Symbol, str]]:
    """The program as part functions and the calls to them; also the array entry of each value
    passed, for code elsewhere that reads them (used_elsewhere). With units, the part
    functions go there (files of their own) and only their prototypes here."""
    parts = split_steps(program, chunk_steps)
    values = passed_values(parts, used_elsewhere or set())
    passed = {name: f"{caller.array}[{k}]" for k, name in enumerate(values)}
    if units is not None:
        caller = dataclasses.replace(caller, function=units.prefix + caller.function)
    functions = [part_function(printer, part, caller, number, len(parts), passed,
                               "static " if units is None else "")
                 for number, part in enumerate(parts, start=1)]
    calls = part_calls(parts, caller, len(values))
    if units is None:
        return Printed("".join(functions), calls), passed
    units.functions += [(text, part.size + len(part.results))
                        for text, part in zip(functions, parts)]
    prototypes = [f"{part_signature(part, caller, number)}; /* in a unit file of its own */"
                  for number, part in enumerate(parts, start=1)]
    return Printed("\n" + "\n".join(prototypes) + "\n", calls), passed


def print_program(
    printer: SymbolTablePrinter, program: Program, caller: Caller, chunk_steps: int,
    units: Units | None = None,
) -> Printed:
    """One body when the program is short, parts when it is long."""
    if program.size <= chunk_steps:
        return Printed("", program_body(printer, program, caller.writes, caller.indent))
    return in_parts(printer, program, caller, chunk_steps, units=units)[0]


# ---- very long programs in several files (issue 19) ----------------------------------------
# gcc compiles one file on one core: a model whose programs have more than UNIT_STEPS steps in
# all puts its part functions in files of their own, <name>_unit<k>.c of about UNIT_FILE_STEPS
# steps each, which nemc.build compiles in parallel on the available cores (the same functions,
# no longer static: the same numbers). Smaller models keep their one file.

UNIT_STEPS = 3000
UNIT_FILE_STEPS = 2400


@dataclass
class Units:
    """The part functions bound for unit files: (C text, its steps and results) in order."""

    prefix: str  # the model's C prefix: the part functions' names, no longer static, carry it
    functions: list[tuple[str, int]] = dataclasses.field(default_factory=list)

    def files(self, name: str) -> tuple[str, ...]:
        """The unit files' C, each about UNIT_FILE_STEPS steps of consecutive functions."""
        groups: list[list[str]] = [[]]
        steps = 0
        for text, size in self.functions:
            if groups[-1] and steps + size > UNIT_FILE_STEPS:
                groups.append([])
                steps = 0
            groups[-1].append(text)
            steps += size
        return tuple(template("unit.c.tmpl").substitute(
            name=name, version=__version__, number=k, count=len(groups),
            functions="".join(group)) for k, group in enumerate(groups, start=1) if group)


def needs_units(block: Block, chunk_steps: int) -> bool:
    """Whether the model's programs are long enough to be compiled in several files."""
    steps = sum(program.size for program in block.programs.values())
    return steps > max(UNIT_STEPS, 2 * chunk_steps)


STATE_INPUTS: tuple[Parameter, ...] = (("double", "t"), ("const double *", "y"),
                                       ("const double *", "p"))
DYNAMICS = Caller("accelerations", "The accelerations", STATE_INPUTS, ("QDD", "qdd"), "v")
AUGMENTED = Caller("accelerations", "The accelerations, drives and unit passes",
                   STATE_INPUTS, ("ACC", "acc"), "v")
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
) -> tuple[Printed, Printed]:
    """The primal (run once) and its tangent (once per column): in parts when either is long,
    the primal then also passing on every value the tangent reads. The tangent's sums are
    printed in sympy's canonical order of their terms (order "none"), not sorted for print,
    more than half of printing's time; the primal, as the RHS, keeps the sorted order and its
    bits (docs/decisions.md, "Printing order")."""
    angles = angles_c(eqs, printer, primal, tangent)
    assert angles.reader is not None
    tangent = angles.reader
    if max(primal.size, tangent.size) <= chunk_steps:
        return (Printed("", angles.prologue + program_body(angles.printer, angles.program,
                                                           PRIMAL.results[0])),
                Printed("", program_body(angles.printer.with_names({}, order="none"), tangent,
                                         TANGENT.results[0], TANGENT.indent)))
    primal_code, passed = in_parts(angles.printer, angles.program, angles.caller(PRIMAL),
                                   chunk_steps, symbols_used(tangent), units)
    tangent_printer = angles.printer.with_names(passed, order="none")
    return (Printed(primal_code.functions, angles.prologue + primal_code.body),
            in_parts(tangent_printer, tangent, angles.caller(TANGENT), chunk_steps,
                     units=units)[0])


# ---- the sections of the C source ------------------------------------------------------------


def outputs_section(eqs: Equations, block: Block, printer: SymbolTablePrinter, prefix: str) -> str:
    """The scene's outputs, or the function saying the scene asks for none. A model with drives
    or loops computes them at its state brought onto the constraints, with its accelerations,
    multipliers and drives."""
    if not eqs.outputs:
        return template("outputs_absent.c.tmpl").substitute(prefix=prefix)
    exprs = block.groups["outputs"]
    if eqs.layout is not None and eqs.layout.augmented:
        state, before = "given", read_template("consistent_dynamics.c.tmpl")
    else:
        uses_qdd = any(s in eqs.accelerations for e in exprs for s in _all_symbols(block, e))
        state, before = "y", read_template("accelerations.c.tmpl") if uses_qdd else ""
    return template("outputs.c.tmpl").substitute(
        prefix=prefix, state=state,
        output_names=comment_text(", ".join(name for name, _ in eqs.outputs)),
        accelerations=before,
        outputs=body(printer, block, indexed("out", exprs)),
    )


def dynamics_targets(layout: DynamicsLayout) -> tuple[str, ...]:
    """Where each result of an augmented dynamics program goes (DynamicsLayout's order)."""
    n, d = layout.coordinates, layout.drives
    targets = [f"ACC_QDD({i})" for i in range(n)] + [f"ACC_DRIVE({j})" for j in range(d)]
    for k in range(layout.equations):
        targets += [f"ACC_UNIT_QDD({k}, {i})" for i in range(n)]
        targets += [f"ACC_UNIT_DRIVE({k}, {j})" for j in range(d)]
    m = layout.equations
    targets += [f"ACC_BIAS({k})" for k in range(m)] + [f"ACC_PHI({k})" for k in range(m)]
    targets += [f"ACC_PHI_Q({k}, {i})" for k in range(m) for i in range(n)]
    return tuple(targets + [f"ACC_PHI_T({k})" for k in range(m)])


@dataclass(frozen=True)
class Phases:
    """A loop's program in two phases: what depends on the positions only, then what the rates
    add; the names of the first that the second reads are passed."""

    positions: Program
    position_targets: tuple[str, ...]
    rates: Program
    rate_targets: tuple[str, ...]
    passed: tuple[sympy.Symbol, ...]


def split_by_rates(program: Program, targets: Sequence[str], rates: set[sympy.Symbol]
                   ) -> Phases:
    """The program's steps and results by whether they depend on the rates (directly or
    through earlier steps)."""
    moving: set[sympy.Symbol] = set(rates)
    first: list = []
    second: list = []
    for step in program.steps:
        expr = step.value if isinstance(step, Guard) else step[1]
        if expr.free_symbols & moving:
            second.append(step)
            if not isinstance(step, Guard):
                moving.add(step[0])
        else:
            first.append(step)
    late = [bool(sympy.sympify(r).free_symbols & moving) for r in program.results]
    rate_results = tuple(r for r, is_late in zip(program.results, late) if is_late)
    rates_program = Program(tuple(second), rate_results)
    needed = symbols_used(rates_program)
    position_results = tuple(r for r, is_late in zip(program.results, late) if not is_late)
    keep = Program(tuple(first), (*position_results, *needed)).pruned()
    positions = Program(keep.steps, position_results)
    passed = tuple(name for name, _ in positions.assignments() if name in needed)
    return Phases(positions, tuple(t for t, is_late in zip(targets, late) if not is_late),
                  rates_program, tuple(t for t, is_late in zip(targets, late) if is_late),
                  passed)


def phased_functions(printer: SymbolTablePrinter, phases: Phases) -> str:
    """The two phases as C (templates/loop_phases.c.tmpl)."""
    slots = {name: f"passed[{k}]" for k, name in enumerate(phases.passed)}
    positions = program_body(printer, phases.positions, phases.position_targets,
                             passed=slots)
    rates = program_body(SymbolTablePrinter({**printer.names, **slots}), phases.rates,
                         phases.rate_targets)
    return template("loop_phases.c.tmpl").substitute(
        n_passed=max(len(phases.passed), 1), positions=positions, rates=rates)


# A tree's accelerations() is inlined into its callers (the RHS, the outputs) when its program
# is estimated at most this many ns (c_cost.estimated_ns) and is not in parts: a call's fixed
# cost, ~3 ns, then weighs. Measured with the RHS called through a pointer, as the drivers call
# it, its evaluations chained: the double pendulum (21 ns estimated) 37.4 -> 34.3 ns, a 3-link
# chain (45) 72.5 -> 68.4, the T pendulum (10) 34.3 -> 31.9; a 4-link chain (80) 101.7 -> 104.5
# (docs/decisions.md, "The accelerations inlined into a small right-hand side").
INLINE_DYNAMICS_NS = 60.0


def dynamics_section(eqs: Equations, block: Block, printer: SymbolTablePrinter, prefix: str,
                     chunk_steps: int, units: Units | None = None,
                     primal: Printed | None = None) -> str:
    """The right-hand side: a tree's (templates/tree.c.tmpl), or with drives or loops the
    articulated-body program with its unit passes, the multipliers and the projection onto
    the constraints (templates/loops.c.tmpl). PRIMAL: the Jacobian's primal in parts, which
    the tree's accelerations run (shares_primal)."""
    program = block.programs["dynamics"]
    if eqs.layout is None or not eqs.layout.augmented:
        dynamics = primal
        if dynamics is None:
            angles = angles_c(eqs, printer, program)
            printed = print_program(angles.printer, angles.program, angles.caller(DYNAMICS),
                                    chunk_steps, units)
            dynamics = Printed(printed.functions, angles.prologue + printed.body)
        form = DYNAMICS_FORMS[eqs.dynamics_form]
        inline = not dynamics.functions and estimated_ns(eqs.dynamics) <= INLINE_DYNAMICS_NS
        return template("tree.c.tmpl").substitute(
            prefix=prefix, dynamics_parts=dynamics.functions, dynamics=dynamics.body,
            dynamics_form=form.label, singular_k=form.singular,
            linkage="static inline __attribute__((always_inline))" if inline else "static")
    targets = dynamics_targets(eqs.layout)
    if eqs.loops is not None:
        functions = phased_functions(printer, split_by_rates(program, targets,
                                                             set(eqs.speeds)))
    else:
        caller = dataclasses.replace(AUGMENTED, targets=targets)
        dynamics = print_program(printer, program, caller, chunk_steps, units)
        functions = template("accelerations_augmented.c.tmpl").substitute(
            dynamics_parts=dynamics.functions, dynamics=dynamics.body)
    return template("loops.c.tmpl").substitute(
        prefix=prefix, dynamics_functions=functions,
        constraint_values=constraint_values(eqs, block, printer))


@dataclass(frozen=True)
class AnglesC:
    """A program whose sines and cosines of its angles are computed first, together
    (nemc/angles.py): the program reading them, its printer, the lines that compute them."""

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


def constraint_values(eqs: Equations, block: Block, printer: SymbolTablePrinter) -> str:
    """PHI, PHI_Q and PHI_T of the loop constraints (empty without loops)."""
    if eqs.loops is None:
        return ""
    count, n = eqs.loops.count, eqs.n
    exprs = block.groups["constraints"]
    targets = ([f"PHI({k})" for k in range(count)]
               + [f"PHI_Q({k}, {i})" for k in range(count) for i in range(n)]
               + [f"PHI_T({k})" for k in range(count)])
    return body(printer, block, list(zip(targets, exprs)))


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


def _all_symbols(block: Block, expr: sympy.Expr) -> set[sympy.Symbol]:
    found = set(sympy.sympify(expr).free_symbols)
    for _, temp in needed(block, (expr,)):
        found |= temp.free_symbols
    return found


def header(eqs: Equations, prefix: str) -> str:
    """The model's C interface (templates/model.h.tmpl)."""
    mech = eqs.mechanism
    return template("model.h.tmpl").substitute(
        name=mech.name, version=__version__, source=comment_text(mech.source),
        source_hash=mech.source_hash, prefix=prefix, n_coord=eqs.n, n_state=2 * eqs.n,
        n_param=len(eqs.parameters), n_output=len(eqs.outputs), n_drive=len(eqs.drives),
        n_lambda=len(eqs.multipliers),
        n_event=len(eqs.events),
        event_names=comment_text(", ".join(event.name for event in eqs.events)),
        parameter_names=comment_text(", ".join(s.name for s in eqs.parameters)),
        state_names=comment_text(", ".join(mech.state_names)),
        equation_names=comment_text(", ".join(equation_labels(eqs))),
        spectrum_max_states=AUTO_SPECTRUM_MAX_STATES,
    )


def equation_labels(eqs: Equations) -> list[str]:
    """Each constraint equation as `constraint[k]`, for comments and messages."""
    owners = eqs.loops.owners if eqs.loops is not None else ()
    return [f"{name}[{owners[:i].count(name)}]" for i, name in enumerate(owners)]


CDEF = re.compile(r"/\* NEMC_CDEF_BEGIN \*/\n(.*)/\* NEMC_CDEF_END \*/", re.DOTALL)


def cdef(*header_texts: str) -> str:
    """The cffi declarations: the headers' texts between their NEMC_CDEF markers, verbatim,
    in order."""
    return "".join(CDEF.search(text).group(1)  # type: ignore[union-attr]
                   for text in header_texts)


class FormText(NamedTuple):
    """How the C describes a form of the dynamics program (derive.fastest_dynamics)."""

    label: str  # accelerations()'s comment
    account: str  # the file's header
    singular: str  # what the guard's status k + 1 means


ARTICULATED_LINES = (
    "The accelerations come from the articulated-body algorithm (Featherstone) in planar form,",
    "written out for this mechanism's joint tree as straight-line code: velocities from the",
    "ground out, articulated inertias and bias forces back to the ground, accelerations out",
    "again. Each w<k> is one named intermediate; the cost grows linearly with the bodies.")
MASS_MATRIX_LINES = (
    "The accelerations solve the mass-matrix form M(q) qdd = f(t, q, dq) (Newton-Euler per",
    "body, projected on the joints' free directions), written out as straight-line code: the",
    "entries' common subexpressions named m<k>, then M solved",
    "{solve}.",
    "On so few coordinates this was estimated faster than the articulated-body algorithm",
    "(nemc/c_cost.py).")

LINEARIZED_LINE = "M's and f's entries are linearized in sines and cosines (sin^2 + cos^2 = 1)."
ADDITION_LINE = ("The sines and cosines of sums of angles come from those of their parts (the "
                 "addition formulas).")
PIVOT = "pivot k of M's LDL^T (0-based, in coordinate order) is not positive"
DYNAMICS_FORMS = {
    ARTICULATED: FormText("articulated-body algorithm", "\n * ".join(ARTICULATED_LINES),
                          "the articulated inertia through joint k (0-based, in file order) is "
                          "not positive"),
    MASS_MATRIX: FormText("mass-matrix form", "\n * ".join(MASS_MATRIX_LINES), PIVOT),
    LINEARIZED: FormText("mass-matrix form, linearized",
                         "\n * ".join((*MASS_MATRIX_LINES, LINEARIZED_LINE)), PIVOT),
    ADDITION_FORMULAS: FormText(
        "mass-matrix form, linearized, addition formulas",
        "\n * ".join((*MASS_MATRIX_LINES, LINEARIZED_LINE, ADDITION_LINE)), PIVOT),
}


def c_source(eqs: Equations, block: Block, prefix: str, chunk_steps: int,
             units: Units | None = None) -> str:
    mech, printer = eqs.mechanism, SymbolTablePrinter(symbol_table(eqs, block))
    shared = (jacobian_programs(eqs, printer, block.programs["dynamics"],
                                block.programs["jacobian"], chunk_steps, units)
              if shares_primal(eqs, block, chunk_steps) else None)
    dynamics = dynamics_section(eqs, block, printer, prefix, chunk_steps, units,
                                shared and shared[0])
    jacobian = jacobian_section(eqs, block, printer, prefix, chunk_steps, units, shared)
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
        outputs_section=outputs_section(eqs, block, printer, prefix),
        jacobian_section=jacobian,
        loops_absent="" if eqs.loops is not None else
        template("loops_absent.c.tmpl").substitute(prefix=prefix),
    ) + events_section(eqs, block, printer, prefix)


def generated_functions(eqs: Equations) -> list[str]:
    """The parts a model's build has: outputs, jacobian and mass_matrix only when needed (the
    header declares every function; those of a part not built return NEMC_NOT_BUILT)."""
    jacobian = ["jacobian"] if has_jacobian(eqs) else []
    mass_matrix = ["mass_matrix"] if eqs.inverse_mass is not None else []
    outputs = ["outputs"] if eqs.outputs else []
    return ["rhs", "rhs_many", "checks", "initial_state"] + outputs + jacobian + mass_matrix


def coordinate_kinds(mech: m.Mechanism) -> list[str]:
    """"angle" or "length" for each coordinate (plots show angles in degrees)."""
    return [kind for joint in mech.joints for kind in joint.coordinate_kinds]


def metadata(eqs: Equations, prefix: str) -> dict:
    mech, sim = eqs.mechanism, eqs.mechanism.simulation
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
        "parameter_names": [s.name for s in eqs.parameters],
        "parameter_defaults": list(eqs.parameter_defaults),
        "derived_parameters": {name: str(expr) for name, expr in eqs.derived_parameters},
        "check_names": [key for key, _ in eqs.checks],
        "output_names": [name for name, _ in eqs.outputs],
        "generated": generated_functions(eqs),
        "dynamics_program": eqs.dynamics_form,
        "drive_names": [joint.name for joint in mech.driven],
        "constraint_equations": list(eqs.loops.owners) if eqs.loops is not None else [],
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


# ---- events (format v2, simulation.events) ----------------------------------------------------

EVENT_DIRECTIONS = {"falling": "NEMC_FALLING", "both": "NEMC_BOTH", "rising": "NEMC_RISING"}
EVENT_ACTIONS = {"record": "NEMC_RECORD", "stop": "NEMC_STOP", "impact": "NEMC_IMPACT"}


def event_metadata(eqs: Equations) -> list[dict]:
    """Each event's name, direction, action and the states its impact law sets (model.json)."""
    return [{"name": event.name, "direction": event.direction, "action": event.action,
             "sets": [name for name, _ in event.law]} for event in eqs.events]


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
    )


# ---- native integrators (issue 9): appended to every model's C -------------------------------


def native_section(eqs: Equations, prefix: str, taylor: str, lanes: str = "") -> str:
    """The model's side of the native integrators in <name>.c: nemc.Taylor's code (the model's
    own coefficients) only in builds that ask for it, its ensembles in SIMD lanes (lanes:
    templates/batch.c.tmpl, else batch_absent.c.tmpl) only when asked, and the model's entry
    points, which hand its functions to the drivers (drivers_source)."""
    entry = template("integrators_entry.c.tmpl").substitute(
        name=eqs.mechanism.name, prefix=prefix, jacobian=jacobian_function(eqs, prefix)
    )
    batch = lanes or template("batch_absent.c.tmpl").substitute(prefix=prefix)
    return "\n" + taylor + entry + batch


def drivers_source(eqs: Equations) -> str:
    """nemc_drivers.c: the model-independent integrators, run control and ensembles' loop for
    a model of N_STATE states (templates/drivers.c.tmpl). Radau only in builds with the
    Jacobian: it halves the compile time the integrators add elsewhere. The text names no
    model, so models of one size (and Jacobian or not) share one compiled object (nemc/build.py,
    drivers_object)."""
    radau = has_jacobian(eqs)
    return template("drivers.c.tmpl").substitute(
        version=__version__, n_state=2 * eqs.n, radau_note=" (with the Jacobian)" if radau else "",
        radau_name=", Radau" if radau else "",
        run_control=read_template("run_control.c.tmpl"),
        integrators=read_template("integrators.c.tmpl"),
        radau=read_template("radau.c.tmpl") if radau else "")


def shared_headers() -> tuple[tuple[str, str], ...]:
    """The headers every model's package holds, the same in each: nemc_run.h, the C interface
    all models share (its cdef comes first), and nemc_drivers.h, what <name>.c and
    nemc_drivers.c share."""
    return (("nemc_run.h", template("nemc_run.h.tmpl").substitute(version=__version__)),
            ("nemc_drivers.h", template("drivers.h.tmpl").substitute(version=__version__)))


def has_jacobian(eqs: Equations) -> bool:
    """Whether the build has the Jacobian (exact, or differences for loops)."""
    return eqs.jacobian is not None or eqs.jacobian_by_differences


def jacobian_function(eqs: Equations, prefix: str) -> str:
    """The C of the Jacobian function a driver is given: the build's, or NULL without it."""
    return f"{prefix}jacobian" if has_jacobian(eqs) else "NULL"


def spectrum_source(eqs: Equations, prefix: str) -> str:
    """<name>_spectrum.c: method auto's look at the start (templates/spectrum.c.tmpl), in a
    file of its own that the build compiles in parallel with <name>.c."""
    return template("spectrum_unit.c.tmpl").substitute(
        name=eqs.mechanism.name, version=__version__, prefix=prefix,
        spectrum=read_template("spectrum.c.tmpl"), jacobian=jacobian_function(eqs, prefix),
        spectrum_max_states=AUTO_SPECTRUM_MAX_STATES)


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
    return TaylorC(source, None)


def scalar_constants(code: SeriesCode) -> str:
    """taylor_coefficients' array of the constants its loop reads (taylor_coefficient_k's)."""
    names = constants_read(code)
    if not names:
        return "const double *constants = NULL;"
    return f"const double constants[{len(names)}] = {{{', '.join(names)}}};"


KERNEL_INLINE = "static inline __attribute__((always_inline))"


def sincos_kernel(prefix: str, vector: str, bits: str, what: str) -> str:
    """The branch-free sin and cos (templates/sincos.c.tmpl) over one GCC vector type."""
    return template("sincos.c.tmpl").substitute(prefix=prefix, vec=vector, bits=bits, what=what,
                                                inline=KERNEL_INLINE)


def taylor_math(prefix: str, vector: str, bits: str, what: str) -> str:
    """nemc.Taylor's sin, cos, log2 and exp2 (templates/taylor_math.c.tmpl) over one GCC vector
    type: the scalar code's one-element vectors and the SIMD lanes' compute the same bits."""
    return template("taylor_math.c.tmpl").substitute(
        prefix=prefix, vec=vector, bits=bits, what=what, inline=KERNEL_INLINE,
        sincos=sincos_kernel(prefix, vector, bits, what))


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


# ---- the drawing's point positions (issue 20): appended to every model's C ------------------


POSITIONS = Caller("positions", "The drawing's point positions", STATE_INPUTS, ("POINT", "xy"),
                  "v", indent=" " * 8)


def positions_part(eqs: Equations, block: Block, prefix: str, chunk_steps: int,
                   units: Units | None = None) -> tuple[str, dict]:
    """The C of `<name>_positions` (declared in templates/model.h.tmpl: the ground positions of
    the points nemc.geometry's drawing needs) and the drawing's structure for model.json. The
    positions are a straight-line program placing each body once from its parent (linear in the
    number of bodies)."""
    from ..derive.articulated import PointPositions
    from ..derive.equations import runtime_values
    from ..derive.geometry import drawing
    from .optimize import rewrite_program

    places = PointPositions(eqs.mechanism, runtime_values(eqs.mechanism))
    picture = drawing(eqs.mechanism, places.position)
    program = rewrite_program(places.prog.finish(
        [v for _, x, y in picture.points for v in (x, y)]))
    names = {**symbol_table(eqs, block), **{s: s.name for s, _ in program.assignments()}}
    targets = [f"{('POINT_X', 'POINT_Y')[k % 2]}({k // 2})" for k in range(len(program.results))]
    positions = print_program(SymbolTablePrinter(names), program,
                              dataclasses.replace(POSITIONS, targets=tuple(targets)), chunk_steps,
                              units)
    source = template("positions.c.tmpl").substitute(
        prefix=prefix, n_points=len(picture.points), n_values=2 * len(picture.points),
        point_names=comment_text(", ".join(name for name, _, _ in picture.points)),
        positions_parts=positions.functions, positions=positions.body,
    )
    return source, picture.metadata()


def emit(eqs: Equations, block: Block, chunk_steps: int | None = None,
         lanes: int = 0, fma: bool = False) -> Emitted:
    """chunk_steps: the most steps of a program printed as one function (CHUNK_STEPS);
    lanes: also nemc.Taylor's ensembles in SIMD lanes, this many per batch (when Taylor's code
    is built); 0: none. fma: nemc.Taylor's multiply-adds fused (a CPU with FMA builds it:
    build.fma_available)."""
    prefix = f"{eqs.mechanism.name}_"
    printer = SymbolTablePrinter(symbol_table(eqs, block))
    taylor_c = taylor_section(eqs, printer, fma)
    taylor, taylor_unavailable = taylor_c.source, taylor_c.unavailable
    lanes_c = lanes_section(eqs, printer, prefix, lanes) if lanes and taylor else ""
    info = metadata(eqs, prefix)
    info.update(unit_metadata(eqs.mechanism, info["output_names"]))
    chunk_steps = chunk_steps or CHUNK_STEPS
    units = Units(prefix) if needs_units(block, chunk_steps) else None
    positions_c, info["drawing"] = positions_part(eqs, block, prefix, chunk_steps, units)
    if taylor:
        info["generated"].append("taylor")
        info["taylor_program"] = eqs.taylor_form
        info["taylor_cost_ratio"] = round(taylor_cost_ratio(eqs), 3)
        info["fma"] = fma
    if lanes_c:
        info["generated"].append("lanes")
        info["lane_count"] = lanes
    if taylor_unavailable:
        info["taylor_unavailable"] = info["lanes_unavailable"] = taylor_unavailable
    interface = header(eqs, prefix)
    headers = shared_headers()
    return Emitted(
        name=eqs.mechanism.name,
        c_source=c_source(eqs, block, prefix, chunk_steps, units)
        + native_section(eqs, prefix, taylor, lanes_c) + positions_c,
        units=units.files(eqs.mechanism.name) if units is not None else (),
        spectrum=spectrum_source(eqs, prefix),
        header=interface,
        cdef=cdef(dict(headers)["nemc_run.h"], interface),
        package_init=template("package_init.py.tmpl").substitute(
            name=eqs.mechanism.name, version=__version__
        ),
        metadata=info,
        rhs_call=template("rhs_call.c.tmpl").substitute(
            name=eqs.mechanism.name, prefix=prefix, version=__version__
        ),
        drivers=drivers_source(eqs),
        shared_headers=headers,
    )

