"""Newton-Euler derivation: a validated Mechanism -> M(q) qdd = f(t, q, dq), symbolically.

As the book does it: kinematics of each body (angle, origin, mass center) built joint by joint
from the ground, velocities and accelerations by differentiation, Newton's and Euler's
equations per body with the joint reactions as unknowns. The reactions are eliminated by
projecting each body's equations onto the free directions of the joints (the partial
velocities d v_C / d dq and d omega / d dq): reactions do no work along them. The mass matrix is
never inverted symbolically; the generated C solves M qdd = f numerically.

Constants are folded and derived parameters replaced by their definitions here, so every
expression this stage returns is in the coordinates, their rates, time and the runtime
(settable) parameters only.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import sympy

from . import model as m
from .kinematics import Kinematics, applied_loads
from .outputs import derive_outputs
from .values import resolve_values


@dataclass(frozen=True)
class Equations:
    """The derived model: everything later stages need, in runtime symbols only."""

    mechanism: m.Mechanism
    coordinates: tuple[sympy.Symbol, ...]
    speeds: tuple[sympy.Symbol, ...]
    accelerations: tuple[sympy.Symbol, ...]
    parameters: tuple[sympy.Symbol, ...]  # the runtime parameter vector p, in order
    parameter_defaults: tuple[float, ...]
    derived_parameters: tuple[tuple[str, sympy.Expr], ...]  # name -> expression of parameters
    mass_matrix: sympy.Matrix
    forcing: sympy.Matrix
    outputs: tuple[tuple[str, sympy.Expr], ...]  # may contain the acceleration symbols
    checks: tuple[tuple[str, sympy.Expr], ...]  # key path -> expression that must be > 0
    initial_state: tuple[sympy.Expr, ...]
    jacobian: tuple[sympy.Matrix, sympy.Matrix] | None = None  # (R, S): see jacobian.py

    @property
    def n(self) -> int:
        return len(self.coordinates)


def newton_euler(mech: m.Mechanism, kin: Kinematics) -> tuple[sympy.Matrix, sympy.Matrix]:
    """M and f of M qdd = f from the projected Newton-Euler equations of every body."""
    n = len(kin.q)
    residual = sympy.zeros(n, 1)  # sum of projections of (m a_C - F, I alpha - T); = 0
    for body in mech.bodies:
        v_c = kin.rate(kin.position(body.name, body.com))
        omega = kin.rate(kin.angle(body.name))
        a_c, alpha = kin.rate(v_c), kin.rate(omega)
        jv, jw = kin.partials(v_c), kin.partials(omega)
        for k in range(n):
            residual[k] += jv[k].dot(body.mass * a_c) + jw[k] * body.inertia * alpha
    forces, couples, generalized = applied_loads(mech, kin)
    for load in forces:
        jv = kin.partials(kin.rate(kin.position(load.body, load.xy)))
        for k in range(n):
            residual[k] -= jv[k].dot(load.force)
    for body, torque in couples:
        if body != m.GROUND:
            jw = kin.partials(kin.rate(kin.angle(body)))
            for k in range(n):
                residual[k] -= jw[k] * torque
    for rel, tension in generalized:
        for k in range(n):
            residual[k] -= sympy.diff(rel, kin.q[k]) * tension
    mass = residual.jacobian(kin.qdd)
    forcing = -residual.xreplace({a: sympy.S.Zero for a in kin.qdd})
    return mass, forcing


def derive(mech: m.Mechanism) -> Equations:
    """The whole derivation stage: Newton-Euler, outputs, runtime symbols only."""
    values = resolve_values(mech)
    kin = Kinematics(mech)
    mass, forcing = newton_euler(mech, kin)
    outputs = derive_outputs(mech, kin)
    fold = values.substitutions

    def runtime(expr):
        return sympy.sympify(expr).xreplace(fold) if fold else sympy.sympify(expr)

    checks = tuple(
        (f"bodies.{b.name}.{field}", runtime(getattr(b, field)))
        for b in mech.bodies
        for field in ("mass", "inertia")
    )
    return Equations(
        mechanism=mech,
        coordinates=kin.q,
        speeds=kin.u,
        accelerations=kin.qdd,
        parameters=values.runtime_symbols,
        parameter_defaults=values.runtime_defaults,
        derived_parameters=values.derived,
        mass_matrix=mass.xreplace(fold),
        forcing=forcing.xreplace(fold),
        outputs=tuple((name, runtime(expr)) for name, expr in outputs),
        checks=checks,
        initial_state=initial_state(mech, runtime),
    )


def initial_state(mech: m.Mechanism, runtime) -> tuple[sympy.Expr, ...]:
    given: Mapping[str, sympy.Expr] = mech.simulation.initial
    return tuple(runtime(given.get(name, sympy.S.Zero)) for name in mech.state_names)
