"""The scene's outputs, derived only when the YAML asks for them.

Joint reactions come from the Newton-Euler equations of the child's subtree: the force of
the parent on the child is the sum of m a_C over the subtree minus the external forces on it;
the constraint couple (prismatic and weld joints) is the same balance of moments about the
joint point. Energy, point kinematics, accelerations and user expressions follow the spec's
names and order.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import sympy

from ..front import mechanism as m

if TYPE_CHECKING:
    from ..kinds.joints import Joint
from ..kinds.spatial import cross_z, rotation, vec
from .kinematics import BalanceLoads, Kinematics, applied_loads, prescribed_motion

Named = list[tuple[str, sympy.Expr]]


def subtree(mech: m.Mechanism, root: str) -> set[str]:
    bodies, grew = {root}, True
    while grew:
        children = {j.child for j in mech.joints if j.parent in bodies}
        grew = not children <= bodies
        bodies |= children
    return bodies


def joint_reaction(mech: m.Mechanism, kin: Kinematics, joint: Joint, loads: BalanceLoads,
                   drive: sympy.Expr | None) -> Named:
    """The force of the parent on the child (the drive of a driven joint left out): the
    Newton-Euler balance of the child's subtree under LOADS (gravity, the YAML's loads, the loop
    constraints' reactions). A tension across the joint itself (a joint spring) acts through
    it: the load's, not the reaction's."""
    inside = subtree(mech, joint.child)
    point = kin.position(joint.child, (0, 0))
    force, moment = sympy.zeros(2, 1), sympy.S.Zero
    for body in (b for b in mech.bodies if b.name in inside):
        r_c = kin.position(body.name, body.com)
        a_c = kin.rate(kin.rate(r_c))
        force += body.mass * a_c
        moment += body.inertia * kin.rate(kin.rate(kin.angle(body.name)))
        moment += cross_z(r_c - point, body.mass * a_c)
    for load in (f for f in loads.forces if f.body in inside):
        force -= load.force
        moment -= cross_z(kin.position(load.body, load.xy) - point, load.force)
    moment -= sum((tq for body, tq in loads.couples if body in inside), sympy.S.Zero)
    for across in loads.tensions:
        through = (joint.spring_force_on_child(kin.angle(joint.parent), across.tension)
                   if across.joint.name == joint.name else None)
        if through is not None:
            force -= vec(through)
    if drive is not None:  # a drive along the joint's motion is the drive's, not a reaction
        along = joint.spring_force_on_child(kin.angle(joint.parent), drive)
        if along is not None:
            force -= vec(along)
    body_frame = rotation(kin.angle(joint.child)).T * force
    named = [(f"{joint.name}.Fx", force[0]), (f"{joint.name}.Fy", force[1])]
    named += [(f"{joint.name}.Fn", body_frame[0]), (f"{joint.name}.Ft", body_frame[1])]
    if joint.reaction_couple:
        named.append((f"{joint.name}.M", moment))
    return named


def energy(mech: m.Mechanism, kin: Kinematics) -> Named:
    kinetic, potential = sympy.S.Zero, sympy.S.Zero
    g = vec(mech.gravity)
    for body in mech.bodies:
        r_c = kin.position(body.name, body.com)
        v_c, omega = kin.velocity(body.name, body.com), kin.rate(kin.angle(body.name))
        kinetic += body.mass * v_c.dot(v_c) / 2 + body.inertia * omega**2 / 2
        potential -= body.mass * g.dot(r_c)
    for load in mech.loads:
        stored = load.potential(kin)
        if stored is not None:
            potential += stored
    return [
        ("energy.kinetic", kinetic),
        ("energy.potential", potential),
        ("energy.total", kinetic + potential),
    ]


def point_motion(kin: Kinematics, point: m.PointRef) -> Named:
    r = kin.position(point.body, point.xy)
    v = kin.velocity(point.body, point.xy)
    return [
        (f"{point.label}.x", r[0]),
        (f"{point.label}.y", r[1]),
        (f"{point.label}.vx", v[0]),
        (f"{point.label}.vy", v[1]),
    ]


def constraint_loads(mech: m.Mechanism, kin: Kinematics,
                     multipliers: dict[str, list[sympy.Expr]], loads: BalanceLoads) -> None:
    """Every loop constraint's reaction as loads into LOADS, as the constraint puts them
    (Constraint.act)."""
    for constraint in mech.constraints:
        constraint.act(kin, loads, multipliers[constraint.name])


def driven_coordinates(mech: m.Mechanism) -> Named:
    """Each driven coordinate and its rate, named as a state entry would be (q1, dot(q1)):
    their prescribed motion, known functions of t."""
    named: Named = []
    for joint in mech.driven:
        value, rate, _ = prescribed_motion(joint)
        q = joint.coordinates[0]
        named += [(q, value), (f"dot({q})", rate)]
    return named


def derive_outputs(mech: m.Mechanism, kin: Kinematics, drives: dict[str, sympy.Expr],
                   multipliers: dict[str, list[sympy.Expr]]) -> Named:
    """Every requested output, in the spec's group order; nothing that was not requested,
    but the driven coordinates and their rates, which lead (the table's, CSV's and figures'
    columns beside the state's). drives: the symbol of each driven joint's drive;
    multipliers: each constraint's."""
    wanted = mech.outputs
    named: Named = driven_coordinates(mech)
    loads = applied_loads(mech, kin)
    constraint_loads(mech, kin, multipliers, loads)
    constraints = {c.name: c for c in mech.constraints}
    for name in wanted.reactions:
        if name in constraints:
            named += [(f"{name}.{suffix}", expr) for suffix, expr in
                      constraints[name].reaction(kin, multipliers[name])]
        else:
            named += joint_reaction(mech, kin, mech.joint(name), loads, drives.get(name))
    named += [(f"{name}.drive", drives[name]) for name in wanted.drives]
    if wanted.energy:
        named += energy(mech, kin)
    for point in wanted.points:
        named += point_motion(kin, point)
    if wanted.accelerations:
        named += [(f"ddot({q})", m.accel_symbol(q)) for q in mech.coordinates]
    named += list(wanted.expressions)
    for name, index in mech.load_names:  # named loads, last: what each reports
        named += [(name + suffix, value) for suffix, value in
                  mech.loads[index].reported(kin, kin.rate)]
    return named

