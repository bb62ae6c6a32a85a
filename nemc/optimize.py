"""Optimization before emission: the rewrite rules that make the C cheap and exact (x*x rather
than pow(x, 2)) applied to the programs of the dynamics (already made of short named steps), and
one common-subexpression elimination shared by the other expressions the model emits (outputs,
checks, the initial state).

sympy's default CSE ordering is superlinear on large systems (31 s against 0.2 s with
order='none' on an 8-link chain; FIELD-NOTES.md), so the canonical ordering is skipped.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy
from sympy.codegen.rewriting import create_expand_pow_optimization, optimize

from .derive import Equations
from .program import Guard, Program

# integer powers up to 4 of any base -> products (pow(x, 2) is slower and no more exact)
REWRITES = [create_expand_pow_optimization(4, base_req=lambda base: True)]


@dataclass(frozen=True)
class Block:
    """Named groups of expressions written in terms of shared temporaries."""

    temporaries: tuple[tuple[sympy.Symbol, sympy.Expr], ...]
    groups: dict[str, tuple[sympy.Expr, ...]]
    programs: dict[str, Program]  # the programs, rewritten, by name


def rewrite(expr: sympy.Expr) -> sympy.Expr:
    return optimize(expr, REWRITES) if isinstance(expr, sympy.Basic) else expr


def shared_cse(groups: dict[str, tuple[sympy.Expr, ...]]) -> tuple[
        tuple[tuple[sympy.Symbol, sympy.Expr], ...], dict[str, tuple[sympy.Expr, ...]]]:
    """One CSE over all groups: the shared temporaries, and each group's reduced expressions."""
    flat = [expr for exprs in groups.values() for expr in exprs]
    symbols = sympy.numbered_symbols("x", cls=sympy.Dummy, real=True)  # never a file's x0
    temporaries, reduced = sympy.cse(flat, symbols=symbols, order="none")
    split, start = {}, 0
    for name, exprs in groups.items():
        split[name] = tuple(rewrite(e) for e in reduced[start : start + len(exprs)])
        start += len(exprs)
    return tuple((s, rewrite(e)) for s, e in temporaries), split


def rewrite_program(program: Program) -> Program:
    steps = tuple(
        step if isinstance(step, Guard) else (step[0], rewrite(step[1])) for step in program.steps
    )
    return Program(steps, tuple(rewrite(sympy.sympify(r)) for r in program.results))


def event_groups(eqs: Equations) -> dict[str, tuple[sympy.Expr, ...]]:
    """The events' functions ("events") and each impact law's new values ("impact.<k>", k the
    event's index), so they share the other expressions' common subexpressions."""
    groups = {"events": tuple(event.when for event in eqs.events)} if eqs.events else {}
    groups.update({f"impact.{k}": tuple(expr for _, expr in event.law)
                   for k, event in enumerate(eqs.events) if event.law})
    return groups


def optimize_equations(eqs: Equations) -> Block:
    groups = {
        "outputs": tuple(expr for _, expr in eqs.outputs),
        "checks": tuple(expr for _, expr in eqs.checks),
        "initial": eqs.initial_state,
        **event_groups(eqs),
    }
    programs = {"dynamics": eqs.dynamics, "jacobian": eqs.jacobian,
                "inverse_mass": eqs.inverse_mass}
    temporaries, reduced = shared_cse(groups)
    rewritten = {name: rewrite_program(prog) for name, prog in programs.items()
                 if prog is not None}
    return Block(temporaries, reduced, rewritten)
