"""The exact linearization of a tree's equations at a state: the forward-mode derivative of the
accelerations' program (and the drives', with driven joints) along each entry of the state and
each input, and of the scene's outputs along the same directions through the accelerations.

    A = d(dy/dt)/dy,  B = d(dy/dt)/du,  C = d out/dy,  D = d out/du

Each input u enters the equations through its law (inputs.py) by its constant term a, with
d(law)/da = 1: the derivative along a is the derivative along u. The derivative along y is the
open-loop A where the law's gains are zero (a linearization is taken at fixed inputs; a run with
a feedback has them, and its Jacobian then is the closed loop's). The outputs are a program of
their own (their common subexpressions named), whose derivative reads the accelerations'
derivatives: outputs such as reactions depend on the accelerations.

The generated C (templates/linearization.c.tmpl) evaluates the programs once and their
derivatives once per column: no finite differences anywhere.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import sympy

from .program import Program, ProgramBuilder, prune
from .tangent import tangent_program


@dataclass(frozen=True)
class Linearization:
    """The programs of a tree's linearization, in runtime symbols."""

    seeds: Mapping[sympy.Symbol, sympy.Symbol]  # state entries' and inputs' values -> tangents
    dynamics: Program  # d(accelerations, drives) along the seeds
    outputs: Program | None  # the named steps of the scene's outputs that their derivative reads
    outputs_tangent: Program | None  # d(outputs) along the seeds and the accelerations'
    results_seeds: Mapping[sympy.Symbol, sympy.Symbol]  # accelerations, drives, multipliers
    #                                                      -> their tangents


def state_seeds(state: tuple[sympy.Symbol, ...]) -> dict[sympy.Symbol, sympy.Symbol]:
    return {symbol: sympy.Dummy(f"seed_{k}", real=True) for k, symbol in enumerate(state)}


def input_seeds(values: tuple[sympy.Symbol, ...]) -> dict[sympy.Symbol, sympy.Symbol]:
    """The tangent of each input's constant term (printed SEED_U(k))."""
    return {value: sympy.Dummy(f"seed_u_{k}", real=True) for k, value in enumerate(values)}


def linearization(dynamics: Program, seeds: Mapping[sympy.Symbol, sympy.Symbol],
                  results: tuple[sympy.Symbol, ...],
                  outputs: tuple[sympy.Expr, ...]) -> Linearization:
    """DYNAMICS (its results: a tree's accelerations, then its drives; a closed loop's pieces,
    DynamicsLayout) and OUTPUTS (expressions of the state, the inputs' laws and RESULTS, the
    symbols of the accelerations, drives and multipliers) differentiated along SEEDS."""
    tangent = tangent_program(dynamics, seeds)
    results_seeds = {symbol: sympy.Dummy(f"d{symbol.name}", real=True) for symbol in results}
    if not outputs:
        return Linearization(seeds, tangent, None, None, results_seeds)
    builder = ProgramBuilder("o")
    program = builder.finish(builder.reduce(outputs))
    outputs_tangent = tangent_program(program, {**seeds, **results_seeds}, prefix="do")
    read = set().union(*(sympy.sympify(e).free_symbols for e in outputs_tangent.results),
                       *(e.free_symbols for _, e in outputs_tangent.assignments()))
    needed = Program(prune(list(program.steps), tuple(read)), ())  # what the derivative reads
    return Linearization(seeds, tangent, needed, outputs_tangent, results_seeds)
