"""The `contacts` mapping (format v3, "Contacts that last"; decision 0041): each contact read by
the kind (nemc/kinds/contact.py), its parameters' bounds checked at their defaults, and a scene
whose method cannot run contacts refused at the method's line.
"""

from __future__ import annotations

import math

from ..kinds.contact import KEYS, Contact
from ..vocabulary import AUTO, CONTACT_METHODS
from .context import Context, check_keys, described, entries_of, join_path
from .fields import default_value, has_defaults
from .parse import Node
from .reader import Reader

SHAPE = ("a mapping of contacts, NAME: {point, radius, surface: {body, at, axis, length}, "
         "restitution, mu}")


def read_contacts(ctx: Context, node: Node) -> tuple[Contact, ...]:
    """The contacts, in file order (their names were claimed with every other name)."""
    if not node.is_map or not entries_of(node):
        ctx.problem(node.line, "contacts", f"expected {SHAPE}, {described(node)}")
        return ()
    found: list[Contact] = []
    for name, item in entries_of(node).items():
        path = join_path("contacts", name)
        if not check_keys(ctx, item, path, KEYS, Contact.required,
                          what="a contact mapping {point, radius, surface, restitution, mu}"):
            continue
        count = len(ctx.problems)
        fields = Contact.read(Reader(ctx, item, path))
        if fields is None or len(ctx.problems) > count:
            continue
        contact = Contact(name=name, loc=ctx.loc(item, path), **fields)
        if _within_bounds(ctx, contact, item, path):
            found.append(contact)
    return tuple(found)


def _within_bounds(ctx: Context, contact: Contact, node: Node, path: str) -> bool:
    """Whether the contact's bounds (restitution <= 1, ...) hold at the default parameters;
    each that does not is a problem at its key's line."""
    entries = entries_of(node)
    ok = True
    for bound in contact.bounds():
        if not has_defaults(ctx, bound.expression):
            continue
        value = default_value(ctx, bound.expression)
        if math.isnan(value) or value < 0 or (bound.strict and value == 0):
            line = entries[bound.key].line if bound.key in entries else node.line
            ctx.problem(line, join_path(path, bound.key), f"{bound.rule}; at the default "
                        "parameter values it is not")
            ok = False
    return ok


def check_contact_method(ctx: Context, contacts: tuple[Contact, ...],
                         simulation: Node | None) -> None:
    """Refuse a scene whose method cannot run contacts: only explicit methods (nemc's, and
    scipy's through runtime/scipy_switches.py) locate the impacts and mode switches inside their
    steps and keep a closed contact's mode (auto takes one of them)."""
    if not contacts or simulation is None or not simulation.is_map:
        return
    method = entries_of(simulation).get("method")
    if method is None or method.value in (*CONTACT_METHODS, AUTO):
        return
    names = ", ".join(contact.name for contact in contacts)
    ctx.problem(method.line, "simulation.method", f"{method.value} cannot run a mechanism with "
                f"contacts ({names}): their impacts and lasting modes switch at events located "
                f"inside the steps, which {', '.join(CONTACT_METHODS)} do (method auto "
                "takes nemc.Vern9); an implicit method's Newton iteration does not keep a "
                "held rate exactly 0")
