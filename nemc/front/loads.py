"""The loads: a list, each item one load of a kind (nemc/kinds/loads/) read by it.
"""

from __future__ import annotations

from ..kinds.loads import LOAD_KINDS, Load
from .context import Context, check_keys, described, entries_of, items_of, join_path, suggestion
from .parse import Node
from .reader import Reader, every_key


def read_loads(ctx: Context, node: Node) -> tuple[tuple[Load, ...], tuple[tuple[str, int], ...]]:
    """The loads, and each named load's name with its index among them."""
    if not node.is_list:
        ctx.problem(node.line, "loads", f"expected a list of loads, {described(node)}")
        return (), ()
    loads, names = [], []
    for i, item in enumerate(items_of(node)):
        load = _load(ctx, item, join_path("loads", i))
        if load is None:
            continue
        name = entries_of(item).get("name")
        path = join_path(join_path("loads", i), "name")
        if name is not None and ctx.names.get(name.value) == ("load", path):
            names.append((name.value, len(loads)))
        loads.append(load)
    return tuple(loads), tuple(names)


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
    check_keys(ctx, node, path, (*kind.keys, "name"), kind.required,
               owner=(f"a {kind.kind} load", all_keys))
    fields = kind.read(Reader(ctx, node, path))
    if fields is None or len(ctx.problems) != count:
        return None
    return kind(**{"loc": ctx.loc(node, path), **fields})  # `name:`: read_loads's
