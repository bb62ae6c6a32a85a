"""The accelerations from the book's mass-matrix form, as a straight-line program.

M(q) qdd = f(t, q, dq) (derive.newton_euler), every entry linearized in its sines and cosines
(or not: both forms are candidates), the entries' common subexpressions named once, and M solved
by LDL^T (Cholesky without square roots) written out as steps.

The articulated-body program (nemc/articulated.py) grows linearly with the bodies; this form
grows as n^3, but on a few coordinates it is the smaller one. The right-hand side runs whichever
program c_cost.estimated_ns ranks fastest (derive.fastest_dynamics: the 5.4 arm's RHS 15 -> 3 ns,
the double pendulum's 36 -> 30; benchmarks/rhs_forms.py). Taylor's method weighs programs
differently: each product of two time-varying values costs a Cauchy sum at every order, a sum or
a constant factor almost nothing. On two or three bodies this form has several times fewer such
products than the articulated-body program (the double pendulum: 13 Cauchy sums per order
against 40.5), so nemc.Taylor's coefficients come from whichever program is cheaper
(taylor.series_cost). For the right-hand side, the linearized entries also come with the sines
and cosines of sums of angles from those of their parts (nemc/angle_sums.py): linearizing turns
a chain's absolute angles into sums of its relative ones, and the addition formulas then leave
one sincos call per joint (the 4-link chain's RHS 148 -> 115 ns, benchmarks/rhs_forms.py).
Past MAX_COORDINATES the form is not derived: its symbolic cost and its size grow as n^3 and
faster. Entries whose multiplied-out polynomial would exceed MAX_TERMS terms (springs' lengths
inside products) are left as they are.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import sympy
from sympy.simplify.fu import TR8

from .angle_sums import split_angle_sums
from .program import Program, ProgramBuilder

# chain of 4: 1.0 s to derive and linearize (0.7 s of it linearizing: a cold compile 1.6 ->
# 2.4 s); chain of 6: 7 s
MAX_COORDINATES = 4
MAX_TERMS = 400  # a polynomial with more terms multiplied out is left as it is
GROWTH = 4  # linearized entries at most this many times larger than M's and f's (count_ops)


def linearized(expr: sympy.Expr) -> sympy.Expr:
    """expr with products of sines and cosines rewritten as sums (sympy's TR8), like terms
    collected: sin(a)**2 + cos(a)**2 becomes 1, cos(a)*cos(b) + sin(a)*sin(b) cos(a - b).

    Only the polynomial in sines and cosines is multiplied out: any other function, root or
    quotient (a spring's length, a load's division) stands for itself meanwhile, with its own
    arguments linearized, so expanding cannot blow up inside it. A result larger than
    GROWTH times the input is not used."""
    stand_ins: dict[sympy.Expr, sympy.Symbol] = {}
    polynomial = _stand_in(expr, stand_ins)
    if expanded_terms(polynomial) > MAX_TERMS:
        return expr
    polynomial = sympy.expand(TR8(sympy.expand(polynomial)))
    result = polynomial.xreplace({symbol: value for value, symbol in stand_ins.items()})
    return result if sympy.count_ops(result) <= GROWTH * sympy.count_ops(expr) + 8 else expr


def expanded_terms(expr: sympy.Expr) -> int:
    """An upper bound of the number of terms of expr multiplied out (before TR8)."""
    if expr.is_Add:
        return sum(expanded_terms(arg) for arg in expr.args)
    if expr.is_Mul:
        return math.prod(expanded_terms(arg) for arg in expr.args)
    if expr.is_Pow and expr.exp.is_Integer and expr.exp > 0:
        return expanded_terms(expr.base) ** int(expr.exp)
    return 1


def _stand_in(expr: sympy.Expr, stand_ins: dict[sympy.Expr, sympy.Symbol]) -> sympy.Expr:
    """expr as a polynomial in atoms, sines and cosines, and stand-in symbols for the rest."""
    if expr.is_Atom or isinstance(expr, (sympy.sin, sympy.cos)):
        return expr
    if expr.is_Add or expr.is_Mul:
        return expr.func(*(_stand_in(arg, stand_ins) for arg in expr.args))
    if expr.is_Pow and expr.exp.is_Integer and expr.exp > 0:
        return _stand_in(expr.base, stand_ins) ** expr.exp
    inner = expr.func(*(linearized(arg) for arg in expr.args))
    if inner not in stand_ins:
        stand_ins[inner] = sympy.Dummy(f"u{len(stand_ins)}")
    return stand_ins[inner]


Solve = Callable[[ProgramBuilder, dict[tuple[int, int], sympy.Expr], list[sympy.Expr]],
                 list[sympy.Expr]]


def mass_form_program(mass: sympy.Matrix, forcing: sympy.Matrix, linearize: bool = True,
                      addition_formulas: bool = False, solve: Solve | None = None) -> Program:
    """The accelerations qdd = M^-1 f as a program, M's and f's entries linearized in sines and
    cosines unless LINEARIZE is False (mass_form_entries), then program_of_entries."""
    return program_of_entries(mass_form_entries(mass, forcing, linearize), addition_formulas,
                              solve)


def mass_form_entries(mass: sympy.Matrix, forcing: sympy.Matrix, linearize: bool = True
                      ) -> tuple[list[sympy.Expr], list[sympy.Expr]]:
    """(M's lower triangle row by row, f), linearized in sines and cosines unless LINEARIZE is
    False."""
    n = mass.shape[0]
    tidy = linearized if linearize else (lambda expr: expr)
    return ([tidy(mass[i, j]) for i in range(n) for j in range(i + 1)],
            [tidy(f) for f in forcing])


def program_of_entries(entries: tuple[list[sympy.Expr], list[sympy.Expr]],
                       addition_formulas: bool = False, solve: Solve | None = None) -> Program:
    """The accelerations qdd = M^-1 f from ENTRIES (mass_form_entries): their common
    subexpressions named once, M solved in steps by SOLVE (ldl_solve, or rhs_solve's choice for
    the right-hand side); with ADDITION_FORMULAS, the sines and cosines of sums of angles come
    from those of their parts where those are computed anyway (nemc/angle_sums.py). Guard j + 1:
    pivot j of M's LDL^T is not positive (the leading (j + 1) x (j + 1) block of the mass matrix
    is singular there), whichever the solve."""
    lower_triangle, forcing = entries
    n = len(forcing)
    builder = ProgramBuilder("m")
    lower = [(i, j) for i in range(n) for j in range(i + 1)]
    exprs = [*lower_triangle, *forcing]
    if addition_formulas:
        exprs = with_angle_sums(builder, exprs)
    temporaries, reduced = sympy.cse(
        exprs, symbols=sympy.numbered_symbols("e", cls=sympy.Dummy, real=True), order="none")
    named: dict[sympy.Symbol, sympy.Expr] = {}
    for symbol, expr in temporaries:
        named[symbol] = builder.let(expr.xreplace(named))
    values = [builder.let(expr.xreplace(named)) for expr in reduced]
    solve = solve or ldl_solve
    return builder.finish(solve(builder, dict(zip(lower, values)), values[len(lower):]))


def with_angle_sums(builder: ProgramBuilder, exprs: list[sympy.Expr]) -> list[sympy.Expr]:
    """exprs with the sines and cosines of sums split (angle_sums.split_angle_sums), each call
    left and each formula a step of BUILDER (so that a call is made once)."""
    definitions, exprs = split_angle_sums(exprs)
    calls = {node: builder.let(node) for expr in [*(value for _, value in definitions), *exprs]
             for node in sympy.preorder_traversal(expr)
             if isinstance(node, (sympy.sin, sympy.cos))}
    named: dict[sympy.Symbol, sympy.Expr] = {}
    for symbol, value in definitions:
        named[symbol] = builder.let(value.xreplace(calls).xreplace(named))
    return [expr.xreplace(calls).xreplace(named) for expr in exprs]


def ldl_solve(builder: ProgramBuilder, mass: dict[tuple[int, int], sympy.Expr],
              forcing: list[sympy.Expr]) -> list[sympy.Expr]:
    """x with M x = f, M symmetric positive definite given by its lower triangle, as steps.

    E[i, j] = M[i, j] - sum_{k<j} E[i, k] L[j, k] (so L[i, j] = E[i, j] / d[j], d[j] = E[j, j]):
    one product per term, one quotient per entry of L."""
    n = len(forcing)
    scaled: dict[tuple[int, int], sympy.Expr] = {}  # E
    unit: dict[tuple[int, int], sympy.Expr] = {}  # L
    pivots: list[sympy.Expr] = []
    for j in range(n):
        for i in range(j, n):
            scaled[i, j] = builder.let(
                mass[i, j] - sum((scaled[i, k] * unit[j, k] for k in range(j)), sympy.S.Zero))
        pivots.append(scaled[j, j])
        builder.require_positive(pivots[j], j + 1)
        for i in range(j + 1, n):
            unit[i, j] = builder.let(scaled[i, j] / pivots[j])
    z: list[sympy.Expr] = []
    for i in range(n):  # L z = f
        z.append(builder.let(forcing[i] - sum((unit[i, k] * z[k] for k in range(i)),
                                              sympy.S.Zero)))
    x: list[sympy.Expr] = [sympy.S.Zero] * n
    for i in reversed(range(n)):  # D L^T x = z
        x[i] = builder.let(z[i] / pivots[i] - sum((unit[k, i] * x[k] for k in range(i + 1, n)),
                                                  sympy.S.Zero))
    return x


def inverse_solve_2x2(builder: ProgramBuilder, mass: dict[tuple[int, int], sympy.Expr],
                      forcing: list[sympy.Expr]) -> list[sympy.Expr]:
    """x with M x = f for two coordinates by the inverse, adj(M) f / det M: one quotient (the
    determinant's reciprocal) where LDL^T has three, each waiting for the one before. The
    guards are LDL^T's: pivot 0 is M[0, 0], pivot 1 is det M / M[0, 0], positive exactly
    when det M is, M[0, 0] being positive."""
    a, b, d = mass[0, 0], mass[1, 0], mass[1, 1]
    builder.require_positive(a, 1)
    determinant = builder.let(a * d - b * b)
    builder.require_positive(determinant, 2)
    reciprocal = builder.let(1 / determinant)
    return [builder.let((d * forcing[0] - b * forcing[1]) * reciprocal),
            builder.let((a * forcing[1] - b * forcing[0]) * reciprocal)]


def rhs_solve(n: int) -> Solve:
    """The solve of the right-hand side's programs: the inverse for two coordinates (the double
    pendulum's RHS 41 -> 37 ns where its evaluations are chained, as a Runge-Kutta step's are:
    docs/decisions.md, "Two coordinates solved by the inverse"), else LDL^T. Not beyond two:
    Cramer's rule is forward stable for 2 x 2 systems, not in general from 3 x 3 on (Higham,
    Accuracy and Stability of Numerical Algorithms, 2nd ed., section 1.10.1). nemc.Taylor's
    programs keep LDL^T: there a quotient by M[0, 0], often constant, costs no Cauchy sum, and the
    inverse's products with the reciprocal two (the double pendulum: 4 sums an order against
    5.5)."""
    return inverse_solve_2x2 if n == 2 else ldl_solve


def rhs_solve_text(n: int) -> str:
    """How rhs_solve(n) solves M, as the generated C's header says it."""
    if rhs_solve(n) is inverse_solve_2x2:
        return "by its inverse, adj(M) f / det M (one division)"
    return "by its LDL^T factorization and the two triangular solves"
