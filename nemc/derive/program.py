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

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import sympy

from ..kinds.terms import post_order


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


# The deepest expression a step keeps: sympy's diff (the Jacobian's tangent program), its
# printers and CSE recurse about 5 Python frames a level, so a load nested 100 levels deep
# (the documented limit, nemc.expr.MAX_DEPTH) overflowed Python's stack in compile. The
# mechanism's own steps are at most 9 deep; only expressions from the file get split.
MAX_STEP_DEPTH = 24


def split_deep(program: Program, prefix: str, max_depth: int = MAX_STEP_DEPTH) -> Program:
    """The same program with no expression deeper than MAX_DEPTH: deeper subexpressions become
    steps of their own (named PREFIX<k>), before the step that uses them (the same operations,
    in the same order)."""
    exprs = [step.value if isinstance(step, Guard) else step[1] for step in program.steps]
    if all(depth_at_most(sympy.sympify(e), max_depth) for e in [*exprs, *program.results]):
        return program
    names = sympy.numbered_symbols(prefix, cls=sympy.Dummy, real=True)
    steps: list[Step] = []

    def name(expr: sympy.Expr) -> sympy.Symbol:
        symbol = next(names)
        steps.append((symbol, expr))
        return symbol

    for step in program.steps:
        if isinstance(step, Guard):
            steps.append(Guard(shallow(step.value, max_depth, name), step.status))
        else:
            steps.append((step[0], shallow(step[1], max_depth, name)))
    results = tuple(shallow(sympy.sympify(r), max_depth, name) for r in program.results)
    return Program(tuple(steps), results)


def depth_at_most(expr: sympy.Basic, limit: int) -> bool:
    """Whether EXPR's tree has at most LIMIT levels (an atom is 1), without recursion."""
    level = {expr}
    for _ in range(limit):
        level = {arg for node in level for arg in node.args}
        if not level:
            return True
    return False


def shallow(expr: sympy.Expr, max_depth: int, name: Callable[[sympy.Expr], sympy.Symbol]
            ) -> sympy.Expr:
    """EXPR with every subexpression that reaches MAX_DEPTH levels replaced by name(it), from
    the leaves up (post-order, without recursion: any depth is handled)."""
    done: dict[sympy.Basic, tuple[sympy.Basic, int]] = {}
    for node in post_order(expr):
        if not node.args:
            done[node] = (node, 1)
            continue
        args = [done[arg][0] for arg in node.args]
        depth = 1 + max(done[arg][1] for arg in node.args)
        same = all(new is old for new, old in zip(args, node.args))
        rebuilt = node if same else node.func(*args)
        done[node] = (name(rebuilt), 1) if depth >= max_depth else (rebuilt, depth)
    return done[expr][0]
