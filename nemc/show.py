"""`nemc show`: the derived equations of motion, symbolically."""

from __future__ import annotations

import sympy

from .derive import derive
from .model import Mechanism

EXPLICIT_MAX_COORDINATES = 2  # solving M qdd = f symbolically blows up beyond a few links


def show(mech: Mechanism, latex: bool = False) -> str:
    eqs = derive(mech)
    render = sympy.latex if latex else sympy.pretty
    parts = [
        f"{mech.name}: M(q) qdd = f(t, q, dq)",
        f"coordinates: {', '.join(mech.coordinates)}",
        "mass matrix M:",
        render(sympy.simplify(eqs.mass_matrix)),
        "forcing f:",
        render(sympy.simplify(eqs.forcing)),
    ]
    if eqs.n <= EXPLICIT_MAX_COORDINATES:
        qdd = sympy.simplify(eqs.mass_matrix.LUsolve(eqs.forcing))
        parts += ["explicit accelerations qdd = M^-1 f:", render(qdd)]
    for name, expr in eqs.outputs:
        parts.append(f"{name} = {render(sympy.simplify(expr))}")
    return "\n\n".join(parts)
