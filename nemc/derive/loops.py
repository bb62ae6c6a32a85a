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
    starts: tuple[tuple[int, sympy.Symbol], ...] = ()  # (equation, its offset): g(q) - offset,
    #                          the offset a runtime parameter set to g at the run's start

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
    starts: list[tuple[int, sympy.Symbol]] = []
    for constraint in mech.constraints:
        found = constraint.equations(kin)
        if constraint.as_at_start:  # g(q) - g(q at the start): the offset a runtime parameter
            offsets = [start_offset(constraint.name, k) for k in range(len(found))]
            starts += [(len(values) + k, offset) for k, offset in enumerate(offsets)]
            found = [g - offset for g, offset in zip(found, offsets)]
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
        starts=tuple(starts),
        values=tuple(runtime(v) for v in values),
        jacobian=tuple(tuple(runtime(jacobian[k, i]) for i in range(n))
                       for k in range(len(values))),
        rate=tuple(runtime(v) for v in rate),
        bias=tuple(runtime(v) for v in bias),
    )


def start_offset(constraint: str, equation: int) -> sympy.Symbol:
    """The offset of a constraint's equation that holds "as at the start": a runtime parameter
    (its name holds spaces: no name from the file equals it)."""
    return sympy.Symbol(f"constraint {constraint} start {equation}", real=True)
