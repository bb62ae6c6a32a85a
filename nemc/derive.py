"""Derivation: a validated Mechanism -> the equations of motion, symbolically.

The compiled right-hand side comes from the articulated-body algorithm (nemc/articulated.py): a
straight-line program whose size grows linearly with the number of bodies. The mass-matrix form
M(q) qdd = f(t, q, dq) of the book (Newton-Euler per body, the reactions eliminated by projecting
each body's equations onto the joints' free directions) is derived only on request: `nemc show`
prints it, and the tests check both forms against an independent Lagrangian derivation.

Constants are folded and derived parameters replaced by their definitions here, so every
expression this stage returns is in the coordinates, their rates, time and the runtime
(settable) parameters only.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property

import sympy

from . import model as m
from .articulated import dynamics_program, generalized_force_symbols, inverse_mass_program
from .kinematics import Kinematics, applied_loads
from .mass_form import MAX_COORDINATES, mass_form_program
from .outputs import derive_outputs
from .program import Program
from .tangent import seed_symbols, tangent_program
from .taylor import series_cost
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
    dynamics: Program  # the accelerations qdd(t, q, dq)
    outputs: tuple[tuple[str, sympy.Expr], ...]  # may contain the acceleration symbols
    checks: tuple[tuple[str, sympy.Expr], ...]  # key path -> expression that must be > 0
    initial_state: tuple[sympy.Expr, ...]
    jacobian: Program | None = None  # d qdd / d y along the seeds: see tangent.py
    seeds: Mapping[sympy.Symbol, sympy.Symbol] = dataclasses.field(default_factory=dict)
    # ^ state symbol -> the symbol of its tangent (the Jacobian's column), with the jacobian
    inverse_mass: Program | None = None  # M^-1 Q at rest, with the jacobian
    generalized_forces: tuple[sympy.Symbol, ...] = ()  # Q, the inverse_mass program's input
    taylor: Program | None = None  # the program nemc.Taylor's coefficients come from, if built
    events: tuple[m.Event, ...] = ()  # the scene's events, when and laws in runtime symbols

    @property
    def n(self) -> int:
        return len(self.coordinates)

    @property
    def state(self) -> tuple[sympy.Symbol, ...]:
        """The state in y's order: each coordinate followed by its rate."""
        return tuple(s for pair in zip(self.coordinates, self.speeds) for s in pair)

    @cached_property
    def mass_forcing(self) -> tuple[sympy.Matrix, sympy.Matrix]:
        """M and f of the book's form M(q) qdd = f(t, q, dq), in runtime symbols."""
        mass, forcing = newton_euler(self.mechanism, Kinematics(self.mechanism))
        runtime = runtime_values(self.mechanism)
        return mass.applyfunc(runtime), forcing.applyfunc(runtime)

    @property
    def mass_matrix(self) -> sympy.Matrix:
        return self.mass_forcing[0]

    @property
    def forcing(self) -> sympy.Matrix:
        return self.mass_forcing[1]


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


def runtime_values(mech: m.Mechanism) -> Callable[[object], sympy.Expr]:
    """expression -> the same in runtime symbols (constants folded, derived parameters expanded)."""
    fold = resolve_values(mech).substitutions

    def runtime(expr: object) -> sympy.Expr:
        return sympy.sympify(expr).xreplace(fold)

    return runtime


def derive(mech: m.Mechanism) -> Equations:
    """The whole derivation stage: the accelerations' program, outputs, runtime symbols only."""
    values = resolve_values(mech)
    kin = Kinematics(mech)
    runtime = runtime_values(mech)
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
        dynamics=dynamics_program(mech, runtime),
        outputs=tuple((name, runtime(expr)) for name, expr in derive_outputs(mech, kin)),
        checks=checks,
        initial_state=initial_state(mech, runtime),
        events=runtime_events(mech, runtime),
    )


def with_diagnostics(eqs: Equations) -> Equations:
    """Add the Jacobian (forward-mode derivative of the program) and M^-1 for diagnostics."""
    seeds = dict(zip(eqs.state, seed_symbols(len(eqs.state))))
    forces = generalized_force_symbols(eqs.n)
    return dataclasses.replace(
        eqs,
        jacobian=tangent_program(eqs.dynamics, seeds),
        seeds=seeds,
        inverse_mass=inverse_mass_program(eqs.mechanism, runtime_values(eqs.mechanism), forces),
        generalized_forces=forces,
    )


def with_taylor(eqs: Equations) -> Equations:
    """Ask for nemc.Taylor's code, from the program with the fewer Cauchy sums per order: the
    articulated-body program, or on small mechanisms the mass-matrix form (nemc/mass_form.py)."""
    program = eqs.dynamics
    if eqs.n <= MAX_COORDINATES:
        candidate = mass_form_program(*eqs.mass_forcing)
        if (series_cost(candidate, eqs.coordinates, eqs.speeds, m.TIME)
                < series_cost(program, eqs.coordinates, eqs.speeds, m.TIME)):
            program = candidate
    return dataclasses.replace(eqs, taylor=program)


def initial_state(mech: m.Mechanism, runtime) -> tuple[sympy.Expr, ...]:
    given: Mapping[str, sympy.Expr] = mech.simulation.initial
    return tuple(runtime(given.get(name, sympy.S.Zero)) for name in mech.state_names)


def runtime_events(mech: m.Mechanism, runtime) -> tuple[m.Event, ...]:
    """The scene's events with their `when` and impact laws in runtime symbols."""
    return tuple(
        dataclasses.replace(event, when=runtime(event.when),
                            law=tuple((name, runtime(expr)) for name, expr in event.law))
        for event in mech.simulation.events
    )
