"""Validate a parsed mechanism file and build the :class:`nemc.model.Mechanism`.

Every rule of ``shared/spec/mechanism-format.md`` is checked here, once. Problems are
collected (not raised one by one) so a user can fix the whole file in one pass; each names
the file, the line, the key path and what was expected.
"""

from __future__ import annotations

import hashlib
import keyword
import math
import os
import re
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import sympy

from ..errors import InputError, Problem
from ..kinds.constraints import CONSTRAINT_KINDS, Constraint
from ..kinds.joints import JOINT_KINDS, Joint
from ..kinds.loads import LOAD_KINDS, Load
from ..vocabulary import (
    METHODS,  # the scene accepts exactly what simulate accepts
    PACKAGE_FILE_STEMS,
)
from .expr import (
    MAX_DEPTH,
    RESERVED,
    Budget,
    ExprError,
    Scope,
    parse_expression,
    suggest,
    tree_depth,
)
from .mechanism import (
    GROUND,
    Body,
    Event,
    Loc,
    Mechanism,
    Outputs,
    Param,
    PointRef,
    Simulation,
    Units,
    Vec2,
    symbol,
)
from .parse import Node, parse_text
from .reading import read_file
from .values import dependency_order


def joint_keys(kind: type[Joint]) -> tuple[str, ...]:
    """Every YAML key a joint of this kind takes (read from the kind, when asked)."""
    return ("type", "parent", "child", *kind.keys, *(("motion",) if kind.drivable else ()))


def constraint_keys(kind: type[Constraint]) -> tuple[str, ...]:
    return ("type", "a", "b", *kind.keys)


def every_key(keys) -> list[str]:
    """Every key any kind of a table takes: a sibling kind's key 'does not apply'."""
    return sorted({key for kind_keys in keys for key in kind_keys})


# The registries as tables of keys, for the fuzzers and tests (validation reads the kinds).
JOINT_TYPES = tuple(JOINT_KINDS)
JOINT_KEYS = {name: joint_keys(kind) for name, kind in JOINT_KINDS.items()}
CONSTRAINT_KEYS = {name: constraint_keys(kind) for name, kind in CONSTRAINT_KINDS.items()}
LOAD_KEYS = {name: kind.keys for name, kind in LOAD_KINDS.items()}
IMPLICIT_POINTS = ("origin", "com")
TOP_KEYS = ("name", "description", "parameters", "constants", "gravity", "bodies", "joints",
            "constraints", "loads", "outputs", "simulation", "units")
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
ZERO2: Vec2 = (sympy.S.Zero, sympy.S.Zero)
# An exported package is imported by its name: it must not hide a module it or its runtime
# needs (a model named json would make the runtime's own `import json` import the model).
SHADOWED_MODULES = frozenset({*sys.stdlib_module_names, "numpy", "scipy", "cffi",
                              "_cffi_backend", "nemc"})
# Problems reported at most: each costs a suggestion (difflib over every name), so a file of
# 15,000 wrong loads and 5,000 parameters took 106 s to report in full.
MAX_PROBLEMS = 100
# The largest mechanism nemc builds. The build grows linearly with the bodies (issue 19): a
# 1000-body chain of revolute joints builds cold in 53 s with 224 MB at most (400 bodies 22 s,
# 200 bodies 16 s), 264 s and 710 MB with its Jacobian (whose derivation, sympy's diff of every
# step, is linear but slow); 2-core machine under a load of 2.3-2.9 (docs/decisions.md, "Size").
MAX_BODIES = 1000
MAX_COORDINATES = 1000
MAX_MODEL_NAME = 64  # characters: it names the package's folder and files, and prefixes C names
FIXED_WHERE = "in body, joint, gravity and initial-condition fields (parameters and constants only)"
MOTION_WHERE = "in a joint's motion (parameters, constants and t only)"


def load_mechanism(path: str | os.PathLike[str]) -> Mechanism:
    """Read, parse and validate the mechanism file at ``path``; raise InputError if it is bad."""
    file = os.fspath(path)
    try:
        data = read_file(file)
    except OSError as exc:
        raise InputError([Problem(file, 1, "", f"cannot read file: {exc.strerror}")]) from None
    return validate_text(data, file)


def validate_text(text: str | bytes, file: str) -> Mechanism:
    """Validate a mechanism given as text (or the file's bytes); ``file`` names it in messages."""
    data = text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass")
    tree = parse_text(text, file)
    ctx = Context(file)
    mechanism = _build(ctx, tree, hashlib.sha256(data).hexdigest())
    if ctx.problems or mechanism is None:
        raise InputError(sorted(ctx.problems, key=lambda p: p.line))
    return mechanism


# ----------------------------------------------------------------------------- context


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
        joint's: fixed and t), ``load`` or ``event`` fields.

        Made once per kind while the names it is made of stay the same (they only grow):
        making it costs time linear in the names, and a file may hold 20,000 expressions."""
        version = (kind, len(self.names), len(self.constants), len(self.parameters),
                   len(self.coordinates))
        if version not in self.scopes:
            self.scopes[version] = self._make_scope(kind)
        return self.scopes[version]

    def _make_scope(self, kind: str) -> Scope:
        allowed = list(self.constants)
        if kind != "constants":
            allowed += self.parameters
        where = {"constants": "in constants (other constants only)",
                 "parameters": "in parameters (parameters and constants only)",
                 "fixed": FIXED_WHERE,
                 "motion": MOTION_WHERE,
                 "load": "in loads and outputs",
                 "event": "in events"}[kind]
        state = kind in ("load", "event")  # coordinates, their rates and t are allowed
        if state:
            allowed += self.coordinates
        names = {name: symbol(name) for name in allowed}
        refused = {name: f"{name!r} is {_article(kind_)} {kind_}, not allowed {where}"
                   for name, (kind_, _) in self.names.items() if name not in names}
        rates = frozenset(self.coordinates) if state else frozenset()
        return Scope(names, rates, state or kind == "motion", refused, where, self.budget)


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


# ----------------------------------------------------------------------------- values


def read_expr(ctx: Context, node: Node, path: str, scope: Scope) -> sympy.Expr | None:
    """A number or expression string; ``None`` (and a problem) if it is not one."""
    value = node.value
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        ctx.problem(node.line, path, f"expected a number or an expression, {described(node)}")
        return None
    if isinstance(value, int):
        return sympy.Integer(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            ctx.problem(node.line, path, f"expected a finite number, got {value}")
            return None
        return sympy.Float(value)
    try:
        expr = parse_expression(value, scope)
    except ExprError as exc:
        shown = value if len(value) <= 60 else value[:57] + "..."
        ctx.problem(node.line, path, f"{exc.message} (in expression {shown!r}, "
                                     f"at character {exc.offset + 1})")
        if ctx.budget.exhausted:  # stop: every later expression would say the same
            raise InputError(sorted(ctx.problems, key=lambda p: p.line)) from None
        return None
    return _shallow_enough(ctx, node, path, expr)


def _shallow_enough(ctx: Context, node: Node, path: str, expr: sympy.Expr) -> sympy.Expr | None:
    """EXPR, unless it is deeper than MAX_DEPTH with the definitions it uses written out (as
    derive substitutes them): every later stage must handle what validation accepts."""
    depth = tree_depth(expr, ctx.depths)
    if depth <= MAX_DEPTH:
        return expr
    ctx.problem(node.line, path, too_deep(expr, depth))
    return None


def default_value(ctx: Context, expr: sympy.Expr) -> float | None:
    """The value of ``expr`` at the default parameter values; nan if not a finite real."""
    try:
        value = float(expr.xreplace(ctx.defaults))
    except (TypeError, ValueError, ArithmeticError):
        return math.nan
    return value if math.isfinite(value) else math.nan


def has_defaults(ctx: Context, expr: sympy.Expr) -> bool:
    """Whether every symbol of a fixed expression has a default value (else skip checks)."""
    return expr.free_symbols <= ctx.defaults.keys()


def read_fixed(ctx: Context, node: Node, path: str, positive: bool = False) -> sympy.Expr | None:
    """An expression of parameters and constants, finite (and > 0) at the default values."""
    expr = read_expr(ctx, node, path, ctx.scope("fixed"))
    if expr is None or not has_defaults(ctx, expr):
        return expr
    value = default_value(ctx, expr)
    if math.isnan(value):
        ctx.problem(node.line, path, "does not evaluate to a finite real number at the "
                                     f"default parameter values (got {expr})")
        return None
    if positive and value <= 0:
        ctx.problem(node.line, path, f"must be > 0, got {value:g} at the default parameter values")
        return None
    return expr


def read_vec2(ctx: Context, node: Node, path: str, scope: Scope | None = None) -> Vec2 | None:
    """``[x, y]``: fixed expressions, or ``scope`` expressions when given."""
    items = items_of(node)
    if not node.is_list or len(items) != 2:
        ctx.problem(node.line, path, f"expected a vector [x, y] of 2 entries, {described(node)}")
        return None
    if scope is None:
        parts = [read_fixed(ctx, item, join_path(path, i)) for i, item in enumerate(items)]
    else:
        parts = [read_expr(ctx, item, join_path(path, i), scope) for i, item in enumerate(items)]
    if parts[0] is None or parts[1] is None:
        return None
    return (parts[0], parts[1])


def read_number(ctx: Context, node: Node, path: str) -> float | None:
    """A finite number: YAML number or an expression without names (``2*pi``)."""
    expr = read_expr(ctx, node, path, Scope(where="here (a plain number is expected)",
                                            budget=ctx.budget))
    if expr is None:
        return None
    value = default_value(ctx, expr)
    if math.isnan(value):
        ctx.problem(node.line, path, f"expected a finite number, got {expr}")
        return None
    return value


def read_string(ctx: Context, node: Node, path: str, what: str) -> str | None:
    if isinstance(node.value, str):
        return node.value
    ctx.problem(node.line, path, f"expected {what}, {described(node)}")
    return None


def read_choice(ctx: Context, node: Node, path: str, choices: Iterable[str], what: str
                ) -> str | None:
    """One of ``choices``, with a suggestion for a misspelling."""
    choices = tuple(choices)
    value = read_string(ctx, node, path, what)
    if value is None:
        return None
    if value not in choices:
        ctx.problem(node.line, path, f"unknown {what} {value!r}{suggestion(value, choices)}; "
                                     f"expected one of: {', '.join(choices)}")
        return None
    return value


def read_flag(ctx: Context, node: Node, path: str) -> bool:
    if isinstance(node.value, bool):
        return node.value
    ctx.problem(node.line, path, f"expected true or false, {described(node)}")
    return False


# ----------------------------------------------------------------------------- names


def register_name(ctx: Context, name: object, line: int, path: str, kind: str) -> bool:
    """Claim ``name`` for a ``kind`` of item; names are identifiers and never collide."""
    if not isinstance(name, str) or not IDENTIFIER.fullmatch(name):
        got = described(Node(name, line, 0)) if isinstance(name, (list, dict)) else f"got {name!r}"
        ctx.problem(line, path, f"{kind} name must be an identifier [A-Za-z_][A-Za-z0-9_]*, "
                                f"{got}")
        return False
    if name in RESERVED:
        ctx.problem(line, path, f"{name!r} is reserved (t, pi, ground, dot, ddot and function "
                                f"names); choose another {kind} name")
        return False
    if name in ctx.names:
        other_kind, other_path = ctx.names[name]
        ctx.problem(line, path, f"{kind} name {name!r} is already used by the {other_kind} "
                                f"at {other_path}")
        return False
    ctx.names[name] = (kind, path)
    ctx.lines[name] = line
    return True


def collect_names(ctx: Context, root: Mapping[str, Node]) -> None:
    """Register every user-chosen name first, so collisions are found whatever the order."""
    for section, kind, target in (("parameters", "parameter", ctx.parameters),
                                  ("constants", "constant", ctx.constants),
                                  ("bodies", "body", ctx.body_names),
                                  ("joints", "joint", None),
                                  ("constraints", "constraint", None)):
        node = root.get(section)
        for name in entries_of(node) if node is not None else {}:
            if section in ("bodies", "joints", "constraints"):
                {"bodies": ctx.body_keys, "joints": ctx.joint_keys,
                 "constraints": ctx.constraint_keys}[section].append(name)
            path = join_path(section, name)
            if register_name(ctx, name, node.key_lines[name], path, kind) and target is not None:
                target.append(name)
    for name, joint in entries_of(root["joints"]).items() if "joints" in root else ():
        ctx.joint_coordinates[name] = _collect_coordinates(ctx, joint, join_path("joints", name))
    outputs = root.get("outputs")
    expressions = entries_of(outputs).get("expressions") if outputs is not None else None
    if expressions is not None:
        for name in entries_of(expressions):
            path = join_path("outputs.expressions", name)
            register_name(ctx, name, expressions.key_lines[name], path, "output expression")


def _collect_coordinates(ctx: Context, joint: Node, path: str) -> tuple[str, ...]:
    """The valid coordinate names a joint declares (its shape is checked with the joint)."""
    entries = entries_of(joint)
    type_node = entries.get("type")
    kind = JOINT_KINDS.get(type_node.value) if type_node is not None and isinstance(
        type_node.value, str) else None
    kinds = [kind] if kind is not None else list(JOINT_KINDS.values())  # unknown: any shape
    shapes = {k.coordinate_key: len(k.coordinate_kinds) for k in kinds if k.coordinate_key}
    names: list[tuple[Node, str]] = []
    for key, count in shapes.items():
        if key not in entries:
            continue
        if count == 1:
            names.append((entries[key], join_path(path, key)))
        else:
            items = items_of(entries[key])
            names += [(item, join_path(join_path(path, key), i)) for i, item in enumerate(items)]
    found = []
    for node, item_path in names:
        if register_name(ctx, node.value, node.line, item_path, "coordinate"):
            ctx.coordinates.append(node.value)  # type: ignore[arg-type]
            found.append(node.value)
    return tuple(found)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- top level


def _build(ctx: Context, tree: Node, source_hash: str) -> Mechanism | None:
    if not check_keys(ctx, tree, "", TOP_KEYS, ("name", "bodies", "joints"),
                      what="a mapping of top-level keys (name, bodies, joints, ...)"):
        return None
    root = entries_of(tree)
    name = model_name(ctx, root.get("name"))
    description = ""
    if "description" in root:
        description = read_string(ctx, root["description"], "description", "text") or ""
    collect_names(ctx, root)
    _check_size(ctx, root)
    parameters, constants = read_parameters(ctx, root)
    gravity = read_vec2(ctx, root["gravity"], "gravity") if "gravity" in root else ZERO2
    bodies = read_bodies(ctx, root.get("bodies"))
    joints = read_joints(ctx, root.get("joints"))
    constraints = read_constraints(ctx, root["constraints"]) if "constraints" in root else ()
    loads = read_loads(ctx, root["loads"]) if "loads" in root else ()
    outputs = read_outputs(ctx, root["outputs"]) if "outputs" in root else Outputs()
    simulation = read_simulation(ctx, root["simulation"]) if "simulation" in root else Simulation()
    units = read_units(ctx, root["units"]) if "units" in root else Units()
    if ctx.problems or name is None or gravity is None:
        return None
    return Mechanism(name=name, description=description, source=ctx.file,
                     source_hash=source_hash, parameters=parameters, constants=constants,
                     gravity=gravity, bodies=bodies, joints=joints, loads=loads,
                     outputs=outputs, simulation=simulation, constraints=constraints,
                     units=units)


def _check_size(ctx: Context, root: Mapping[str, Node]) -> None:
    """Refuse, at once, a mechanism larger than nemc builds in reasonable time (MAX_BODIES)."""
    sizes = (("bodies", len(ctx.body_keys), MAX_BODIES, "bodies"),
             ("joints", len(ctx.coordinates), MAX_COORDINATES, "coordinates"))
    too_large = [(key, count, most, what) for key, count, most, what in sizes if count > most]
    for key, count, most, what in too_large:
        ctx.problem(root[key].line, key, f"{count} {what}: nemc builds at most {most} {what} "
                    f"(a {MAX_BODIES}-body chain builds in about a minute, about five with its "
                    "Jacobian)")
    if too_large:  # validating the rest would take long and say nothing more useful
        raise InputError(sorted(ctx.problems, key=lambda p: p.line))


def model_name(ctx: Context, node: Node | None) -> str | None:
    if node is None:
        return None
    name = read_string(ctx, node, "name", "an identifier naming the generated module")
    if name is None:
        return None
    if not IDENTIFIER.fullmatch(name) or keyword.iskeyword(name):
        ctx.problem(node.line, "name", "expected an identifier [A-Za-z_][A-Za-z0-9_]* that is "
                                       f"not a Python keyword (it names a module), got {name!r}")
        return None
    if name in SHADOWED_MODULES:
        ctx.problem(node.line, "name", f"{name!r} is the name of a Python module the generated "
                                       "package would hide when imported; choose another name")
        return None
    clash = _package_name_clash(name)
    if clash:
        ctx.problem(node.line, "name", f"{clash}; choose another name")
        return None
    return name


def _package_name_clash(name: str) -> str | None:
    """Why NAME cannot name a generated package (its folder, module, C file and C prefix)."""
    if len(name) > MAX_MODEL_NAME:
        return (f"a model name has at most {MAX_MODEL_NAME} characters (it names files and C "
                f"functions), got {len(name)}")
    if name in PACKAGE_FILE_STEMS:
        return f"{name!r} is the name of a module or file inside every generated package"
    if name.startswith("__") and name.endswith("__"):
        return f"{name!r} has the form of a Python special name (__x__)"
    return None


# ----------------------------------------------------------------------------- parameters


def read_parameters(ctx: Context, root: Mapping[str, Node]) -> tuple[tuple[Param, ...], ...]:
    """Parameters and constants: parsed, free of cycles, with finite default values."""
    parsed: dict[str, tuple[Node, str, sympy.Expr]] = {}
    for section, kind in (("constants", "constant"), ("parameters", "parameter")):
        node = root.get(section)
        if node is None:
            continue
        if not node.is_map:
            ctx.problem(node.line, section, f"expected a mapping name -> number or expression, "
                                            f"{described(node)}")
            continue
        scope = ctx.scope(section)
        for name, value in entries_of(node).items():
            path = join_path(section, name)
            if ctx.names.get(name) != (kind, path):
                continue  # a bad or colliding name, already reported
            expr = read_expr(ctx, value, path, scope)
            if expr is not None:
                parsed[name] = (value, path, expr)
    cyclic = _check_cycles(ctx, parsed)
    _compute_defaults(ctx, parsed, cyclic)
    made = {name: Param(name, expr, ctx.loc(node, path))
            for name, (node, path, expr) in parsed.items()}
    return (tuple(made[n] for n in ctx.parameters if n in made),
            tuple(made[n] for n in ctx.constants if n in made))


def _dependencies(expr: sympy.Expr) -> list[str]:
    return sorted(s.name for s in expr.free_symbols if isinstance(s, sympy.Symbol))


def _check_cycles(ctx: Context, parsed: Mapping[str, tuple[Node, str, sympy.Expr]]) -> set[str]:
    """Report each cycle among parameter definitions once; return the names on cycles.
    A depth-first search with its own stack: a chain of thousands of definitions is fine."""
    cyclic: set[str] = set()
    done: set[str] = set()
    for start in parsed:
        if start in done:
            continue
        path = [start]
        pending = [iter(_dependencies(parsed[start][2]))]
        while path:
            dep = next(pending[-1], None)
            if dep is None:
                done.add(path.pop())
                pending.pop()
            elif dep in path:
                cycle = path[path.index(dep):]
                if not cyclic & set(cycle):
                    node, key, _ = parsed[cycle[0]]
                    chain = " -> ".join([*cycle, cycle[0]])
                    ctx.problem(node.line, key, f"definitions form a cycle: {chain}")
                cyclic.update(cycle)
            elif dep in parsed and dep not in done:
                path.append(dep)
                pending.append(iter(_dependencies(parsed[dep][2])))
    return cyclic


def _compute_defaults(ctx: Context, parsed: Mapping[str, tuple[Node, str, sympy.Expr]],
                      cyclic: set[str]) -> None:
    """Evaluate default values in dependency order; each must be a finite real number, and
    each definition, with the definitions it uses written out, at most MAX_DEPTH deep."""
    names = [name for name in parsed if name not in cyclic]
    for name in dependency_order(names, lambda n: _dependencies(parsed[n][2])):
        node, path, expr = parsed[name]
        if not has_defaults(ctx, expr):
            continue
        depth = tree_depth(expr, ctx.depths)
        if depth > MAX_DEPTH:
            ctx.problem(node.line, path, too_deep(expr, depth))
            continue
        ctx.depths[symbol(name)] = depth
        value = default_value(ctx, expr)
        if math.isnan(value):
            ctx.problem(node.line, path, "default value does not evaluate to a finite real "
                                         f"number (got {expr})")
        else:
            ctx.defaults[symbol(name)] = sympy.Float(value)


def too_deep(expr: sympy.Expr, depth: int) -> str:
    """The message for an expression DEPTH levels deep with its definitions written out."""
    if tree_depth(expr) == depth:
        return (f"expression is nested too deeply: {depth} levels, at most {MAX_DEPTH} (each "
                "operation and function call is a level)")
    return (f"expression is nested too deeply: {depth} levels once the parameters and constants "
            f"it uses are written out, at most {MAX_DEPTH}")


# ----------------------------------------------------------------------------- bodies


def nonempty_mapping(ctx: Context, node: Node | None, key: str, item: str) -> bool:
    """Whether NODE is a mapping with at least one entry (a problem is recorded if not)."""
    if node is None:
        return False
    if not node.is_map or not node.value:
        ctx.problem(node.line, key, f"expected a mapping {item} name -> {item} with at least "
                                    f"one {item}, {described(node)}")
        return False
    return True


def read_bodies(ctx: Context, node: Node | None) -> tuple[Body, ...]:
    if not nonempty_mapping(ctx, node, "bodies", "body"):
        return ()
    for name, body_node in entries_of(node).items():
        path = join_path("bodies", name)
        if ctx.names.get(name) == ("body", path):
            body = _body(ctx, name, body_node, path)
            if body is not None:
                ctx.bodies[name] = body
    return tuple(ctx.bodies.values())


def _body(ctx: Context, name: str, node: Node, path: str) -> Body | None:
    if not check_keys(ctx, node, path, ("mass", "inertia", "com", "points"), ("mass", "inertia")):
        return None
    entries = entries_of(node)
    mass = None
    if "mass" in entries:
        mass = read_fixed(ctx, entries["mass"], join_path(path, "mass"), True)
    inertia = None
    if "inertia" in entries:
        inertia = read_fixed(ctx, entries["inertia"], join_path(path, "inertia"), True)
    com = read_vec2(ctx, entries["com"], join_path(path, "com")) if "com" in entries else ZERO2
    points: dict[str, Vec2] | None = {}
    if "points" in entries:
        points = _points(ctx, entries["points"], join_path(path, "points"))
    if mass is None or inertia is None or com is None or points is None:
        return None
    return Body(name, mass, inertia, com, points, ctx.loc(node, path))


def _points(ctx: Context, node: Node, path: str) -> dict[str, Vec2] | None:
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a mapping point name -> [x, y], {described(node)}")
        return None
    points: dict[str, Vec2] = {}
    ok = True
    for name, value in entries_of(node).items():
        item_path = join_path(path, name)
        line = node.key_lines[name]
        if name in IMPLICIT_POINTS:
            ctx.problem(line, item_path, f"{name!r} is an implicit point of every body and "
                                         "cannot be redefined")
        elif not IDENTIFIER.fullmatch(name) or name in RESERVED:
            ctx.problem(line, item_path, "point name must be an identifier [A-Za-z_][A-Za-z0-9_]*"
                                         f" and not a reserved word, got {name!r}")
        else:
            xy = read_vec2(ctx, value, item_path)
            if xy is not None:
                points[name] = xy
                continue
        ok = False
    return points if ok else None


# ----------------------------------------------------------------------------- joints


@dataclass(frozen=True)
class _Edge:
    joint: str
    parent: str
    child: str
    parent_line: int
    child_line: int


def read_joints(ctx: Context, node: Node | None) -> tuple[Joint, ...]:
    if not nonempty_mapping(ctx, node, "joints", "joint"):
        return ()
    edges: list[_Edge] = []
    for name, joint_node in entries_of(node).items():
        path = join_path("joints", name)
        if ctx.names.get(name) == ("joint", path) and joint_node.is_map:
            edge = _edge(ctx, name, joint_node, path)
            if edge is not None:
                edges.append(edge)
            joint = _joint(ctx, name, joint_node, path, edge)
            if joint is not None:
                ctx.joints[name] = joint
        elif not joint_node.is_map:
            ctx.problem(joint_node.line, path, f"expected a joint mapping, {described(joint_node)}")
    _check_tree(ctx, edges, _named_children(node))
    return tuple(ctx.joints.values())


def _edge(ctx: Context, name: str, node: Node, path: str) -> _Edge | None:
    """The joint's parent and child, if both name real bodies (or ground for the parent)."""
    entries = entries_of(node)
    parent = child = None
    if "parent" in entries:
        parent = body_name(ctx, entries["parent"], join_path(path, "parent"), ground=True)
    if "child" in entries:
        child = body_name(ctx, entries["child"], join_path(path, "child"), ground=False)
    if parent is None or child is None:
        return None
    return _Edge(name, parent, child, entries["parent"].line, entries["child"].line)


def body_name(ctx: Context, node: Node, path: str, ground: bool) -> str | None:
    """A body name (or ``ground`` where allowed), with a suggestion for misspellings."""
    name = read_string(ctx, node, path, "a body name")
    if name is None:
        return None
    if name == GROUND and not ground:
        ctx.problem(node.line, path, "expected a body, got 'ground' (ground is not allowed here)")
        return None
    if name == GROUND or name in ctx.body_keys:
        return name
    candidates = [*ctx.body_keys, GROUND] if ground else ctx.body_keys
    ctx.problem(node.line, path, f"unknown body {name!r}{suggestion(name, candidates)}")
    return None


def _joint(ctx: Context, name: str, node: Node, path: str, edge: _Edge | None) -> Joint | None:
    entries = entries_of(node)
    kind = None
    if "type" in entries:
        type_name = read_choice(ctx, entries["type"], join_path(path, "type"), tuple(JOINT_KINDS),
                                "joint type")
        kind = JOINT_KINDS.get(type_name) if type_name is not None else None
    all_keys = every_key(joint_keys(k) for k in JOINT_KINDS.values())
    if kind is None:
        check_keys(ctx, node, path, all_keys, ("type", "parent", "child"))
        return None
    required = ["type", "parent", "child", *([kind.coordinate_key] if kind.coordinate_key else [])]
    check_keys(ctx, node, path, joint_keys(kind), required,
               owner=(f"a {kind.type} joint", all_keys))
    count = len(ctx.problems)
    coordinates = _joint_coordinates(ctx, kind, name, entries, path)
    if edge is not None and (why := kind.parent_problem(edge.parent)) is not None:
        ctx.problem(edge.parent_line, join_path(path, "parent"), why)
    fields = kind.read(Reader(ctx, node, path, parent=edge.parent if edge else None))
    motion = None
    if "motion" in entries and kind.drivable:
        motion = read_expr(ctx, entries["motion"], join_path(path, "motion"), ctx.scope("motion"))
    if len(ctx.problems) > count or edge is None or fields is None or coordinates is None:
        return None
    joint = kind(name=name, parent=edge.parent, child=edge.child, coordinates=coordinates,
                 loc=ctx.loc(node, path), motion=motion, **fields)
    if joint.driven and (why := joint.drive_problem()) is not None:
        ctx.problem(entries["motion"].line, join_path(path, "motion"), why)
        return None
    return joint


def _joint_coordinates(ctx: Context, kind: type[Joint], name: str, entries: Mapping[str, Node],
                       path: str) -> tuple[str, ...] | None:
    """The joint's coordinates; their names were checked when they were collected."""
    count = len(kind.coordinate_kinds)
    if count == 0 or kind.coordinate_key is None:
        return ()
    node = entries.get(kind.coordinate_key)
    if node is None:
        return None
    if count > 1 and (not node.is_list or len(items_of(node)) != count):
        ctx.problem(node.line, join_path(path, kind.coordinate_key),
                    f"expected a list of {count} coordinate names, {described(node)}")
        return None
    found = ctx.joint_coordinates.get(name, ())
    return found if len(found) == count else None


def read_axis(ctx: Context, node: Node, path: str) -> Vec2 | None:
    axis = read_vec2(ctx, node, path)
    if axis is None or not all(has_defaults(ctx, part) for part in axis):
        return axis
    if all(default_value(ctx, part) == 0 for part in axis):
        ctx.problem(node.line, path, "axis must not be [0, 0] at the default parameter values")
        return None
    return axis


def point_of(ctx: Context, node: Node, path: str, body: str | None) -> Vec2 | None:
    """A point of ``body``: a point name (``origin``, ``com``, named) or fixed ``[x, y]``."""
    if node.is_list:
        return read_vec2(ctx, node, path)
    name = read_string(ctx, node, path, "a point name or [x, y]")
    if name is None or body is None:
        return None
    return named_point(ctx, body, name, node.line, path)


def named_point(ctx: Context, body: str, name: str, line: int, path: str) -> Vec2 | None:
    if body == GROUND:
        if name == "origin":
            return ZERO2
        ctx.problem(line, path, f"ground has no point {name!r}: its only named point is origin; "
                                "give a position as [x, y]")
        return None
    if body not in ctx.bodies:
        return None  # the body itself is wrong, and already reported
    found = ctx.bodies[body]
    if name == "origin":
        return ZERO2
    if name == "com":
        return found.com
    if name in found.points:
        return found.points[name]
    candidates = [*found.points, *IMPLICIT_POINTS]
    ctx.problem(line, path, f"body {body!r} has no point {name!r}{suggestion(name, candidates)}; "
                            f"its points: {', '.join(candidates)}")
    return None


def _named_children(node: Node) -> set[object]:
    """Every child any joint names, valid or not: a body a broken joint names is reported
    with that joint, not as unattached too."""
    children = [entries_of(joint).get("child") for joint in entries_of(node).values()]
    return {child.value for child in children if child is not None and child.is_scalar}


def _check_tree(ctx: Context, edges: list[_Edge], named_children: set[object]) -> None:
    """Every body is the child of exactly one joint, and every chain reaches ground."""
    parent_of: dict[str, _Edge] = {}
    for edge in edges:
        if edge.child in parent_of:
            first = parent_of[edge.child].joint
            ctx.problem(edge.child_line, join_path(join_path("joints", edge.joint), "child"),
                        f"body {edge.child!r} is already the child of joint {first!r}; every "
                        "body is the child of exactly one joint")
        else:
            parent_of[edge.child] = edge
    for body in ctx.body_names:
        if body not in parent_of and body not in named_children:
            ctx.problem(ctx.lines[body], ctx.names[body][1], f"body {body!r} is not attached: "
                        f"no joint has child: {body} (every body is the child of exactly one "
                        "joint)")
    _check_cycles_in_tree(ctx, parent_of)


def _check_cycles_in_tree(ctx: Context, parent_of: Mapping[str, _Edge]) -> None:
    """Each cycle once; every body's way up is walked once (linear in the bodies)."""
    reported: set[str] = set()
    settled: set[str] = set()  # bodies whose way up an earlier walk took: nothing new there
    for start in parent_of:
        chain: list[str] = []
        on_chain: set[str] = set()
        body = start
        while body in parent_of and body not in on_chain and body not in settled:
            chain.append(body)
            on_chain.add(body)
            body = parent_of[body].parent
        settled.update(chain)
        if body not in on_chain or body in reported:
            continue
        cycle = chain[chain.index(body):]
        reported.update(cycle)
        edge = parent_of[cycle[0]]
        bodies = " -> ".join([*cycle, cycle[0]])
        joints = ", ".join(parent_of[b].joint for b in cycle)
        ctx.problem(edge.parent_line, join_path(join_path("joints", edge.joint), "parent"),
                    f"joints {joints} form a cycle (child -> parent: {bodies}) that never "
                    "reaches ground; the joints must form a tree rooted at ground")


# ----------------------------------------------------------------------------- constraints


def read_constraints(ctx: Context, node: Node) -> tuple[Constraint, ...]:
    """The loop-closing constraints; with them, no more equations than free coordinates."""
    if not nonempty_mapping(ctx, node, "constraints", "constraint"):
        return ()
    found = []
    for name, item in entries_of(node).items():
        path = join_path("constraints", name)
        if ctx.names.get(name) != ("constraint", path):
            continue  # a bad or colliding name, already reported
        constraint = _constraint(ctx, name, item, path)
        if constraint is not None:
            found.append(constraint)
    equations = sum(c.equations_count for c in found)
    free = len([q for joint in ctx.joints.values() if not joint.driven
                for q in joint.coordinates])
    if found and equations > free:
        ctx.problem(node.line, "constraints", f"the constraints add {equations} equations but "
                    f"the joints leave only {free} free coordinates: the mechanism is "
                    "over-constrained (remove a constraint, or free a joint)")
    return tuple(found)


def _constraint(ctx: Context, name: str, node: Node, path: str) -> Constraint | None:
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a constraint mapping {{type, a, b, ...}}, "
                                     f"{described(node)}")
        return None
    entries = entries_of(node)
    type_node = entries.get("type")
    type_name = None if type_node is None else read_choice(
        ctx, type_node, join_path(path, "type"), tuple(CONSTRAINT_KINDS), "constraint type")
    kind = CONSTRAINT_KINDS.get(type_name) if type_name is not None else None
    all_keys = every_key(constraint_keys(k) for k in CONSTRAINT_KINDS.values())
    allowed = constraint_keys(kind) if kind is not None else all_keys
    owner = (f"a {kind.type} constraint" if kind is not None else "", all_keys)
    count = len(ctx.problems)
    check_keys(ctx, node, path, allowed, ("type", "a", "b"), owner=owner)
    reader = Reader(ctx, node, path)
    ends = {key: reader.point_ref(key) for key in ("a", "b")}
    fields = kind.read(reader) if kind is not None else None
    a, b = ends["a"], ends["b"]
    if a is not None and b is not None and a.body == b.body:
        ctx.problem(entries["b"].line, join_path(path, "b"), f"a constraint joins two bodies, but "
                    f"a and b are both on {a.body!r}")
    if kind is None or fields is None or a is None or b is None or len(ctx.problems) > count:
        return None
    return kind(name=name, a=a, b=b, loc=ctx.loc(node, path), **fields)


# ----------------------------------------------------------------------------- loads


def read_loads(ctx: Context, node: Node) -> tuple[Load, ...]:
    if not node.is_list:
        ctx.problem(node.line, "loads", f"expected a list of loads, {described(node)}")
        return ()
    loads = [_load(ctx, item, join_path("loads", i)) for i, item in enumerate(items_of(node))]
    return tuple(load for load in loads if load is not None)


def _load(ctx: Context, node: Node, path: str) -> Load | None:
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a load mapping with one of "
                                     f"{', '.join(LOAD_KINDS)}, {described(node)}")
        return None
    entries = entries_of(node)
    kinds = [name for name in LOAD_KINDS if name in entries]
    if len(kinds) != 1:
        found = f"got {' and '.join(kinds)}" if kinds else f"got keys {', '.join(entries)}"
        hint = "" if kinds else "".join(suggestion(key, LOAD_KINDS) for key in entries)
        ctx.problem(node.line, path, f"a load has exactly one of {', '.join(LOAD_KINDS)}; "
                                     f"{found}{hint}")
        return None
    kind = LOAD_KINDS[kinds[0]]
    count = len(ctx.problems)
    all_keys = every_key(k.keys for k in LOAD_KINDS.values())
    check_keys(ctx, node, path, kind.keys, kind.required, owner=(f"a {kind.kind} load", all_keys))
    fields = kind.read(Reader(ctx, node, path))
    if fields is None or len(ctx.problems) != count:
        return None
    return kind(**{"loc": ctx.loc(node, path), **fields})


def joint_name(ctx: Context, node: Node, path: str) -> str | None:
    name = read_string(ctx, node, path, "a joint name")
    if name is None:
        return None
    if name not in ctx.joint_keys:
        ctx.problem(node.line, path, f"unknown joint {name!r}{suggestion(name, ctx.joint_keys)}")
        return None
    return name


def point_ref(ctx: Context, node: Node, path: str, ground: bool) -> PointRef | None:
    """``BODY.POINT``, or (where ``ground`` is true, for springs) ``{body: BODY, at: [x, y]}``."""
    if node.is_map and ground:
        if not check_keys(ctx, node, path, ("body", "at"), ("body", "at")):
            return None
        entries = entries_of(node)
        body = None
        if "body" in entries:
            body = body_name(ctx, entries["body"], join_path(path, "body"), ground=True)
        xy = read_vec2(ctx, entries["at"], join_path(path, "at")) if "at" in entries else None
        if body is None or xy is None:
            return None
        return PointRef(body, xy, f"{body}.[{xy[0]}, {xy[1]}]")
    text = node.value if isinstance(node.value, str) else None
    parts = text.split(".") if text is not None else []
    if len(parts) != 2:
        other = " or {body: BODY, at: [x, y]}" if ground else ""
        ctx.problem(node.line, path, f"expected BODY.POINT (e.g. link1.com){other}, "
                                     f"{described(node)}")
        return None
    body = body_name(ctx, Node(parts[0], node.line, node.column), path, ground)
    if body is None:
        return None
    xy = named_point(ctx, body, parts[1], node.line, path)
    return PointRef(body, xy, f"{body}.{parts[1]}") if xy is not None else None


# ----------------------------------------------------------------------------- kinds' keys


class Reader:
    """One YAML mapping of a joint or a load, as its kind reads it (nemc/joints/, nemc/loads/):
    a typed value per key, checked with its location. A wrong value records a problem and
    reads as None; a missing key reads as its default."""

    def __init__(self, ctx: Context, node: Node, path: str, parent: str | None = None):
        self.ctx, self.node, self.path = ctx, node, path
        self.parent = parent  # the joint's parent body, where its points are read
        self.entries = entries_of(node)
        self._problems_before = len(ctx.problems)

    @property
    def location(self) -> Loc:
        return self.ctx.loc(self.node, self.path)

    def fields(self, **values: Any) -> dict[str, Any] | None:
        """The values read, or None when one is None or a problem was recorded meanwhile."""
        if len(self.ctx.problems) > self._problems_before or None in values.values():
            return None
        return values

    def problem(self, key: str, message: str) -> None:
        self.ctx.problem(self.entries.get(key, self.node).line, join_path(self.path, key), message)

    def _at(self, key: str) -> tuple[Node, str] | None:
        return (self.entries[key], join_path(self.path, key)) if key in self.entries else None

    def expr(self, key: str, default: sympy.Expr | None = None) -> sympy.Expr | None:
        """An expression of t, coordinates, rates, parameters and constants (as loads take)."""
        found = self._at(key)
        return default if found is None else read_expr(self.ctx, *found, self.ctx.scope("load"))

    def fixed(self, key: str, default: sympy.Expr) -> sympy.Expr | None:
        """An expression of parameters and constants, finite at their defaults."""
        found = self._at(key)
        return default if found is None else read_fixed(self.ctx, *found)

    def vec2(self, key: str) -> Vec2 | None:
        """[x, y], each as `expr` reads it."""
        found = self._at(key)
        return None if found is None else read_vec2(self.ctx, *found, self.ctx.scope("load"))

    def axis(self, key: str) -> Vec2 | None:
        """A fixed direction [x, y], not zero; default [1, 0]."""
        found = self._at(key)
        return (sympy.S.One, sympy.S.Zero) if found is None else read_axis(self.ctx, *found)

    def choice(self, key: str, choices: tuple[str, ...], default: str) -> str | None:
        found = self._at(key)
        return default if found is None else read_choice(self.ctx, *found, choices, key)

    def parent_point(self, key: str) -> Vec2 | None:
        """A point of the joint's parent: a point name or [x, y]; default its origin."""
        found = self._at(key)
        return ZERO2 if found is None else point_of(self.ctx, *found, self.parent)

    def body_point(self, key: str, body: str | None) -> Vec2 | None:
        """A point of `body`: a point name or [x, y]; default its mass center."""
        found = self._at(key)
        if found is not None:
            return point_of(self.ctx, *found, body)
        return self.ctx.bodies[body].com if body in self.ctx.bodies else None

    def body(self, key: str, ground: bool, default: str | None = None) -> str | None:
        found = self._at(key)
        return default if found is None else body_name(self.ctx, *found, ground=ground)

    def point_ref(self, key: str) -> PointRef | None:
        """BODY.POINT or {body: BODY, at: [x, y]} (ground allowed)."""
        found = self._at(key)
        return None if found is None else point_ref(self.ctx, *found, ground=True)

    def joint(self, key: str, accepts: Callable[[type[Joint]], bool], needs: str) -> str | None:
        """A joint's name; `needs` says what a joint of a kind that `accepts` refuses lacks."""
        found = self._at(key)
        name = None if found is None else joint_name(self.ctx, *found)
        joint = self.ctx.joints.get(name) if name is not None else None
        if joint is not None and not accepts(type(joint)):
            self.problem(key, f"{needs}; {name!r} is a {joint.type} joint")
        return name

    def mapping(self, key: str, allowed: tuple[str, ...], required: tuple[str, ...]
                ) -> Reader | None:
        """The mapping under `key`, to read in turn (None: not a mapping of these keys)."""
        found = self._at(key)
        if found is None or not check_keys(self.ctx, *found, allowed, required,
                                           what=f"a mapping {{{', '.join(allowed)}}}"):
            return None
        return Reader(self.ctx, *found)


# ----------------------------------------------------------------------------- outputs


def read_outputs(ctx: Context, node: Node) -> Outputs:
    keys = ("reactions", "energy", "points", "accelerations", "expressions", "drives")
    if not check_keys(ctx, node, "outputs", keys):
        return Outputs()
    entries = entries_of(node)
    reactions: list[str] = []
    for i, item in enumerate(list_of(ctx, entries.get("reactions"), "outputs.reactions")):
        name = _reaction_name(ctx, item, f"outputs.reactions[{i}]")
        if name in reactions:
            ctx.problem(item.line, f"outputs.reactions[{i}]", f"{name!r} is listed twice")
        elif name is not None:
            reactions.append(name)
    drives: list[str] = []
    for i, item in enumerate(list_of(ctx, entries.get("drives"), "outputs.drives")):
        name = _driven_joint(ctx, item, f"outputs.drives[{i}]")
        if name in drives:
            ctx.problem(item.line, f"outputs.drives[{i}]", f"{name!r} is listed twice")
        elif name is not None:
            drives.append(name)
    points: list[PointRef] = []
    for i, item in enumerate(list_of(ctx, entries.get("points"), "outputs.points")):
        point = point_ref(ctx, item, f"outputs.points[{i}]", ground=False)
        if point is not None and point.label in [p.label for p in points]:
            ctx.problem(item.line, f"outputs.points[{i}]", f"{point.label} is listed twice")
        elif point is not None:
            points.append(point)
    flags = {key: read_flag(ctx, entries[key], join_path("outputs", key)) if key in entries
             else False for key in ("energy", "accelerations")}
    expressions = _output_expressions(ctx, entries.get("expressions"))
    return Outputs(tuple(reactions), flags["energy"], tuple(points), flags["accelerations"],
                   expressions, tuple(drives))


def _reaction_name(ctx: Context, node: Node, path: str) -> str | None:
    """A joint's or a constraint's name."""
    name = read_string(ctx, node, path, "a joint or constraint name")
    if name is None:
        return None
    if name not in ctx.joint_keys and name not in ctx.constraint_keys:
        known = [*ctx.joint_keys, *ctx.constraint_keys]
        ctx.problem(node.line, path, f"unknown joint or constraint {name!r}"
                                     f"{suggestion(name, known)}")
        return None
    return name


def _driven_joint(ctx: Context, node: Node, path: str) -> str | None:
    """A driven joint's name (one with `motion:`)."""
    name = joint_name(ctx, node, path)
    joint = ctx.joints.get(name) if name is not None else None
    if joint is not None and not joint.driven:
        driven = [j.name for j in ctx.joints.values() if j.driven]
        ctx.problem(node.line, path, f"joint {name!r} is not driven (it has no motion:); "
                                     f"driven joints: {', '.join(driven) or 'none'}")
        return None
    return name


def list_of(ctx: Context, node: Node | None, path: str) -> list[Node]:
    if node is None:
        return []
    if not node.is_list:
        ctx.problem(node.line, path, f"expected a list, {described(node)}")
    return items_of(node)


def _output_expressions(ctx: Context, node: Node | None) -> tuple[tuple[str, sympy.Expr], ...]:
    if node is None:
        return ()
    if not node.is_map:
        ctx.problem(node.line, "outputs.expressions", "expected a mapping name -> expression, "
                                                      f"{described(node)}")
        return ()
    result = []
    for name, value in entries_of(node).items():
        path = join_path("outputs.expressions", name)
        if ctx.names.get(name) != ("output expression", path):
            continue  # a bad or colliding name, already reported
        expr = read_expr(ctx, value, path, ctx.scope("load"))
        if expr is not None:
            result.append((name, expr))
    return tuple(result)


# ----------------------------------------------------------------------------- simulation


def read_simulation(ctx: Context, node: Node) -> Simulation:
    keys = ("t_span", "initial", "t_eval", "method", "rtol", "atol", "guess", *RUN_CONTROL_KEYS)
    if not check_keys(ctx, node, "simulation", keys):
        return Simulation()
    entries = entries_of(node)
    t_span = _t_span(ctx, entries["t_span"]) if "t_span" in entries else None
    initial = _initial(ctx, entries["initial"]) if "initial" in entries else {}
    t_eval = step = None
    if "t_eval" in entries:
        t_eval, step = _t_eval(ctx, entries["t_eval"], t_span, "t_span" in entries)
    method = None
    if "method" in entries:
        method = read_choice(ctx, entries["method"], "simulation.method", METHODS, "method")
    tolerances = {key: _positive(ctx, entries[key], join_path("simulation", key))
                  if key in entries else None for key in ("rtol", "atol")}
    guess = {}
    if "guess" in entries:
        guess = _initial(ctx, entries["guess"], "simulation.guess", rates=False)
    initial_loc = (ctx.loc(entries["initial"], "simulation.initial") if "initial" in entries
                   else None)
    return Simulation(t_span, initial, t_eval, step, method, tolerances["rtol"],
                      tolerances["atol"], guess, initial_loc, **_run_control(ctx, entries, t_span))


def _positive(ctx: Context, node: Node, path: str) -> float | None:
    value = read_number(ctx, node, path)
    if value is not None and value <= 0:
        ctx.problem(node.line, path, f"must be a number > 0, got {value:g}")
        return None
    return value


def _t_span(ctx: Context, node: Node) -> tuple[float, float] | None:
    path = "simulation.t_span"
    if not node.is_list or len(items_of(node)) != 2:
        ctx.problem(node.line, path, f"expected [t0, t1], {described(node)}")
        return None
    t0, t1 = (read_number(ctx, item, join_path(path, i)) for i, item in enumerate(items_of(node)))
    if t0 is None or t1 is None:
        return None
    if not t1 > t0:
        ctx.problem(node.line, path, f"the end must be after the start, got [{t0:g}, {t1:g}]")
        return None
    return (t0, t1)


def _initial(ctx: Context, node: Node, path: str = "simulation.initial",
             rates: bool = True) -> dict[str, sympy.Expr]:
    """Values of the state's coordinates (and, where `rates`, of their rates): `initial`, or
    the assembly's `guess`."""
    what = "q or dot(q)" if rates else "q"
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a mapping {what} -> value, {described(node)}")
        return {}
    driven = {q: joint.name for joint in ctx.joints.values() if joint.driven
              for q in joint.coordinates}
    free = [q for q in ctx.coordinates if q not in driven]
    states = [name for q in free for name in ((q, f"dot({q})") if rates else (q,))]
    initial: dict[str, sympy.Expr] = {}
    for key, value in entries_of(node).items():
        match = re.fullmatch(r"dot\(\s*(\w+)\s*\)", key)
        name = f"dot({match.group(1)})" if match else key
        coordinate = match.group(1) if match else key
        if coordinate in driven:
            ctx.problem(node.key_lines[key], join_path(path, key), f"{coordinate} is driven "
                        f"(joints.{driven[coordinate]}.motion): its value is prescribed, not "
                        "given here")
            continue
        if name not in states:
            ctx.problem(node.key_lines[key], join_path(path, key), f"unknown coordinate"
                        f"{' or rate' if rates else ''} {key!r}{suggestion(key, states)}; "
                        f"expected a coordinate {what}")
            continue
        if name in initial:
            ctx.problem(node.key_lines[key], join_path(path, key), f"{name} is given twice")
            continue
        expr = read_fixed(ctx, value, join_path(path, key))
        if expr is not None:
            initial[name] = expr
    return initial


def _t_eval(ctx: Context, node: Node, t_span: tuple[float, float] | None,
            has_span: bool) -> tuple[tuple[float, ...] | None, float | None]:
    path = "simulation.t_eval"
    if not has_span:
        ctx.problem(node.line, path, "t_eval needs simulation.t_span")
    if node.is_map:
        if not check_keys(ctx, node, path, ("step",), ("step",), what="{step: h}"):
            return None, None
        step = entries_of(node).get("step")
        return None, _positive(ctx, step, join_path(path, "step")) if step is not None else None
    if not node.is_list or not node.value:
        ctx.problem(node.line, path, f"expected {{step: h}} or a list of times, {described(node)}")
        return None, None
    return _times(ctx, node, path, t_span), None


def _times(ctx: Context, node: Node, path: str, t_span: tuple[float, float] | None
           ) -> tuple[float, ...] | None:
    """A non-empty list of increasing times inside t_span (when the scene gives one)."""
    times = [read_number(ctx, item, join_path(path, i)) for i, item in enumerate(items_of(node))]
    if None in times:
        return None
    for i, (before, after) in enumerate(zip(times, times[1:])):
        if not after > before:  # type: ignore[operator]
            ctx.problem(node.line, join_path(path, i + 1), "times must increase, got "
                                                       f"{after:g} after {before:g}")
            return None
    if t_span is not None and (times[0] < t_span[0] or times[-1] > t_span[1]):  # type: ignore
        ctx.problem(node.line, path, f"times must lie inside t_span [{t_span[0]:g}, "
                                     f"{t_span[1]:g}], got [{times[0]:g} .. {times[-1]:g}]")
        return None
    return tuple(times)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- run control
# Format v2: events, max_step, tstops and the step budget (docs/decisions.md, "Format v2:
# events, max_step, tstops").

RUN_CONTROL_KEYS = ("events", "max_step", "tstops", "max_steps")
EVENT_KEYS = ("when", "direction", "action")
EVENT_DIRECTIONS = ("rising", "falling", "both")
EVENT_ACTIONS = ("record", "stop")  # or a mapping: an impact law
MAX_STEPS_LIMIT = 2**62  # a C long


def _run_control(ctx: Context, entries: Mapping[str, Node],
                 t_span: tuple[float, float] | None) -> dict:
    """The scene's events, max_step, tstops and max_steps, as Simulation's keyword arguments."""
    found: dict = {}
    if "events" in entries:
        found["events"] = _events(ctx, entries["events"])
    if "max_step" in entries:
        found["max_step"] = _positive(ctx, entries["max_step"], "simulation.max_step")
    if "tstops" in entries:
        found["tstops"] = _tstops(ctx, entries["tstops"], t_span)
    if "max_steps" in entries:
        found["max_steps"] = _max_steps(ctx, entries["max_steps"])
    return {key: value for key, value in found.items() if value is not None}


def _events(ctx: Context, node: Node) -> tuple[Event, ...]:
    path = "simulation.events"
    if not node.is_map or not node.value:
        ctx.problem(node.line, path, "expected a mapping event name -> {when, direction, "
                                     f"action}}, {described(node)}")
        return ()
    events = []
    for name, item in entries_of(node).items():
        item_path = join_path(path, name)
        if not register_name(ctx, name, node.key_lines[name], item_path, "event"):
            continue
        event = _event(ctx, name, item, item_path)
        if event is not None:
            events.append(event)
    return tuple(events)


def _event(ctx: Context, name: str, node: Node, path: str) -> Event | None:
    if not check_keys(ctx, node, path, EVENT_KEYS, ("when",), what="{when, direction, action}"):
        return None
    entries = entries_of(node)
    if "when" not in entries:
        return None
    when = read_expr(ctx, entries["when"], join_path(path, "when"), ctx.scope("event"))
    direction = "both"
    if "direction" in entries:
        direction = read_choice(ctx, entries["direction"], join_path(path, "direction"),
                                EVENT_DIRECTIONS, "direction")
    action, law = "record", ()
    if "action" in entries:
        action, law = _event_action(ctx, entries["action"], join_path(path, "action"))
    if when is None or direction is None or action is None:
        return None
    return Event(name, when, direction, action, law, ctx.loc(node, path))  # type: ignore


def _event_action(ctx: Context, node: Node, path: str
                  ) -> tuple[str | None, tuple[tuple[str, sympy.Expr], ...]]:
    """record, stop, or an impact law {q or dot(q): new value, ...} (action "impact")."""
    if not node.is_map:
        if not isinstance(node.value, str):
            ctx.problem(node.line, path, "expected record, stop, or a mapping of new values "
                                         "{q or dot(q): expression} (an impact), "
                                         f"{described(node)}")
            return None, ()
        return read_choice(ctx, node, path, EVENT_ACTIONS, "action"), ()
    if not node.value:
        ctx.problem(node.line, path, "an impact law needs at least one new value "
                                     "{q or dot(q): expression}")
        return None, ()
    states = [name for q in ctx.coordinates for name in (q, f"dot({q})")]
    law: dict[str, sympy.Expr] = {}
    ok = True
    for key, value in entries_of(node).items():
        match = re.fullmatch(r"dot\(\s*(\w+)\s*\)", key)
        state = f"dot({match.group(1)})" if match else key
        key_path, line = join_path(path, key), node.key_lines[key]
        if state not in states:
            ctx.problem(line, key_path, f"unknown coordinate or rate {key!r}"
                                        f"{suggestion(key, states)}; an impact law sets "
                                        "coordinates q and rates dot(q)")
            ok = False
        elif state in law:
            ctx.problem(line, key_path, f"{state} is given twice")
            ok = False
        else:
            expr = read_expr(ctx, value, key_path, ctx.scope("event"))
            ok = ok and expr is not None
            if expr is not None:
                law[state] = expr
    return ("impact" if ok else None), tuple(law.items())


def _tstops(ctx: Context, node: Node, t_span: tuple[float, float] | None
            ) -> tuple[float, ...] | None:
    path = "simulation.tstops"
    if not node.is_list or not node.value:
        ctx.problem(node.line, path, f"expected a list of times, {described(node)}")
        return None
    return _times(ctx, node, path, t_span)


def _max_steps(ctx: Context, node: Node) -> int | None:
    path = "simulation.max_steps"
    value = read_number(ctx, node, path)
    if value is None:
        return None
    if not (0 <= value <= MAX_STEPS_LIMIT and value == int(value)):
        ctx.problem(node.line, path, "expected a whole number of steps >= 0 (0: no budget), "
                                     f"got {value:g}")
        return None
    return int(value)


# ----------------------------------------------------------------------------- units

UNIT_KEYS = ("length", "mass", "time", "angle")
ANGLE_DISPLAYS = ("rad", "deg")
# A unit label goes into figures, CSV headers and MATLAB files: letters, digits and a few
# signs, never `$` (matplotlib's mathtext), quotes, commas or control characters.
UNIT_LABEL = re.compile(r"[^\W\d][\w .*/^()\u00b7\u00b0-]{0,23}")


def read_units(ctx: Context, node: Node) -> Units:
    """`units: {length: m, mass: kg, time: s, angle: deg}`: labels, every key optional."""
    if not check_keys(ctx, node, "units", UNIT_KEYS, what="a mapping {length, mass, time, angle}"):
        return Units()
    entries = entries_of(node)
    labels: dict[str, str | None] = {}
    for key in UNIT_KEYS[:3]:
        labels[key] = _unit_label(ctx, entries[key], join_path("units", key)) if key in entries \
            else None
    angle = "rad"
    if "angle" in entries:
        angle = read_choice(ctx, entries["angle"], "units.angle", ANGLE_DISPLAYS,
                            "angle display (how figures show angles)") or angle
    return Units(labels["length"], labels["mass"], labels["time"], angle)  # type: ignore[arg-type]


def _unit_label(ctx: Context, node: Node, path: str) -> str | None:
    label = read_string(ctx, node, path, "a unit label such as m, kg, s, ft or slug")
    if label is not None and not UNIT_LABEL.fullmatch(label):
        ctx.problem(node.line, path, "a unit label starts with a letter and has at most 24 "
                                     "letters, digits, spaces and . * / ^ ( ) - signs, "
                                     f"got {label!r}")
        return None
    return label
