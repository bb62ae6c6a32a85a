"""Parameter and constant values: what folds at compile time and what stays a runtime input.

Constants fold to numbers. A parameter given as a number is a runtime input (an entry of the
parameter vector p); a parameter given as an expression is derived: it is replaced by its
definition, so it follows its inputs when they are changed at run time.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from . import model as m


@dataclass(frozen=True)
class Values:
    runtime_symbols: tuple[sympy.Symbol, ...]
    runtime_defaults: tuple[float, ...]
    derived: tuple[tuple[str, sympy.Expr], ...]  # derived parameter -> expression of runtime ones
    substitutions: dict[sympy.Symbol, sympy.Expr]  # constants and derived parameters


def _resolve(items: tuple[m.Param, ...], known: dict[sympy.Symbol, sympy.Expr]) -> None:
    """Put each item's definition into `known`, in dependency order (validated: no cycles)."""
    pending = list(items)
    while pending:
        progressed = False
        for item in list(pending):
            expr = sympy.sympify(item.expr).xreplace(known)
            names = {s.name for s in expr.free_symbols}
            if not names & {p.name for p in pending}:
                known[m.symbol(item.name)] = expr
                pending.remove(item)
                progressed = True
        if not progressed:
            raise ValueError("cyclic parameter definitions (validate first)")


def resolve_values(mech: m.Mechanism) -> Values:
    constants: dict[sympy.Symbol, sympy.Expr] = {}
    _resolve(mech.constants, constants)
    runtime = [p for p in mech.parameters if sympy.sympify(p.expr).xreplace(constants).is_number]
    runtime_syms = tuple(m.symbol(p.name) for p in runtime)
    defaults = tuple(float(sympy.sympify(p.expr).xreplace(constants)) for p in runtime)
    derived_items = tuple(p for p in mech.parameters if p not in runtime)
    known = dict(constants)
    _resolve(derived_items, known)
    derived = tuple((p.name, known[m.symbol(p.name)]) for p in derived_items)
    return Values(runtime_syms, defaults, derived, known)

