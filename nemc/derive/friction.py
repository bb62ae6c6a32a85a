"""Coulomb friction's equations (format v3 `friction`): what the generated C needs to solve
the friction forces with the accelerations at every state (templates/friction.c.tmpl).

Each item's force F is a runtime unknown (nemc/kinds/friction.py's friction_symbol) acting
across its joint in the dynamics program. Here: per item, the coordinate whose rate is its
sliding speed, and its terms mu, mu_static and the normal force's two components, in the
coordinates, rates, accelerations (the reaction's Newton-Euler balance) and parameters. The
state holds the mode: a stuck joint's rate is exactly 0 (decision 0039), so the outputs
NAME.stuck and NAME.friction and the switching events follow from the state alone.

Friction along a slot or prismatic constraint (nemc/kinds/guide_friction.py) is an item after
the joints' (law GUIDE): its terms mu N, mu_static N, the sliding speed and its rate, N the
constraint's normal multiplier; the state says its mode only within GUIDE_TOUCH (its speed is
not a coordinate's rate, which a stuck joint keeps at exactly 0).

Contacts (format v3 `contacts`; nemc/kinds/contact.py, decision 0041) are items too, after the
friction items: each one's normal force an unknown, its terms restitution, gap, normal speed
and normal acceleration, its outputs NAME.Fn, NAME.Ft, NAME.active and its event NAME.contact.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import sympy

from ..front import mechanism as m
from ..kinds.friction import Friction
from ..kinds.guide_friction import GuideFriction
from .kinematics import Kinematics, applied_loads
from .outputs import constraint_loads, joint_reaction

TERMS = 4  # per item: mu, mu_static, the normal force's x and y (magnitude: their norm); per
#            contact: restitution, gap, normal speed, normal acceleration (nemc/kinds/contact.py)
COULOMB, CONTACT, CONTACT_TANGENT, GUIDE = 0, 1, 2, 3  # an item's law: friction across a
#   joint, a contact's normal force, its friction (`mu`), friction along a constraint's guide
GUIDE_TOUCH = 1e-9  # outside a run, a guide whose sliding speed is this small is stuck (C's
#                     CONTACT_TOUCH)


@dataclass(frozen=True)
class FrictionEquations:
    """The friction items' unknowns and terms, in the `friction` list's order."""

    names: tuple[str, ...]  # each item's joint (a contact: its name)
    forces: tuple[sympy.Symbol, ...]  # its friction force's symbol (FRICTION(k) in C)
    coordinates: tuple[int, ...]  # the index of its joint's coordinate (its rate: the speed)
    terms: tuple[sympy.Expr, ...]  # TERMS per item, in runtime symbols
    laws: tuple[int, ...] = ()  # each item's law (COULOMB, CONTACT): the friction items first

    @property
    def rates(self) -> tuple[int, ...]:
        """The coordinates whose rates the friction items hold (not the contacts')."""
        return tuple(c for c, law in zip(self.coordinates, self.laws) if law == COULOMB)

    @property
    def count(self) -> int:
        return len(self.names)


def friction_equations(mech: m.Mechanism, kin: Kinematics,
                       runtime: Callable[[object], sympy.Expr],
                       multipliers: dict[str, list[sympy.Symbol]]) -> FrictionEquations | None:
    """The friction items' equations, or None without any. MULTIPLIERS: each loop
    constraint's (its reaction is a load on the bodies a joint's reaction balances)."""
    items = [item for item in mech.frictions if isinstance(item, Friction)]
    guides = _guides(mech)
    if not items and not guides and not mech.contacts:
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
    laws = [COULOMB] * len(items) + [GUIDE] * len(guides)
    forces = [item.symbol for item in items] + [guide.symbol for guide in guides]
    for guide in guides:
        terms += [runtime(term) for term in guide.terms(kin, kin.rate,
                                                        multipliers[guide.on_constraint])]
        names.append(guide.on_constraint)
    for contact in mech.contacts:
        terms += [runtime(term) for term in contact.terms(kin, kin.rate)]
        forces += contact.symbols
        laws += [CONTACT, CONTACT_TANGENT][:len(contact.symbols)]
        names += [contact.name, f"{contact.name}.tangent"][:len(contact.symbols)]
    return FrictionEquations(names=tuple(names), forces=tuple(forces),
                             coordinates=tuple(coordinates) + (0,) * (len(laws) - len(items)),
                             terms=tuple(terms), laws=tuple(laws))


def _guides(mech: m.Mechanism) -> list[GuideFriction]:
    """The friction items along constraints' guides, in the `friction` list's order."""
    return [item for item in mech.frictions if isinstance(item, GuideFriction)]


def friction_parameters(mech: m.Mechanism) -> tuple[tuple[sympy.Symbol, ...], tuple[float, ...]]:
    """The last runtime parameters, and their defaults: each item's force (0: no friction
    where a call outside friction.c.tmpl's solver reads it), then each item's mode (NaN: read
    from the state; a run sets them at its start and each switch writes its item's)."""
    items = [item for item in mech.frictions if isinstance(item, Friction)]
    guides = _guides(mech)
    forces = tuple(item.symbol for item in items) + tuple(g.symbol for g in guides) + tuple(
        force for contact in mech.contacts for force in contact.symbols)
    modes = tuple(m.symbol(f"mode({item.on_joint})") for item in items) + tuple(
        m.symbol(f"mode({guide.on_constraint})") for guide in guides) + tuple(
        m.symbol(f"mode({force.name})") for contact in mech.contacts
        for force in contact.symbols)
    return forces + modes, (0.0,) * len(forces) + (math.nan,) * len(modes)


def friction_outputs(mech: m.Mechanism, kin: Kinematics) -> list[tuple[str, sympy.Expr]]:
    """Each item's outputs: NAME.friction (the force or torque on the child; along a guide, on
    its sliding body) and NAME.stuck (1 while its joint is stuck, its rate exactly 0; a guide
    while its sliding speed is within GUIDE_TOUCH of 0); a guide's NAME.speed too (its sliding
    speed, which no state entry is: the friction's power is NAME.friction times it)."""
    named: list[tuple[str, sympy.Expr]] = []
    for item in mech.frictions:
        if isinstance(item, Friction):
            name = item.on_joint
            rate = m.rate_symbol(mech.joint(name).coordinates[0])
            stuck = sympy.Piecewise((sympy.S.One, sympy.Eq(rate, 0)), (sympy.S.Zero, True))
            named += [(f"{name}.friction", item.symbol), (f"{name}.stuck", stuck)]
    for guide in _guides(mech):
        speed = guide.sliding_speed(kin, kin.rate)
        stuck = sympy.Piecewise((sympy.S.One, sympy.Abs(speed) <= GUIDE_TOUCH),
                                (sympy.S.Zero, True))
        named += [(f"{guide.on_constraint}.friction", guide.symbol),
                  (f"{guide.on_constraint}.stuck", stuck),
                  (f"{guide.on_constraint}.speed", speed)]
    for contact in mech.contacts:  # NAME.active: 1 while it lasts (its normal force > 0)
        active = sympy.Piecewise((sympy.S.One, contact.symbol > 0), (sympy.S.Zero, True))
        forces = (*contact.symbols, sympy.S.Zero)
        named += [(f"{contact.name}.Fn", forces[0]), (f"{contact.name}.Ft", forces[1]),
                  (f"{contact.name}.active", active)]
    return named


def friction_events(mech: m.Mechanism) -> tuple[m.Event, ...]:
    """Each item's switching event NAME.stick_slip: its value and law are friction.c.tmpl's
    (the speed while slipping, the holding margin while stuck), so `when` here is a stand-in."""
    return tuple(m.Event(name=f"{item.on_joint}.stick_slip", when=sympy.S.Zero,
                         direction="both", action="switch", loc=item.location)
                 for item in mech.frictions if isinstance(item, Friction)) + tuple(
        m.Event(name=f"{guide.on_constraint}.stick_slip", when=sympy.S.Zero, direction="both",
                action="switch", loc=guide.location) for guide in _guides(mech)) + tuple(
        m.Event(name=f"{contact.name}.{which}", when=sympy.S.Zero, direction=direction,
                action="switch", loc=contact.location) for contact in mech.contacts
        for which, direction in (("contact", "falling"), ("stick_slip", "both"))[
            :len(contact.symbols)])


def friction_checks(mech: m.Mechanism, runtime: Callable[[object], sympy.Expr]
                    ) -> list[tuple[str, sympy.Expr, bool]]:
    """(key path, expression, strict) of what each item needs of the run's parameters."""
    found = []
    for k, item in enumerate(mech.frictions):
        if isinstance(item, (Friction, GuideFriction)):
            found += [(f"friction.{k}.{key}", runtime(expr), strict)
                      for key, expr, strict in item.checks()]
    for contact in mech.contacts:
        found += [(f"{bound.prefix}contacts.{contact.name}.{bound.key}", runtime(bound.expression),
                   bound.strict) for bound in contact.bounds()]
    return found


def friction_refusal(mech: m.Mechanism, what: str) -> str | None:
    """Why WHAT (a part of the build that differentiates or expands the right-hand side) is
    not available with Coulomb friction, at the first item's FILE:LINE; None without any."""
    if not mech.frictions and not mech.contacts:
        return None
    where = (mech.frictions or mech.contacts)[0].location
    which = "Coulomb friction" if mech.frictions else "contacts"
    return (f"{where.file}:{where.line}: {where.key}: {what} of a mechanism with {which} "
            "are not available: its right-hand side switches between modes at events (stuck, "
            "slipping either way; a contact open or lasting) and is not differentiable across "
            "them")
