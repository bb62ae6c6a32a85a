"""What the build of contacts (format v3 `contacts`; decision 0041) does not take yet, refused
at the contact's FILE:LINE rather than run wrong: the inverse-dynamics regressor of a mechanism
with contacts (their forces are not known from a motion alone). Contacts together with
`friction` items are built (issue 50; decision 0041's amendment).
"""

from __future__ import annotations

from ..errors import InputError, Problem
from ..front import mechanism as m


def refuse_contacts(mech: m.Mechanism, what: str | None = None) -> None:
    """Raise InputError at the first contact's line where WHAT (the regressor) is asked of a
    mechanism with contacts; without WHAT nothing is refused."""
    if not mech.contacts or what is None:
        return
    where = mech.contacts[0].location
    why = f"{what} of a mechanism with contacts is not available: their forces are not " \
          "known from the motion alone"
    raise InputError([Problem(where.file, where.line, where.key, why)])
