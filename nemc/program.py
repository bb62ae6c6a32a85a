"""Straight-line programs: named intermediates instead of one expression per result.

A recursive derivation (nemc/articulated.py) writes each body's quantities as a few short
assignments `w<k> = expression of earlier names`, so the emitted code grows linearly with the
number of bodies instead of expanding every result into one large expression. The builder folds
known zeros and ones (sympy does it as expressions are built), reuses an assignment when the same
expression is asked for twice, and drops what no result needs.

Guards are the program's only control flow: `require_positive(value, status)` makes the
generated C return `status` when the value is not > 0 (a singular articulated inertia).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import sympy


@dataclass(frozen=True)
class Guard:
    """The generated code returns `status` unless `value` > 0."""

    value: sympy.Expr
    status: int


Step = tuple[sympy.Symbol, sympy.Expr] | Guard


@dataclass(frozen=True)
class Program:
    """Assignments and guards, in order, then the results as expressions of the names."""

    steps: tuple[Step, ...]
    results: tuple[sympy.Expr, ...]

    def assignments(self) -> Iterator[tuple[sympy.Symbol, sympy.Expr]]:
        return (step for step in self.steps if not isinstance(step, Guard))

    @property
    def size(self) -> int:
        return len(self.steps)

    def pruned(self) -> Program:
        """The program without the steps its results and guards do not need."""
        return Program(prune(list(self.steps), self.results), self.results)


def is_cheap(expr: sympy.Expr) -> bool:
    """Atoms and a number times an atom are used in place, never given a name."""
    if expr.is_Atom:
        return True
    return bool(expr.is_Mul and len(expr.args) == 2 and expr.args[0].is_Number
                and expr.args[1].is_Atom)


class ProgramBuilder:
    """Collects assignments; `let` returns the name (or the cheap expression itself)."""

    def __init__(self, prefix: str = "w"):
        self._steps: list[Step] = []
        self._known: dict[sympy.Expr, sympy.Symbol] = {}
        # Dummies: never equal to a symbol of the file, even one named like w3
        self._names = sympy.numbered_symbols(prefix, cls=sympy.Dummy, real=True)

    def let(self, expr: sympy.Expr | float) -> sympy.Expr:
        expr = sympy.sympify(expr)
        if is_cheap(expr):
            return expr
        name = self._known.get(expr)
        if name is None:
            name = next(self._names)
            self._steps.append((name, expr))
            self._known[expr] = name
        return name

    def lets(self, exprs: Iterable[sympy.Expr]) -> tuple[sympy.Expr, ...]:
        return tuple(self.let(e) for e in exprs)

    def reduce(self, exprs: Iterable[sympy.Expr]) -> tuple[sympy.Expr, ...]:
        """Expressions made of named steps: their common subexpressions (sympy's cse) become
        steps, each reusing the name of an equal step the program already has (a cosine the
        kinematics computed is not computed again)."""
        temporaries = sympy.numbered_symbols("c", cls=sympy.Dummy, real=True)
        replacements, reduced = sympy.cse(list(exprs), symbols=temporaries, order="none")
        names: dict[sympy.Symbol, sympy.Expr] = {}
        for temporary, expr in replacements:
            names[temporary] = self.let(expr.xreplace(names).xreplace(self._known))
        return tuple(expr.xreplace(names).xreplace(self._known) for expr in reduced)

    def require_positive(self, value: sympy.Expr, status: int) -> None:
        if not (value.is_number and value > 0):
            self._steps.append(Guard(value, status))

    @property
    def known(self) -> dict[sympy.Expr, sympy.Symbol]:
        """expression -> its name, to rewrite derivatives in terms of existing names."""
        return self._known

    def finish(self, results: Iterable[sympy.Expr]) -> Program:
        results = tuple(results)
        return Program(prune(self._steps, results), results)


def prune(steps: list[Step], results: tuple[sympy.Expr, ...]) -> tuple[Step, ...]:
    """Drop assignments that neither a result nor a guard needs (dead code)."""
    live: set[sympy.Symbol] = set()
    for expr in results:
        live |= sympy.sympify(expr).free_symbols
    kept: list[Step] = []
    for step in reversed(steps):
        if isinstance(step, Guard):
            live |= step.value.free_symbols
            kept.append(step)
        elif step[0] in live:
            live |= step[1].free_symbols
            kept.append(step)
    return tuple(reversed(kept))
