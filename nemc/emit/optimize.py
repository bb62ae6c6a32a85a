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
from sympy.codegen.rewriting import ReplaceOptim, create_expand_pow_optimization, optimize

from ..derive.equations import Equations
from ..derive.program import Guard, Program

# integer powers up to 4 of any base -> products (pow(x, 2) is slower and no more exact)
EXPANDED_POWERS = 4
# x**(-1/2), x**(3/2), x**(-3/2) -> sqrt and products: a spring's 1/length is pow(x, -1.0/2.0) in
# sympy's C, 20-30 ns where 1.0/sqrt(x) takes a few (free_body_on_spring's linearized mass form:
# 52 -> 33 ns)
HALF_POWERS = (sympy.Rational(-1, 2), sympy.Rational(3, 2), sympy.Rational(-3, 2))


def is_half_power(expr: sympy.Basic) -> bool:
    return expr.is_Pow and expr.exp in HALF_POWERS


def with_sqrt(power: sympy.Pow) -> sympy.Expr:
    root = sympy.sqrt(power.base)
    if abs(power.exp) == sympy.S.Half:
        return 1 / sympy.UnevaluatedExpr(root)
    product = sympy.UnevaluatedExpr(sympy.Mul(power.base, root, evaluate=False))
    return product if power.exp > 0 else 1 / product


REWRITES = [create_expand_pow_optimization(EXPANDED_POWERS, base_req=lambda base: True),
            ReplaceOptim(is_half_power, with_sqrt)]


@dataclass(frozen=True)
class Block:
    """Named groups of expressions written in terms of shared temporaries."""

    temporaries: tuple[tuple[sympy.Symbol, sympy.Expr], ...]
    groups: dict[str, tuple[sympy.Expr, ...]]
    programs: dict[str, Program]  # the programs, rewritten, by name


# sympy's rewritten powers (x*x inside an UnevaluatedExpr) have no assumptions: Min and Max then
# refuse them ("not comparable") and Heaviside's conditions call them non-real, so expressions
# holding those keep pow() (min(q, q**2) failed to compile, found by tests/test_hostile_runs.py)
KEEP_POWERS_IN = (sympy.Min, sympy.Max, sympy.Heaviside, sympy.Piecewise)


def rewrite(expr: sympy.Expr) -> sympy.Expr:
    """EXPR with REWRITES applied, unless it has none to apply (most steps of a program: one
    walk through it, where sympy's `has` and `replace` took two and rebuilt it)."""
    if not isinstance(expr, sympy.Basic):
        return expr
    expandable = False
    for node in sympy.preorder_traversal(expr):
        if isinstance(node, KEEP_POWERS_IN):
            return expr
        expandable = expandable or (node.is_Pow and node.exp.is_Integer
                                    and abs(node.exp) <= EXPANDED_POWERS) or is_half_power(node)
    return optimize(expr, REWRITES) if expandable else expr


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


def event_partial_groups(eqs: Equations) -> dict[str, tuple[sympy.Expr, ...]]:
    """Each event's partial derivatives ("event_partials.<k>": its function's, then its impact
    law's), for the sensitivities' jump there (none without the part)."""
    if eqs.sensitivities is None:
        return {}
    return {f"event_partials.{k}": (*partials.when, *partials.law)
            for k, partials in enumerate(eqs.sensitivities.events)}


def sensitivity_programs(eqs: Equations) -> dict[str, Program | None]:
    """The variational equations' programs, by name (none without the part)."""
    if eqs.sensitivities is None:
        return {}
    tangents = eqs.sensitivities.tangents
    return {"sensitivities": tangents.dynamics, "sensitivity_outputs": tangents.outputs,
            "sensitivity_outputs_tangent": tangents.outputs_tangent}


def optimize_equations(eqs: Equations) -> Block:
    loops = eqs.loops
    groups = {
        "outputs": tuple(expr for _, expr in eqs.outputs),
        "checks": tuple(expr for _, expr in eqs.checks),
        "initial": eqs.initial_state,
        "inputs": eqs.inputs.laws,
        "constraints": () if loops is None else
        (*loops.values, *(v for row in loops.jacobian for v in row), *loops.rate),
        **event_groups(eqs),
        **({"friction": eqs.friction.terms} if eqs.friction else {}),
        **({"sensitivity_initial": eqs.sensitivities.initial} if eqs.sensitivities else {}),
        **event_partial_groups(eqs),
    }
    primal = eqs.accelerations_program if eqs.jacobian is not None else None
    lin = eqs.linearization
    programs = {"dynamics": eqs.dynamics, "jacobian": eqs.jacobian,
                "inverse_mass": eqs.inverse_mass,
                "primal": primal if primal is not eqs.dynamics else None,
                "linearization": lin and lin.dynamics,
                "linearization_outputs": lin and lin.outputs,
                "linearization_outputs_tangent": lin and lin.outputs_tangent,
                **sensitivity_programs(eqs)}
    temporaries, reduced = shared_cse(groups)
    rewritten = {name: rewrite_program(prog) for name, prog in programs.items()
                 if prog is not None}
    return Block(temporaries, reduced, rewritten)
