"""The names a file chooses: each claimed once (`register_name`), all of them before anything
else is read, so that a collision is found whatever the order; and the model's own name, which
names its package, files and C functions.
"""

from __future__ import annotations

import keyword
import re
import sys
from collections.abc import Mapping

from ..kinds.joints import JOINT_KINDS
from ..vocabulary import PACKAGE_FILE_STEMS
from .context import Context, described, entries_of, items_of, join_path
from .expr import RESERVED
from .fields import read_string
from .parse import Node

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
# An exported package is imported by its name: it must not hide a module it or its runtime
# needs (a model named json would make the runtime's own `import json` import the model).
SHADOWED_MODULES = frozenset({*sys.stdlib_module_names, "numpy", "scipy", "cffi",
                              "_cffi_backend", "nemc"})
MAX_MODEL_NAME = 64  # characters: it names the package's folder and files, and prefixes C names


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
                                  ("inputs", "input", ctx.inputs),
                                  ("bodies", "body", ctx.body_names),
                                  ("joints", "joint", None),
                                  ("constraints", "constraint", None),
                                  ("contacts", "contact", None)):
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
    loads = root.get("loads")
    for i, load in enumerate(items_of(loads) if loads is not None else ()):
        name = entries_of(load).get("name")
        if name is not None:
            register_name(ctx, name.value, name.line, join_path(join_path("loads", i), "name"),
                          "load")
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
