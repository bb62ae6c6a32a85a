"""Closed loops at run time: a consistent initial state from the scene's (or the caller's)
partial one, the states a run returns brought onto the constraints, their residuals, and the
kinematic analysis of a mechanism its drives leave without a degree of freedom.

The model's C does the numerical work (templates/loops.c.tmpl: `assemble`, `project`,
`constraint_residual`); Loops calls it and says, by name, which constraint cannot hold.
`Model.loops` is one, for tools and tests too.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .compiled import Compiled
from .failures import ModelError, loop_equation
from .kinematic import BranchFollower, KinematicStates, kinematic_states
from .passages import SingularPassage, singular_passages

ASSEMBLY_TOLERANCE = 1e-10  # what an assembled or given state may leave of a constraint


SINGULAR_START = 1e-6  # a start where Phi_q's singular values fall below this (relative)
GENERIC_SAMPLES = 5  # random positions at which Phi_q's rank away from singularities is taken


def matrix_rank(matrix: np.ndarray, relative: float = 1e-9) -> int:
    """The numerical rank: singular values over RELATIVE x the largest entry (at least 1)."""
    if not matrix.size or not np.all(np.isfinite(matrix)):
        return 0
    return int(np.linalg.matrix_rank(matrix, tol=relative * max(1.0, np.abs(matrix).max())))


class Loops:
    """The closed loops of one build (none for a tree: then every state is consistent)."""

    def __init__(self, metadata: Mapping[str, Any], compiled: Compiled):
        self.metadata = metadata
        self.compiled = compiled
        self.state_names = compiled.state_names
        self.n_state = compiled.n_state
        # the constraint owning each constraint equation (empty for a tree)
        self.constraint_equations: tuple[str, ...] = compiled.constraint_equations
        self.has_loops = bool(self.constraint_equations)
        self._generic_rank: tuple[Any, int] = (None, 0)  # ((t, p), Phi_q's generic rank)
        # (equation, its offset's index in p) of the equations that hold "as at the start"
        self.starts: list[tuple[int, int]] = [tuple(pair) for pair in  # type: ignore[misc]
                                              metadata.get("constraint_starts", [])]
        # the equations on the velocities (nonholonomic: a knife edge's), by index
        self.on_velocities: tuple[int, ...] = tuple(metadata.get("constraint_on_velocities", []))

    def started(self, t0: float, y0: np.ndarray, p: np.ndarray) -> np.ndarray:
        """p with the offsets of the equations that hold "as at the start" (a gear pair's,
        a rolling disc's) set to what those equations' g(q) are at (t0, y0); p itself without
        such equations."""
        if not self.starts:
            return p
        p = p.copy()
        offsets = [index for _, index in self.starts]
        p[offsets] = 0.0
        phi = np.empty(len(self.constraint_equations))
        buffer = self.compiled.buffer
        state = np.ascontiguousarray(y0, dtype=float)
        self._loop_c("constraint_phi")(float(t0), buffer(state), buffer(p), buffer(phi))
        p[offsets] = phi[[k for k, _ in self.starts]]
        return p

    def started_runs(self, t0: float, y0s: np.ndarray, ps: np.ndarray) -> np.ndarray:
        """An ensemble's parameter rows (k of them where offsets are set) started at y0s."""
        if not self.starts:
            return ps
        return np.array([self.started(t0, y0, ps[run % len(ps)])
                         for run, y0 in enumerate(y0s)])

    def _loop_c(self, name: str) -> Any:
        return getattr(self.compiled.lib, self.compiled.prefix + name)

    # -- residuals and projection -------------------------------------------------------------

    def residual(self, ts: np.ndarray, ys: np.ndarray, p: np.ndarray) -> np.ndarray:
        """|Phi(q, t)| and |Phi_q q' + Phi_t| (the largest entry of each) at the states YS
        (n, n_state) and times TS (n,), shape (n, 2) (Model.constraint_residual)."""
        out = np.empty((len(ys), 2))
        buffer = self.compiled.buffer
        self._loop_c("constraint_residual")(len(ys), buffer(ts), buffer(ys), buffer(p),
                                            buffer(out))
        return out

    def projected(self, t: np.ndarray, y: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The states y (n_state, n_t) at times t brought onto the constraints (y itself for a
        tree). A state that cannot be is left as it is (its run reports why)."""
        if not self.has_loops or not y.size:
            return y
        ys = np.ascontiguousarray(y.T, dtype=float)
        ts = np.ascontiguousarray(np.broadcast_to(np.asarray(t, dtype=float), (len(ys),)))
        out = ys.copy()
        buffer, project = self.compiled.buffer, self._loop_c("project")
        for k in range(len(ys)):  # one by one: a state that fails keeps its value
            project(1, buffer(ts[k:k + 1]), buffer(ys[k]), buffer(p), buffer(out[k]))
        return out.T

    def jacobian_at(self, t: float, y: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Phi_q at (t, y) and parameters p (one row a constraint equation)."""
        jacobian = np.empty((len(self.constraint_equations), len(self.state_names) // 2))
        buffer = self.compiled.buffer
        state = np.ascontiguousarray(y, dtype=float)
        self._loop_c("constraint_jacobian")(float(t), buffer(state), buffer(p), buffer(jacobian))
        return jacobian

    def conditioning_at(self, t: float, y: np.ndarray, p: np.ndarray) -> tuple[float, int]:
        """Phi_q's conditioning at (t, y) as the right-hand side measures it (R's smallest kept
        pivot over its largest, Phi_q^T = Q R: below 2e-2 it passes a singular configuration)
        and its rank (the pivots kept)."""
        return self.pivot_at(t, y, p)[:2]

    def pivot_at(self, t: float, y: np.ndarray, p: np.ndarray) -> tuple[float, int, int]:
        """conditioning_at's two and the constraint equation of the smallest kept pivot."""
        ratio, rank, where = self.pivots_at(np.array([t]), np.asarray(y)[None, :], p)
        return float(ratio[0]), int(rank[0]), int(where[0])

    def pivots_at(self, ts: np.ndarray, ys: np.ndarray, p: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """pivot_at's three at the states YS (n, n_state) and times TS (n,), one C call."""
        out = np.empty((len(ys), 3))
        buffer = self.compiled.buffer
        states = np.ascontiguousarray(ys, dtype=float)
        times = np.ascontiguousarray(ts, dtype=float)
        self._loop_c("constraint_conditioning")(len(states), buffer(times), buffer(states),
                                                buffer(p), buffer(out))
        rank = len(self.constraint_equations) - out[:, 1].astype(int)
        return out[:, 0], rank, out[:, 2].astype(int)

    def passages(self, t: np.ndarray, y: np.ndarray, p: np.ndarray) -> list[SingularPassage]:
        """The singular configurations a free run of states Y (n_state, n_t) at times T passed
        (passages.singular_passages), in order; none for a tree."""
        if not self.has_loops or not len(t):
            return []
        return singular_passages(lambda s, states: self.pivots_at(s, states.T, p),
                                 self.generic_rank(float(t[0]), p), self.constraint_equations,
                                 np.asarray(t, dtype=float), np.asarray(y, dtype=float))

    def generic_rank(self, t: float, p: np.ndarray) -> int:
        """The rank Phi_q has away from singular configurations: its largest at a few seeded
        random positions (a singular one is a set of measure zero), kept per parameters."""
        key = (float(t), p.tobytes())
        if self._generic_rank[0] != key:
            rng = np.random.default_rng(51)
            states = [self.random_positions(rng) for _ in range(GENERIC_SAMPLES)]
            self._generic_rank = (key, max(matrix_rank(self.jacobian_at(t, y, p))
                                           for y in states))
        return self._generic_rank[1]

    def random_positions(self, rng: np.random.Generator) -> np.ndarray:
        """A state with every coordinate drawn in [-pi, pi] and every rate 0 (the state holds
        each coordinate then its rate: STATE_Q(i) = 2 i)."""
        state = np.zeros(len(self.state_names))
        state[0::2] = rng.uniform(-np.pi, np.pi, state.size // 2)
        return state

    def singular_start(self, t0: float, y0: np.ndarray, p: np.ndarray) -> str:
        """Whether the start y0 is at a singular configuration (Phi_q loses rank there): the
        note naming the constraint most involved and the ranks, or ''."""
        jacobian = self.jacobian_at(t0, y0, p)  # a start the solve nears only to 1e-8 or so
        rank, generic = matrix_rank(jacobian, SINGULAR_START), self.generic_rank(t0, p)
        if rank >= generic:
            return ""
        left = np.linalg.svd(jacobian)[0]
        weakest = self.constraint_equations[int(np.abs(left[:, rank]).argmax())]
        n = len(self.state_names) // 2
        return (f"the initial state is at a singular configuration: constraint {weakest!r} "
                f"loses rank there (Phi_q has rank {rank} there, {generic} elsewhere), where "
                f"the degrees of freedom ({n - rank} there, {n - generic} elsewhere) and the "
                "rates are not the mechanism's; start away from it (a run passes such "
                "positions, decision 0036, but cannot start at one)")

    def singularity_note(self, t: float, y: np.ndarray, p: np.ndarray) -> str:
        """Where a run of a closed loop stopped, whether the constraints lose rank there (a
        singular configuration), naming the constraint most involved; '' if they do not."""
        if not self.has_loops or not np.all(np.isfinite(y)):
            return ""
        n = len(self.state_names) // 2
        jacobian = np.empty((len(self.constraint_equations), n))
        buffer = self.compiled.buffer
        state = np.ascontiguousarray(y, dtype=float)
        self._loop_c("constraint_jacobian")(float(t), buffer(state), buffer(p), buffer(jacobian))
        left, values, _ = np.linalg.svd(jacobian)
        ratio = values[-1] / values[0] if values[0] > 0 else 0.0
        if len(values) < len(self.constraint_equations):
            ratio = 0.0
        if ratio > 1e-4:
            return ""
        weakest = self.constraint_equations[int(np.abs(left[:, -1]).argmax())]
        return (f" Near t={t:.9g} constraint {weakest!r} is at a singular configuration (its "
                f"equations lose rank: smallest singular value {ratio:.2g} of the largest), "
                "where the accelerations are ill-conditioned (a configuration passed at speed "
                "is extrapolated through: decision 0036)")

    # -- assembly -------------------------------------------------------------------------

    def assembled(self, t0: float, y0: np.ndarray, given: np.ndarray, p: np.ndarray,
                  check_start: bool = True) -> tuple[np.ndarray, int]:
        """y0 made consistent at t0: the entries marked given kept, the others solved from the
        constraints starting from their values in y0 (the guess); and the number of degrees of
        freedom left (coordinates less the rank of Phi_q). Raises the model's error naming the
        constraint that cannot hold, or (check_start: a run's start, not a kinematic
        analysis's later step) the singular configuration it starts at."""
        if not self.has_loops:
            return y0, len(self.state_names) // 2
        state = np.ascontiguousarray(y0, dtype=float).copy()
        mask = np.ascontiguousarray(given, dtype=np.intc)
        info = np.zeros(5)
        buffer = self.compiled.buffer
        status = self._loop_c("assemble")(float(t0), buffer(state),
                                          self.compiled.ffi.from_buffer("int[]", mask),
                                          buffer(p), buffer(info))
        if status:
            singular = self.singular_start(t0, state, p) if check_start else ""
            raise ModelError(singular or self.assembly_failure(status, info, given, state))
        if check_start and (singular := self.singular_start(t0, state, p)):
            raise ModelError(singular)
        freedom = len(self.state_names) // 2 - int(info[4])
        # equations on the velocities leave positions that move with the rates: integrated,
        # never a kinematic analysis, even where they leave no freedom of motion
        return state, max(freedom, 1) if self.on_velocities else freedom

    def assembly_failure(self, status: int, info: np.ndarray, given: np.ndarray,
                         state: np.ndarray) -> str:
        """Why an assembly failed, naming the constraint and the given values (kept in
        STATE)."""
        named = [f"{name}={value:.9g}" for name, kept, value
                 in zip(self.state_names, given, state) if kept]
        constraint = loop_equation(self.constraint_equations, status)
        values = f" with {', '.join(named)} given" if named else ""
        if -2000 < status <= -1000:
            return (f"the mechanism cannot be assembled{values}: constraint "
                    f"{constraint!r} is left {info[0]:.3g} from closing "
                    f"(more than {ASSEMBLY_TOLERANCE:g}); change the initial values, the guess "
                    "(which picks the assembly's branch) or the geometry")
        if not np.asarray(given)[1::2].any():  # no rate given: the drives' motion
            return (f"no rates satisfy constraint {constraint!r} (residual {info[2]:.3g})"
                    f"{values}: the mechanism cannot move as its drives prescribe there (locked "
                    "against them, or at a dead position)")
        return (f"the given rates cannot satisfy constraint {constraint!r} "
                f"(residual {info[2]:.3g}){values}; give fewer rates, or consistent ones")

    def assembled_runs(self, t0: float, y0s: np.ndarray, given: np.ndarray, ps: np.ndarray
                       ) -> np.ndarray:
        """An ensemble's initial states (k, n_state), each assembled at its parameters ps
        (k or 1 rows); a run that cannot be is refused by its number; an ensemble needs a
        degree of freedom."""
        states = np.empty_like(y0s)
        for run, y0 in enumerate(y0s):
            try:
                states[run], freedom = self.assembled(t0, y0, given, ps[run % len(ps)])
            except ModelError as error:
                raise ModelError(f"simulate_many: run {run} of {len(y0s)}: {error}") from None
            if freedom == 0:
                raise ModelError(
                    "simulate_many: this mechanism has no degree of freedom left by its drives "
                    "(a kinematic analysis): use simulate")
        return states

    def projected_runs(self, t: np.ndarray, y: np.ndarray, ps: np.ndarray) -> np.ndarray:
        """An ensemble's states (k, n_t, n_state) brought onto the constraints (NaN rows of runs
        that stopped early stay NaN)."""
        out = y.copy()
        for run in range(len(y)):
            finite = np.all(np.isfinite(y[run]), axis=1)
            out[run, finite] = self.projected(t[finite], y[run, finite].T,
                                              ps[run % len(ps)]).T
        return out

    # -- no degree of freedom: a kinematic analysis -----------------------------------------

    def kinematic_states(self, t0: float, times: np.ndarray, y0: np.ndarray, p: np.ndarray
                         ) -> KinematicStates:
        """The states of a mechanism its drives leave without a degree of freedom at each time,
        on the branch of y0 (assembled at t0 already), through isolated singular configurations
        (runtime/kinematic.py): the times reached, their states, the passages, and why the
        analysis stopped early (or None)."""
        nothing = np.zeros(self.n_state, dtype=bool)

        def assemble(t: float, guess: np.ndarray) -> np.ndarray:
            return self.assembled(t, guess, nothing, p, check_start=False)[0]

        def conditioning(t: float, y: np.ndarray) -> tuple[float, int]:
            return self.conditioning_at(t, y, p)

        follower = BranchFollower(assemble, conditioning, self.generic_rank(t0, p), float(t0),
                                  y0)
        return kinematic_states(follower, times, lambda t, y: self.lasting(t, y, p))

    def lasting(self, t: float, y: np.ndarray, p: np.ndarray) -> str:
        """Why a kinematic analysis stops at a singular configuration whose loss of rank lasts
        (the drives hold the mechanism in it, or move it within it)."""
        left, values, _ = np.linalg.svd(self.jacobian_at(t, y, p))
        weakest = self.constraint_equations[int(np.abs(left[:, values.size - 1]).argmax())]
        return (f"at t={t:.9g}: constraint {weakest!r} loses rank there and the drives do not "
                "carry the mechanism out of it on a determined branch: a singular (locked) "
                "configuration that lasts (an isolated one is passed: decision 0036)")

    def given_mask(self, y0: Any) -> np.ndarray:
        """Which entries of the initial state the caller (or the scene) gives: the scene's
        `initial` for y0 None, a dict's keys, every entry of an array."""
        if y0 is None:
            given = set(self.metadata.get("initial_given", ()))
        elif isinstance(y0, Mapping):
            given = set(y0)
        else:
            given = set(self.state_names)
        return np.array([name in given for name in self.state_names])
