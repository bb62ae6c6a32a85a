"""Closed loops: the constraint equations Phi(q, t) = 0 of a mechanism's loop-closing
constraints, and what the right-hand side and its projection need of them.

Each constraint kind (nemc/kinds/constraints/) gives its equations from the bodies' frames
(the kinematics of the tree, driven coordinates replaced by their motions); here they are
differentiated: Phi_q (m x n, the undriven coordinates), Phi_t, and the velocity-product bias
G = d/dt (Phi_q qdot + Phi_t) at qdd = 0, so that the accelerations satisfy
Phi_q qdd + G = 0. An equation on the velocities (nonholonomic, A(q, t) qdot + a(q, t) = 0)
takes the same place with Phi = 0, Phi_q = A and Phi_t = a: the projection then keeps the
positions off its direction and the rates on it, and everything else is the same. The
equations are those of a planar loop (a few bodies each): their symbolic size stays small.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import sympy

from ..front import mechanism as m
from .kinematics import Kinematics, time_derivative


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
    on_velocities: tuple[int, ...] = ()  # equations on the velocities: Phi 0, Phi_q A(q, t)

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
    values: list[sympy.Expr] = []  # Phi: 0 for an equation on the velocities
    velocities: list[sympy.Expr | None] = []  # its Phi_q dq + Phi_t, for those
    starts: list[tuple[int, sympy.Symbol]] = []
    for constraint in mech.constraints:
        found = constraint.equations(kin)
        on_velocities, held = constraint.on_velocities(), constraint.held_as_at_start()
        for k, g in enumerate(found):
            if k in held:  # g(q) - g(q at the start): the offset a runtime parameter
                starts.append((len(values), start_offset(constraint.name, k)))
                g = g - starts[-1][1]
            owners.append(constraint.name)
            values.append(sympy.S.Zero if k in on_velocities else g)
            velocities.append(g if k in on_velocities else None)
    u = sympy.Matrix(kin.u)
    rows, rates = [], []
    for value, velocity in zip(values, velocities):
        if velocity is None:  # Phi(q, t): its gradient and time derivative
            rows.append([sympy.diff(value, q) for q in kin.q])
            rates.append(time_derivative(value))
        else:  # A(q, t) dq + a(q, t): A's row and a
            rows.append([sympy.diff(velocity, v) for v in kin.u])
            rates.append(velocity.xreplace({v: sympy.S.Zero for v in kin.u}))
    jacobian = sympy.Matrix(rows) if rows else sympy.zeros(0, len(kin.q))
    velocity = jacobian * u + sympy.Matrix(rates)
    at_rest = {a: sympy.S.Zero for a in kin.qdd}
    bias = [kin.rate(v).xreplace(at_rest) for v in velocity]
    n = len(kin.q)
    return LoopEquations(
        owners=tuple(owners),
        starts=tuple(starts),
        on_velocities=tuple(k for k, v in enumerate(velocities) if v is not None),
        values=tuple(runtime(v) for v in values),
        jacobian=tuple(tuple(runtime(jacobian[k, i]) for i in range(n))
                       for k in range(len(values))),
        rate=tuple(runtime(v) for v in rates),
        bias=tuple(runtime(v) for v in bias),
    )


def start_offset(constraint: str, equation: int) -> sympy.Symbol:
    """The offset of a constraint's equation that holds "as at the start": a runtime parameter
    (its name holds spaces: no name from the file equals it)."""
    return sympy.Symbol(f"constraint {constraint} start {equation}", real=True)
