"""The inverse dynamics linear in the bodies' inertial parameters: the regressor.

For every body the four standard inertial parameters that enter the equations of motion
linearly, phi_b = (m, m cx, m cy, I_O): the mass, its first moments in the body frame and the
inertia about the body's origin (I_O = I_C + m |c|^2). Every joint coordinate is a coordinate
here, a driven one too (its motion is what the data say), so that

    Y(q, qd, qdd) phi - Q(t, q, qd) = tau + Phi_q^T lambda,

tau the generalized forces the joints' actuators supply (a driven joint's drive), Q the
generalized forces of the YAML's loads and lambda the multipliers of the closed loops' equations
(Phi_q over every coordinate). Per body, by the virtual power of its Newton-Euler balance about
its origin O with gravity as an acceleration of the frame (a = a_O - g):

    F = m a + alpha x (R mc) - omega^2 (R mc),    M_O = I_O alpha + (R mc) x a,

each linear in phi_b. A load coefficient named as linear (a damping, a Coulomb friction's
coefficient written into a load) adds a column: the loads' generalized forces' derivative by it,
refused unless they are linear in it and it is nowhere else in Y.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy

from ..front import mechanism as m
from ..front.values import resolve_values
from ..kinds.spatial import Vec, cross_z, rotation, vec
from .contacts import refuse_contacts
from .inputs import input_law
from .kinematics import BalanceLoads, Kinematics, generalized_forces
from .loops import loop_equations

# the names of a body's inertial parameters, after its name and a dot ("crank.m", ...)
INERTIAL = ("m", "mx", "my", "I")


@dataclass(frozen=True)
class RegressorEquations:
    """Y, the loads' Q and the loops' Phi_q in runtime symbols (module docstring)."""

    coordinates: tuple[sympy.Symbol, ...]  # every joint's, driven ones included, file order
    speeds: tuple[sympy.Symbol, ...]
    accelerations: tuple[sympy.Symbol, ...]
    parameters: tuple[sympy.Symbol, ...]  # the runtime parameter vector p, as the model's
    names: tuple[str, ...]  # phi's: "BODY.m", "BODY.mx", "BODY.my", "BODY.I", then the linear
    values: tuple[sympy.Expr, ...]  # phi in the runtime parameters
    columns: tuple[tuple[sympy.Expr, ...], ...]  # Y, a row per coordinate
    loads: tuple[sympy.Expr, ...]  # Q, without the linear coefficients' parts
    constraints: tuple[tuple[sympy.Expr, ...], ...]  # Phi_q (equations x coordinates)
    driven: tuple[int, ...]  # the driven coordinates' places among the coordinates


class EveryCoordinate(Kinematics):
    """The kinematics with every joint coordinate free: a driven one's motion not put in."""

    def __init__(self, mech: m.Mechanism):
        super().__init__(mech)
        names = tuple(name for joint in mech.joints for name in joint.coordinates)
        self.q = tuple(m.symbol(name) for name in names)
        self.u = tuple(m.rate_symbol(name) for name in names)
        self.qdd = tuple(m.accel_symbol(name) for name in names)
        self.motions = {}


def regressor_equations(mech: m.Mechanism, linear: Sequence[str] = ()) -> RegressorEquations:
    """The regressor of MECH (validated), with a column for each parameter named in LINEAR.
    ValueError: a name that is no runtime parameter, or one that does not enter linearly."""
    refuse_contacts(mech, "the inverse-dynamics regressor")
    values = resolve_values(mech)
    fold = values.substitutions
    inputs = input_law(mech, lambda expr: sympy.sympify(expr).xreplace(fold))
    laws = inputs.substitutions

    def runtime(expr: object) -> sympy.Expr:
        return sympy.sympify(expr).xreplace(fold).xreplace(laws)

    kin = EveryCoordinate(mech)
    columns: list[list[sympy.Expr]] = [[] for _ in kin.q]
    phi: list[sympy.Expr] = []
    gravity = vec(mech.gravity)
    for body in mech.bodies:
        for row, entries in zip(columns, body_columns(kin, body.name, gravity)):
            row.extend(runtime(entry) for entry in entries)
        phi.extend(runtime(value) for value in inertial_values(body))
    sink = BalanceLoads()
    for load in mech.loads:
        load.act(kin, sink)
    loads = [runtime(force) for force in generalized_forces(kin, sink)]
    symbols = (*values.runtime_symbols, *inputs.coefficients)
    loads = with_linear_columns(columns, phi, loads, linear, symbols)
    loops = loop_equations(mech, kin, runtime) if mech.constraints else None
    starts = tuple(offset for _, offset in loops.starts) if loops is not None else ()
    driven = tuple(kin.q.index(m.symbol(joint.coordinates[0])) for joint in mech.driven)
    return RegressorEquations(
        coordinates=kin.q, speeds=kin.u, accelerations=kin.qdd,
        parameters=(*symbols, *starts),
        names=(*(f"{body.name}.{key}" for body in mech.bodies for key in INERTIAL), *linear),
        values=tuple(phi), columns=tuple(tuple(row) for row in columns), loads=tuple(loads),
        constraints=loops.jacobian if loops is not None else (), driven=driven)


def inertial_values(body: m.Body) -> tuple[sympy.Expr, ...]:
    """(m, m cx, m cy, I_O) of BODY: its inertia moved from its mass center to its origin."""
    mass, (cx, cy) = sympy.sympify(body.mass), (sympy.sympify(c) for c in body.com)
    return mass, mass * cx, mass * cy, sympy.sympify(body.inertia) + mass * (cx**2 + cy**2)


def body_columns(kin: Kinematics, body: str, gravity: Vec) -> list[list[sympy.Expr]]:
    """Per coordinate k, the four entries by which (m, m cx, m cy, I_O) of BODY enter its
    generalized inertial force: the virtual power of F and M_O (module docstring)."""
    angle = kin.angle(body)
    omega = kin.rate(angle)
    alpha = kin.rate(omega)
    v_origin = kin.velocity(body, (sympy.S.Zero, sympy.S.Zero))
    a = kin.rate(v_origin) - gravity  # gravity as the frame's acceleration
    axes = [rotation(angle) * vec(axis) for axis in ([1, 0], [0, 1])]
    forces = [alpha * vec([-e[1], e[0]]) - omega**2 * e for e in axes]  # of a unit mc along e
    moments = [cross_z(e, a) for e in axes]
    rows = []
    for jv, jw in zip(kin.partials(v_origin), kin.partials(omega)):
        rows.append([jv.dot(a), *(jv.dot(f) + jw * moment
                                  for f, moment in zip(forces, moments)), jw * alpha])
    return rows


def with_linear_columns(columns: list[list[sympy.Expr]], phi: list[sympy.Expr],
                        loads: list[sympy.Expr], linear: Sequence[str],
                        symbols: Sequence[sympy.Symbol]) -> list[sympy.Expr]:
    """Add to COLUMNS (and PHI) a column per name in LINEAR: -dQ/dc (tau = Y phi - Q); the
    loads' Q without those parts. ValueError: an unknown name, or one not linear in Q alone."""
    by_name = {symbol.name: symbol for symbol in symbols}
    if len(set(linear)) != len(linear):
        raise ValueError(f"linear names a parameter twice: {list(linear)}")
    for name in linear:
        symbol = by_name.get(name)
        if symbol is None:
            raise ValueError(f"{name!r} is not a runtime parameter (known: {sorted(by_name)})")
        column = [sympy.diff(force, symbol) for force in loads]
        elsewhere = any(entry.has(symbol) for row in columns for entry in row) or any(
            value.has(symbol) for value in phi)
        if elsewhere or any(entry.has(symbol) for entry in column):
            raise ValueError(f"{name!r} does not enter the equations linearly through the loads "
                             "alone: it cannot be a column of the regressor")
        for row, entry in zip(columns, column):
            row.append(-entry)
        phi.append(symbol)
        loads = [force.xreplace({symbol: sympy.S.Zero}) for force in loads]
    return loads

