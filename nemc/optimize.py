"""Optimization before emission: one common-subexpression elimination shared by everything the
model emits, and the rewrite rules that make the C cheap and exact (x*x rather than pow(x, 2)).

sympy's default CSE ordering is superlinear on large systems (31 s against 0.2 s with
order='none' on an 8-link chain; FIELD-NOTES.md), so the canonical ordering is skipped.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy
from sympy.codegen.rewriting import create_expand_pow_optimization, optimize

from .derive import Equations

# integer powers up to 4 of any base -> products (pow(x, 2) is slower and no more exact)
REWRITES = [create_expand_pow_optimization(4, base_req=lambda base: True)]


@dataclass(frozen=True)
class Block:
    """Named groups of expressions written in terms of shared temporaries."""

    temporaries: tuple[tuple[sympy.Symbol, sympy.Expr], ...]
    groups: dict[str, tuple[sympy.Expr, ...]]


def lower_triangle(matrix: sympy.Matrix) -> tuple[sympy.Expr, ...]:
    n = matrix.shape[0]
    return tuple(matrix[i, j] for i in range(n) for j in range(i + 1))


def rewrite(expr: sympy.Expr) -> sympy.Expr:
    return optimize(expr, REWRITES) if isinstance(expr, sympy.Basic) else expr


def shared_cse(groups: dict[str, tuple[sympy.Expr, ...]]) -> Block:
    """One CSE over all groups; each group keeps its own (reduced) expressions."""
    flat = [expr for exprs in groups.values() for expr in exprs]
    symbols = sympy.numbered_symbols("x", real=True)
    temporaries, reduced = sympy.cse(flat, symbols=symbols, order="none")
    split, start = {}, 0
    for name, exprs in groups.items():
        split[name] = tuple(rewrite(e) for e in reduced[start : start + len(exprs)])
        start += len(exprs)
    return Block(tuple((s, rewrite(e)) for s, e in temporaries), split)


def optimize_equations(eqs: Equations) -> Block:
    groups = {
        "mass": lower_triangle(eqs.mass_matrix),
        "forcing": tuple(eqs.forcing),
        "outputs": tuple(expr for _, expr in eqs.outputs),
        "checks": tuple(expr for _, expr in eqs.checks),
        "initial": eqs.initial_state,
    }
    if eqs.jacobian is not None:
        groups["jacobian_r"], groups["jacobian_s"] = (tuple(m) for m in eqs.jacobian)
    return shared_cse(groups)
