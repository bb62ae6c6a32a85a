"""`nemc show`: the derived equations of motion, symbolically.

The printed form is the book's M(q) qdd = f(t, q, dq), as derive already derives it
(Equations.mass_forcing), each entry tidied by the linearization nemc.Taylor uses
(mass_form.linearized: products of sines and cosines as sums, sin^2 + cos^2 -> 1) and common
factors pulled out, instead of sympy's simplify (minutes at three coordinates). The explicit
accelerations, for up to two coordinates, are adj(M) f / det(M) tidied the same way.

LaTeX names the state as a textbook does: \\dot{q}_{1}, \\ddot{q}_{1} (nemc.typeset).
"""

from __future__ import annotations

import sympy

from ..derive.equations import Equations, derive
from ..derive.mass_form import linearized
from ..front import mechanism as m
from ..front.mechanism import Mechanism
from .typeset import latex_name

EXPLICIT_MAX_COORDINATES = 2  # adj(M) f / det(M) grows fast past two coordinates


def tidy(expr: sympy.Expr) -> sympy.Expr:
    """The expression as nemc prints it: linearized in sines and cosines, factors pulled out."""
    return sympy.factor_terms(linearized(sympy.sympify(expr)))


def explicit_accelerations(mass: sympy.Matrix, forcing: sympy.Matrix) -> sympy.Matrix:
    """qdd = adj(M) f / det(M), numerator and determinant tidied."""
    determinant = tidy(mass.det(method="berkowitz"))
    numerator = (mass.adjugate() * forcing).applyfunc(tidy)
    return numerator.applyfunc(lambda entry: entry / determinant)


def symbol_names(eqs: Equations) -> dict[sympy.Symbol, str]:
    """LaTeX of the coordinates, their rates and accelerations, and the parameters (beta ->
    \\beta, L1 -> L_{1}, thetaf -> \\mathrm{thetaf}, not a product of five letters)."""
    symbols = (*eqs.coordinates, *eqs.speeds, *eqs.accelerations, *eqs.parameters, m.TIME)
    names = {s: latex_name(s.name) for s in symbols}
    names.update({s: f"\\lambda_{{{k + 1}}}" for k, s in enumerate(eqs.multipliers)})
    names.update({s: f"\\tau_{{\\mathrm{{{joint.name}}}}}"
                  for s, joint in zip(eqs.drives, eqs.mechanism.driven)})
    return names


def sections(eqs: Equations) -> list[tuple[str, sympy.Basic]]:
    """(what, expression) in the printed order: M, f, explicit qdd (a tree's), the loops'
    constraints Phi, the outputs."""
    mass, forcing = eqs.mass_forcing
    parts: list[tuple[str, sympy.Basic]] = [("M", mass.applyfunc(tidy)),
                                            ("f", forcing.applyfunc(tidy))]
    if eqs.n <= EXPLICIT_MAX_COORDINATES and eqs.loops is None:
        parts.append(("qdd", explicit_accelerations(mass, forcing)))
    if eqs.loops is not None:
        parts.append(("Phi", sympy.Matrix(eqs.loops.values).applyfunc(tidy)))
    parts += [(name, tidy(expr)) for name, expr in eqs.outputs]
    return parts


LATEX_LEFT = {"M": "M", "f": "f", "qdd": "\\ddot{q}", "Phi": "\\Phi"}
TEXT_TITLE = {"M": "mass matrix M:", "f": "forcing f:",
              "qdd": "explicit accelerations qdd = M^-1 f:",
              "Phi": "loop constraints Phi(q, t) = 0 (their multipliers lambda: the reactions):"}


def latex_left(what: str) -> str:
    """The left side of a printed LaTeX equation: M, f, \\ddot{q}, or an output's name."""
    if what in LATEX_LEFT:
        return LATEX_LEFT[what]
    if what.startswith("ddot("):
        return latex_name(what)
    return f"\\mathtt{{{what}}}"


def show(mech: Mechanism, latex: bool = False) -> str:
    eqs = derive(mech)
    eqs_names = symbol_names(eqs) if latex else {}
    form = ("M(q) qdd = f(t, q, dq) + Phi_q^T lambda, Phi(q, t) = 0" if eqs.loops is not None
            else "M(q) qdd = f(t, q, dq)")
    header = [f"{mech.name}: {form}", f"coordinates: {', '.join(mech.coordinates)}"]
    if mech.driven:
        header.append("driven: " + ", ".join(f"{j.coordinates[0]} = {j.motion}"
                                             for j in mech.driven))
    lines = []
    for what, expr in sections(eqs):
        if latex:
            lines.append(f"{latex_left(what)} = {sympy.latex(expr, symbol_names=eqs_names)}")
        elif what in TEXT_TITLE:
            lines.append(f"{TEXT_TITLE[what]}\n\n{sympy.pretty(expr)}")
        else:
            lines.append(f"{what} = {sympy.pretty(expr)}")
    if latex:
        header = [f"% {line}" for line in header]
    return "\n\n".join(header + lines)
