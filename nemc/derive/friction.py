"""Coulomb friction's equations (format v3 `friction`): what the generated C needs to solve
the friction forces with the accelerations at every state (templates/friction.c.tmpl).

Each item's force F is a runtime unknown (nemc/kinds/friction.py's friction_symbol) acting
across its joint in the dynamics program. Here: per item, the coordinate whose rate is its
sliding speed, and its terms mu, mu_static and the normal force's two components, in the
coordinates, rates, accelerations (the reaction's Newton-Euler balance) and parameters. The
state holds the mode: a stuck joint's rate is exactly 0 (decision 0039), so the outputs
NAME.stuck and NAME.friction and the switching events follow from the state alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import sympy

from ..front import mechanism as m
from ..kinds.friction import Friction
from .kinematics import Kinematics, applied_loads
from .outputs import constraint_loads, joint_reaction

TERMS = 4  # per item: mu, mu_static, the normal force's x and y (magnitude: their norm)


@dataclass(frozen=True)
class FrictionEquations:
    """The friction items' unknowns and terms, in the `friction` list's order."""

    names: tuple[str, ...]  # each item's joint
    forces: tuple[sympy.Symbol, ...]  # its friction force's symbol (FRICTION(k) in C)
    coordinates: tuple[int, ...]  # the index of its joint's coordinate (its rate: the speed)
    terms: tuple[sympy.Expr, ...]  # TERMS per item, in runtime symbols

    @property
    def count(self) -> int:
        return len(self.names)


def friction_equations(mech: m.Mechanism, kin: Kinematics,
                       runtime: Callable[[object], sympy.Expr],
                       multipliers: dict[str, list[sympy.Symbol]]) -> FrictionEquations | None:
    """The friction items' equations, or None without any. MULTIPLIERS: each loop
    constraint's (its reaction is a load on the bodies a joint's reaction balances)."""
    items = [item for item in mech.frictions if isinstance(item, Friction)]
    if not items:
        return None
    loads = applied_loads(mech, kin)
    constraint_loads(mech, kin, multipliers, loads)
    coordinates, terms = [], []
    names = [item.on_joint for item in items]
    for item, name in zip(items, names):
        joint = mech.joint(name)
        reaction = joint_reaction(mech, kin, joint, loads, None)
        force = (reaction[0][1], reaction[1][1])  # NAME.Fx, NAME.Fy: ground axes
        normal = joint.friction_normal(kin.angle(joint.parent), force)
        assert normal is not None  # the front end refused the others
        terms += [runtime(term) for term in item.terms(normal, joint.friction_lever)]
        coordinates.append(mech.coordinates.index(joint.coordinates[0]))
    return FrictionEquations(names=tuple(names),
                             forces=tuple(item.symbol for item in items),
                             coordinates=tuple(coordinates), terms=tuple(terms))


def friction_parameters(mech: m.Mechanism) -> tuple[tuple[sympy.Symbol, ...], tuple[float, ...]]:
    """The last runtime parameters, and their defaults: each item's force (0: no friction
    where a call outside friction.c.tmpl's solver reads it), then each item's mode (NaN: read
    from the state; a run sets them at its start and each switch writes its item's)."""
    items = [item for item in mech.frictions if isinstance(item, Friction)]
    forces = tuple(item.symbol for item in items)
    modes = tuple(m.symbol(f"mode({item.on_joint})") for item in items)
    return forces + modes, (0.0,) * len(forces) + (math.nan,) * len(modes)


def friction_outputs(mech: m.Mechanism) -> list[tuple[str, sympy.Expr]]:
    """Each item's outputs: NAME.friction (the force or torque on the child) and NAME.stuck
    (1 while its joint is stuck, its rate exactly 0)."""
    named: list[tuple[str, sympy.Expr]] = []
    for item in mech.frictions:
        if isinstance(item, Friction):
            name = item.on_joint
            rate = m.rate_symbol(mech.joint(name).coordinates[0])
            stuck = sympy.Piecewise((sympy.S.One, sympy.Eq(rate, 0)), (sympy.S.Zero, True))
            named += [(f"{name}.friction", item.symbol), (f"{name}.stuck", stuck)]
    return named


def friction_events(mech: m.Mechanism) -> tuple[m.Event, ...]:
    """Each item's switching event NAME.stick_slip: its value and law are friction.c.tmpl's
    (the speed while slipping, the holding margin while stuck), so `when` here is a stand-in."""
    return tuple(m.Event(name=f"{item.on_joint}.stick_slip", when=sympy.S.Zero,
                         direction="both", action="switch", loc=item.location)
                 for item in mech.frictions if isinstance(item, Friction))


def friction_checks(mech: m.Mechanism, runtime: Callable[[object], sympy.Expr]
                    ) -> list[tuple[str, sympy.Expr, bool]]:
    """(key path, expression, strict) of what each item needs of the run's parameters."""
    found = []
    for k, item in enumerate(mech.frictions):
        if isinstance(item, Friction):
            found += [(f"friction.{k}.{key}", runtime(expr), strict)
                      for key, expr, strict in item.checks()]
    return found


def friction_refusal(mech: m.Mechanism, what: str) -> str | None:
    """Why WHAT (a part of the build that differentiates or expands the right-hand side) is
    not available with Coulomb friction, at the first item's FILE:LINE; None without any."""
    if not mech.frictions:
        return None
    where = mech.frictions[0].location
    return (f"{where.file}:{where.line}: {where.key}: {what} of a mechanism with Coulomb "
            "friction are not available: its right-hand side switches between modes at "
            "events (stuck, slipping either way) and is not differentiable across them")
