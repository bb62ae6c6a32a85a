"""Parameter and constant values: what folds at compile time and what stays a runtime input.

Constants fold to numbers. A parameter given as a number is a runtime input (an entry of the
parameter vector p); a parameter given as an expression is derived: it is replaced by its
definition, so it follows its inputs when they are changed at run time.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import sympy

from . import mechanism as m


@dataclass(frozen=True)
class Values:
    runtime_symbols: tuple[sympy.Symbol, ...]
    runtime_defaults: tuple[float, ...]
    derived: tuple[tuple[str, sympy.Expr], ...]  # derived parameter -> expression of runtime ones
    substitutions: dict[sympy.Symbol, sympy.Expr]  # constants and derived parameters


def dependency_order(names: Iterable[str], dependencies: Callable[[str], Iterable[str]]
                     ) -> list[str]:
    """NAMES with every name after those of NAMES it depends on (a depth-first post-order,
    without recursion: a chain of 3,000 definitions overflowed Python's stack, and repeated
    passes over the pending names took time cubic in their number). Names on a cycle come
    out in some order; callers check cycles first."""
    names = list(names)
    known = set(names)
    order: list[str] = []
    placed: set[str] = set()
    for start in names:
        if start in placed:
            continue
        placed.add(start)
        stack = [(start, iter(dependencies(start)))]
        while stack:
            name, pending = stack[-1]
            dep = next((d for d in pending if d in known and d not in placed), None)
            if dep is None:
                stack.pop()
                order.append(name)
            else:
                placed.add(dep)
                stack.append((dep, iter(dependencies(dep))))
    return order


def _resolve(items: tuple[m.Param, ...], known: dict[sympy.Symbol, sympy.Expr]) -> None:
    """Put each item's definition into `known`, in dependency order (validated: no cycles)."""
    by_name: Mapping[str, m.Param] = {item.name: item for item in items}

    def dependencies(name: str) -> list[str]:
        return [s.name for s in sympy.sympify(by_name[name].expr).free_symbols]

    for name in dependency_order(by_name, dependencies):
        known[m.symbol(name)] = sympy.sympify(by_name[name].expr).xreplace(known)


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

