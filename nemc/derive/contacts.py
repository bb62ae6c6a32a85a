"""Contacts (format v3 `contacts`; decision 0041) as the derivation sees them today: read and
checked by the front end (nemc/front/contacts.py), their dynamics (the impacts, the lasting
constraint and its release) not built yet, so a build of a mechanism with contacts is refused
at the first contact's FILE:LINE rather than run as if the contacts were not there.
"""

from __future__ import annotations

from ..errors import InputError, Problem
from ..front import mechanism as m


def refuse_contacts(mech: m.Mechanism, what: str) -> None:
    """Raise InputError at the first contact's line when MECH has contacts: WHAT (its
    equations of motion, its regressor) would leave them out."""
    if not mech.contacts:
        return
    where = mech.contacts[0].location
    names = ", ".join(contact.name for contact in mech.contacts)
    raise InputError([Problem(where.file, where.line, "contacts", (
        f"contacts ({names}) are read and checked, but {what} with contacts are not built "
        "yet (issue 50: the impacts, the lasting constraint and its release); model a "
        "contact by an impact event (simulation.events) or a stiff one-sided spring"))])
