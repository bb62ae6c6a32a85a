"""The model as a plant: its linearization at a state (linear.py's matrices, from the build's
part "linearization"), an equilibrium by Newton with that exact Jacobian (trim), and the
Floquet multipliers of a periodic motion from the variational equations (floquet).
Model.linearize, Model.trim and Model.floquet call these."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .built import BuiltModel
from .checks import checked_time
from .failures import IntegrationFailure, ModelError
from .inputs import SCALE, VALUE
from .linear import Linearization, LoopPieces, Solved, loop_matrices, tree_matrices

TRIM_TOLERANCE = 1e-10  # the largest |dy/dt| an equilibrium keeps, relative to its scale


def input_vector(model: BuiltModel, p: np.ndarray, t: float, y: np.ndarray) -> np.ndarray:
    """The inputs' values at (t, y) under the laws in p."""
    u = np.empty(len(model.input_names))
    if u.size:
        buffer = model.compiled.buffer
        model.compiled.functions["input_values"](t, buffer(y), buffer(p), buffer(u))
    return u


def with_inputs(model: BuiltModel, p: np.ndarray, u: Any) -> np.ndarray:
    """p with the inputs held at the values U (a mapping by name or a vector in
    input_names' order; None: their laws as they are)."""
    if u is None:
        return p
    layout, names = model.input_layout, model.input_names
    if isinstance(u, Mapping):
        unknown = [name for name in u if name not in names]
        if unknown:
            raise ModelError(f"unknown inputs {unknown}; this model's: {list(names)}")
        values = {name: float(value) for name, value in u.items()}
    else:
        vector = np.atleast_1d(np.asarray(u, dtype=float))
        if vector.shape != (len(names),):
            raise ModelError(f"u: expected {len(names)} values, one per input {list(names)}; "
                             f"got shape {vector.shape}")
        values = dict(zip(names, vector.tolist()))
    p = p.copy()
    for name, value in values.items():
        if not np.isfinite(value):
            raise ModelError(f"input {name}: {value} is not finite")
        law = layout.law(names.index(name))
        p[law: law + layout.stride] = 0.0
        p[law + VALUE] = value
    return p


def linearize(model: BuiltModel, y: Any = None, u: Any = None, *, t: float = 0.0,
              params: Mapping[str, float] | None = None,
              independent: Sequence[str] | None = None) -> Linearization:
    """A, B, C, D at (t, y, u), exact (see Model.linearize)."""
    model.friction.refuse("linearize")
    t = checked_time(t)
    p = with_inputs(model, model.parameter_vector(params), u)
    state, p = point_state(model, y, t, p, params)
    build = model.compiled_with("linearization")
    if not build.has_part("linearization"):
        raise ModelError("this standalone package was built without its linearization: "
                         "compile it with nemc (the part \"linearization\")")
    inputs = input_vector(model, p, t, state)
    names = (model.state_names, model.input_names, model.output_names)
    if not model.has_loops:
        call = build.compiled.functions["linearization"]
        a, b, c, d = tree_matrices(call, t, state, p, len(names[1]), len(names[2]),
                                   build.compiled.buffer)
        return Linearization(a, b, c, d, *names, t, state, inputs, model.state_names)
    return loop_linearization(model, build, t, state, p, inputs, independent)


def point_state(model: BuiltModel, y: Any, t: float, p: np.ndarray,
                params: Mapping[str, float] | None) -> tuple[np.ndarray, np.ndarray]:
    """The state a linearization is taken at: Y (an array; a mapping of named values, the
    rates it does not name 0, the coordinates the scene's), a closed loop's on its
    constraints (the named values kept, the others solved; an array's nearest consistent
    state), and p with the offsets of constraints "as at the start" set there."""
    state = model.state_vector(y, params).copy()
    if isinstance(y, Mapping):
        rates = [i for i in range(1, model.n_state, 2) if model.state_names[i] not in y]
        state[rates] = 0.0
    if not model.has_loops:
        return state, p
    p = model.loops.started(t, state, p)
    if isinstance(y, Mapping):  # the rates it does not name solved from 0 (none: at rest)
        return model.loops.assembled(t, state, model.loops.given_mask(y), p)[0], p
    return model.loops.projected(np.array([t]), state.reshape(-1, 1), p)[:, 0], p


def loop_linearization(model: BuiltModel, build: BuiltModel, t: float, y: np.ndarray,
                       p: np.ndarray, inputs: np.ndarray,
                       independent: Sequence[str] | None) -> Linearization:
    """A closed loop's linearization in independent coordinates (linear.loop_matrices)."""
    meta = model.metadata
    if model.loops.on_velocities:
        named = sorted({meta["constraint_equations"][k] for k in model.loops.on_velocities})
        raise ModelError(
            f"linearize: constraints {named} are on the velocities (nonholonomic), whose "
            "linearization needs independent rates apart from independent coordinates: not "
            "supported yet; model.jacobian(t, y) gives d(dy/dt)/dy in the full state")
    n, drives = len(model.coordinate_names), len(meta["drive_names"])
    m = len(meta["constraint_equations"])
    size = (m + 1) * (n + drives) + m * (n + 3)
    columns = model.n_state + len(model.input_names)
    acc, dacc = np.empty(size), np.empty((columns, size))
    compiled, buffer = build.compiled, build.compiled.buffer
    status = compiled.functions["loop_tangents"](t, buffer(y), buffer(p), buffer(acc),
                                                 buffer(dacc))
    if status:
        raise IntegrationFailure(t, y, status, model.state_names)
    pieces = LoopPieces(n, drives, m, acc, dacc)

    def outputs(solved: Solved, directions: np.ndarray) -> np.ndarray:
        return outputs_tangents(build, t, y, p, solved, directions)

    a, b, c, d, free, dependent, tangent = loop_matrices(
        pieces, y, model.coordinate_names, independent, len(model.input_names),
        outputs if model.output_names else None)
    state_names = tuple(name for i in free for name in model.state_names[2 * i: 2 * i + 2])
    return Linearization(a, b, c, d, state_names, model.input_names, model.output_names, t,
                         y, inputs, model.state_names,
                         tuple(model.coordinate_names[i] for i in dependent), tangent)


def outputs_tangents(build: BuiltModel, t: float, y: np.ndarray, p: np.ndarray,
                     solved: Solved, directions: np.ndarray) -> np.ndarray:
    """The outputs' derivatives along DIRECTIONS (rows: the state's entries, then the
    inputs'), through the accelerations, drives and multipliers SOLVED gives."""
    compiled, buffer = build.compiled, build.compiled.buffer
    call = compiled.functions["outputs_tangent"]
    n_state = y.size
    qdd = np.ascontiguousarray(np.concatenate([solved.qdd, solved.drive]))
    lam = np.ascontiguousarray(solved.multipliers if solved.multipliers.size else np.zeros(1))
    out = np.empty((len(directions), len(build.output_names)))
    for k, direction in enumerate(directions):
        seed = np.ascontiguousarray(direction[:n_state])
        seed_u = np.ascontiguousarray(np.append(direction[n_state:], 0.0))
        dqdd = np.ascontiguousarray(np.concatenate([solved.dqdd[k], solved.ddrive[k]]))
        dlam = np.ascontiguousarray(np.append(solved.dmultipliers[k], 0.0))
        call(t, buffer(y), buffer(p), buffer(qdd), buffer(lam), buffer(seed), buffer(seed_u),
             buffer(dqdd), buffer(dlam), buffer(out[k]))
    return out


# ---- an equilibrium ---------------------------------------------------------------------------


@dataclass(frozen=True)
class OperatingPoint:
    """An equilibrium (dy/dt = 0): its state, its inputs' values, the largest |dy/dt| left,
    what was solved for, and what the equations do not fix there (left at the start)."""

    y: np.ndarray
    u: np.ndarray
    residual: float
    free: tuple[str, ...]
    undetermined: tuple[str, ...]
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]

    def __repr__(self) -> str:
        values = ", ".join(f"{n}={v:.6g}" for n, v in zip(
            (*self.state_names, *self.input_names), (*self.y, *self.u)))
        return f"OperatingPoint({values}; residual {self.residual:.2g})"


def trim(model: BuiltModel, y: Any = None, u: Any = None, *, fix: Mapping[str, float] | None
         = None, free: Sequence[str] | None = None, t: float = 0.0,
         params: Mapping[str, float] | None = None) -> OperatingPoint:
    """An equilibrium (see Model.trim)."""
    model.friction.refuse("trim")
    from scipy.optimize import least_squares

    t = checked_time(t)
    p0 = model.parameter_vector(params)
    start = model.state_vector(y, params).copy()
    names = (*model.state_names, *model.input_names)
    point = np.concatenate([start, input_vector(model, with_inputs(model, p0, u), t, start)])
    point[1:model.n_state:2] = 0.0  # at rest, unless fixed otherwise (or freed)
    for name, value in (fix or {}).items():
        if name not in names:
            raise ModelError(f"trim: fix names {name!r}, not a state entry or input of "
                             f"{list(names)}")
        point[names.index(name)] = float(value)
    chosen = list(free) if free is not None else default_free(model, point, t, params)
    unknown = [name for name in chosen if name not in names]
    if unknown:
        raise ModelError(f"trim: free names {unknown}, not state entries or inputs of "
                         f"{list(names)}")
    clash = [name for name in chosen if name in (fix or {})]
    if clash:
        raise ModelError(f"trim: {clash} both fixed and free")
    equilibrium = Equilibrium(model, point, [names.index(name) for name in chosen], t, params)
    found = least_squares(equilibrium.residual, point[equilibrium.columns],
                          jac=equilibrium.jacobian, method="trf", xtol=1e-15, ftol=1e-15,
                          gtol=1e-15, max_nfev=200)
    y_found, u_found = equilibrium.state(found.x)
    left = equilibrium.residual(found.x)
    scale = max(1.0, float(np.abs(found.x).max(initial=0.0)))
    if not np.abs(left).max(initial=0.0) <= TRIM_TOLERANCE * scale:
        worst = equilibrium.rows[int(np.abs(left).argmax())]
        raise ModelError(
            f"trim found no equilibrium: d({model.state_names[worst]})/dt stays "
            f"{np.abs(left).max():.3g} from 0 with {', '.join(chosen) or 'nothing'} free "
            "(start elsewhere, free more, or fix what cannot hold)")
    undetermined = equilibrium.undetermined(found.x, chosen)
    if free is not None and undetermined:
        raise ModelError(f"trim: the equilibrium does not fix {list(undetermined)} (the "
                         "equations do not depend on them there): hold them with fix= or "
                         "leave them out of free")
    return OperatingPoint(y_found, u_found, float(np.abs(left).max(initial=0.0)),
                          tuple(chosen), undetermined, model.state_names, model.input_names)


def default_free(model: BuiltModel, point: np.ndarray, t: float,
                 params: Mapping[str, float] | None) -> list[str]:
    """What trim solves for by default: the coordinates (a closed loop's independent ones),
    the rates and inputs held."""
    if not model.has_loops:
        return list(model.coordinate_names)
    lin = linearize(model, point[:model.n_state], point[model.n_state:] if
                    model.input_names else None, t=t, params=params)
    return list(lin.state_names[0::2])


class Equilibrium:
    """dy/dt at a point whose entries COLUMNS vary (the rest held), and its exact Jacobian (a
    closed loop's: at its state assembled from the varying coordinates, in its independent
    coordinates' rows)."""

    def __init__(self, model: BuiltModel, point: np.ndarray, columns: list[int], t: float,
                 params: Mapping[str, float] | None):
        self.model, self.point, self.columns, self.t, self.params = (model, point, columns, t,
                                                                     params)
        self.p0 = model.loops.started(t, point[:model.n_state], model.parameter_vector(params))
        self.rows = list(range(model.n_state))
        if model.has_loops:  # the rows: the state entries of the varying coordinates
            kept = {model.state_names[c] for c in columns if c < model.n_state}
            self.rows = [i for i, name in enumerate(model.state_names)
                         if name in kept or name.startswith("dot(") and name[4:-1] in kept]

    def state(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        full = self.point.copy()
        full[self.columns] = x
        y, u = full[:self.model.n_state], full[self.model.n_state:]
        if self.model.has_loops:
            given = np.zeros(self.model.n_state, dtype=bool)
            given[[c for c in self.columns if c < self.model.n_state]] = True
            given[1::2] = True  # the rates held (their values: the point's)
            y = self.model.loops.assembled(self.t, y, given, self.p(u))[0]
        return y, u

    def p(self, u: np.ndarray) -> np.ndarray:
        return with_inputs(self.model, self.p0, u) if u.size else self.p0

    def residual(self, x: np.ndarray) -> np.ndarray:
        y, u = self.state(x)
        return rhs_at(self.model, self.t, y, self.p(u))[self.rows]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        y, u = self.state(x)
        names = [self.model.state_names[c] for c in self.columns if c < self.model.n_state]
        lin = linearize(self.model, y, u if u.size else None, t=self.t, params=self.params,
                        independent=[n for n in names if not n.startswith("dot(")]
                        if self.model.has_loops else None)
        full = np.hstack([lin.A, lin.B])
        reduced_names = (*lin.state_names, *lin.input_names)
        all_names = (*self.model.state_names, *self.model.input_names)
        rows = [reduced_names.index(self.model.state_names[r]) for r in self.rows]
        cols = [reduced_names.index(all_names[c]) for c in self.columns]
        return full[np.ix_(rows, cols)]

    def undetermined(self, x: np.ndarray, chosen: Sequence[str]) -> tuple[str, ...]:
        """The varying entries along the Jacobian's null space: what the equilibrium does not
        fix."""
        jac = self.jacobian(x)
        _, singular, vt = np.linalg.svd(jac)
        rank = int(np.sum(singular > 1e-10 * max(singular.max(initial=0.0), 1.0)))
        null = vt[rank:]
        return tuple(name for i, name in enumerate(chosen)
                     if null.size and np.abs(null[:, i]).max() > 1e-6)


def rhs_at(model: BuiltModel, t: float, y: np.ndarray, p: np.ndarray) -> np.ndarray:
    return model.compiled.checked_rhs(p)(t, y)


# ---- a periodic motion ------------------------------------------------------------------------


@dataclass(frozen=True)
class Floquet:
    """The monodromy matrix of the motion from y over one period (d y(t0 + T) / d y(t0)), its
    multipliers (eigenvalues, by modulus) and exponents (log(mu) / T). The motion is stable
    in the linear sense when every multiplier lies inside the unit circle; a conservative
    system's lie on it (max_modulus 1)."""

    period: float
    monodromy: np.ndarray
    multipliers: np.ndarray
    y: np.ndarray  # the motion's state at t0
    y_end: np.ndarray  # at t0 + T (y again for a periodic motion)

    @property
    def max_modulus(self) -> float:
        return float(np.abs(self.multipliers).max())

    @property
    def exponents(self) -> np.ndarray:
        return np.log(self.multipliers.astype(complex)) / self.period


def floquet(model: BuiltModel, period: float, y: Any = None, *, t0: float = 0.0,
            params: Mapping[str, float] | None = None, u: Any = None,
            rtol: float = 1e-11, atol: float = 1e-13) -> Floquet:
    """The Floquet multipliers of the motion from y at t0 over PERIOD (see Model.floquet)."""
    model.friction.refuse("floquet")
    from scipy.integrate import solve_ivp

    if model.has_loops:
        raise ModelError("floquet: a closed loop's monodromy in independent coordinates is not "
                         "available yet; linearize it at states along the motion instead")
    if not (np.isfinite(period) and period > 0):
        raise ModelError(f"floquet: the period must be a finite number > 0, got {period}")
    p = with_inputs(model, model.parameter_vector(params), u)
    state = model.state_vector(y, params).copy()
    n = model.n_state
    rhs = model.compiled.checked_rhs(p)
    jacobian = model.compiled_with("jacobian")
    if not jacobian.has_part("jacobian"):
        raise ModelError("floquet needs the exact Jacobian: this standalone package was built "
                         "without it (nemc compile --jacobian)")
    jac = jacobian.compiled.integrator_jacobian(p)

    def variational(t: float, z: np.ndarray) -> np.ndarray:
        x, phi = z[:n], z[n:].reshape(n, n)
        return np.concatenate([rhs(t, x), (jac(t, x) @ phi).ravel()])

    z0 = np.concatenate([state, np.eye(n).ravel()])
    solution = solve_ivp(variational, (t0, t0 + period), z0, method="DOP853", rtol=rtol,
                         atol=atol)
    if not solution.success:
        raise ModelError(f"floquet: the variational equations failed: {solution.message}")
    end = solution.y[:, -1]
    monodromy = end[n:].reshape(n, n)
    multipliers = np.linalg.eigvals(monodromy)
    order = np.argsort(-np.abs(multipliers))
    return Floquet(period, monodromy, multipliers[order], state, end[:n])


__all__ = ["Floquet", "OperatingPoint", "floquet", "linearize", "trim", "SCALE"]
