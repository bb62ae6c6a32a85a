"""The Jacobian of the right-hand side by forward-mode differentiation of its program.

For every assignment w = e(a, b, ...) of the accelerations' program (nemc/program.py) the
tangent program assigns dw = de/da * da + de/db * db + ..., where the tangents of the state
y[k] are the seed symbols seed[k]. Evaluated once per column of the Jacobian with seed = e_col
(a loop in the generated C, reusing the primal values), it gives d qdd / d y exactly, at a cost
linear in the program's size; M is never inverted symbolically. Derivatives are rewritten in
terms of names the primal program already has (d cos(w)/dw = -sin(w) becomes -w', when w' =
sin(w) was computed), so the tangents call no extra functions.
"""

from __future__ import annotations

from collections.abc import Mapping

import sympy

from .program import Program, ProgramBuilder


def seed_symbols(n_state: int) -> tuple[sympy.Symbol, ...]:
    """The tangent of y[k], as new symbols no name from the file can equal (printed seed[k])."""
    return tuple(sympy.Dummy(f"seed_{k}", real=True) for k in range(n_state))


def tangent_program(primal: Program, seeds: Mapping[sympy.Symbol, sympy.Symbol]) -> Program:
    """The directional derivatives of primal's results along seeds (state symbol -> the symbol
    of its tangent)."""
    tangent: dict[sympy.Symbol, sympy.Expr] = dict(seeds)
    known = {expr: name for name, expr in primal.assignments()}
    builder = ProgramBuilder("dw")

    def derivative(expr: sympy.Expr) -> sympy.Expr:
        expr = sympy.sympify(expr)
        terms = [
            sympy.diff(expr, symbol).xreplace(known) * tangent[symbol]
            for symbol in expr.free_symbols
            if symbol in tangent
        ]
        return sympy.Add(*terms)

    for name, expr in primal.assignments():
        change = derivative(expr)
        if change != 0:
            tangent[name] = builder.let(change)
    return builder.finish(derivative(result) for result in primal.results)
