"""The regressor's numeric code (nemc/derive/regressor.py): its expressions as numpy functions
(sympy's lambdify, common subexpressions once), not C: the regressor is evaluated over a data
set at once, a numpy expression per entry over all the samples (decision 0040).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import sympy

from ..derive.regressor import RegressorEquations
from ..front import mechanism as m

Entries = Callable[..., list]  # (t, q, qd, qdd, p) -> the entries, each a number or an array


@dataclass(frozen=True)
class RegressorCode:
    """What the runtime's regressor (nemc/runtime/regressor.py) evaluates: names and numpy
    functions of (t, q, qd, qdd, p), q, qd, qdd each a sequence over every coordinate."""

    names: tuple[str, ...]  # phi's
    coordinate_names: tuple[str, ...]  # every joint's, driven ones included
    driven: tuple[int, ...]  # the driven coordinates' places
    equations: int  # the closed loops' constraint equations
    columns: Entries  # Y, row by row (coordinates x names)
    loads: Entries  # the loads' generalized forces Q (tau = Y phi - Q)
    constraints: Entries  # Phi_q, row by row (equations x coordinates)
    values: Entries  # phi at p (the other arguments unused)


def regressor_code(eqs: RegressorEquations) -> RegressorCode:
    """EQS as numpy functions."""
    return RegressorCode(
        names=eqs.names, coordinate_names=tuple(q.name for q in eqs.coordinates),
        driven=eqs.driven, equations=len(eqs.constraints),
        columns=numpy_function(eqs, [entry for row in eqs.columns for entry in row]),
        loads=numpy_function(eqs, eqs.loads),
        constraints=numpy_function(eqs, [entry for row in eqs.constraints for entry in row]),
        values=numpy_function(eqs, eqs.values))


def numpy_function(eqs: RegressorEquations, exprs: Sequence[sympy.Expr]) -> Entries:
    """EXPRS as a numpy function of (t, q, qd, qdd, p), each argument but t a sequence."""
    return sympy.lambdify([m.TIME, list(eqs.coordinates), list(eqs.speeds),
                           list(eqs.accelerations), list(eqs.parameters)],
                          list(exprs), modules="numpy", cse=True, dummify=True)
