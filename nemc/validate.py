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
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import sympy

from nemc.errors import InputError, Problem
from nemc.expr import RESERVED, Budget, ExprError, Scope, parse_expression, suggest
from nemc.methods import METHODS  # the scene accepts exactly what simulate accepts
from nemc.model import (
    GROUND,
    Body,
    Event,
    Force,
    Joint,
    JointSpring,
    Load,
    Loc,
    Mechanism,
    Outputs,
    Param,
    PointRef,
    Simulation,
    Spring,
    Torque,
    Vec2,
    symbol,
)
from nemc.parse import Node, parse_text

JOINT_TYPES = ("revolute", "prismatic", "free", "weld")
LOAD_KINDS = ("torque", "force", "spring", "joint_spring")
IMPLICIT_POINTS = ("origin", "com")
TOP_KEYS = ("name", "description", "parameters", "constants", "gravity", "bodies", "joints",
            "loads", "outputs", "simulation")
JOINT_KEYS = {
    "revolute": ("type", "parent", "child", "at", "coordinate", "angle", "offset"),
    "prismatic": ("type", "parent", "child", "at", "coordinate", "axis", "offset"),
    "free": ("type", "parent", "child", "coordinates"),
    "weld": ("type", "parent", "child", "at", "offset"),
}
LOAD_KEYS = {
    "torque": ("torque", "body", "reaction"),
    "force": ("force", "body", "at", "frame"),
    "spring": ("spring",),
    "joint_spring": ("joint_spring",),
}
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
ZERO2: Vec2 = (sympy.S.Zero, sympy.S.Zero)
# An exported package is imported by its name: it must not hide a module it or its runtime
# needs (a model named json would make the runtime's own `import json` import the model).
SHADOWED_MODULES = frozenset({*sys.stdlib_module_names, "numpy", "scipy", "cffi",
                              "_cffi_backend", "nemc"})
FIXED_WHERE = "in body, joint, gravity and initial-condition fields (parameters and constants only)"


def load_mechanism(path: str | os.PathLike[str]) -> Mechanism:
    """Read, parse and validate the mechanism file at ``path``; raise InputError if it is bad."""
    file = os.fspath(path)
    try:
        data = Path(file).read_bytes()
    except OSError as exc:
        raise InputError([Problem(file, 1, "", f"cannot read file: {exc.strerror}")]) from None
    return validate_text(data, file)


def validate_text(text: str | bytes, file: str) -> Mechanism:
    """Validate a mechanism given as text (or the file's bytes); ``file`` names it in messages."""
    data = text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass")
    tree = parse_text(text, file)
    ctx = _Ctx(file)
    mechanism = _build(ctx, tree, hashlib.sha256(data).hexdigest())
    if ctx.problems or mechanism is None:
        raise InputError(sorted(ctx.problems, key=lambda p: p.line))
    return mechanism


# ----------------------------------------------------------------------------- context


@dataclass
class _Ctx:
    """What validation has learned so far, and the problems found."""

    file: str
    problems: list[Problem] = field(default_factory=list)
    names: dict[str, tuple[str, str]] = field(default_factory=dict)  # name -> (kind, path)
    lines: dict[str, int] = field(default_factory=dict)  # name -> line where it is defined
    parameters: list[str] = field(default_factory=list)
    constants: list[str] = field(default_factory=list)
    coordinates: list[str] = field(default_factory=list)
    defaults: dict[sympy.Symbol, sympy.Expr] = field(default_factory=dict)
    bodies: dict[str, Body] = field(default_factory=dict)
    body_names: list[str] = field(default_factory=list)  # valid names, in file order
    body_keys: list[str] = field(default_factory=list)  # every key under bodies
    joint_keys: list[str] = field(default_factory=list)  # every key under joints
    joints: dict[str, Joint] = field(default_factory=dict)
    joint_coordinates: dict[str, tuple[str, ...]] = field(default_factory=dict)
    budget: Budget = field(default_factory=Budget)  # tokens left for the file's expressions

    def problem(self, line: int, key: str, message: str) -> None:
        self.problems.append(Problem(self.file, line, key, message))

    def loc(self, node: Node, key: str) -> Loc:
        return Loc(self.file, node.line, node.column, key)

    def scope(self, kind: str) -> Scope:
        """``constants``, ``parameters``, ``fixed`` (body, joint, ...), ``load`` or ``event``
        fields."""
        allowed = list(self.constants)
        if kind != "constants":
            allowed += self.parameters
        where = {"constants": "in constants (other constants only)",
                 "parameters": "in parameters (parameters and constants only)",
                 "fixed": FIXED_WHERE,
                 "load": "in loads and outputs",
                 "event": "in events"}[kind]
        state = kind in ("load", "event")  # coordinates, their rates and t are allowed
        if state:
            allowed += self.coordinates
        names = {name: symbol(name) for name in allowed}
        refused = {name: f"{name!r} is {_article(kind_)} {kind_}, not allowed {where}"
                   for name, (kind_, _) in self.names.items() if name not in names}
        rates = frozenset(self.coordinates) if state else frozenset()
        return Scope(names, rates, state, refused, where, self.budget)


def _article(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"


def _join(path: str, key: str | int) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else key


def _suggest(word: object, candidates: Iterable[str]) -> str:
    return suggest(word, candidates) if isinstance(word, str) else ""


def _got(node: Node) -> str:
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


def _keys(ctx: _Ctx, node: Node, path: str, allowed: Iterable[str],
          required: Iterable[str] = (), what: str = "a mapping",
          owner: tuple[str, Iterable[str]] = ("", ())) -> bool:
    """Check ``node`` is a mapping with only ``allowed`` keys and all ``required`` ones.

    ``owner`` is ``(description, keys of its siblings)``, e.g. ``("a revolute joint", every
    joint key)``: a sibling's key is then refused as not applying rather than as unknown.
    """
    if not node.is_map:
        ctx.problem(node.line, path, f"expected {what}, {_got(node)}")
        return False
    allowed = tuple(allowed)
    for key in node.value:  # type: ignore[union-attr]
        if key in allowed:
            continue
        if key in owner[1]:
            message = f"key {key!r} does not apply to {owner[0]}"
        else:
            message = f"unknown key {key!r}{_suggest(key, allowed)}"
        ctx.problem(node.key_lines[key], _join(path, key),
                    f"{message}; expected one of: {', '.join(allowed)}")
    for key in required:
        if key not in node.value:  # type: ignore[operator]
            ctx.problem(node.line, _join(path, key), f"missing required key {key!r}")
    return True


def _entries(node: Node) -> Mapping[str, Node]:
    return node.value if isinstance(node.value, dict) else {}


def _items(node: Node) -> list[Node]:
    return node.value if isinstance(node.value, list) else []


# ----------------------------------------------------------------------------- values


def _expr(ctx: _Ctx, node: Node, path: str, scope: Scope) -> sympy.Expr | None:
    """A number or expression string; ``None`` (and a problem) if it is not one."""
    value = node.value
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        ctx.problem(node.line, path, f"expected a number or an expression, {_got(node)}")
        return None
    if isinstance(value, int):
        return sympy.Integer(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            ctx.problem(node.line, path, f"expected a finite number, got {value}")
            return None
        return sympy.Float(value)
    try:
        return parse_expression(value, scope)
    except ExprError as exc:
        shown = value if len(value) <= 60 else value[:57] + "..."
        ctx.problem(node.line, path, f"{exc.message} (in expression {shown!r}, "
                                     f"at character {exc.offset + 1})")
        if ctx.budget.exhausted:  # stop: every later expression would say the same
            raise InputError(sorted(ctx.problems, key=lambda p: p.line)) from None
        return None


def _value(ctx: _Ctx, expr: sympy.Expr) -> float | None:
    """The value of ``expr`` at the default parameter values; nan if not a finite real."""
    try:
        value = float(expr.xreplace(ctx.defaults))
    except (TypeError, ValueError, ArithmeticError):
        return math.nan
    return value if math.isfinite(value) else math.nan


def _known(ctx: _Ctx, expr: sympy.Expr) -> bool:
    """Whether every symbol of a fixed expression has a default value (else skip checks)."""
    return expr.free_symbols <= ctx.defaults.keys()


def _fixed(ctx: _Ctx, node: Node, path: str, positive: bool = False) -> sympy.Expr | None:
    """An expression of parameters and constants, finite (and > 0) at the default values."""
    expr = _expr(ctx, node, path, ctx.scope("fixed"))
    if expr is None or not _known(ctx, expr):
        return expr
    value = _value(ctx, expr)
    if math.isnan(value):
        ctx.problem(node.line, path, "does not evaluate to a finite real number at the "
                                     f"default parameter values (got {expr})")
        return None
    if positive and value <= 0:
        ctx.problem(node.line, path, f"must be > 0, got {value:g} at the default parameter values")
        return None
    return expr


def _vec2(ctx: _Ctx, node: Node, path: str, scope: Scope | None = None) -> Vec2 | None:
    """``[x, y]``: fixed expressions, or ``scope`` expressions when given."""
    items = _items(node)
    if not node.is_list or len(items) != 2:
        ctx.problem(node.line, path, f"expected a vector [x, y] of 2 entries, {_got(node)}")
        return None
    if scope is None:
        parts = [_fixed(ctx, item, _join(path, i)) for i, item in enumerate(items)]
    else:
        parts = [_expr(ctx, item, _join(path, i), scope) for i, item in enumerate(items)]
    if parts[0] is None or parts[1] is None:
        return None
    return (parts[0], parts[1])


def _number(ctx: _Ctx, node: Node, path: str) -> float | None:
    """A finite number: YAML number or an expression without names (``2*pi``)."""
    expr = _expr(ctx, node, path, Scope(where="here (a plain number is expected)",
                                        budget=ctx.budget))
    if expr is None:
        return None
    value = _value(ctx, expr)
    if math.isnan(value):
        ctx.problem(node.line, path, f"expected a finite number, got {expr}")
        return None
    return value


def _string(ctx: _Ctx, node: Node, path: str, what: str) -> str | None:
    if isinstance(node.value, str):
        return node.value
    ctx.problem(node.line, path, f"expected {what}, {_got(node)}")
    return None


def _choice(ctx: _Ctx, node: Node, path: str, choices: Iterable[str], what: str) -> str | None:
    """One of ``choices``, with a suggestion for a misspelling."""
    choices = tuple(choices)
    value = _string(ctx, node, path, what)
    if value is None:
        return None
    if value not in choices:
        ctx.problem(node.line, path, f"unknown {what} {value!r}{_suggest(value, choices)}; "
                                     f"expected one of: {', '.join(choices)}")
        return None
    return value


def _flag(ctx: _Ctx, node: Node, path: str) -> bool:
    if isinstance(node.value, bool):
        return node.value
    ctx.problem(node.line, path, f"expected true or false, {_got(node)}")
    return False


# ----------------------------------------------------------------------------- names


def _register(ctx: _Ctx, name: object, line: int, path: str, kind: str) -> bool:
    """Claim ``name`` for a ``kind`` of item; names are identifiers and never collide."""
    if not isinstance(name, str) or not IDENTIFIER.fullmatch(name):
        got = _got(Node(name, line, 0)) if isinstance(name, (list, dict)) else f"got {name!r}"
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


def _collect_names(ctx: _Ctx, root: Mapping[str, Node]) -> None:
    """Register every user-chosen name first, so collisions are found whatever the order."""
    for section, kind, target in (("parameters", "parameter", ctx.parameters),
                                  ("constants", "constant", ctx.constants),
                                  ("bodies", "body", ctx.body_names),
                                  ("joints", "joint", None)):
        node = root.get(section)
        for name in _entries(node) if node is not None else {}:
            if section in ("bodies", "joints"):
                (ctx.body_keys if section == "bodies" else ctx.joint_keys).append(name)
            path = _join(section, name)
            if _register(ctx, name, node.key_lines[name], path, kind) and target is not None:
                target.append(name)
    for name, joint in _entries(root["joints"]).items() if "joints" in root else ():
        ctx.joint_coordinates[name] = _collect_coordinates(ctx, joint, _join("joints", name))
    outputs = root.get("outputs")
    expressions = _entries(outputs).get("expressions") if outputs is not None else None
    if expressions is not None:
        for name in _entries(expressions):
            path = _join("outputs.expressions", name)
            _register(ctx, name, expressions.key_lines[name], path, "output expression")


def _collect_coordinates(ctx: _Ctx, joint: Node, path: str) -> tuple[str, ...]:
    """The valid coordinate names a joint declares (its shape is checked with the joint)."""
    entries = _entries(joint)
    kind = entries["type"].value if "type" in entries else None
    names: list[tuple[Node, str]] = []
    unknown = kind not in JOINT_TYPES
    if "coordinate" in entries and (kind in ("revolute", "prismatic") or unknown):
        names.append((entries["coordinate"], _join(path, "coordinate")))
    if "coordinates" in entries and (kind == "free" or unknown):
        items = _items(entries["coordinates"])
        names += [(item, _join(_join(path, "coordinates"), i)) for i, item in enumerate(items)]
    found = []
    for node, item_path in names:
        if _register(ctx, node.value, node.line, item_path, "coordinate"):
            ctx.coordinates.append(node.value)  # type: ignore[arg-type]
            found.append(node.value)
    return tuple(found)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- top level


def _build(ctx: _Ctx, tree: Node, source_hash: str) -> Mechanism | None:
    if not _keys(ctx, tree, "", TOP_KEYS, ("name", "bodies", "joints"),
                 what="a mapping of top-level keys (name, bodies, joints, ...)"):
        return None
    root = _entries(tree)
    name = _module_name(ctx, root.get("name"))
    description = ""
    if "description" in root:
        description = _string(ctx, root["description"], "description", "text") or ""
    _collect_names(ctx, root)
    parameters, constants = _parameters(ctx, root)
    gravity = _vec2(ctx, root["gravity"], "gravity") if "gravity" in root else ZERO2
    bodies = _bodies(ctx, root.get("bodies"))
    joints = _joints(ctx, root.get("joints"))
    loads = _loads(ctx, root["loads"]) if "loads" in root else ()
    outputs = _outputs(ctx, root["outputs"]) if "outputs" in root else Outputs()
    simulation = _simulation(ctx, root["simulation"]) if "simulation" in root else Simulation()
    if ctx.problems or name is None or gravity is None:
        return None
    return Mechanism(name=name, description=description, source=ctx.file,
                     source_hash=source_hash, parameters=parameters, constants=constants,
                     gravity=gravity, bodies=bodies, joints=joints, loads=loads,
                     outputs=outputs, simulation=simulation)


def _module_name(ctx: _Ctx, node: Node | None) -> str | None:
    if node is None:
        return None
    name = _string(ctx, node, "name", "an identifier naming the generated module")
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
    return name


# ----------------------------------------------------------------------------- parameters


def _parameters(ctx: _Ctx, root: Mapping[str, Node]) -> tuple[tuple[Param, ...], ...]:
    """Parameters and constants: parsed, free of cycles, with finite default values."""
    parsed: dict[str, tuple[Node, str, sympy.Expr]] = {}
    for section, kind in (("constants", "constant"), ("parameters", "parameter")):
        node = root.get(section)
        if node is None:
            continue
        if not node.is_map:
            ctx.problem(node.line, section, f"expected a mapping name -> number or expression, "
                                            f"{_got(node)}")
            continue
        scope = ctx.scope(section)
        for name, value in _entries(node).items():
            path = _join(section, name)
            if ctx.names.get(name) != (kind, path):
                continue  # a bad or colliding name, already reported
            expr = _expr(ctx, value, path, scope)
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


def _check_cycles(ctx: _Ctx, parsed: Mapping[str, tuple[Node, str, sympy.Expr]]) -> set[str]:
    """Report each cycle among parameter definitions once; return the names on cycles."""
    cyclic: set[str] = set()
    done: set[str] = set()

    def visit(name: str, stack: list[str]) -> None:
        if name in done or name not in parsed:
            return
        if name in stack:
            cycle = stack[stack.index(name):]
            if not cyclic & set(cycle):
                node, path, _ = parsed[cycle[0]]
                chain = " -> ".join([*cycle, cycle[0]])
                ctx.problem(node.line, path, f"definitions form a cycle: {chain}")
            cyclic.update(cycle)
            return
        stack.append(name)
        for dep in _dependencies(parsed[name][2]):
            visit(dep, stack)
        stack.pop()
        done.add(name)

    for name in parsed:
        visit(name, [])
    return cyclic


def _compute_defaults(ctx: _Ctx, parsed: Mapping[str, tuple[Node, str, sympy.Expr]],
                      cyclic: set[str]) -> None:
    """Evaluate default values in dependency order; each must be a finite real number."""
    pending = [name for name in parsed if name not in cyclic]
    progress = True
    while pending and progress:
        progress = False
        for name in list(pending):
            node, path, expr = parsed[name]
            if not _known(ctx, expr):
                continue
            pending.remove(name)
            progress = True
            value = _value(ctx, expr)
            if math.isnan(value):
                ctx.problem(node.line, path, "default value does not evaluate to a finite real "
                                             f"number (got {expr})")
            else:
                ctx.defaults[symbol(name)] = sympy.Float(value)


# ----------------------------------------------------------------------------- bodies


def _nonempty_mapping(ctx: _Ctx, node: Node | None, key: str, item: str) -> bool:
    """Whether NODE is a mapping with at least one entry (a problem is recorded if not)."""
    if node is None:
        return False
    if not node.is_map or not node.value:
        ctx.problem(node.line, key, f"expected a mapping {item} name -> {item} with at least "
                                    f"one {item}, {_got(node)}")
        return False
    return True


def _bodies(ctx: _Ctx, node: Node | None) -> tuple[Body, ...]:
    if not _nonempty_mapping(ctx, node, "bodies", "body"):
        return ()
    for name, body_node in _entries(node).items():
        path = _join("bodies", name)
        if ctx.names.get(name) == ("body", path):
            body = _body(ctx, name, body_node, path)
            if body is not None:
                ctx.bodies[name] = body
    return tuple(ctx.bodies.values())


def _body(ctx: _Ctx, name: str, node: Node, path: str) -> Body | None:
    if not _keys(ctx, node, path, ("mass", "inertia", "com", "points"), ("mass", "inertia")):
        return None
    entries = _entries(node)
    mass = _fixed(ctx, entries["mass"], _join(path, "mass"), True) if "mass" in entries else None
    inertia = None
    if "inertia" in entries:
        inertia = _fixed(ctx, entries["inertia"], _join(path, "inertia"), True)
    com = _vec2(ctx, entries["com"], _join(path, "com")) if "com" in entries else ZERO2
    points = _points(ctx, entries["points"], _join(path, "points")) if "points" in entries else {}
    if mass is None or inertia is None or com is None or points is None:
        return None
    return Body(name, mass, inertia, com, points, ctx.loc(node, path))


def _points(ctx: _Ctx, node: Node, path: str) -> dict[str, Vec2] | None:
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a mapping point name -> [x, y], {_got(node)}")
        return None
    points: dict[str, Vec2] = {}
    ok = True
    for name, value in _entries(node).items():
        item_path = _join(path, name)
        line = node.key_lines[name]
        if name in IMPLICIT_POINTS:
            ctx.problem(line, item_path, f"{name!r} is an implicit point of every body and "
                                         "cannot be redefined")
        elif not IDENTIFIER.fullmatch(name) or name in RESERVED:
            ctx.problem(line, item_path, "point name must be an identifier [A-Za-z_][A-Za-z0-9_]*"
                                         f" and not a reserved word, got {name!r}")
        else:
            xy = _vec2(ctx, value, item_path)
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


def _joints(ctx: _Ctx, node: Node | None) -> tuple[Joint, ...]:
    if not _nonempty_mapping(ctx, node, "joints", "joint"):
        return ()
    edges: list[_Edge] = []
    for name, joint_node in _entries(node).items():
        path = _join("joints", name)
        if ctx.names.get(name) == ("joint", path) and joint_node.is_map:
            edge = _edge(ctx, name, joint_node, path)
            if edge is not None:
                edges.append(edge)
            joint = _joint(ctx, name, joint_node, path, edge)
            if joint is not None:
                ctx.joints[name] = joint
        elif not joint_node.is_map:
            ctx.problem(joint_node.line, path, f"expected a joint mapping, {_got(joint_node)}")
    _check_tree(ctx, edges, _named_children(node))
    return tuple(ctx.joints.values())


def _edge(ctx: _Ctx, name: str, node: Node, path: str) -> _Edge | None:
    """The joint's parent and child, if both name real bodies (or ground for the parent)."""
    entries = _entries(node)
    parent = child = None
    if "parent" in entries:
        parent = _body_name(ctx, entries["parent"], _join(path, "parent"), ground=True)
    if "child" in entries:
        child = _body_name(ctx, entries["child"], _join(path, "child"), ground=False)
    if parent is None or child is None:
        return None
    return _Edge(name, parent, child, entries["parent"].line, entries["child"].line)


def _body_name(ctx: _Ctx, node: Node, path: str, ground: bool) -> str | None:
    """A body name (or ``ground`` where allowed), with a suggestion for misspellings."""
    name = _string(ctx, node, path, "a body name")
    if name is None:
        return None
    if name == GROUND and not ground:
        ctx.problem(node.line, path, "expected a body, got 'ground' (ground is not allowed here)")
        return None
    if name == GROUND or name in ctx.body_keys:
        return name
    candidates = [*ctx.body_keys, GROUND] if ground else ctx.body_keys
    ctx.problem(node.line, path, f"unknown body {name!r}{_suggest(name, candidates)}")
    return None


def _joint(ctx: _Ctx, name: str, node: Node, path: str, edge: _Edge | None) -> Joint | None:
    entries = _entries(node)
    kind = None
    if "type" in entries:
        kind = _choice(ctx, entries["type"], _join(path, "type"), JOINT_TYPES, "joint type")
    every_key = sorted({key for keys in JOINT_KEYS.values() for key in keys})
    required = ["type", "parent", "child"]
    if kind in ("revolute", "prismatic"):
        required.append("coordinate")
    elif kind == "free":
        required.append("coordinates")
    allowed = JOINT_KEYS[kind] if kind is not None else every_key
    _keys(ctx, node, path, allowed, required, owner=(f"a {kind} joint", every_key))
    if kind is None:
        return None
    return _joint_fields(ctx, Joint(name, kind, "", "", ZERO2, (), loc=ctx.loc(node, path)),
                         entries, path, edge)


def _joint_fields(ctx: _Ctx, joint: Joint, entries: Mapping[str, Node], path: str,
                  edge: _Edge | None) -> Joint | None:
    """Fill in a joint of known type from its entries; ``None`` if anything is wrong."""
    count = len(ctx.problems)
    coordinates = _joint_coordinates(ctx, joint, entries, path)
    at = ZERO2
    if "at" in entries and joint.type in JOINT_KEYS and "at" in JOINT_KEYS[joint.type]:
        parent = edge.parent if edge is not None else None
        at = _point_of(ctx, entries["at"], _join(path, "at"), parent)
    if joint.type == "free" and edge is not None and edge.parent != GROUND:
        ctx.problem(edge.parent_line, _join(path, "parent"), "a free joint's parent must be "
                                                             f"ground, got {edge.parent!r}")
    angle = "relative"
    if "angle" in entries and joint.type == "revolute":
        angle = _choice(ctx, entries["angle"], _join(path, "angle"), ("relative", "absolute"),
                        "angle") or angle
    offset = sympy.S.Zero
    if "offset" in entries and joint.type != "free":
        offset = _fixed(ctx, entries["offset"], _join(path, "offset"))
    axis = (sympy.S.One, sympy.S.Zero)
    if "axis" in entries and joint.type == "prismatic":
        axis = _axis(ctx, entries["axis"], _join(path, "axis"))
    if len(ctx.problems) > count or edge is None or None in (at, offset, axis, coordinates):
        return None
    return Joint(joint.name, joint.type, edge.parent, edge.child, at, coordinates,
                 angle, offset, axis, joint.loc)  # type: ignore[arg-type]


def _joint_coordinates(ctx: _Ctx, joint: Joint, entries: Mapping[str, Node],
                       path: str) -> tuple[str, ...] | None:
    """The joint's coordinates; their names were checked when they were collected."""
    found = ctx.joint_coordinates.get(joint.name, ())
    if joint.type == "weld":
        return ()
    if joint.type == "free":
        node = entries.get("coordinates")
        if node is None:
            return None
        if not node.is_list or len(_items(node)) != 3:
            ctx.problem(node.line, _join(path, "coordinates"), "expected a list of 3 coordinate "
                                                               f"names [x, y, th], {_got(node)}")
            return None
        return found if len(found) == 3 else None
    if "coordinate" not in entries:
        return None
    return found if len(found) == 1 else None


def _axis(ctx: _Ctx, node: Node, path: str) -> Vec2 | None:
    axis = _vec2(ctx, node, path)
    if axis is None or not all(_known(ctx, part) for part in axis):
        return axis
    if all(_value(ctx, part) == 0 for part in axis):
        ctx.problem(node.line, path, "axis must not be [0, 0] at the default parameter values")
        return None
    return axis


def _point_of(ctx: _Ctx, node: Node, path: str, body: str | None) -> Vec2 | None:
    """A point of ``body``: a point name (``origin``, ``com``, named) or fixed ``[x, y]``."""
    if node.is_list:
        return _vec2(ctx, node, path)
    name = _string(ctx, node, path, "a point name or [x, y]")
    if name is None or body is None:
        return None
    return _named_point(ctx, body, name, node.line, path)


def _named_point(ctx: _Ctx, body: str, name: str, line: int, path: str) -> Vec2 | None:
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
    ctx.problem(line, path, f"body {body!r} has no point {name!r}{_suggest(name, candidates)}; "
                            f"its points: {', '.join(candidates)}")
    return None


def _named_children(node: Node) -> set[object]:
    """Every child any joint names, valid or not: a body a broken joint names is reported
    with that joint, not as unattached too."""
    children = [_entries(joint).get("child") for joint in _entries(node).values()]
    return {child.value for child in children if child is not None and child.is_scalar}


def _check_tree(ctx: _Ctx, edges: list[_Edge], named_children: set[object]) -> None:
    """Every body is the child of exactly one joint, and every chain reaches ground."""
    parent_of: dict[str, _Edge] = {}
    for edge in edges:
        if edge.child in parent_of:
            first = parent_of[edge.child].joint
            ctx.problem(edge.child_line, _join(_join("joints", edge.joint), "child"),
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


def _check_cycles_in_tree(ctx: _Ctx, parent_of: Mapping[str, _Edge]) -> None:
    reported: set[str] = set()
    for start in parent_of:
        chain: list[str] = []
        body = start
        while body in parent_of and body not in chain:
            chain.append(body)
            body = parent_of[body].parent
        if body not in chain or body in reported:
            continue
        cycle = chain[chain.index(body):]
        reported.update(cycle)
        edge = parent_of[cycle[0]]
        bodies = " -> ".join([*cycle, cycle[0]])
        joints = ", ".join(parent_of[b].joint for b in cycle)
        ctx.problem(edge.parent_line, _join(_join("joints", edge.joint), "parent"),
                    f"joints {joints} form a cycle (child -> parent: {bodies}) that never "
                    "reaches ground; the joints must form a tree rooted at ground")


# ----------------------------------------------------------------------------- loads


def _loads(ctx: _Ctx, node: Node) -> tuple[Load, ...]:
    if not node.is_list:
        ctx.problem(node.line, "loads", f"expected a list of loads, {_got(node)}")
        return ()
    loads = [_load(ctx, item, _join("loads", i)) for i, item in enumerate(_items(node))]
    return tuple(load for load in loads if load is not None)


def _load(ctx: _Ctx, node: Node, path: str) -> Load | None:
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a load mapping with one of "
                                     f"{', '.join(LOAD_KINDS)}, {_got(node)}")
        return None
    entries = _entries(node)
    kinds = [kind for kind in LOAD_KINDS if kind in entries]
    if len(kinds) != 1:
        found = f"got {' and '.join(kinds)}" if kinds else f"got keys {', '.join(entries)}"
        hint = "" if kinds else "".join(_suggest(key, LOAD_KINDS) for key in entries)
        ctx.problem(node.line, path, f"a load has exactly one of {', '.join(LOAD_KINDS)}; "
                                     f"{found}{hint}")
        return None
    kind = kinds[0]
    required = ("body",) if kind in ("torque", "force") else ()
    count = len(ctx.problems)
    every_key = {key for keys in LOAD_KEYS.values() for key in keys}
    _keys(ctx, node, path, LOAD_KEYS[kind], required, owner=(f"a {kind} load", every_key))
    maker = {"torque": _torque, "force": _force, "spring": _spring,
             "joint_spring": _joint_spring}[kind]
    load = maker(ctx, node, path)
    return load if len(ctx.problems) == count else None


def _torque(ctx: _Ctx, node: Node, path: str) -> Torque | None:
    entries = _entries(node)
    expr = _expr(ctx, entries["torque"], _join(path, "torque"), ctx.scope("load"))
    body = _load_body(ctx, entries, path)
    reaction: str | None = GROUND
    if "reaction" in entries:
        reaction_node = entries["reaction"]
        reaction = _body_name(ctx, reaction_node, _join(path, "reaction"), ground=True)
        if reaction is not None and reaction == body:
            ctx.problem(reaction_node.line, _join(path, "reaction"),
                        f"reaction must differ from body, got {body!r} for both")
    if expr is None or body is None or reaction is None:
        return None
    return Torque(expr, body, reaction, ctx.loc(node, path))


def _load_body(ctx: _Ctx, entries: Mapping[str, Node], path: str) -> str | None:
    if "body" not in entries:
        return None
    return _body_name(ctx, entries["body"], _join(path, "body"), ground=False)


def _force(ctx: _Ctx, node: Node, path: str) -> Force | None:
    entries = _entries(node)
    components = _vec2(ctx, entries["force"], _join(path, "force"), ctx.scope("load"))
    body = _load_body(ctx, entries, path)
    at: Vec2 | None = None
    if "at" in entries:
        at = _point_of(ctx, entries["at"], _join(path, "at"), body)
    elif body is not None and body in ctx.bodies:
        at = ctx.bodies[body].com
    frame = "ground"
    if "frame" in entries:
        frame = _choice(ctx, entries["frame"], _join(path, "frame"), ("ground", "body"),
                        "frame") or frame
    if components is None or body is None or at is None:
        return None
    return Force(components, body, at, frame, ctx.loc(node, path))  # type: ignore[arg-type]


def _spring(ctx: _Ctx, node: Node, path: str) -> Spring | None:
    spring = _entries(node)["spring"]
    path = _join(path, "spring")
    keys = ("a", "b", "k", "length", "damping")
    if not _keys(ctx, spring, path, keys, keys[:4], what="a mapping {a, b, k, length, damping}"):
        return None
    entries = _entries(spring)
    ends = [_point_ref(ctx, entries[key], _join(path, key), ground=True)
            for key in ("a", "b") if key in entries]
    scope = ctx.scope("load")
    values = [_expr(ctx, entries[key], _join(path, key), scope) if key in entries else None
              for key in ("k", "length")]
    damping = sympy.S.Zero
    if "damping" in entries:
        damping = _expr(ctx, entries["damping"], _join(path, "damping"), scope)
    if len(ends) != 2 or None in (*ends, *values, damping):
        return None
    return Spring(ends[0], ends[1], values[0], values[1], damping,  # type: ignore[arg-type]
                  ctx.loc(spring, path))


def _joint_spring(ctx: _Ctx, node: Node, path: str) -> JointSpring | None:
    spring = _entries(node)["joint_spring"]
    path = _join(path, "joint_spring")
    keys = ("joint", "k", "rest", "damping")
    if not _keys(ctx, spring, path, keys, keys[:2], what="a mapping {joint, k, rest, damping}"):
        return None
    entries = _entries(spring)
    joint = _joint_name(ctx, entries["joint"], _join(path, "joint")) if "joint" in entries else None
    if joint is not None and joint in ctx.joints:
        kind = ctx.joints[joint].type
        if kind not in ("revolute", "prismatic"):
            ctx.problem(entries["joint"].line, _join(path, "joint"), "a joint_spring needs a "
                        f"revolute or prismatic joint; {joint!r} is a {kind} joint")
    scope = ctx.scope("load")
    values = {key: _expr(ctx, entries[key], _join(path, key), scope) if key in entries
              else sympy.S.Zero for key in ("k", "rest", "damping")}
    if joint is None or None in values.values():
        return None
    return JointSpring(joint, values["k"], values["rest"], values["damping"],  # type: ignore
                       ctx.loc(spring, path))


def _joint_name(ctx: _Ctx, node: Node, path: str) -> str | None:
    name = _string(ctx, node, path, "a joint name")
    if name is None:
        return None
    if name not in ctx.joint_keys:
        ctx.problem(node.line, path, f"unknown joint {name!r}{_suggest(name, ctx.joint_keys)}")
        return None
    return name


def _point_ref(ctx: _Ctx, node: Node, path: str, ground: bool) -> PointRef | None:
    """``BODY.POINT``, or (where ``ground`` is true, for springs) ``{body: BODY, at: [x, y]}``."""
    if node.is_map and ground:
        if not _keys(ctx, node, path, ("body", "at"), ("body", "at")):
            return None
        entries = _entries(node)
        body = None
        if "body" in entries:
            body = _body_name(ctx, entries["body"], _join(path, "body"), ground=True)
        xy = _vec2(ctx, entries["at"], _join(path, "at")) if "at" in entries else None
        if body is None or xy is None:
            return None
        return PointRef(body, xy, f"{body}.[{xy[0]}, {xy[1]}]")
    text = node.value if isinstance(node.value, str) else None
    parts = text.split(".") if text is not None else []
    if len(parts) != 2:
        other = " or {body: BODY, at: [x, y]}" if ground else ""
        ctx.problem(node.line, path, f"expected BODY.POINT (e.g. link1.com){other}, "
                                     f"{_got(node)}")
        return None
    body = _body_name(ctx, Node(parts[0], node.line, node.column), path, ground)
    if body is None:
        return None
    xy = _named_point(ctx, body, parts[1], node.line, path)
    return PointRef(body, xy, f"{body}.{parts[1]}") if xy is not None else None


# ----------------------------------------------------------------------------- outputs


def _outputs(ctx: _Ctx, node: Node) -> Outputs:
    keys = ("reactions", "energy", "points", "accelerations", "expressions")
    if not _keys(ctx, node, "outputs", keys):
        return Outputs()
    entries = _entries(node)
    reactions: list[str] = []
    for i, item in enumerate(_list(ctx, entries.get("reactions"), "outputs.reactions")):
        name = _joint_name(ctx, item, f"outputs.reactions[{i}]")
        if name in reactions:
            ctx.problem(item.line, f"outputs.reactions[{i}]", f"joint {name!r} is listed twice")
        elif name is not None:
            reactions.append(name)
    points: list[PointRef] = []
    for i, item in enumerate(_list(ctx, entries.get("points"), "outputs.points")):
        point = _point_ref(ctx, item, f"outputs.points[{i}]", ground=False)
        if point is not None and point.label in [p.label for p in points]:
            ctx.problem(item.line, f"outputs.points[{i}]", f"{point.label} is listed twice")
        elif point is not None:
            points.append(point)
    flags = {key: _flag(ctx, entries[key], _join("outputs", key)) if key in entries else False
             for key in ("energy", "accelerations")}
    expressions = _output_expressions(ctx, entries.get("expressions"))
    return Outputs(tuple(reactions), flags["energy"], tuple(points), flags["accelerations"],
                   expressions)


def _list(ctx: _Ctx, node: Node | None, path: str) -> list[Node]:
    if node is None:
        return []
    if not node.is_list:
        ctx.problem(node.line, path, f"expected a list, {_got(node)}")
    return _items(node)


def _output_expressions(ctx: _Ctx, node: Node | None) -> tuple[tuple[str, sympy.Expr], ...]:
    if node is None:
        return ()
    if not node.is_map:
        ctx.problem(node.line, "outputs.expressions", "expected a mapping name -> expression, "
                                                      f"{_got(node)}")
        return ()
    result = []
    for name, value in _entries(node).items():
        path = _join("outputs.expressions", name)
        if ctx.names.get(name) != ("output expression", path):
            continue  # a bad or colliding name, already reported
        expr = _expr(ctx, value, path, ctx.scope("load"))
        if expr is not None:
            result.append((name, expr))
    return tuple(result)


# ----------------------------------------------------------------------------- simulation


def _simulation(ctx: _Ctx, node: Node) -> Simulation:
    keys = ("t_span", "initial", "t_eval", "method", "rtol", "atol", *RUN_CONTROL_KEYS)
    if not _keys(ctx, node, "simulation", keys):
        return Simulation()
    entries = _entries(node)
    t_span = _t_span(ctx, entries["t_span"]) if "t_span" in entries else None
    initial = _initial(ctx, entries["initial"]) if "initial" in entries else {}
    t_eval = step = None
    if "t_eval" in entries:
        t_eval, step = _t_eval(ctx, entries["t_eval"], t_span, "t_span" in entries)
    method = None
    if "method" in entries:
        method = _choice(ctx, entries["method"], "simulation.method", METHODS, "method")
    tolerances = {key: _positive(ctx, entries[key], _join("simulation", key))
                  if key in entries else None for key in ("rtol", "atol")}
    return Simulation(t_span, initial, t_eval, step, method, tolerances["rtol"],
                      tolerances["atol"], **_run_control(ctx, entries, t_span))


def _positive(ctx: _Ctx, node: Node, path: str) -> float | None:
    value = _number(ctx, node, path)
    if value is not None and value <= 0:
        ctx.problem(node.line, path, f"must be a number > 0, got {value:g}")
        return None
    return value


def _t_span(ctx: _Ctx, node: Node) -> tuple[float, float] | None:
    path = "simulation.t_span"
    if not node.is_list or len(_items(node)) != 2:
        ctx.problem(node.line, path, f"expected [t0, t1], {_got(node)}")
        return None
    t0, t1 = (_number(ctx, item, _join(path, i)) for i, item in enumerate(_items(node)))
    if t0 is None or t1 is None:
        return None
    if not t1 > t0:
        ctx.problem(node.line, path, f"the end must be after the start, got [{t0:g}, {t1:g}]")
        return None
    return (t0, t1)


def _initial(ctx: _Ctx, node: Node) -> dict[str, sympy.Expr]:
    path = "simulation.initial"
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a mapping q or dot(q) -> value, {_got(node)}")
        return {}
    states = [name for q in ctx.coordinates for name in (q, f"dot({q})")]
    initial: dict[str, sympy.Expr] = {}
    for key, value in _entries(node).items():
        match = re.fullmatch(r"dot\(\s*(\w+)\s*\)", key)
        name = f"dot({match.group(1)})" if match else key
        if name not in states:
            ctx.problem(node.key_lines[key], _join(path, key), f"unknown coordinate or rate "
                        f"{key!r}{_suggest(key, states)}; expected a coordinate q or dot(q)")
            continue
        if name in initial:
            ctx.problem(node.key_lines[key], _join(path, key), f"{name} is given twice")
            continue
        expr = _fixed(ctx, value, _join(path, key))
        if expr is not None:
            initial[name] = expr
    return initial


def _t_eval(ctx: _Ctx, node: Node, t_span: tuple[float, float] | None,
            has_span: bool) -> tuple[tuple[float, ...] | None, float | None]:
    path = "simulation.t_eval"
    if not has_span:
        ctx.problem(node.line, path, "t_eval needs simulation.t_span")
    if node.is_map:
        if not _keys(ctx, node, path, ("step",), ("step",), what="{step: h}"):
            return None, None
        step = _entries(node).get("step")
        return None, _positive(ctx, step, _join(path, "step")) if step is not None else None
    if not node.is_list or not node.value:
        ctx.problem(node.line, path, f"expected {{step: h}} or a list of times, {_got(node)}")
        return None, None
    return _times(ctx, node, path, t_span), None


def _times(ctx: _Ctx, node: Node, path: str, t_span: tuple[float, float] | None
           ) -> tuple[float, ...] | None:
    """A non-empty list of increasing times inside t_span (when the scene gives one)."""
    times = [_number(ctx, item, _join(path, i)) for i, item in enumerate(_items(node))]
    if None in times:
        return None
    for i, (before, after) in enumerate(zip(times, times[1:])):
        if not after > before:  # type: ignore[operator]
            ctx.problem(node.line, _join(path, i + 1), "times must increase, got "
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


def _run_control(ctx: _Ctx, entries: Mapping[str, Node],
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


def _events(ctx: _Ctx, node: Node) -> tuple[Event, ...]:
    path = "simulation.events"
    if not node.is_map or not node.value:
        ctx.problem(node.line, path, "expected a mapping event name -> {when, direction, "
                                     f"action}}, {_got(node)}")
        return ()
    events = []
    for name, item in _entries(node).items():
        item_path = _join(path, name)
        if not _register(ctx, name, node.key_lines[name], item_path, "event"):
            continue
        event = _event(ctx, name, item, item_path)
        if event is not None:
            events.append(event)
    return tuple(events)


def _event(ctx: _Ctx, name: str, node: Node, path: str) -> Event | None:
    if not _keys(ctx, node, path, EVENT_KEYS, ("when",), what="{when, direction, action}"):
        return None
    entries = _entries(node)
    if "when" not in entries:
        return None
    when = _expr(ctx, entries["when"], _join(path, "when"), ctx.scope("event"))
    direction = "both"
    if "direction" in entries:
        direction = _choice(ctx, entries["direction"], _join(path, "direction"),
                            EVENT_DIRECTIONS, "direction")
    action, law = "record", ()
    if "action" in entries:
        action, law = _event_action(ctx, entries["action"], _join(path, "action"))
    if when is None or direction is None or action is None:
        return None
    return Event(name, when, direction, action, law, ctx.loc(node, path))  # type: ignore


def _event_action(ctx: _Ctx, node: Node, path: str
                  ) -> tuple[str | None, tuple[tuple[str, sympy.Expr], ...]]:
    """record, stop, or an impact law {q or dot(q): new value, ...} (action "impact")."""
    if not node.is_map:
        if not isinstance(node.value, str):
            ctx.problem(node.line, path, "expected record, stop, or a mapping of new values "
                                         f"{{q or dot(q): expression}} (an impact), {_got(node)}")
            return None, ()
        return _choice(ctx, node, path, EVENT_ACTIONS, "action"), ()
    if not node.value:
        ctx.problem(node.line, path, "an impact law needs at least one new value "
                                     "{q or dot(q): expression}")
        return None, ()
    states = [name for q in ctx.coordinates for name in (q, f"dot({q})")]
    law: dict[str, sympy.Expr] = {}
    ok = True
    for key, value in _entries(node).items():
        match = re.fullmatch(r"dot\(\s*(\w+)\s*\)", key)
        state = f"dot({match.group(1)})" if match else key
        key_path, line = _join(path, key), node.key_lines[key]
        if state not in states:
            ctx.problem(line, key_path, f"unknown coordinate or rate {key!r}"
                                        f"{_suggest(key, states)}; an impact law sets "
                                        "coordinates q and rates dot(q)")
            ok = False
        elif state in law:
            ctx.problem(line, key_path, f"{state} is given twice")
            ok = False
        else:
            expr = _expr(ctx, value, key_path, ctx.scope("event"))
            ok = ok and expr is not None
            if expr is not None:
                law[state] = expr
    return ("impact" if ok else None), tuple(law.items())


def _tstops(ctx: _Ctx, node: Node, t_span: tuple[float, float] | None
            ) -> tuple[float, ...] | None:
    path = "simulation.tstops"
    if not node.is_list or not node.value:
        ctx.problem(node.line, path, f"expected a list of times, {_got(node)}")
        return None
    return _times(ctx, node, path, t_span)


def _max_steps(ctx: _Ctx, node: Node) -> int | None:
    path = "simulation.max_steps"
    value = _number(ctx, node, path)
    if value is None:
        return None
    if not (0 <= value <= MAX_STEPS_LIMIT and value == int(value)):
        ctx.problem(node.line, path, "expected a whole number of steps >= 0 (0: no budget), "
                                     f"got {value:g}")
        return None
    return int(value)
