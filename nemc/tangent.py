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


class RealAbs(sympy.Function):
    """|x| of a real x, differentiated as sign(x). sympy's Abs allows a complex argument: its
    derivative of |asin(q)| holds re() and im(), which C cannot print."""

    def fdiff(self, argindex: int = 1) -> sympy.Expr:
        return sympy.sign(self.args[0])


class RealSign(sympy.Function):
    """sign(x) of a real x, differentiated as 0: its derivative is 0 wherever it exists (all but
    x = 0). sympy's is 2 DiracDelta(x), which C cannot print."""

    def fdiff(self, argindex: int = 1) -> sympy.Expr:
        return sympy.S.Zero


# min and max need no rule: sympy differentiates them to Heaviside steps (a piecewise choice of
# the argument that is the minimum or maximum), which C prints as a conditional.
REAL_DERIVATIVES = {sympy.Abs: RealAbs, sympy.sign: RealSign}


def with_real_derivatives(expr: sympy.Expr) -> sympy.Expr:
    if not expr.has(*REAL_DERIVATIVES):
        return expr
    for function, real in REAL_DERIVATIVES.items():
        expr = expr.replace(function, real)
    return expr


def from_real_derivatives(expr: sympy.Expr) -> sympy.Expr:
    if not expr.has(*REAL_DERIVATIVES.values()):
        return expr
    for function, real in REAL_DERIVATIVES.items():
        expr = expr.replace(real, function)
    return expr


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
        real = with_real_derivatives(expr)
        terms = [
            from_real_derivatives(sympy.diff(real, symbol)).xreplace(known) * tangent[symbol]
            for symbol in expr.free_symbols
            if symbol in tangent
        ]
        return sympy.Add(*terms)

    for name, expr in primal.assignments():
        change = derivative(expr)
        if change != 0:
            tangent[name] = builder.let(change)
    return builder.finish(derivative(result) for result in primal.results)
