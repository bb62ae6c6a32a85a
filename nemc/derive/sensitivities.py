"""Forward sensitivities along a run: the programs of the variational equations of a tree.

For a parameter (or an input's constant term, or none: an initial value) direction e and the
state's sensitivity s = d y / d (direction), the variational equations are

    ds/dt = J_y(t, y, p) s + J_p(t, y, p) e,

which is the forward-mode derivative of the right-hand side along the seeds (y -> s, p -> e):
the same tangent as the linearization's (linearization.py), with the parameters seeded as well
as the state. The generated C (templates/sensitivities.c.tmpl) runs the accelerations' program
once, then forms their Jacobian [J_y | J_p] once from this tangent (read backwards: reverse
accumulation) and makes each column a small dense product (a long program's tangent runs
forward once per column, seeded with its own s and e). The outputs' tangent along the same
seeds gives the outputs' sensitivities by the chain rule (through the accelerations' and drives'
tangents), and the initial state's partial derivatives by the parameters give the columns'
start (a scene's initial values may be expressions of parameters).

At a scene's event (g(t, y, p) = 0 at its time tau) the columns jump: the event's partial
derivatives g_y, g_p, g_t and, for an impact law y+ = G(t, y-, p), G_y, G_p, G_t are derived
here (`event_partials`), exactly, and templates/event_sensitivities.c.tmpl applies

    d tau = -(g_y s + g_p e) / (g_t + g_y f-),
    s+ = G_y s + G_p e + (G_t + G_y f- - f+) d tau

(f-, f+ the right-hand side before and after the impact).

A closed loop's: the same tangent of its program's every result (its pieces: the tree's
accelerations, the unit passes, G, Phi, Phi_q, Phi_t), along the state's and the parameters'
seeds; templates/loop_sensitivities.c.tmpl solves the index-1 equations' derivative from them
(decision 0035's amendment); its outputs' tangent reads the multipliers' tangents as well."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import sympy

from .linearization import Linearization, linearization, state_seeds
from .program import Program


@dataclass(frozen=True)
class Sensitivities:
    """The programs of a tree's variational equations, in runtime symbols."""

    tangents: Linearization  # the accelerations', drives' and outputs' tangents along seeds
    parameter_seeds: Mapping[sympy.Symbol, sympy.Symbol]  # runtime parameter -> its seed
    initial: tuple[sympy.Expr, ...]  # d y0[i] / d p[k], row-major (state entry, parameter)
    events: tuple[EventPartials, ...] = ()  # each scene event's partial derivatives, in order

    @property
    def dynamics(self) -> Program:
        return self.tangents.dynamics

    @property
    def state_seeds(self) -> Mapping[sympy.Symbol, sympy.Symbol]:
        return {symbol: seed for symbol, seed in self.tangents.seeds.items()
                if symbol not in self.parameter_seeds}


@dataclass(frozen=True)
class EventPartials:
    """One event's partial derivatives in runtime symbols: of its function g (``when``: g_y,
    then g_p, then g_t) and, for an impact law, of the new state G (G_y row-major, then G_p
    row-major, then G_t: an entry the law does not set keeps its value, G_i = y_i)."""

    when: tuple[sympy.Expr, ...]
    law: tuple[sympy.Expr, ...] = ()


def event_partials(when: sympy.Expr, law: Mapping[sympy.Symbol, sympy.Expr],
                   state: tuple[sympy.Symbol, ...], parameters: tuple[sympy.Symbol, ...],
                   time: sympy.Symbol) -> EventPartials:
    """The partial derivatives of an event's function WHEN and of its impact LAW (state entry
    -> new value; empty for a located or stopping event) by the STATE, the PARAMETERS and
    TIME."""
    by = (*state, *parameters)
    g = tuple(sympy.diff(when, x) for x in by) + (sympy.diff(when, time),)
    if not law:
        return EventPartials(g)
    new = [law.get(x, x) for x in state]
    rows = [sympy.diff(value, x) for value in new for x in state]
    rows += [sympy.diff(value, x) for value in new for x in parameters]
    rows += [sympy.diff(value, time) for value in new]
    return EventPartials(g, tuple(rows))


def parameter_seeds(parameters: tuple[sympy.Symbol, ...]) -> dict[sympy.Symbol, sympy.Symbol]:
    """The tangent of each runtime parameter (printed SEED_P(k))."""
    return {p: sympy.Dummy(f"seed_p_{k}", real=True) for k, p in enumerate(parameters)}


def sensitivities(dynamics: Program, state: tuple[sympy.Symbol, ...],
                  parameters: tuple[sympy.Symbol, ...], results: tuple[sympy.Symbol, ...],
                  outputs: tuple[sympy.Expr, ...],
                  initial_state: tuple[sympy.Expr, ...]) -> Sensitivities:
    """DYNAMICS (a tree's accelerations, then its drives: RESULTS name them) and OUTPUTS
    differentiated along the STATE's and the PARAMETERS' seeds; the INITIAL_STATE's
    derivatives by the parameters."""
    by_parameter = parameter_seeds(parameters)
    tangents = linearization(dynamics, {**state_seeds(state), **by_parameter}, results,
                             outputs)
    initial = tuple(sympy.diff(sympy.sympify(value), p) for value in initial_state
                    for p in parameters)
    return Sensitivities(tangents, by_parameter, initial)
