"""Sines and cosines of sums of angles from those of their parts (the addition formulas).

The mass-matrix form linearized in sines and cosines (nemc/mass_form.py) is compact, but takes
sines and cosines of many sums of angles: a 4-link chain's M and f have 10 distinct arguments
(q2, q2 + q3, q1 + q2 + q3 + q4, ...), each one sincos call in C, about 7.4 ns
(nemc/c_cost.py), where a product costs 0.08 ns and a sum 0.35. When an argument a is b + c or
b - c with sin and cos of both b and c computed anyway, the addition formulas

    sin(b + s c) = sin b cos c + s cos b sin c,    cos(b + s c) = cos b cos c - s sin b sin c

(s = +1 or -1) give sin a and cos a from four products and two sums instead of a call. The
arguments are taken by their number of terms, so every part is ready before the sums made of
it, and an argument is split only into parts computed anyway: no call is ever added, and a chain
of n links in relative angles is left with the n calls of its joints' own angles.

Each formula rounds once or twice more than a call (a few units in the last place, absolute, on
values of size 1). Taylor's coefficients do not use this form: there a sine-cosine pair costs
two Cauchy sums per order and the formulas four (derive.with_taylor leaves it out).
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy

Definition = tuple[sympy.Symbol, sympy.Expr]


def split_angle_sums(exprs: Sequence[sympy.Expr]
                     ) -> tuple[list[Definition], list[sympy.Expr]]:
    """(definitions, exprs rewritten): every sin(a) and cos(a) of the expressions whose argument
    a is a sum or difference of two arguments also present (or split before) is replaced by a
    new symbol, defined in order, parts first, by the addition formulas. No definitions and the
    expressions as they are when nothing splits."""
    arguments = sorted({node.args[0] for expr in exprs for node in sympy.preorder_traversal(expr)
                        if isinstance(node, (sympy.sin, sympy.cos))},
                       key=lambda a: (term_count(a), sympy.default_sort_key(a)))
    values: dict[sympy.Expr, tuple[sympy.Expr, sympy.Expr]] = {}  # a -> (sin a, cos a)
    definitions: list[Definition] = []
    replacements: dict[sympy.Expr, sympy.Expr] = {}
    for argument in arguments:
        split = two_parts(argument, values)
        if split is None:
            values[argument] = (sympy.sin(argument), sympy.cos(argument))  # a call
            continue
        rest, sign, part = split
        (sin_b, cos_b), (sin_c, cos_c) = values[rest], values[part]
        count = len(definitions) // 2
        sine = sympy.Dummy(f"sin_sum{count}", real=True)
        cosine = sympy.Dummy(f"cos_sum{count}", real=True)
        definitions += [(sine, sin_b * cos_c + sign * cos_b * sin_c),
                        (cosine, cos_b * cos_c - sign * sin_b * sin_c)]
        values[argument] = (sine, cosine)
        replacements[sympy.sin(argument)] = sine
        replacements[sympy.cos(argument)] = cosine
    return definitions, [expr.xreplace(replacements) for expr in exprs]


def term_count(argument: sympy.Expr) -> int:
    return len(argument.args) if argument.is_Add else 1


def two_parts(argument: sympy.Expr, ready: dict[sympy.Expr, object]
              ) -> tuple[sympy.Expr, int, sympy.Expr] | None:
    """(b, s, c) with argument = b + s c, b and c both in READY and b of fewer terms than the
    argument (s = 1 or -1), or None."""
    if not argument.is_Add:
        return None
    for part in ready:
        for sign in (1, -1):
            rest = argument - sign * part
            if rest in ready and term_count(rest) < term_count(argument):
                return rest, sign, part
    return None
