"""The sines and cosines of a program's angles, computed together (issue 19).

libm's sin and cos take one value at a time: a call each, with branches on the argument's size
that a chaotic motion mispredicts. In a right-hand side of a few coordinates they are a large
part of its critical path: every mass-matrix entry waits for them (`python
benchmarks/rhs_forms.py`: the double pendulum's RHS 36 -> 27 ns, the 4-link chain's 115 -> 88;
docs/decisions.md, "The right-hand side's sines and cosines together").

`angle_calls` finds the sines and cosines whose argument is made of the program's inputs
(coordinates, rates, parameters, time: known when it starts), directly or through steps that
only add and multiply them (a chain's absolute angles q1 + q2, q1 + q2 + q3, ... each one step
from the one before), and rewrites them as names that the generated C fills in one go, before
the program's first step, with nemc.Taylor's branch-free kernel over two-element vectors
(templates/angles.c.tmpl, templates/sincos.c.tmpl). Those steps are computed once more for it,
ahead (`AngleCalls.ahead`): one addition per joint on a chain. A sine or cosine of another
intermediate value keeps libm.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import sympy

from ..derive.program import Guard, Program


@dataclass(frozen=True)
class AngleCalls:
    """A program whose sines and cosines of inputs are the names sines[k] and cosines[k] of
    angles[k], computed before its first step."""

    angles: tuple[sympy.Expr, ...]  # the arguments, in order of first use
    sines: tuple[sympy.Symbol, ...]
    cosines: tuple[sympy.Symbol, ...]
    program: Program
    ahead: tuple[tuple[sympy.Symbol, sympy.Expr], ...]  # the steps the angles read, in order

    def names_in(self, program: Program) -> Program:
        """PROGRAM, one that reads this program's steps (the Jacobian's tangent reads its
        primal's), with the sines and cosines of these angles as these names too."""
        index = {angle: k for k, angle in enumerate(self.angles)}
        names: dict[sympy.Expr, sympy.Symbol] = {}
        for expr in step_expressions(program):
            for node in preorder(expr):
                if isinstance(node, TRIG) and node not in names:
                    k = index.get(node.args[0])
                    if k is not None:
                        names[node] = (self.sines if isinstance(node, sympy.sin)
                                       else self.cosines)[k]
        return renamed(program, names)


TRIG = (sympy.sin, sympy.cos)


def preorder(expr: sympy.Basic) -> Iterable[sympy.Basic]:
    """EXPR's nodes in sympy.preorder_traversal's order (each node, then its arguments' nodes
    in turn), walked without its generator per node: on a 1000-body chain's Jacobian that
    walk was most of the angles' 1.7 s."""
    stack = [expr]
    while stack:
        node = stack.pop()
        yield node
        if node.args:
            stack.extend(reversed(node.args))


def step_expressions(program: Program) -> Iterable[sympy.Expr]:
    """The program's expressions: its steps' values, its guards' and its results."""
    for step in program.steps:
        yield step.value if isinstance(step, Guard) else step[1]
    yield from (sympy.sympify(result) for result in program.results)


def is_arithmetic(expr: sympy.Expr) -> bool:
    """Sums and products of symbols and numbers only: cheap to compute again."""
    return all(node.is_Symbol or node.is_Number or node.is_Add or node.is_Mul
               for node in preorder(expr))


def input_steps(program: Program, inputs: frozenset[sympy.Symbol]
                ) -> dict[sympy.Symbol, sympy.Expr]:
    """The steps that only add and multiply inputs and each other (q1 - q2, a chain's absolute
    angles), in order."""
    steps: dict[sympy.Symbol, sympy.Expr] = {}
    known = set(inputs)
    for name, expr in program.assignments():
        if expr.free_symbols <= known and is_arithmetic(expr):
            steps[name] = expr
            known.add(name)
    return steps


def trig_calls(program: Program, known: frozenset[sympy.Symbol]) -> list[sympy.Expr]:
    """The program's sines and cosines whose argument is made of KNOWN symbols, each once, in
    the order the program first uses them."""
    found: dict[sympy.Expr, None] = {}
    for expr in step_expressions(program):
        for node in preorder(expr):
            if (isinstance(node, TRIG) and node not in found
                    and node.args[0].free_symbols <= known):
                found[node] = None
    return list(found)


def read_ahead(angles: tuple[sympy.Expr, ...], steps: dict[sympy.Symbol, sympy.Expr]
               ) -> tuple[tuple[sympy.Symbol, sympy.Expr], ...]:
    """The STEPS the angles read, directly or through each other, in the program's order."""
    needed = set().union(*(angle.free_symbols for angle in angles)) & steps.keys()
    for name in reversed(list(steps)):
        if name in needed:
            needed |= steps[name].free_symbols & steps.keys()
    return tuple((name, expr) for name, expr in steps.items() if name in needed)


def renamed(program: Program, names: dict[sympy.Expr, sympy.Symbol]) -> Program:
    """PROGRAM with each call in NAMES replaced by its name."""
    if not names:
        return program

    def rename(expr: sympy.Expr) -> sympy.Expr:
        return sympy.sympify(expr).xreplace(names)

    steps = tuple(Guard(rename(step.value), step.status) if isinstance(step, Guard)
                  else (step[0], rename(step[1])) for step in program.steps)
    return Program(steps, tuple(rename(r) for r in program.results))


def angle_calls(program: Program, inputs: frozenset[sympy.Symbol]) -> AngleCalls:
    """The program with the sines and cosines of its input angles as names (none: as it is)."""
    steps = input_steps(program, inputs)
    calls = trig_calls(program, frozenset(inputs | steps.keys()))
    angles = tuple(dict.fromkeys(call.args[0] for call in calls))
    sines = tuple(sympy.Dummy(f"sine{k}", real=True) for k in range(len(angles)))
    cosines = tuple(sympy.Dummy(f"cosine{k}", real=True) for k in range(len(angles)))
    index = {angle: k for k, angle in enumerate(angles)}
    names = {call: (sines if isinstance(call, sympy.sin) else cosines)[index[call.args[0]]]
             for call in calls}
    return AngleCalls(angles, sines, cosines, renamed(program, names),
                      read_ahead(angles, steps))
