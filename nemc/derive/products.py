"""Fewer Cauchy products in nemc.Taylor's program (derive.with_taylor; issue 19).

A Taylor step costs, per order, one Cauchy sum for each product of two time-varying values;
sums and constant factors cost next to nothing (taylor.SERIES_WEIGHTS). Two rewrites lower the
number of products without changing what the program computes (only its rounding):

- `distributed`: a time-varying factor common to several terms of a sum is taken out of them
  (a b c + a b d - a e -> a (b (c + d) - e)), greedily, the factor in the most terms first.
  Products that earlier steps named are seen through (those steps stay for their other uses).
  The mass-matrix form gains most: 118 -> 88.5 sums per order on a 4-link chain.
- `shared_pairs`: the pair of time-varying names found in the most products of three or more
  factors is named once and used by all of them, until no pair is in two products (the greedy
  rule of multiplicative common-subexpression elimination). The articulated-body program's
  U D^-1 U^T terms share their U_i D^-1 this way: 368.5 -> 337 sums on an 8-link chain.

`fewer_products` keeps whichever of the program, shared_pairs(program) and
shared_pairs(distributed(program)) has the fewest sums by the caller's cost (taylor.series_cost):
taking factors out can break a product an earlier step shares, so neither rewrite wins always.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable
from itertools import combinations

import sympy

from ..kinds.terms import post_order
from .program import Guard, Program, Step

Factors = Counter  # a product's time-varying factors, with their multiplicities


def fewer_products(program: Program, varying: Iterable[sympy.Symbol],
                   cost: Callable[[Program], float]) -> Program:
    """The cheapest by `cost` of the program and its rewrites; varying: the symbols that
    change with time (coordinates, speeds, time), the program's own names found from them."""
    varying = time_varying(program, varying)
    candidates = [program, shared_pairs(program, varying),
                  shared_pairs(distributed(program, varying), varying)]
    costs = [cost(candidate) for candidate in candidates]
    return candidates[costs.index(min(costs))]


def time_varying(program: Program, given: Iterable[sympy.Symbol]) -> frozenset[sympy.Symbol]:
    """The given symbols and every name of the program whose value depends on them."""
    varying = set(given)
    for step in program.steps:
        if not isinstance(step, Guard) and step[1].free_symbols & varying:
            varying.add(step[0])
    return frozenset(varying)


def constant_and_factors(product: sympy.Expr, varying: frozenset[sympy.Symbol]
                         ) -> tuple[sympy.Expr, Factors]:
    """A product as its time-independent factor and its time-varying factors (a whole
    positive power counts as that many factors; any other factor is one, as it is)."""
    constant, factors = sympy.S.One, Factors()
    for arg in sympy.Mul.make_args(product):
        if not arg.free_symbols & varying:
            constant *= arg
        elif arg.is_Pow and arg.exp.is_Integer and arg.exp > 1:
            factors[arg.base] += int(arg.exp)
        else:
            factors[arg] += 1
    return constant, factors


def degree(factors: Factors) -> int:
    return sum(factors.values())


def product_of(constant: sympy.Expr, factors: Factors) -> sympy.Expr:
    return constant * sympy.Mul(*(base**count for base, count in factors.items()))


# ---- distributed: common factors out of sums --------------------------------------------------


def distributed(program: Program, varying: frozenset[sympy.Symbol]) -> Program:
    """The program with each sum of products factored (`factored`), looking through the
    products earlier steps named (a step a b, used in a sum as a term's factor, counts as a and
    b there). Steps no longer used are dropped."""
    named: dict[sympy.Symbol, tuple[sympy.Expr, Factors]] = {}  # step -> its product's parts
    steps: list[Step] = []
    for step in program.steps:
        if isinstance(step, Guard):
            steps.append(step)
            continue
        name, expr = step
        if expr.is_Add and expr.free_symbols & varying:
            expr = factored(expr, varying, named)
        elif expr.is_Mul or expr.is_Pow:
            constant, factors = constant_and_factors(expr, varying)
            if degree(factors) >= 2:
                named[name] = seen_through(constant, factors, named)
        steps.append((name, expr))
    return Program(tuple(steps), program.results).pruned()


def seen_through(constant: sympy.Expr, factors: Factors,
                 named: dict[sympy.Symbol, tuple[sympy.Expr, Factors]]
                 ) -> tuple[sympy.Expr, Factors]:
    """The product with each factor that names a product replaced by that product's parts."""
    total = Factors()
    for factor, count in factors.items():
        if factor in named:
            inner_constant, inner = named[factor]
            constant *= inner_constant**count
            for base, times in inner.items():
                total[base] += times * count
        else:
            total[factor] += count
    return constant, total


def factored(expr: sympy.Add, varying: frozenset[sympy.Symbol],
             named: dict[sympy.Symbol, tuple[sympy.Expr, Factors]]) -> sympy.Expr:
    """A sum with its time-varying factors taken out of its terms (greedy_factored)."""
    fixed = [term for term in expr.args if not term.free_symbols & varying]
    terms = [seen_through(*constant_and_factors(term, varying), named)
             for term in expr.args if term.free_symbols & varying]
    if not all(is_simple(factor) for _, factors in terms for factor in factors):
        return expr  # measured: taking factors out next to sums or quotients costs more
    return greedy_factored(terms) + sympy.Add(*fixed)


def is_simple(factor: sympy.Expr) -> bool:
    """A name, or a function (sin, cos, ...) of one."""
    return factor.is_Symbol or bool(factor.is_Function and factor.args[0].is_Symbol)


def greedy_factored(terms: list[tuple[sympy.Expr, Factors]]) -> sympy.Expr:
    """sum(constant * product of factors) with the factor common to the most terms that are
    products taken out of them, then the same within and outside, until no factor is common
    to two products."""
    counts = Counter(factor for _, factors in terms if degree(factors) >= 2
                     for factor in factors)
    if not counts or counts.most_common(1)[0][1] < 2:
        return sympy.Add(*(product_of(constant, factors) for constant, factors in terms))
    common = counts.most_common(1)[0][0]
    inner: list[tuple[sympy.Expr, Factors]] = []
    rest: list[tuple[sympy.Expr, Factors]] = []
    for constant, factors in terms:
        if common in factors and degree(factors) >= 2:
            factors = factors.copy()
            factors[common] -= 1
            inner.append((constant, +factors))  # unary + drops the zero counts
        else:
            rest.append((constant, factors))
    return common * greedy_factored(inner) + greedy_factored(rest)


# ---- shared_pairs: a pair in many products named once -----------------------------------------


def shared_pairs(program: Program, varying: frozenset[sympy.Symbol], prefix: str = "wp"
                 ) -> Program:
    """The program with the pair of time-varying names in the most products of three or more
    factors named (PREFIX<k> = a b, placed before its first use), again until no pair is in
    two products. Only names (symbols) are paired; other factors stay as they are."""
    exprs = [step.value if isinstance(step, Guard) else step[1] for step in program.steps]
    products = distinct_products([*exprs, *program.results], varying)
    pairs = PairIndex(products.values())
    names = sympy.numbered_symbols(prefix, cls=sympy.Dummy, real=True)
    definitions: dict[sympy.Symbol, tuple[sympy.Symbol, sympy.Symbol]] = {}
    while (best := pairs.most_shared()) is not None:
        name = next(names)
        definitions[name] = best
        pairs.replace(best, name)
    if not definitions:
        return program
    rewritten = {node: (products[node], pairs.factors[k]) for k, node in enumerate(products)}
    return placed(program, rewritten, definitions)


def distinct_products(exprs: Iterable[sympy.Expr], varying: frozenset[sympy.Symbol]
                      ) -> dict[sympy.Expr, Factors]:
    """Every product node in the expressions (each once) -> its time-varying names (symbols),
    with their multiplicities: what shared_pairs may pair."""
    products: dict[sympy.Expr, Factors] = {}
    for expr in exprs:
        for node in post_order(sympy.sympify(expr)):
            if node.is_Mul and node not in products:
                _, factors = constant_and_factors(node, varying)
                products[node] = Factors({f: c for f, c in factors.items() if f.is_Symbol})
    return products


class PairIndex:
    """The products' name multisets and, for each pair of names, which products hold it."""

    def __init__(self, factor_lists: Iterable[Factors]):
        self.factors: list[Factors] = [Factors(f) for f in factor_lists]
        self.holders: dict[tuple[sympy.Symbol, sympy.Symbol], set[int]] = {}
        for k, factors in enumerate(self.factors):
            self._index(k, factors, add=True)

    def _index(self, k: int, factors: Factors, add: bool) -> None:
        for pair in pairs_in(factors):
            holders = self.holders.setdefault(pair, set())
            if add:
                holders.add(k)
            else:
                holders.discard(k)

    def most_shared(self) -> tuple[sympy.Symbol, sympy.Symbol] | None:
        """The pair in the most products, if it is in two or more and in one of at least three
        factors (a product of the pair alone is shared already); ties: the first indexed."""
        best, best_count = None, 1
        for pair, holders in self.holders.items():
            if len(holders) > best_count and any(degree(self.factors[k]) >= 3
                                                 for k in holders):
                best, best_count = pair, len(holders)
        return best

    def replace(self, pair: tuple[sympy.Symbol, sympy.Symbol], name: sympy.Symbol) -> None:
        """In every product holding the pair: the pair's two factors become NAME."""
        for k in list(self.holders[pair]):
            self._index(k, self.factors[k], add=False)
            factors = self.factors[k].copy()
            for factor in pair:
                factors[factor] -= 1
            factors = +factors
            factors[name] += 1
            self.factors[k] = factors
            self._index(k, factors, add=True)


def pairs_in(factors: Factors) -> list[tuple[sympy.Symbol, sympy.Symbol]]:
    """The distinct unordered pairs of a multiset of names (a name twice: its square), in a
    fixed order: ties between pairs go the same way in every process, so do the builds."""
    names = sorted(factors, key=sympy.default_sort_key)
    pairs = [(name, name) for name in names if factors[name] >= 2]
    return pairs + list(combinations(names, 2))


Rewritten = dict[sympy.Expr, tuple[Factors, Factors]]  # product -> its names before, after


def placed(program: Program, rewritten: Rewritten,
           definitions: dict[sympy.Symbol, tuple[sympy.Symbol, sympy.Symbol]]) -> Program:
    """The program with its products rewritten and each pair's step just before its first
    use (after the steps that define its two factors, which that use needs too)."""
    steps: list[Step] = []
    defined: set[sympy.Symbol] = set()

    def define(needed: Iterable[sympy.Symbol]) -> None:
        for name in sorted(needed, key=sympy.default_sort_key):
            if name in definitions and name not in defined:
                first, second = definitions[name]
                define((first, second))
                steps.append((name, first * second))
                defined.add(name)

    for step in program.steps:
        if isinstance(step, Guard):
            value = substituted(step.value, rewritten)
            define(value.free_symbols)
            steps.append(Guard(value, step.status))
        else:
            value = substituted(step[1], rewritten)
            define(value.free_symbols)
            steps.append((step[0], value))
    results = tuple(substituted(sympy.sympify(r), rewritten) for r in program.results)
    define(set().union(*(r.free_symbols for r in results)))
    return Program(tuple(steps), results)


def substituted(expr: sympy.Expr, rewritten: Rewritten) -> sympy.Expr:
    """EXPR with its products' names replaced by the pairs that hold them, from the leaves up
    (a product's other factors, kept, may hold products too)."""
    done: dict[sympy.Basic, sympy.Basic] = {}
    for node in post_order(expr):
        args = [done[arg] for arg in node.args]
        if node in rewritten:
            before, after = rewritten[node]
            kept = [new for new, old in zip(args, node.args) if not is_one_of(old, before)]
            done[node] = sympy.Mul(*kept) * product_of(sympy.S.One, after)
        elif all(new is old for new, old in zip(args, node.args)):
            done[node] = node
        else:
            done[node] = node.func(*args)
    return done[expr]


def is_one_of(factor: sympy.Expr, names: Factors) -> bool:
    """Whether a product's argument is one of its names or a whole power of one."""
    return factor in names or bool(factor.is_Pow and factor.base in names
                                   and factor.exp.is_Integer and factor.exp > 1)
