"""What the build of contacts (format v3 `contacts`; decision 0041) does not take yet, refused
at the contact's FILE:LINE rather than run wrong: contacts together with `friction` items,
and the inverse-dynamics regressor of a mechanism with contacts (their forces are not known
from a motion alone).
"""

from __future__ import annotations

from ..errors import InputError, Problem
from ..front import mechanism as m

NOT_YET = "not built yet (issue 50; decision 0041)"


def refuse_contacts(mech: m.Mechanism, what: str | None = None) -> None:
    """Raise InputError at the contact's line where MECH's contacts need what is not built;
    WHAT (the regressor) refuses any contact."""
    if not mech.contacts:
        return
    first = mech.contacts[0]
    why, where = None, first.location
    if what is not None:
        why = f"{what} of a mechanism with contacts is not available: their forces are not " \
              "known from the motion alone"
    elif mech.frictions:
        why = f"contacts together with `friction` items are {NOT_YET}"
    if why is not None:
        raise InputError([Problem(where.file, where.line, where.key, why)])
