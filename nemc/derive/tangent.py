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

from collections.abc import Callable, Mapping

import sympy
from sympy.core.basic import _args_sortkey

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


MINUS_ONE = sympy.S.NegativeOne


def monomial(expr: sympy.Expr) -> tuple[sympy.Rational, tuple[sympy.Symbol, ...]] | None:
    """(coefficient, symbols) of expr when it is a rational number, a commutative symbol, or a
    rational times distinct commutative symbols (sympy's order); else None."""
    if expr.is_Symbol:
        return (sympy.S.One, (expr,)) if expr.is_commutative else None
    if expr.is_Rational:
        return expr, ()
    if expr.is_Mul:
        coefficient, symbols = sympy.S.One, expr.args
        if symbols[0].is_Rational:
            coefficient, symbols = symbols[0], symbols[1:]
        if all(s.is_Symbol and s.is_commutative for s in symbols):
            return coefficient, symbols
    return None


def product(*factors: sympy.Expr) -> sympy.Expr:
    """sympy.Mul(*factors), the same expression, made directly where every factor is a
    monomial and no symbol repeats: the rationals multiplied, the symbols in sympy's canonical
    order (Basic.compare). Most of the tangent's products are of that kind, and sympy's general
    Mul.flatten was over 40% of the tangent program's time (issue 19: a 1000-body chain's
    Jacobian). Anything else goes to sympy.Mul."""
    parts = [monomial(factor) for factor in factors]
    if None in parts:
        return sympy.Mul(*factors)
    coefficient, symbols = sympy.S.One, []
    for factor_coefficient, factor_symbols in parts:
        coefficient *= factor_coefficient
        symbols.extend(factor_symbols)
    if coefficient == 0:
        return sympy.S.Zero
    if len(set(symbols)) != len(symbols):  # a power
        return sympy.Mul(*factors)
    symbols.sort(key=_args_sortkey)
    if coefficient != 1:
        symbols.insert(0, coefficient)
    if len(symbols) == 1:
        return symbols[0]
    return sympy.Mul._exec_constructor_postprocessors(sympy.Mul._from_args(symbols, True))


def seed_symbols(n_state: int) -> tuple[sympy.Symbol, ...]:
    """The tangent of y[k], as new symbols no name from the file can equal (printed seed[k])."""
    return tuple(sympy.Dummy(f"seed_{k}", real=True) for k in range(n_state))


def tangent_program(primal: Program, seeds: Mapping[sympy.Symbol, sympy.Symbol],
                    prefix: str = "dw") -> Program:
    """The directional derivatives of primal's results along seeds (state symbol -> the symbol
    of its tangent); its steps named PREFIX<k>."""
    tangent: dict[sympy.Symbol, sympy.Expr] = dict(seeds)
    known = {expr: name for name, expr in primal.assignments()}
    builder = ProgramBuilder(prefix)
    for name, expr in primal.assignments():
        change = directional_derivative(expr, tangent, known)
        if change != 0:
            tangent[name] = builder.let(change)
    return builder.finish(directional_derivative(result, tangent, known)
                          for result in primal.results)


def directional_derivative(expr: sympy.Expr, tangent: Mapping[sympy.Symbol, sympy.Expr],
                           known: Mapping[sympy.Expr, sympy.Symbol]) -> sympy.Expr:
    """d expr along the tangents (symbol -> its tangent; symbols without one are constants), by
    the chain rule over expr's tree: sums, products, powers with a constant exponent, sine and
    cosine by their rules, anything else by sympy's diff (derivative_by_diff). A derivative's
    factors that the primal program already computed are its names (known: expression -> name).
    sympy's diff of a whole step per symbol costs 10-50 times more (issue 19: a 100-body chain's
    tangent program took 19 s of its 39 s build)."""
    done: dict[sympy.Basic, sympy.Expr] = {}

    def name_of(expr: sympy.Expr) -> sympy.Expr:
        return known.get(expr, expr)

    def rule(node: sympy.Basic, args: list[sympy.Expr]) -> sympy.Expr:
        if node.is_Add:
            return sympy.Add(*args)
        if node.is_Mul:
            factors = node.args
            return sympy.Add(*(
                product(change, name_of(product(*factors[:k], *factors[k + 1:])))
                for k, change in enumerate(args) if change != 0))
        if node.is_Pow and args[1] == 0:  # b**e, e constant along the tangents
            base, exponent = node.args
            if exponent == -1:  # d(1/b) = -(1/b)^2 db: the primal's reciprocal, no division
                return -name_of(node) ** 2 * args[0]
            return exponent * name_of(base ** (exponent - 1)) * args[0]
        if isinstance(node, sympy.sin):
            return product(name_of(sympy.cos(node.args[0])), args[0])
        if isinstance(node, sympy.cos):
            return product(product(MINUS_ONE, name_of(sympy.sin(node.args[0]))), args[0])
        return derivative_by_diff(node, tangent, known)  # b**e with e varying

    def by_rule(node: sympy.Basic) -> bool:
        return node.is_Add or node.is_Mul or node.is_Pow or (
            isinstance(node, (sympy.sin, sympy.cos)) and len(node.args) == 1)

    expr = sympy.sympify(expr)
    stack = [expr]  # post-order without recursion, into the nodes the rules take apart
    while stack:
        node = stack[-1]
        if node in done:
            stack.pop()
            continue
        if not node.args:
            done[node] = tangent.get(node, sympy.S.Zero) if node.is_Symbol else sympy.S.Zero
        elif not by_rule(node):
            done[node] = derivative_by_diff(node, tangent, known)
        else:
            pending = [arg for arg in node.args if arg not in done]
            if pending:
                stack.extend(pending)
                continue
            args = [done[arg] for arg in node.args]
            done[node] = sympy.S.Zero if all(a == 0 for a in args) else rule(node, args)
        stack.pop()
    return done[expr]


def derivative_by_diff(expr: sympy.Expr, tangent: Mapping[sympy.Symbol, sympy.Expr],
                       known: Mapping[sympy.Expr, sympy.Symbol]) -> sympy.Expr:
    """d expr along the tangents as the sum over its symbols of sympy's partial derivative times
    the symbol's tangent (|x| and sign differentiated for real x)."""
    real = with_real_derivatives(expr)
    return sympy.Add(*(
        from_real_derivatives(sympy.diff(real, symbol)).xreplace(known) * tangent[symbol]
        for symbol in expr.free_symbols if symbol in tangent))


# ---- the tangent's linear form, and the Jacobian by reverse accumulation -------------------
# (templates/sensitivities.c.tmpl's dense product, nemc.Taylor's columns: derive/taylor.py)

Linear = dict[sympy.Symbol, sympy.Expr]  # tangent symbol -> its coefficient


class NotLinear(Exception):
    """A tangent step that is not a sum of coefficient x tangent (then printed as it is)."""


def linear_form(expr: sympy.Expr, tangents: frozenset[sympy.Symbol]) -> Linear:
    """EXPR as {tangent: coefficient}, the coefficients free of TANGENTS."""
    expr = sympy.sympify(expr)
    if expr in tangents:
        return {expr: sympy.S.One}
    if not (expr.free_symbols & tangents):
        if expr == 0:
            return {}
        raise NotLinear(expr)
    if expr.is_Add:
        total: Linear = {}
        for term in expr.args:
            for symbol, coefficient in linear_form(term, tangents).items():
                total[symbol] = total.get(symbol, sympy.S.Zero) + coefficient
        return total
    if expr.is_Mul:
        varying = [f for f in expr.args if f.free_symbols & tangents]
        if len(varying) != 1:
            raise NotLinear(expr)
        scale = sympy.Mul(*(f for f in expr.args if f is not varying[0]))
        return {symbol: scale * coefficient
                for symbol, coefficient in linear_form(varying[0], tangents).items()}
    raise NotLinear(expr)


def jacobian_row(steps: list[tuple[sympy.Symbol, Linear]], result: Linear,
                 named: Callable[[sympy.Expr], sympy.Expr]) -> Linear:
    """RESULT's derivative by each seed, its row of J: its adjoint carried back through
    STEPS, each step's adjoint named once complete (it is then read by earlier steps)."""
    adjoint: dict[sympy.Expr, sympy.Expr] = dict(result)
    for name, form in reversed(steps):
        weight = adjoint.pop(name, None)
        if weight is None:
            continue
        weight = named(weight)
        for symbol, coefficient in form.items():
            adjoint[symbol] = adjoint.get(symbol, sympy.S.Zero) + weight * coefficient
    return {seed: named(value) for seed, value in adjoint.items() if value != 0}
