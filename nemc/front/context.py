"""What validation has learned of a file so far and the problems found in it (`Context`), and
the checks of a YAML node's shape every part of the file shares: a mapping's keys, a value's
description in a message, a key path.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import sympy

from ..errors import InputError, Problem
from ..kinds.joints import Joint
from .expr import Budget, Scope, suggest
from .mechanism import Body, Loc, symbol
from .parse import Node

# Problems reported at most: each costs a suggestion (difflib over every name), so a file of
# 15,000 wrong loads and 5,000 parameters took 106 s to report in full.
MAX_PROBLEMS = 100
FIXED_WHERE = ("in body, joint, gravity and initial-condition fields (parameters and constants "
               "only)")
MOTION_WHERE = "in a joint's motion (parameters, constants and t only)"
POINT_WHERE = ("in a load's point (parameters, constants, coordinates, inputs and t; a moving "
               "point's place depends on no rate)")


@dataclass
class Context:
    """What validation has learned so far, and the problems found."""

    file: str
    problems: list[Problem] = field(default_factory=list)
    names: dict[str, tuple[str, str]] = field(default_factory=dict)  # name -> (kind, path)
    lines: dict[str, int] = field(default_factory=dict)  # name -> line where it is defined
    parameters: list[str] = field(default_factory=list)
    constants: list[str] = field(default_factory=list)
    coordinates: list[str] = field(default_factory=list)
    inputs: list[str] = field(default_factory=list)  # the inputs' names, in file order
    defaults: dict[sympy.Symbol, sympy.Expr] = field(default_factory=dict)
    depths: dict[sympy.Symbol, int] = field(default_factory=dict)  # of written-out definitions
    bodies: dict[str, Body] = field(default_factory=dict)
    body_names: list[str] = field(default_factory=list)  # valid names, in file order
    body_keys: list[str] = field(default_factory=list)  # every key under bodies
    joint_keys: list[str] = field(default_factory=list)  # every key under joints
    constraint_keys: list[str] = field(default_factory=list)  # every key under constraints
    joints: dict[str, Joint] = field(default_factory=dict)
    joint_coordinates: dict[str, tuple[str, ...]] = field(default_factory=dict)
    budget: Budget = field(default_factory=Budget)  # tokens left for the file's expressions
    scopes: dict[tuple, Scope] = field(default_factory=dict)  # see scope()

    def problem(self, line: int, key: str, message: str) -> None:
        self.problems.append(Problem(self.file, line, key, message))
        if len(self.problems) >= MAX_PROBLEMS:
            raise InputError([*sorted(self.problems, key=lambda p: p.line), Problem(
                self.file, line, "", f"stopped after {MAX_PROBLEMS} problems: fix these first")])

    def loc(self, node: Node, key: str) -> Loc:
        return Loc(self.file, node.line, node.column, key)

    def scope(self, kind: str) -> Scope:
        """``constants``, ``parameters``, ``fixed`` (body, joint, ...), ``motion`` (a driven
        joint's: fixed and t; also the scene's inputs), ``load`` or ``event`` fields (these
        also the state and the inputs), ``point`` (a load's moving point: a load's names but
        no rates).

        Made once per kind while the names it is made of stay the same (they only grow):
        making it costs time linear in the names, and a file may hold 20,000 expressions."""
        version = (kind, len(self.names), len(self.constants), len(self.parameters),
                   len(self.coordinates), len(self.inputs))
        if version not in self.scopes:
            self.scopes[version] = self._make_scope(kind)
        return self.scopes[version]

    def _make_scope(self, kind: str) -> Scope:
        allowed = list(self.constants)
        if kind != "constants":  # every other kind also takes the parameters
            allowed += self.parameters
        where = {"constants": "in constants (other constants only)",
                 "parameters": "in parameters (parameters and constants only)",
                 "fixed": FIXED_WHERE,
                 "motion": MOTION_WHERE,
                 "inputs": "in inputs' defaults (parameters and constants only)",
                 "scene inputs": "in simulation.inputs (parameters, constants and t only)",
                 "load": "in loads and outputs",
                 "point": POINT_WHERE,
                 "event": "in events"}[kind]
        state = kind in ("load", "event")  # coordinates, their rates, inputs and t are allowed
        if state or kind == "point":
            allowed += self.coordinates + self.inputs
        names = {name: symbol(name) for name in allowed}
        refused = {name: f"{name!r} is {_article(kind_)} {kind_}, not allowed {where}"
                   for name, (kind_, _) in self.names.items() if name not in names}
        rates = frozenset(self.coordinates) if state else frozenset()
        timed = state or kind in ("motion", "scene inputs", "point")
        return Scope(names, rates, timed, refused, where, self.budget)


def _article(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"


def join_path(path: str, key: str | int) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else key


def suggestion(word: object, candidates: Iterable[str]) -> str:
    return suggest(word, candidates) if isinstance(word, str) else ""


def described(node: Node) -> str:
    """How a value that arrived is described in a message."""
    value = node.value
    if isinstance(value, dict):
        return "got a mapping" if value else "got an empty mapping"
    if isinstance(value, list):
        return f"got a list of {len(value)}" if value else "got an empty list"
    if value is None:
        return "got nothing (null)"
    if isinstance(value, bool):
        return f"got boolean {str(value).lower()}"
    if isinstance(value, (int, float)):
        return f"got number {value}"
    return f"got {value!r}"


def check_keys(ctx: Context, node: Node, path: str, allowed: Iterable[str],
               required: Iterable[str] = (), what: str = "a mapping",
               owner: tuple[str, Iterable[str]] = ("", ())) -> bool:
    """Check ``node`` is a mapping with only ``allowed`` keys and all ``required`` ones.

    ``owner`` is ``(description, keys of its siblings)``, e.g. ``("a revolute joint", every
    joint key)``: a sibling's key is then refused as not applying rather than as unknown.
    """
    if not node.is_map:
        ctx.problem(node.line, path, f"expected {what}, {described(node)}")
        return False
    allowed = tuple(allowed)
    for key in node.value:  # type: ignore[union-attr]
        if key in allowed:
            continue
        if key in owner[1]:
            message = f"key {key!r} does not apply to {owner[0]}"
        else:
            message = f"unknown key {key!r}{suggestion(key, allowed)}"
        ctx.problem(node.key_lines[key], join_path(path, key),
                    f"{message}; expected one of: {', '.join(allowed)}")
    for key in required:
        if key not in node.value:  # type: ignore[operator]
            ctx.problem(node.line, join_path(path, key), f"missing required key {key!r}")
    return True


def entries_of(node: Node) -> Mapping[str, Node]:
    return node.value if isinstance(node.value, dict) else {}


def items_of(node: Node) -> list[Node]:
    return node.value if isinstance(node.value, list) else []


def list_of(ctx: Context, node: Node | None, path: str) -> list[Node]:
    if node is None:
        return []
    if not node.is_list:
        ctx.problem(node.line, path, f"expected a list, {described(node)}")
    return items_of(node)


def nonempty_mapping(ctx: Context, node: Node | None, key: str, item: str) -> bool:
    """Whether NODE is a mapping with at least one entry (a problem is recorded if not)."""
    if node is None:
        return False
    if not node.is_map or not node.value:
        ctx.problem(node.line, key, f"expected a mapping {item} name -> {item} with at least "
                                    f"one {item}, {described(node)}")
        return False
    return True
