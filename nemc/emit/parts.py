"""Long programs printed as consecutive part functions (issue 5), and a very long model's part
functions in unit files of their own, compiled in parallel (issue 19).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import sympy

from ..derive.program import Program
from ..vocabulary import NEMC_VERSION as __version__
from .c_text import SymbolTablePrinter
from .optimize import Block
from .printing import (
    Caller,
    Parameter,
    Printed,
    has_guard,
    program_body,
    symbols_used,
    template,
)

# ---- long programs in parts (issue 5) ------------------------------------------------------
# gcc's register allocation is superlinear in a function's size: a program longer than
# CHUNK_STEPS steps is printed as consecutive part functions (templates/part.c.tmpl) of at most
# that many steps, which its caller runs in order. A value one part defines and a later part (or
# the results) uses travels through an array on the caller's stack; the operations are the
# same, so are the numbers. gcc CPU seconds for the model's C of a 32/64-body chain with the
# Jacobian: 11.8/33.8 in one body each, 3.6-3.9/6.1-7.0 with parts of 100 to 300 steps, 4.4/7.3
# with 400; the RHS costs the same or less (docs/decisions.md).

CHUNK_STEPS = 300


def split_steps(program: Program, chunk_steps: int) -> list[Program]:
    """Consecutive parts of at most chunk_steps steps, of near-equal size; the last part
    carries the results."""
    count = -(-program.size // chunk_steps)
    size = -(-program.size // count)
    steps = [program.steps[start : start + size] for start in range(0, program.size, size)]
    return [Program(part, ()) for part in steps[:-1]] + [Program(steps[-1], program.results)]


def passed_values(
    parts: list[Program], used_elsewhere: set[sympy.Symbol]
) -> list[sympy.Symbol]:
    """The values a part defines that a later part, or the code in used_elsewhere, reads."""
    read_later, passed = set(used_elsewhere), set()
    for part in reversed(parts):
        passed |= {name for name, _ in part.assignments() if name in read_later}
        read_later |= symbols_used(part)
    return [name for part in parts for name, _ in part.assignments() if name in passed]


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
