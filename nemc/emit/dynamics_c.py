"""The right-hand side's C: a tree's accelerations (the articulated-body algorithm or the
mass-matrix form, inlined into its callers when short), or with drives or loops the
articulated-body program with its unit passes, the multipliers and the projection onto the
constraints; the loops' constraint values.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
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
)
from ..derive.program import Guard, Program
from .angles_c import angles_c
from .c_text import SymbolTablePrinter
from .optimize import Block
from .parts import Units, print_program
from .printing import (
    STATE_INPUTS,
    Caller,
    Printed,
    body,
    comment_text,
    indexed,
    program_body,
    symbols_used,
    template,
)
from .resources import read_template

DYNAMICS = Caller("accelerations", "The accelerations", STATE_INPUTS, ("QDD", "qdd"), "v")
AUGMENTED = Caller("accelerations", "The accelerations, drives and unit passes",
                   STATE_INPUTS, ("ACC", "acc"), "v")


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
        rhs = friction_section(eqs, block, printer, prefix, TREE_PASS) \
            if eqs.friction is not None else template("tree_rhs.c.tmpl").substitute(prefix=prefix)
        return template("tree.c.tmpl").substitute(
            prefix=prefix, dynamics_parts=dynamics.functions, dynamics=dynamics.body,
            dynamics_form=form.label, singular_k=form.singular, rhs=rhs,
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
    on_velocities = eqs.loops.on_velocities if eqs.loops is not None else ()
    rhs = friction_section(eqs, block, printer, prefix, LOOPS_PASS) \
        if eqs.friction is not None else template("loops_rhs.c.tmpl").substitute(prefix=prefix)
    return template("loops.c.tmpl").substitute(
        prefix=prefix, dynamics_functions=functions, rhs=rhs,
        constraint_values=constraint_values(eqs, block, printer),
        on_velocities=" || ".join(f"(k) == {k}" for k in on_velocities) or "0")


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


# friction.c.tmpl's pass of the dynamics: a tree's accelerations, or with drives or loops the
# state brought onto the constraints with its accelerations, multipliers and drives
TREE_PASS = """    for (int i = 0; i < N_STATE; ++i)
        r->ys[i] = y[i];
    int status = accelerations(t, y, pf, r->qdd);"""
LOOPS_PASS = ("    int status = consistent_dynamics(t, y, pf, r->ys, r->qdd, r->lambda, "
              "r->drive);")


def friction_section(eqs: Equations, block: Block, printer: SymbolTablePrinter, prefix: str,
                     dynamics_call: str) -> str:
    """Coulomb friction's solver and the right-hand side through it (templates/
    friction.c.tmpl): each item's terms printed from the "friction" group."""
    friction = eqs.friction
    assert friction is not None
    return template("friction.c.tmpl").substitute(
        prefix=prefix, friction_names=comment_text(", ".join(friction.names)),
        coordinates=", ".join(str(i) for i in friction.coordinates), dynamics_call=dynamics_call,
        laws=", ".join(str(law) for law in friction.laws),
        contact_switches=read_template("contacts.c.tmpl"),
        terms=body(printer, block, indexed("terms", block.groups["friction"])))
