"""The model's C interface: its header (templates/model.h.tmpl), the headers every model
shares (nemc_run.h, nemc_drivers.h), and the cffi cdef, their declarations cut out verbatim.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from ..vocabulary import AUTO_SPECTRUM_MAX_STATES
from ..vocabulary import NEMC_VERSION as __version__
from .resources import comment_text, template

if TYPE_CHECKING:
    from ..derive.equations import Equations


def header(eqs: Equations, prefix: str) -> str:
    """The model's C interface (templates/model.h.tmpl)."""
    mech = eqs.mechanism
    return template("model.h.tmpl").substitute(
        name=mech.name, version=__version__, source=comment_text(mech.source),
        source_hash=mech.source_hash, prefix=prefix, n_coord=eqs.n, n_state=2 * eqs.n,
        n_param=len(eqs.parameters), n_output=len(eqs.outputs), n_drive=len(eqs.drives),
        n_lambda=len(eqs.multipliers),
        n_event=len(eqs.events), n_input=len(eqs.inputs.names),
        n_friction=eqs.friction.count if eqs.friction else 0,
        friction_names=comment_text(", ".join(eqs.friction.names if eqs.friction else ())),
        input_names=comment_text(", ".join(eqs.inputs.names)),
        event_names=comment_text(", ".join(event.name for event in eqs.events)),
        parameter_names=comment_text(", ".join(s.name for s in eqs.parameters)),
        state_names=comment_text(", ".join(mech.state_names)),
        equation_names=comment_text(", ".join(equation_labels(eqs))),
        spectrum_max_states=AUTO_SPECTRUM_MAX_STATES,
    )


def equation_labels(eqs: Equations) -> list[str]:
    """Each constraint equation as `constraint[k]`, for comments and messages."""
    owners = eqs.loops.owners if eqs.loops is not None else ()
    return [f"{name}[{owners[:i].count(name)}]" for i, name in enumerate(owners)]


CDEF = re.compile(r"/\* NEMC_CDEF_BEGIN \*/\n(.*)/\* NEMC_CDEF_END \*/", re.DOTALL)


def cdef(*header_texts: str) -> str:
    """The cffi declarations: the headers' texts between their NEMC_CDEF markers, verbatim,
    in order."""
    return "".join(CDEF.search(text).group(1)  # type: ignore[union-attr]
                   for text in header_texts)


def shared_headers() -> tuple[tuple[str, str], ...]:
    """The headers every model's package holds, the same in each: nemc_run.h, the C interface
    all models share (its cdef comes first), and nemc_drivers.h, what <name>.c and
    nemc_drivers.c share."""
    return (("nemc_run.h", template("nemc_run.h.tmpl").substitute(version=__version__)),
            ("nemc_drivers.h", template("drivers.h.tmpl").substitute(version=__version__)))
