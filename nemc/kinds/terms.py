"""The terms every stage uses to speak of a mechanism: expressions and their symbols (a
parameter, constant or coordinate q is Symbol("q"), its rate dot(q) is Symbol("dot(q)"), time
is Symbol("t")), planar vectors, the ground, points fixed in bodies, and where an item came from
in the YAML. The lowest module of the kinds: the kinds, the front end and the derivation build
on it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TypeVar

import sympy

Expr = sympy.Expr
Vec2 = tuple[sympy.Expr, sympy.Expr]

TIME = sympy.Symbol("t", real=True)
GROUND = "ground"
ZERO2: Vec2 = (sympy.S.Zero, sympy.S.Zero)


Record = TypeVar("Record")


def with_expressions_mapped(record: Record, f: Callable[[sympy.Expr], sympy.Expr]) -> Record:
    """A joint, load or constraint (a dataclass) with f applied to every expression of its own
    fields: sympy values and tuples of them (e.g. constants folded)."""
    changes = {}
    for item in dataclasses.fields(record):  # type: ignore[arg-type]
        value = getattr(record, item.name)
        if isinstance(value, sympy.Basic):
            changes[item.name] = f(value)
        elif isinstance(value, tuple) and value and all(
                isinstance(v, sympy.Basic) for v in value):
            changes[item.name] = tuple(f(v) for v in value)
    return dataclasses.replace(record, **changes)  # type: ignore[type-var]


def symbol(name: str) -> sympy.Symbol:
    """The symbol of a parameter, constant or coordinate."""
    return sympy.Symbol(name, real=True)


def rate_symbol(coordinate: str) -> sympy.Symbol:
    """The symbol of ``dot(coordinate)``."""
    return sympy.Symbol(f"dot({coordinate})", real=True)


def accel_symbol(coordinate: str) -> sympy.Symbol:
    """The symbol of ``ddot(coordinate)`` (never written by users; used by outputs)."""
    return sympy.Symbol(f"ddot({coordinate})", real=True)


@dataclass(frozen=True)
class Loc:
    """Where an item came from: file, 1-based line and column, and its key path."""

    file: str
    line: int
    column: int
    key: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}: {self.key}"


@dataclass(frozen=True)
class PointRef:
    """A point fixed in a body (``ground`` allowed), by its coordinates in that body's frame."""

    body: str
    xy: Vec2
    label: str  # how the user wrote it: "link1.B", "link1.com", "ground.[2, 0]"


def post_order(expr: sympy.Basic) -> Iterator[sympy.Basic]:
    """Each distinct node of EXPR's tree once, after all its arguments (without recursion:
    any depth)."""
    seen: set[sympy.Basic] = set()
    stack = [expr]
    while stack:
        node = stack[-1]
        if node in seen:
            stack.pop()
            continue
        pending = [arg for arg in node.args if arg not in seen]
        if pending:
            stack.extend(pending)
            continue
        stack.pop()
        seen.add(node)
        yield node
