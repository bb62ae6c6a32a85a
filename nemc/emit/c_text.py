"""C text of sympy expressions: sympy's C99 printer, with a fast path for what the programs hold.

`SymbolTablePrinter` is sympy's C99CodePrinter with an explicit symbol table (no name from the
YAML reaches C) and numbers as correctly rounded double literals. Its `doprint` first tries
`FastText`, which prints the expressions of nemc's straight-line programs (symbols, numbers,
sums, products, integer and rational powers, sin, cos, unevaluated groupings) with sympy's own
rules: the same order of terms and factors, the same signs and parentheses, the same text, at
a fifth to a seventh of the time (a 1000-body chain with its Jacobian: emit 37 s -> 6 s,
docs/decisions.md "Size"). Anything else, or anything the fast path finds unusual, goes to
sympy's printer unchanged. `tests/test_c_text.py` compares the two on every program of a
set of models and on random expressions of the same grammar, in both orders.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import sympy
from sympy.core.expr import Expr
from sympy.core.exprtools import decompose_power
from sympy.core.mul import _keep_coeff
from sympy.printing.c import C99CodePrinter

EXACT_INTEGERS = 2**53  # every integer up to this magnitude is a double exactly


class NumberOutOfRange(ValueError):
    """A number of the derived equations that no double holds (e.g. constants 1e300 * 1e300)."""


def double_literal(number: sympy.Rational | sympy.Float) -> str:
    """The C literal of the double nearest NUMBER (ties to even): Python's int division is
    correctly rounded, and repr() gives the shortest text that reads back as the same double."""
    exact = sympy.Rational(number)
    try:
        value = int(exact.p) / int(exact.q)
    except OverflowError:
        value = math.inf
    if not math.isfinite(value) or (value == 0 and exact != 0):
        shown = sympy.Float(number, 3)
        raise NumberOutOfRange(f"a number of the equations, {shown}, is beyond the range of a "
                               "double (about 1e-308 to 1e308): rescale the constants or "
                               "parameters that make it")
    text = repr(value)
    return text if any(c in text for c in ".en") else text + ".0"


def rational_text(number: sympy.Rational) -> str:
    """p/q as one IEEE division of two exact doubles, or the nearest double when they are not."""
    if max(abs(number.p), number.q) > EXACT_INTEGERS:
        return double_literal(number)
    return f"{double_literal(sympy.Integer(number.p))}/{double_literal(sympy.Integer(number.q))}"


class SymbolTablePrinter(C99CodePrinter):
    """C99 printer that refuses anything it cannot print and names symbols from a table."""

    def __init__(self, names: Mapping[sympy.Symbol, str], order: str | None = None,
                 sort_keys: dict | None = None):
        super().__init__({"strict": True, **({"order": order} if order else {})})
        self.names = names
        # sympy's sort keys of factors and generators, shared with the printers made from this
        self.sort_keys = {} if sort_keys is None else sort_keys
        self.fast = FastText(names, self._settings["order"] != "none", self.sort_keys)

    def with_names(self, more: Mapping[sympy.Symbol, str], order: str | None = None
                   ) -> SymbolTablePrinter:
        """A printer of these names too, in this printer's order of terms unless ORDER."""
        return self.with_table({**self.names, **more}, order)

    def with_table(self, names: Mapping[sympy.Symbol, str], order: str | None = None
                   ) -> SymbolTablePrinter:
        """A printer of these names only, in this printer's order of terms unless ORDER."""
        return SymbolTablePrinter(names, order or self._settings["order"], self.sort_keys)

    def doprint(self, expr: Any, assign_to: Any = None) -> Any:
        """sympy's text of EXPR: by the fast path when it can, else by sympy's printer."""
        if assign_to is None and isinstance(expr, sympy.Basic):
            try:
                return self.fast.text(expr)
            except Exception:  # noqa: BLE001 (sympy's printer gives the answer, or the error)
                pass
        return super().doprint(expr, assign_to)

    def _print_Symbol(self, expr: sympy.Symbol) -> str:
        try:
            return self.names[expr]
        except KeyError:
            raise ValueError(f"no C name for symbol {expr.name!r}") from None

    _print_Dummy = _print_Symbol

    # Every number reaches C as a double literal, correctly rounded: an integer literal of 2**64
    # or more was cut modulo 2**64 by gcc (a constant k: 1e20 written out became -3.88e18).
    def _print_Integer(self, expr: sympy.Integer) -> str:
        return double_literal(expr)

    _print_Zero = _print_Integer

    def _print_Rational(self, expr: sympy.Rational) -> str:
        return rational_text(expr)

    def _print_Float(self, expr: sympy.Float) -> str:
        return double_literal(expr)


class Unsupported(Exception):
    """An expression the fast path leaves to sympy's printer."""


# sympy.printing.precedence's levels
ADD, MUL, POW, FUNCTION, ATOM = 40, 50, 60, 70, 1000
UNARY_MINUS = 0.5 * (POW + MUL)  # sympy's weight for a lone factor after a minus sign
FUNCTIONS = {sympy.sin: "sin", sympy.cos: "cos"}


def precedence(expr: sympy.Basic) -> float:
    """sympy.printing.precedence.precedence, for the fast path's kinds of expression."""
    if expr.is_Symbol:
        return ATOM
    if expr.is_Add:
        return ADD
    if expr.is_Mul:  # Mul.could_extract_minus_sign: a finite product with a negative number
        first = expr.args[0]
        return ADD if first.is_Number and first.is_extended_negative else MUL
    if expr.is_Pow:
        return POW
    if expr.is_Integer:
        return ADD if expr.p < 0 else ATOM
    if expr.is_Rational:
        return ADD if expr.p < 0 else MUL
    if expr.is_Float:
        return ADD if expr < 0 else ATOM
    if type(expr) in FUNCTIONS:
        return FUNCTION
    if isinstance(expr, sympy.UnevaluatedExpr):
        return precedence(expr.args[0]) - 0.5
    raise Unsupported(type(expr).__name__)


def number_value(number: sympy.Number) -> float:
    """complex(number).real, as sympy's as_terms has it, without evalf: a rational's nearest
    double is its correctly rounded quotient (evalf at 53 bits rounds to nearest too)."""
    if number.is_Rational:
        return int(number.p) / int(number.q)
    if number.is_Float:
        return float(number)
    raise Unsupported(type(number).__name__)


class FastText:
    """sympy's C99 text of an expression (SymbolTablePrinter's, names from NAMES), written
    directly. SORTED: terms and factors in sympy's order for print (as_ordered_terms and
    as_ordered_factors), else in the order of their arguments (order "none")."""

    def __init__(self, names: Mapping[sympy.Symbol, str], sorted_order: bool, sort_keys: dict):
        self.names = names
        self.sorted_order = sorted_order
        self.sort_keys = sort_keys

    def text(self, expr: sympy.Basic) -> str:
        if expr.is_Symbol:
            return self.names[expr]
        if expr.is_Number:
            return self.number(expr)
        if expr.is_Add:
            return self.add(expr)
        if expr.is_Mul:
            return self.mul(expr)
        if expr.is_Pow:
            return self.power(expr)
        name = FUNCTIONS.get(type(expr))
        if name is not None:
            return f"{name}({self.text(expr.args[0])})"
        if isinstance(expr, sympy.UnevaluatedExpr):
            return self.text(expr.args[0])
        raise Unsupported(type(expr).__name__)

    @staticmethod
    def number(expr: sympy.Number) -> str:
        if expr.is_Integer or expr.is_Float:
            return double_literal(expr)
        if expr.is_Rational:
            return rational_text(expr)
        raise Unsupported(type(expr).__name__)  # oo, nan

    def parenthesize(self, expr: sympy.Basic, level: float) -> str:
        text = self.text(expr)
        return f"({text})" if precedence(expr) <= level else text

    # -- sums: StrPrinter._print_Add ---------------------------------------------------------

    def add(self, expr: sympy.Add) -> str:
        terms = self.ordered_terms(expr) if self.sorted_order else expr.args
        words = []
        for term in terms:
            text = self.text(term)
            if text.startswith("-") and not term.is_Add:
                sign, text = "-", text[1:]
            else:
                sign = "+"
            words += [sign, f"({text})" if precedence(term) < ADD or term.is_Add else text]
        sign = words.pop(0)
        return ("" if sign == "+" else sign) + " ".join(words)

    def ordered_terms(self, expr: sympy.Add) -> list[sympy.Basic]:
        """Expr.as_ordered_terms() (order None: lex on the monomials of the terms' factors)."""
        args = expr.args
        if len(args) == 2:  # the special case Number + (negative number)*x keeps its order
            numbers_first = sorted(args, key=lambda a: not a.is_Number)
            number, other = numbers_first
            if number.is_Number and other.is_Mul:
                factors = sorted(other.args, key=lambda a: not a.is_Number)
                if (len(factors) == 2 and factors[0].is_Number and number.is_positive
                        and factors[0].is_negative):
                    return numbers_first
        monomials = []
        generators: set[sympy.Basic] = set()
        for term in args:
            coefficient, rest = term.as_coeff_Mul()
            value = number_value(coefficient)
            powers, others = {}, []
            if rest is not sympy.S.One:
                for factor in sympy.Mul.make_args(rest):
                    if factor.is_Number or factor.is_number:
                        raise Unsupported("a numeric factor")
                    if factor.is_commutative:
                        base, exponent = self.decompose(factor)
                        powers[base] = exponent
                        generators.add(base)
                    else:  # not known to commute: a sum or product of unevaluated groupings
                        others.append(self.sort_key(factor))
            monomials.append((term, value, powers, tuple(others)))
        order = sorted(generators, key=self.sort_key)

        def key(entry: tuple) -> tuple:  # Expr._parse_order's key, for real coefficients
            _, value, powers, others = entry
            return (tuple(-powers.get(g, 0) for g in order), others,
                    ((False, 0.0), (value, 0.0)))

        return [entry[0] for entry in sorted(monomials, key=key)]

    @staticmethod
    def decompose(factor: sympy.Basic) -> tuple[sympy.Basic, int]:
        if factor.is_Pow:
            if not factor.exp.is_Rational:
                raise Unsupported("a power of a non-rational exponent")
            if factor.exp.is_Integer:
                return factor.base, int(factor.exp.p)
            return decompose_power(factor)
        return factor, 1

    def sort_key(self, expr: sympy.Basic) -> Any:
        """expr.sort_key(), remembered; Expr.sort_key's own for compound expressions, with the
        fast path's orders of terms and factors (sympy's recomputes them every time)."""
        key = self.sort_keys.get(expr)
        if key is None:
            compound = type(expr).sort_key is Expr.sort_key and not expr.is_Atom
            key = self.sort_keys[expr] = (self.compound_sort_key(expr) if compound
                                          else expr.sort_key())
        return key

    def compound_sort_key(self, expr: sympy.Expr) -> tuple:
        """Expr.sort_key (order None)."""
        coefficient, rest = expr.as_coeff_Mul()
        exponent = sympy.S.One
        if rest.is_Pow:
            rest, exponent = rest.as_base_exp()
            if rest is sympy.S.Exp1:
                raise Unsupported("a power of e")
        if rest.is_Dummy:
            args: tuple = (rest.sort_key(),)
        elif rest.is_Atom:
            args = (str(rest),)
        else:
            if rest.is_Add:
                parts = self.ordered_terms(rest)
            elif rest.is_Mul:
                parts = self.ordered_factors(rest.args)
            else:
                parts = rest.args
            args = tuple(self.sort_key(part) for part in parts)
        return (rest.class_key(), (len(args), args), exponent.sort_key(), coefficient)

    # -- products: CodePrinter._print_Mul ----------------------------------------------------

    def mul(self, expr: sympy.Mul) -> str:
        level = precedence(expr)
        coefficient, rest = expr.as_coeff_Mul()
        sign = ""
        if coefficient < 0:
            expr, sign = _keep_coeff(-coefficient, rest), "-"
        factors = sympy.Mul.make_args(expr)
        if self.sorted_order and len(factors) > 1:
            factors = self.ordered_factors(factors)
        above: list[sympy.Basic] = []  # the numerator's factors
        below: list[sympy.Basic] = []  # the denominator's
        grouped = []  # reciprocals of products, parenthesized twice as sympy does
        for item in factors:
            if item.is_commutative and item.is_Pow and item.exp.is_Rational and (
                    item.exp.is_negative):  # 1/grouping is not known to commute: a factor
                if item.exp != -1:
                    below.append(sympy.Pow(item.base, -item.exp, evaluate=False))
                else:
                    if item.base.is_Mul:
                        grouped.append(item)
                    below.append(item.base)
            else:
                above.append(item)
        above = above or [sympy.S.One]
        if len(above) == 1 and sign == "-":
            above_text = [self.parenthesize(above[0], UNARY_MINUS)]
        else:
            above_text = [self.parenthesize(item, level) for item in above]
        below_text = [self.parenthesize(item, level) for item in below]
        for item in grouped:  # the first equal base, as sympy's list.index finds it
            at = below.index(item.base)
            below_text[at] = f"({below_text[at]})"
        if not below:
            return sign + "*".join(above_text)
        if len(below) == 1:
            return sign + "*".join(above_text) + "/" + below_text[0]
        return sign + "*".join(above_text) + "/(" + "*".join(below_text) + ")"

    def ordered_factors(self, factors: tuple[sympy.Basic, ...]) -> list[sympy.Basic]:
        """Mul.as_ordered_factors(): the factors before the first one not known to commute
        (an unevaluated grouping's is_commutative is None) sorted, the others as they are."""
        split = next((k for k, f in enumerate(factors) if not f.is_commutative), len(factors))
        if split and factors[0].is_Number and factors[0].is_extended_negative and (
                factors[0] is not sympy.S.NegativeOne):
            raise Unsupported("a negative coefficient args_cnc would split")
        return sorted(factors[:split], key=self.sort_key) + list(factors[split:])

    # -- powers: C89CodePrinter._print_Pow ---------------------------------------------------

    def power(self, expr: sympy.Pow) -> str:
        base, exponent = expr.args
        if base.is_number or not exponent.is_Rational:  # sympy's math macros: M_SQRT2, ...
            raise Unsupported("a power of a number, or a non-rational power")
        if exponent == -1:
            return f"1.0/{self.parenthesize(base, POW)}"
        if exponent == sympy.S.Half:
            return f"sqrt({self.text(base)})"
        if exponent == sympy.Rational(1, 3):
            return f"cbrt({self.text(base)})"
        return f"pow({self.text(base)}, {self.text(exponent)})"
