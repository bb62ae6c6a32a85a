"""Closed loops: the constraint equations Phi(q, t) = 0 of a mechanism's loop-closing
constraints, and what the right-hand side and its projection need of them.

Each constraint kind (nemc/constraints/) gives its equations from the two bodies' frames (the
kinematics of the tree, driven coordinates replaced by their motions); here they are
differentiated: Phi_q (m x n, the undriven coordinates), Phi_t, and the velocity-product bias
G = d/dt (Phi_q qdot + Phi_t) at qdd = 0, so that the accelerations satisfy
Phi_q qdd + G = 0. The equations are those of a planar loop (a few bodies each): their symbolic
size stays small.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import sympy

from ..front import mechanism as m
from .kinematics import Kinematics


@dataclass(frozen=True)
class LoopEquations:
    """The constraint equations and their derivatives, in runtime symbols."""

    owners: tuple[str, ...]  # the constraint each equation belongs to
    values: tuple[sympy.Expr, ...]  # Phi
    jacobian: tuple[tuple[sympy.Expr, ...], ...]  # Phi_q, m x n
    rate: tuple[sympy.Expr, ...]  # Phi_t
    bias: tuple[sympy.Expr, ...]  # G = d/dt (Phi_q qdot + Phi_t) at qdd = 0

    @property
    def count(self) -> int:
        return len(self.values)

    @property
    def results(self) -> tuple[sympy.Expr, ...]:
        """What the dynamics program computes of them (DynamicsLayout's order): G, Phi, Phi_q
        row by row, Phi_t."""
        return (*self.bias, *self.values, *(v for row in self.jacobian for v in row),
                *self.rate)


def loop_equations(mech: m.Mechanism, kin: Kinematics,
                   runtime: Callable[[object], sympy.Expr]) -> LoopEquations:
    owners: list[str] = []
    values: list[sympy.Expr] = []
    for constraint in mech.constraints:
        found = constraint.equations(kin.frame(constraint.a.body), kin.frame(constraint.b.body))
        owners += [constraint.name] * len(found)
        values += found
    phi = sympy.Matrix(values)
    jacobian = phi.jacobian(kin.q)
    rate = phi.diff(m.TIME)
    velocity = jacobian * sympy.Matrix(kin.u) + rate
    at_rest = {a: sympy.S.Zero for a in kin.qdd}
    bias = sympy.Matrix([kin.rate(v).xreplace(at_rest) for v in velocity])
    n = len(kin.q)
    return LoopEquations(
        owners=tuple(owners),
        values=tuple(runtime(v) for v in values),
        jacobian=tuple(tuple(runtime(jacobian[k, i]) for i in range(n))
                       for k in range(len(values))),
        rate=tuple(runtime(v) for v in rate),
        bias=tuple(runtime(v) for v in bias),
    )
