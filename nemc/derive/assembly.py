"""Can the mechanism be assembled? The closed loops' check before anything is generated.

At the default parameter values, the scene's initial state is assembled as the runtime will
(the given coordinates kept, the others solved from the guess by Gauss-Newton: here numpy's
least squares on the derived constraint equations, the runtime's is the model's C): a loop
that cannot close, or given values that over-determine it, is a bad input, refused with the
constraint's FILE:LINE; otherwise the degrees of freedom are the coordinates less the rank of
Phi_q there (`nemc check` prints them).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import sympy

from ..errors import InputError, Problem
from ..front import mechanism as m
from ..front.values import resolve_values
from .kinematics import Kinematics
from .loops import LoopEquations, loop_equations

TOLERANCE = 1e-10  # the largest residual an assembled state may keep (as the runtime's)
ITERATIONS = 100


@dataclass(frozen=True)
class Assembly:
    """The scene's initial positions, assembled at the default parameters."""

    coordinates: dict[str, float]
    freedom: int  # degrees of freedom (of position): coordinates less the rank of Phi_q
    equations: int  # constraint equations
    motion: int  # degrees of freedom of motion: less the equations on the velocities too


def check_assembly(mech: m.Mechanism) -> Assembly:
    """Assemble the scene's initial positions; raise InputError naming the constraint that
    cannot close. A mechanism without loops has every coordinate free."""
    names = mech.coordinates
    if not mech.constraints:
        return Assembly({}, len(names), 0, len(names))
    phi, jacobian, start, given, positions = numeric_loops(mech)
    q = gauss_newton(phi, lambda x: jacobian(x) * positions[:, None], start, ~given)
    residual = np.abs(phi(q))
    if not residual.max() <= TOLERANCE:
        raise InputError([assembly_problem(mech, phi, jacobian, start, given, residual)])
    singular = singular_start(mech, jacobian, q)
    if singular:
        raise InputError([singular])
    stuck = rates_problem(mech, phi, jacobian, q)
    if stuck:
        raise InputError([stuck])
    return Assembly(dict(zip(names, q.tolist())), len(names) - rank(jacobian(q)[positions]),
                    len(residual), len(names) - rank(jacobian(q)))


def rank(matrix: np.ndarray, relative: float = 1e-9) -> int:
    if not matrix.size:
        return 0
    return int(np.linalg.matrix_rank(matrix, tol=relative * max(1.0, np.abs(matrix).max())))


SINGULAR_START = 1e-6  # Phi_q's singular values below this (relative): a singular start
GENERIC_SAMPLES = 5  # seeded random positions at which Phi_q's rank elsewhere is taken


def singular_start(mech: m.Mechanism, jacobian, q: np.ndarray) -> Problem | None:
    """A start at a singular configuration (Phi_q of lower rank there than elsewhere), where
    the degrees of freedom counted are not the mechanism's (runtime loops.singular_start)."""
    rng = np.random.default_rng(51)
    elsewhere = max(rank(jacobian(rng.uniform(-np.pi, np.pi, q.size)))
                    for _ in range(GENERIC_SAMPLES))
    here = rank(jacobian(q), SINGULAR_START)
    if here >= elsewhere:
        return None
    owners = [c for c in mech.constraints for _ in range(c.equations_count)]
    weakest = owners[int(np.abs(np.linalg.svd(jacobian(q))[0][:, here]).argmax())]
    where = mech.simulation.initial_loc or weakest.loc
    n = len(mech.coordinates)
    return Problem(where.file, where.line, where.key,
                   f"the initial state is at a singular configuration: constraint "
                   f"{weakest.name!r} ({weakest.loc.key}, line {weakest.loc.line}) loses rank "
                   f"there (rank {here} there, {elsewhere} elsewhere), where the degrees of "
                   f"freedom ({n - here} there, {n - elsewhere} elsewhere) are not the "
                   "mechanism's; start away from it (a run passes such positions, decision "
                   "0036, but cannot start at one)")


RATES_TOLERANCE = 1e-6  # a rate residual over this, relative to its terms, is not rounding


def rates_problem(mech: m.Mechanism, phi, jacobian, q: np.ndarray) -> Problem | None:
    """The start's rates (the runtime solves Phi_q q' = -Phi_t, the given rates kept): where
    no rates satisfy it (Phi_t, the drives' motion, out of Phi_q's range: a mechanism locked
    against its drives; or given rates that over-determine it), the problem naming the
    constraint left farthest and the initial values or the constraint's line."""
    rates = np.array([float(mech_number(mech, mech.simulation.initial[f"dot({name})"]))
                      if f"dot({name})" in mech.simulation.initial else 0.0
                      for name in mech.coordinates])
    given = np.array([f"dot({name})" in mech.simulation.initial for name in mech.coordinates])
    step = 1e-6 * (1.0 + abs(start_time(mech)))
    later, earlier = (numeric_loops(mech, start_time(mech) + sign * step)[0]
                      for sign in (1.0, -1.0))
    phi_t = (later(q) - earlier(q)) / (2 * step)
    phi_q = jacobian(q)
    free = ~given
    if free.any():
        rates[free] = np.linalg.lstsq(phi_q[:, free], -phi_t - phi_q[:, given] @ rates[given],
                                      rcond=None)[0]
    residual = np.abs(phi_q @ rates + phi_t)
    size = np.abs(phi_q) @ np.abs(rates) + np.abs(phi_t)
    if not residual.max() > RATES_TOLERANCE * max(1.0, size.max()):
        return None
    owners = [c for c in mech.constraints for _ in range(c.equations_count)]
    worst = owners[int(residual.argmax())]
    where = mech.simulation.initial_loc if given.any() else None
    if where is not None:
        return Problem(where.file, where.line, where.key,
                       f"constraint {worst.name!r} ({worst.loc.key}, line {worst.loc.line}) "
                       f"cannot hold with these initial rates: its rate stays "
                       f"{residual.max():.3g} from 0; give fewer rates, or consistent ones")
    return Problem(worst.loc.file, worst.loc.line, worst.loc.key,
                   f"no rates satisfy this constraint at the start (its rate stays "
                   f"{residual.max():.3g} from 0): the mechanism cannot move as its drives "
                   "prescribe there (locked against them, or at a dead position); change the "
                   "geometry, the drives or the start")


def assembly_problem(mech: m.Mechanism, phi, jacobian, start: np.ndarray, given: np.ndarray,
                     residual: np.ndarray) -> Problem:
    """Why the loops cannot close: the given initial values (when the loops close once they
    are free), or the geometry (named by the constraint left farthest from closing)."""
    kept = [name for name, keep in zip(mech.coordinates, given) if keep]
    where = mech.simulation.initial_loc
    owners = [c for c in mech.constraints for _ in range(c.equations_count)]
    worst = owners[int(residual.argmax())]
    if kept and where is not None:
        free = np.abs(phi(gauss_newton(phi, jacobian, start, np.ones_like(given)))).max()
        if free <= TOLERANCE:
            return Problem(where.file, where.line, where.key,
                           f"constraint {worst.name!r} ({worst.loc.key}, line "
                           f"{worst.loc.line}) cannot close with these values of "
                           f"{', '.join(kept)}: it stays {residual.max():.3g} from closing, "
                           "and closes when the coordinates are free; give fewer coordinates, "
                           "or values the loop can take")
    return Problem(worst.loc.file, worst.loc.line, worst.loc.key,
                   f"the mechanism cannot be assembled: this constraint stays "
                   f"{residual.max():.3g} from closing (the loop is too short or too long to "
                   "close); change the geometry, or the guess that starts the solve")


def start_time(mech: m.Mechanism) -> float:
    return float((mech.simulation.t_span or (0.0, 0.0))[0])


def mech_number(mech: m.Mechanism, expr: sympy.Expr) -> float:
    """EXPR (an initial value) at the default parameters and the start time."""
    values = resolve_values(mech)
    at = {**{symbol: sympy.Float(value) for symbol, value
             in zip(values.runtime_symbols, values.runtime_defaults)},
          m.TIME: sympy.Float(start_time(mech))}
    return float(sympy.sympify(expr).xreplace(values.substitutions).xreplace(at))


def numeric_loops(mech: m.Mechanism, t0: float | None = None):
    """Phi(q) and Phi_q(q) at the default parameters and t0 (the scene's start unless given),
    the start of the solve (the
    scene's given values and guesses), which coordinates are given and which equations are on
    the positions (an equation on the velocities has Phi 0 and its A as its row of Phi_q: the
    solve keeps the positions off that direction)."""
    values = resolve_values(mech)
    defaults = dict(zip(values.runtime_symbols, values.runtime_defaults))
    t0 = start_time(mech) if t0 is None else t0

    at_start = {**{symbol: sympy.Float(value) for symbol, value in defaults.items()},
                m.TIME: sympy.Float(t0)}

    def number(expr: sympy.Expr) -> sympy.Expr:
        """EXPR at the defaults and t0 (a bare symbol's xreplace gives its value as it is
        mapped: a sympy number, never a Python float)."""
        return sympy.sympify(expr).xreplace(values.substitutions).xreplace(at_start)

    from .equations import with_motions

    loops = loop_equations(with_motions(mech), Kinematics(with_motions(mech)), number)
    q = [m.symbol(name) for name in mech.coordinates]
    scene = {**mech.simulation.guess, **mech.simulation.initial}
    start = np.array([float(number(scene.get(name, 0))) for name in mech.coordinates])
    loops = with_start_offsets(loops, dict(zip(q, start)))
    phi = sympy.lambdify([q], list(loops.values), "numpy")
    jacobian = sympy.lambdify([q], [list(row) for row in loops.jacobian], "numpy")
    given = np.array([name in mech.simulation.initial for name in mech.coordinates])
    positions = np.array([k not in loops.on_velocities for k in range(loops.count)])
    return (lambda x: np.asarray(phi(x), dtype=float),
            lambda x: np.asarray(jacobian(x), dtype=float).reshape(len(loops.values), -1),
            start, given, positions)


def with_start_offsets(loops: LoopEquations, start: dict[sympy.Symbol, float]) -> LoopEquations:
    """LOOPS with the offsets of the equations that hold "as at the start" set to what their
    g(q) is at START (the runtime sets them so at each run's start)."""
    at = {symbol: sympy.Float(value) for symbol, value in start.items()}
    offsets = {offset: (loops.values[k] + offset).xreplace(at) for k, offset in loops.starts}
    if not offsets:
        return loops
    return dataclasses.replace(
        loops, values=tuple(v.xreplace(offsets) for v in loops.values),
        jacobian=tuple(tuple(e.xreplace(offsets) for e in row) for row in loops.jacobian))


def gauss_newton(phi, jacobian, q: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Damped Gauss-Newton on the free entries of q toward phi(q) = 0 (least squares)."""
    q = q.copy()
    residual = np.abs(phi(q)).max()
    for _ in range(ITERATIONS):
        if residual == 0.0 or not free.any():
            break
        step = np.linalg.lstsq(jacobian(q)[:, free], phi(q), rcond=None)[0]
        for _halving in range(30):
            trial = q.copy()
            trial[free] -= step
            tried = np.abs(phi(trial)).max()
            if tried < residual:
                break
            step = step / 2
        else:
            break  # nothing lowers the residual: as close as it gets
        q, residual = trial, tried
    return q
