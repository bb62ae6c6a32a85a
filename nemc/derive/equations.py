"""Derivation: a validated Mechanism -> the equations of motion, symbolically.

The compiled right-hand side comes from the articulated-body algorithm (nemc/articulated.py): a
straight-line program whose size grows linearly with the number of bodies. On open trees of up to
mass_form.MAX_COORDINATES coordinates the mass-matrix form M(q) qdd = f(t, q, dq) of the book
(Newton-Euler per body, the reactions eliminated by projecting each body's equations onto the
joints' free directions), solved by LDL^T in steps, is often smaller: the right-hand side runs
whichever of the forms c_cost.estimated_ns ranks fastest (fastest_dynamics). `nemc show` prints
M and f, and the tests check both forms against an independent Lagrangian derivation.

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

from ..front import mechanism as m
from ..front.carried import carried
from ..front.values import resolve_values
from .articulated import dynamics_program, generalized_force_symbols, inverse_mass_program
from .c_cost import estimated_ns
from .contacts import refuse_contacts
from .friction import (
    FrictionEquations,
    friction_checks,
    friction_equations,
    friction_events,
    friction_outputs,
    friction_parameters,
    friction_refusal,
)
from .inputs import InputLaw, input_law
from .kinematics import Kinematics, applied_loads, generalized_forces, motion_substitutions
from .linearization import Linearization, input_seeds, linearization, state_seeds
from .loops import LoopEquations, loop_equations
from .mass_form import (
    MAX_COORDINATES,
    ldl_solve,
    mass_form_entries,
    mass_form_program,
    program_of_entries,
    rhs_solve,
)
from .outputs import derive_outputs
from .products import fewer_products
from .program import Program, split_deep
from .sensitivities import Sensitivities, event_partials, sensitivities
from .tangent import seed_symbols, tangent_program
from .taylor import series_cost, unsupported_operation

# the forms of the accelerations' program (Equations.dynamics_form, model.json's
# "dynamics_program" and "taylor_program")
ARTICULATED = "articulated body"
MASS_MATRIX = "mass matrix"
LINEARIZED = "mass matrix, linearized"
ADDITION_FORMULAS = "mass matrix, linearized, addition formulas"  # nemc/angle_sums.py


@dataclass(frozen=True)
class DynamicsLayout:
    """What the dynamics program's results are, in order: the accelerations of the undriven
    coordinates (of the tree: before any constraint force), the drives of the driven joints,
    then per constraint equation k its unit pass (the accelerations and drives under the
    reaction of a unit multiplier k: M^-1 Phi_q^T's column k), then the constraint bias G,
    Phi, Phi_q (row by row) and Phi_t."""

    coordinates: int
    drives: int = 0
    equations: int = 0

    @property
    def augmented(self) -> bool:
        """Whether the right-hand side is more than the tree's accelerations."""
        return bool(self.drives or self.equations)


@dataclass(frozen=True)
class Equations:
    """The derived model: everything later stages need, in runtime symbols only."""

    mechanism: m.Mechanism
    coordinates: tuple[sympy.Symbol, ...]
    speeds: tuple[sympy.Symbol, ...]
    accelerations: tuple[sympy.Symbol, ...]
    parameters: tuple[sympy.Symbol, ...]  # the runtime parameter vector p, in order: the
    parameter_defaults: tuple[float, ...]  # YAML's runtime parameters, then the inputs' laws'
    #                                        coefficients (inputs.InputLaw)
    derived_parameters: tuple[tuple[str, sympy.Expr], ...]  # name -> expression of parameters
    dynamics: Program  # the accelerations qdd(t, q, dq)
    outputs: tuple[tuple[str, sympy.Expr], ...]  # may contain the acceleration symbols
    checks: tuple[tuple[str, sympy.Expr], ...]  # key path -> expression that must be >= 0,
    check_strict: tuple[bool, ...]  # or (these) > 0: masses and inertias, what joints carry
    initial_state: tuple[sympy.Expr, ...]
    jacobian: Program | None = None  # d qdd / d y along the seeds: see tangent.py
    seeds: Mapping[sympy.Symbol, sympy.Symbol] = dataclasses.field(default_factory=dict)
    # ^ state symbol -> the symbol of its tangent (the Jacobian's column), with the jacobian
    jacobian_by_differences: bool = False  # a closed loop's Jacobian: differences in C
    inverse_mass: Program | None = None  # M^-1 Q at rest, when the mass matrix is built
    generalized_forces: tuple[sympy.Symbol, ...] = ()  # Q, the inverse_mass program's input
    taylor: Program | None = None  # the program nemc.Taylor's coefficients come from, if built
    taylor_unavailable: str | None = None  # why nemc.Taylor cannot be built: FILE:LINE: ...
    layout: DynamicsLayout | None = None  # what the dynamics program's results are
    loops: LoopEquations | None = None  # the constraint equations, with constraints
    multipliers: tuple[sympy.Symbol, ...] = ()  # lambda, per constraint equation
    drives: tuple[sympy.Symbol, ...] = ()  # the drives of the driven joints, in file order
    events: tuple[m.Event, ...] = ()  # the scene's events, when and laws in runtime symbols
    dynamics_form: str = ARTICULATED  # which program the dynamics are (fastest_dynamics)
    forms: Mapping[str, Program] = dataclasses.field(default_factory=dict)
    # ^ the forms of the accelerations' program derived, by name (nemc.Taylor chooses among them)
    taylor_form: str | None = None  # the form nemc.Taylor's program was made from
    taylor_sums: float | None = None  # its Cauchy sums per order (taylor.series_cost)
    derived_mass_forcing: tuple[sympy.Matrix, sympy.Matrix] | None = None  # M, f if derived
    inputs: InputLaw = InputLaw((), (), (), ())  # the inputs' laws and their coefficients
    linearization: Linearization | None = None  # A, B, C, D's programs (trees), if built
    linearization_unavailable: str | None = None  # why it is not, where it is asked for
    sensitivities: Sensitivities | None = None  # the variational equations' programs, if built
    sensitivities_unavailable: str | None = None  # why they are not (FILE:LINE: ...)
    friction: FrictionEquations | None = None  # Coulomb friction's unknowns and terms

    @property
    def n(self) -> int:
        return len(self.coordinates)

    @property
    def state(self) -> tuple[sympy.Symbol, ...]:
        """The state in y's order: each coordinate followed by its rate."""
        return tuple(s for pair in zip(self.coordinates, self.speeds) for s in pair)

    @property
    def accelerations_program(self) -> Program:
        """The dynamics program with only the accelerations as results (what Taylor and the
        Jacobian differentiate; the same as dynamics for a tree)."""
        if self.layout is None or not self.layout.augmented:
            return self.dynamics
        return Program(self.dynamics.steps, self.dynamics.results[: self.n]).pruned()

    @cached_property
    def mass_forcing(self) -> tuple[sympy.Matrix, sympy.Matrix]:
        """M and f of the book's form M(q) qdd = f(t, q, dq), in runtime symbols."""
        return self.derived_mass_forcing or mass_and_forcing(self.mechanism)

    @property
    def mass_matrix(self) -> sympy.Matrix:
        return self.mass_forcing[0]

    @property
    def forcing(self) -> sympy.Matrix:
        return self.mass_forcing[1]


def mass_and_forcing(mech: m.Mechanism) -> tuple[sympy.Matrix, sympy.Matrix]:
    """M and f of M qdd = f in runtime symbols."""
    mass, forcing = newton_euler(mech, Kinematics(mech))
    runtime = runtime_values(mech)
    return mass.applyfunc(runtime), forcing.applyfunc(runtime)


def newton_euler(mech: m.Mechanism, kin: Kinematics) -> tuple[sympy.Matrix, sympy.Matrix]:
    """M and f of M qdd = f from the projected Newton-Euler equations of every body."""
    n = len(kin.q)
    if n == 0:  # every coordinate driven: no equation of motion (an inverse-dynamic analysis)
        return sympy.zeros(0, 0), sympy.zeros(0, 1)
    residual = sympy.zeros(n, 1)  # sum of projections of (m a_C - F, I alpha - T); = 0
    for body in mech.bodies:
        v_c = kin.rate(kin.position(body.name, body.com))
        omega = kin.rate(kin.angle(body.name))
        a_c, alpha = kin.rate(v_c), kin.rate(omega)
        jv, jw = kin.partials(v_c), kin.partials(omega)
        for k in range(n):
            residual[k] += jv[k].dot(body.mass * a_c) + jw[k] * body.inertia * alpha
    for k, force in enumerate(generalized_forces(kin, applied_loads(mech, kin))):
        residual[k] -= force
    mass = residual.jacobian(kin.qdd)
    forcing = -residual.xreplace({a: sympy.S.Zero for a in kin.qdd})
    return mass, forcing


def runtime_values(mech: m.Mechanism) -> Callable[[object], sympy.Expr]:
    """expression -> the same in runtime symbols (constants folded, derived parameters expanded,
    each input replaced by its law: nemc/derive/inputs.py)."""
    fold = resolve_values(mech).substitutions

    def folded(expr: object) -> sympy.Expr:
        return sympy.sympify(expr).xreplace(fold)

    laws = input_law(mech, folded).substitutions
    if not laws:
        return folded

    def runtime(expr: object) -> sympy.Expr:
        return sympy.sympify(expr).xreplace(fold).xreplace(laws)

    return runtime


def derive(mech: m.Mechanism) -> Equations:
    """The whole derivation stage: the accelerations' program, outputs, runtime symbols only."""
    refuse_contacts(mech)
    mech = with_motions(mech)
    values = resolve_values(mech)
    kin = Kinematics(mech)
    runtime = runtime_values(mech)
    inputs = input_law(mech, lambda expr: sympy.sympify(expr).xreplace(values.substitutions))
    bodies = {body.name: body for body in mech.bodies}
    needs = tuple(carried(bodies, mech.joints))
    checks = tuple(
        (f"bodies.{b.name}.{field}", runtime(getattr(b, field)))
        for b in mech.bodies
        for field in ("mass", "inertia")
    ) + tuple((need.key, runtime(need.value)) for need in needs)
    check_strict = (False,) * (2 * len(mech.bodies)) + (True,) * len(needs)
    friction_needs = friction_checks(mech, runtime)
    checks += tuple((key, expr) for key, expr, _ in friction_needs)
    check_strict += tuple(strict for _, _, strict in friction_needs)
    loops = loop_equations(mech, kin, runtime) if mech.constraints else None
    starts = tuple(offset for _, offset in loops.starts) if loops is not None else ()
    count = loops.count if loops is not None else 0
    multipliers = tuple(sympy.Dummy(f"multiplier_{k}", real=True) for k in range(count))
    drives = tuple(sympy.Dummy(f"drive_{joint.name}", real=True) for joint in mech.driven)
    # with loops, the program also computes G, Phi, Phi_q and Phi_t (DynamicsLayout), sharing
    # the kinematics' names
    dynamics = split_deep(dynamics_program(mech, runtime, () if loops is None else loops.results),
                          "v")
    forms, mass_forcing = {ARTICULATED: dynamics}, None
    if loops is None and not mech.driven and len(kin.q) <= MAX_COORDINATES:
        mass_forcing = mass_and_forcing(mech)
        forms.update(mass_forms(*mass_forcing))
    form = fastest_dynamics(forms)
    hidden = friction_parameters(mech)
    return Equations(
        mechanism=mech,
        coordinates=kin.q,
        speeds=kin.u,
        accelerations=kin.qdd,
        parameters=values.runtime_symbols + inputs.coefficients + starts + hidden[0],
        parameter_defaults=values.runtime_defaults + inputs.defaults + (0.0,) * len(starts)
        + hidden[1],
        derived_parameters=values.derived,
        dynamics=forms[form],
        outputs=tuple((name, runtime(expr)) for name, expr in
                      derive_outputs(mech, kin, dict(zip((j.name for j in mech.driven), drives)),
                                     multipliers_by_constraint(mech, multipliers))
                      + friction_outputs(mech, kin)),
        checks=checks,
        check_strict=check_strict,
        initial_state=initial_state(mech, runtime),
        layout=DynamicsLayout(len(kin.q), len(drives), count),
        loops=loops,
        multipliers=multipliers,
        drives=drives,
        events=runtime_events(mech, runtime) + friction_events(mech),
        dynamics_form=form,
        forms=forms,
        derived_mass_forcing=mass_forcing,
        inputs=inputs,
        friction=friction_equations(mech, kin, runtime,
                                    multipliers_by_constraint(mech, multipliers)),
        sensitivities_unavailable=friction_refusal(mech, "sensitivities"),
    )


def mass_forms(mass: sympy.Matrix, forcing: sympy.Matrix) -> dict[str, Program]:
    """The mass-matrix form's programs the right-hand side may run: M's and f's entries as
    derived, linearized, and linearized with the sines and cosines of sums of angles from those
    of their parts (nemc/angle_sums.py), the entries linearized once for both; M solved as
    mass_form.rhs_solve says."""
    linear, solve = mass_form_entries(mass, forcing), rhs_solve(mass.shape[0])
    return {MASS_MATRIX: split_deep(mass_form_program(mass, forcing, linearize=False,
                                                      solve=solve), "v"),
            LINEARIZED: split_deep(program_of_entries(linear, solve=solve), "v"),
            ADDITION_FORMULAS: split_deep(program_of_entries(linear, addition_formulas=True,
                                                             solve=solve), "v")}


def taylor_mass_forms(eqs: Equations) -> dict[str, Program]:
    """The mass-matrix form's programs nemc.Taylor may run, M solved by LDL^T: the right-hand
    side's where it solves so too, else made again (mass_form.rhs_solve)."""
    if rhs_solve(eqs.n) is ldl_solve and LINEARIZED in eqs.forms:
        return {form: eqs.forms[form] for form in (MASS_MATRIX, LINEARIZED)}
    mass, forcing = eqs.mass_forcing
    made = {LINEARIZED: split_deep(mass_form_program(mass, forcing), "vt")}
    if MASS_MATRIX in eqs.forms:  # a candidate where the right-hand side had it
        made[MASS_MATRIX] = split_deep(mass_form_program(mass, forcing, linearize=False), "vt")
    return made


def fastest_dynamics(forms: Mapping[str, Program]) -> str:
    """The form whose program c_cost estimates fastest as C; ties keep the articulated-body
    program (the first)."""
    return min(forms, key=lambda name: estimated_ns(forms[name]))


def with_motions(mech: m.Mechanism) -> m.Mechanism:
    """The mechanism with the driven coordinates (and their rates) replaced by their prescribed
    values wherever loads, output expressions, events' functions and impact laws name them."""
    motions = motion_substitutions(mech)
    if not motions:
        return mech

    def prescribe(expr: sympy.Expr) -> sympy.Expr:
        return sympy.sympify(expr).xreplace(motions)

    outputs = dataclasses.replace(mech.outputs, expressions=tuple(
        (name, prescribe(expr)) for name, expr in mech.outputs.expressions))
    events = tuple(dataclasses.replace(event, when=prescribe(event.when), law=tuple(
        (name, prescribe(expr)) for name, expr in event.law)) for event in mech.simulation.events)
    return dataclasses.replace(mech, loads=tuple(load.map_expressions(prescribe)
                                                 for load in mech.loads), outputs=outputs,
                               simulation=dataclasses.replace(mech.simulation, events=events))


def multipliers_by_constraint(mech: m.Mechanism, multipliers: tuple[sympy.Symbol, ...]
                              ) -> dict[str, list[sympy.Symbol]]:
    found: dict[str, list[sympy.Symbol]] = {}
    start = 0
    for constraint in mech.constraints:
        found[constraint.name] = list(multipliers[start: start + constraint.equations_count])
        start += constraint.equations_count
    return found


def with_diagnostics(eqs: Equations) -> Equations:
    """Add both optional diagnostics parts: the Jacobian and M^-1."""
    return with_mass_matrix(with_jacobian(eqs))


def with_jacobian(eqs: Equations) -> Equations:
    """Add the Jacobian of the right-hand side: the forward-mode derivative of the program, or
    for a closed loop's projected right-hand side, differences (jacobian_differences.c.tmpl)."""
    if eqs.loops is not None or eqs.friction is not None:
        return dataclasses.replace(eqs, jacobian_by_differences=True)
    seeds = dict(zip(eqs.state, seed_symbols(len(eqs.state))))
    return dataclasses.replace(eqs, jacobian=tangent_program(eqs.accelerations_program, seeds),
                               seeds=seeds)


def with_linearization(eqs: Equations) -> Equations:
    """Add the exact linearization's programs (A, B, C, D at a state: nemc/derive/
    linearization.py): a tree's, or a closed loop's pieces (the derivatives of its dynamics
    program's every result: the runtime solves the index-1 equations' derivative and reduces
    them to independent coordinates)."""
    seeds = {**(eqs.seeds or state_seeds(eqs.state)), **input_seeds(eqs.inputs.values())}
    results = (*eqs.accelerations, *eqs.drives, *eqs.multipliers)
    return dataclasses.replace(eqs, linearization=linearization(
        eqs.dynamics, seeds, results, tuple(expr for _, expr in eqs.outputs)))


def with_sensitivities(eqs: Equations) -> Equations:
    """Add the variational equations' programs (nemc/derive/sensitivities.py): the tangent of
    a tree's dynamics and outputs along the state's and the parameters' seeds, and the initial
    state's derivatives by the parameters, and each event's partial derivatives (the jump at
    an event). A closed loop's: its pieces' tangent; what loop_refusal names is refused, with
    its line."""
    if eqs.sensitivities_unavailable:
        return eqs
    why = loop_refusal(eqs) or event_refusal(eqs)
    if why:
        return dataclasses.replace(eqs, sensitivities_unavailable=why)
    # a closed loop's: the tangent of the program's every result (its pieces, DynamicsLayout;
    # templates/loop_sensitivities.c.tmpl solves the index-1 equations' derivative), its
    # outputs' reading the multipliers' too
    results = (*eqs.accelerations, *eqs.drives, *eqs.multipliers)
    found = sensitivities(eqs.dynamics, eqs.state, eqs.parameters, results,
                          tuple(expr for _, expr in eqs.outputs), eqs.initial_state)
    partials = tuple(event_partials(event.when, {m.symbol(name): value for name, value
                                                 in event.law},
                                    eqs.state, eqs.parameters, m.TIME) for event in eqs.events)
    return dataclasses.replace(eqs, sensitivities=dataclasses.replace(found, events=partials))


def loop_refusal(eqs: Equations) -> str | None:
    """Why a closed loop's sensitivities cannot be derived (FILE:LINE: ...): what decision
    0035's amendment leaves out: equations held "as at the start" (their offset moves with
    y0 and p), equations on the velocities, and impacts (their jump goes through the
    assembly). None for a tree."""
    loops = eqs.loops
    if loops is None:
        return None
    owners = {constraint.name: constraint.loc for constraint in eqs.mechanism.constraints}
    for equations, what in ((tuple(k for k, _ in loops.starts), "holds its equations as at "
                             "the start (their offset moves with y0 and the parameters)"),
                            (loops.on_velocities, "is on the velocities")):
        if equations:
            where = owners[loops.owners[equations[0]]]
            return (f"{where.file}:{where.line}: {where.key}: sensitivities of a closed loop "
                    f"whose constraint {what} are not available")
    for event in eqs.events:
        if event.law:
            where = f"{event.loc.file}:{event.loc.line}: {event.loc.key}: " if event.loc else ""
            return (f"{where}sensitivities through an impact on a closed loop (its jump goes "
                    "through the assembly) are not available")
    return None


def event_refusal(eqs: Equations) -> str | None:
    """Why an event's jump of the sensitivities cannot be derived (FILE:LINE: ...): its
    function or law reads something other than the state, the parameters and the time."""
    known = {*eqs.state, *eqs.parameters, m.TIME}
    for event in eqs.events:
        read = (event.when, *(value for _, value in event.law))
        stray = set().union(*(sympy.sympify(e).free_symbols for e in read)) - known
        if stray and event.loc is not None:
            return (f"{event.loc.file}:{event.loc.line}: {event.loc.key}: the event reads "
                    f"{sorted(map(str, stray))}, whose derivatives at the event are not "
                    "derived")
        if stray:
            return f"event {event.name!r} reads {sorted(map(str, stray))}"
    return None


def with_mass_matrix(eqs: Equations) -> Equations:
    """Add M^-1 Q (Model.mass_matrix, the stress report's conditioning): a part of its own,
    which neither the integrators nor the Jacobian read (issue 19: a fifth of a 1000-body
    chain's build with its Jacobian)."""
    forces = generalized_force_symbols(eqs.n)
    inverse_mass = inverse_mass_program(eqs.mechanism, runtime_values(eqs.mechanism), forces)
    return dataclasses.replace(
        eqs, inverse_mass=inverse_mass if eqs.loops is not None else split_deep(inverse_mass, "vm"),
        generalized_forces=forces)


def with_taylor(eqs: Equations) -> Equations:
    """Ask for nemc.Taylor's code, from the program with the fewer Cauchy sums per order: the
    articulated-body program, or on small mechanisms the mass-matrix form (nemc/mass_form.py),
    each with its products shared and factored (nemc/products.py).
    A load whose expressions have no Taylor recurrence makes it unavailable, said with the
    load's FILE:LINE."""
    refusal = taylor_refusal(eqs)
    if refusal is not None:
        return dataclasses.replace(eqs, taylor_unavailable=refusal)
    varying = (*eqs.coordinates, *eqs.speeds, m.TIME)

    def cost(program: Program) -> float:
        return series_cost(program, eqs.coordinates, eqs.speeds, m.TIME)

    # the articulated-body program, and the mass-matrix form's solved by LDL^T; the addition
    # formulas trade a sine-cosine pair (two Cauchy sums an order) for four products: never
    # fewer sums, so not a candidate here
    candidates = {form: program for form, program in
                  {**eqs.forms, eqs.dynamics_form: eqs.accelerations_program}.items()
                  if form not in (MASS_MATRIX, LINEARIZED, ADDITION_FORMULAS)}
    if eqs.n <= MAX_COORDINATES:
        candidates.update(taylor_mass_forms(eqs))
    # taking factors out nests sums: split again (other names than the first split's)
    programs = {form: split_deep(fewer_products(candidate, varying, cost), "vf")
                for form, candidate in candidates.items()}
    sums = {form: cost(program) for form, program in programs.items()}
    form = min(sums, key=sums.__getitem__)
    return dataclasses.replace(eqs, taylor=programs[form], taylor_form=form,
                               taylor_sums=sums[form])


def taylor_cost_ratio(eqs: Equations) -> float:
    """nemc.Taylor's Cauchy sums per order over the right-hand side's estimated ns
    (c_cost.estimated_ns): a step of nemc.Taylor costs about the first times p^2, one of
    nemc.Vern9 about 16 times the second, and their steps' ratio changes little from one
    smooth mechanism to the next, so this ratio decides which a single run takes
    (methods.auto_takes_taylor). Called with Taylor's program built."""
    assert eqs.taylor_sums is not None
    return eqs.taylor_sums / max(estimated_ns(eqs.dynamics), 1.0)


def taylor_refusal(eqs: Equations) -> str | None:
    """Where the equations use an operation with no Taylor recurrence here, with its place in
    the file, or None."""
    mech = eqs.mechanism
    if mech.frictions or mech.contacts:
        return friction_refusal(mech, "nemc.Taylor's series")
    if mech.constraints:
        where = mech.constraints[0].loc
        return (f"{where.file}:{where.line}: {where.key}: a closed loop's state is projected "
                "onto its constraints (a Newton solve), which has no Taylor recurrence")
    runtime, varying = runtime_values(mech), {*eqs.state, m.TIME}
    for joint in mech.driven:
        why = unsupported_operation(runtime(joint.motion), varying)
        if why is not None:
            where = joint.loc
            return (f"{where.file}:{where.line}: {where.key}.motion: {why} has no Taylor "
                    "recurrence here")
    for load in mech.loads:
        for key, expr in load.expressions():
            why = unsupported_operation(runtime(expr), varying)
            if why is not None:
                where = load.location
                return (f"{where.file}:{where.line}: {where.key}.{key}: {why} has no Taylor "
                        "recurrence here")
    return None


def initial_state(mech: m.Mechanism, runtime) -> tuple[sympy.Expr, ...]:
    """The scene's initial state: the values given, else (closed loops: where the assembly
    starts) the guess, else 0."""
    given: Mapping[str, sympy.Expr] = {**mech.simulation.guess, **mech.simulation.initial}
    return tuple(runtime(given.get(name, sympy.S.Zero)) for name in mech.state_names)


def runtime_events(mech: m.Mechanism, runtime) -> tuple[m.Event, ...]:
    """The scene's events with their `when` and impact laws in runtime symbols."""
    return tuple(
        dataclasses.replace(event, when=runtime(event.when),
                            law=tuple((name, runtime(expr)) for name, expr in event.law))
        for event in mech.simulation.events
    )
