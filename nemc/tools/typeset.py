"""How a coordinate's name is typeset: q1 -> q_{1}, dot(q1) -> \\dot{q}_{1}, theta -> \\theta.

One home for the LaTeX of the state's names: `nemc show --latex` prints the equations with it and
the figures' axis labels use it (matplotlib's mathtext reads the same LaTeX). No sympy here.
"""

from __future__ import annotations

import re

GREEK = frozenset({
    "alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa",
    "lambda", "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi",
    "omega", "Gamma", "Delta", "Theta", "Lambda", "Xi", "Pi", "Sigma", "Upsilon", "Phi", "Psi",
    "Omega",
})
DERIVATIVE = re.compile(r"(d{1,2})ot\((\w+)\)")


def split_name(name: str) -> tuple[str, str]:
    """(head, subscript): q1 -> (q, 1), theta_2 -> (theta, 2), x_tip -> (x, tip), th -> (th, "")."""
    match = re.fullmatch(r"([A-Za-z]+?)_?(\d+)", name) or re.fullmatch(r"([A-Za-z]+)_(\w+)", name)
    return (match.group(1), match.group(2)) if match else (name, "")


def head_latex(head: str) -> str:
    if head in GREEK:
        return "\\" + head
    return head if len(head) == 1 else f"\\mathrm{{{head}}}"


def latex_name(name: str) -> str:
    """The LaTeX of a coordinate, dot(q) or ddot(q): \\dot{q}_{1}, \\ddot{\\theta}."""
    match = DERIVATIVE.fullmatch(name)
    accent = {"d": "\\dot", "dd": "\\ddot"}[match.group(1)] if match else ""
    head, sub = split_name(match.group(2) if match else name)
    text = f"{accent}{{{head_latex(head)}}}" if accent else head_latex(head)
    return f"{text}_{{{sub}}}" if sub else text


def math_label(name: str) -> str:
    """The name for a matplotlib label: $\\dot{q}_{1}$."""
    return f"${latex_name(name)}$"
