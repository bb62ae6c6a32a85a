"""Programs and expressions printed as straight-line C statements, and the templates they go in.

The templates own the C: signatures, loops, memory layout. templates/model.h.tmpl is the one
description of the model's C interface: its functions, enums and run structure, and the layout
macros (Q(i), DQ(i), P(k), QDD(i), ...) through which printed code reads and writes its arrays;
its declarations are cut out verbatim as the cffi cdef (interface.py). The emitter prints only
straight-line bodies of statements, through an explicit symbol table (coordinates -> Q(i),
parameters -> P(k), temporaries -> x<k>, ...), so no name from the YAML ever reaches C code;
names appear only inside comments, sanitized. A long program is printed in parts (parts.py);
`Caller` says where a program is printed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy

from ..derive.equations import Equations
from ..derive.program import Guard, Program
from ..front import mechanism as m
from .c_text import SymbolTablePrinter
from .optimize import Block
from .resources import comment_text, read_template, template  # noqa: F401 (theirs, here too)


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
    if eqs.friction is not None:
        names.update({s: f"FRICTION({k})" for k, s in enumerate(eqs.friction.forces)})

    if eqs.seeds:
        for i, (q, u) in enumerate(zip(eqs.coordinates, eqs.speeds)):
            names[eqs.seeds[q]], names[eqs.seeds[u]] = f"SEED_Q({i})", f"SEED_DQ({i})"
    if eqs.linearization is not None:
        names.update(linearization_names(eqs))
    if eqs.sensitivities is not None:
        names.update(sensitivity_names(eqs))
    names.update({s: s.name for s, _ in block.temporaries})
    for program in (*block.programs.values(), eqs.taylor):
        if program is not None:
            names.update({s: s.name for s, _ in program.assignments()})
    return names


def linearization_names(eqs: Equations) -> dict[sympy.Symbol, str]:
    """The linearization's seeds and the tangents of the accelerations and drives."""
    lin = eqs.linearization
    assert lin is not None
    names = {}
    for i, (q, u) in enumerate(zip(eqs.coordinates, eqs.speeds)):
        names[lin.seeds[q]], names[lin.seeds[u]] = f"SEED_Q({i})", f"SEED_DQ({i})"
    names.update({lin.seeds[value]: f"SEED_U({k})" for k, value in
                  enumerate(eqs.inputs.values())})
    names.update({lin.results_seeds[a]: f"DQDD({i})" for i, a in enumerate(eqs.accelerations)})
    names.update({lin.results_seeds[d]: f"DDRIVE({j})" for j, d in enumerate(eqs.drives)})
    names.update({lin.results_seeds[k]: f"DLAMBDA({j})" for j, k in enumerate(eqs.multipliers)})
    return names


def sensitivity_names(eqs: Equations) -> dict[sympy.Symbol, str]:
    """The variational equations' seeds (the state's, the parameters') and the tangents of
    the accelerations, drives and (a closed loop's) multipliers."""
    sens = eqs.sensitivities
    assert sens is not None
    seeds, names = sens.tangents.seeds, {}
    for i, (q, u) in enumerate(zip(eqs.coordinates, eqs.speeds)):
        names[seeds[q]], names[seeds[u]] = f"SEED_Q({i})", f"SEED_DQ({i})"
    names.update({seed: f"SEED_P({k})" for k, seed in enumerate(sens.parameter_seeds.values())})
    results = sens.tangents.results_seeds
    names.update({results[a]: f"DQDD({i})" for i, a in enumerate(eqs.accelerations)})
    names.update({results[d]: f"DDRIVE({j})" for j, d in enumerate(eqs.drives)})
    names.update({results[k]: f"DLAMBDA({j})" for j, k in enumerate(eqs.multipliers)})
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


def symbols_used(program: Program) -> set[sympy.Symbol]:
    used: set[sympy.Symbol] = set()
    for step in program.steps:
        used |= (step.value if isinstance(step, Guard) else step[1]).free_symbols
    for result in program.results:
        used |= sympy.sympify(result).free_symbols
    return used


def has_guard(program: Program) -> bool:
    return any(isinstance(step, Guard) for step in program.steps)


# ---- where a program is printed ------------------------------------------------------------


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


STATE_INPUTS: tuple[Parameter, ...] = (("double", "t"), ("const double *", "y"),
                                       ("const double *", "p"))
