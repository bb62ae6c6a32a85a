"""A kinematic analysis's states (a closed loop its drives leave without a degree of freedom):
each time's state assembled from the constraints and kept on the branch the analysis starts on,
through isolated singular configurations too (decision 0036's continuation, in time).

Each state is assembled from its nearest known state (as before this module: a run away from
singular configurations gives the same states bit for bit) and checked against the prediction
along the motion (cubic Hermite through the two nearest known states, apart; near a singular
configuration within a fraction of Phi_q's conditioning, about the crossed branch's distance);
a solution on another branch is refused, the assembly started from the prediction, then the
step split. A time near a singular configuration (Phi_q's conditioning below KINEMATIC_WINDOW,
or its rank lost) takes its state and outputs from NODES times on each side of it out of the
configuration, by the polynomial through them (degree 7); where the motion does not leave the
configuration on a side, the loss of rank lasts and the analysis stops there.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .failures import ModelError

# Phi_q's conditioning (R's smallest kept pivot over its largest, Phi_q^T = Q R) below which the
# model's C extrapolates its dynamics (templates/loops.c.tmpl: two SINGULAR_WINDOWs): a state
# there takes its values from times out of it
KINEMATIC_WINDOW = 2e-2
SHIFT = 0.02  # near a singular configuration, the interpolation's nodes' spacing: coordinate
#               units over the rates' norm
NODES = 4  # the nodes on each side of a singular configuration (degree 2 NODES - 1)
EDGE_STEPS = 200  # the steps on each side within which the motion leaves it, else it lasts
BRANCH_FRACTION = 0.05  # how far a solution may lie from its prediction: this of the step's...
BRANCH_FLOOR = 1e-8  # ...motion, plus this (relative to the coordinates' size); and beyond the
#                      floor, this fraction of Phi_q's conditioning at the solution
LONGEST_STEP = 0.1  # the largest motion of a step the prediction is trusted over (coordinates)
REFINEMENTS = 30  # the splits of a step before the branch is declared lost
SPLITS = (0.5, 0.3)  # where a refined step is split (the second where the first is singular)
TRUSTED = 1e-6  # the conditioning above which a state predicts the ones after it
SEPARATION = 1e-2  # the least distance of the two known states predicting t, over t's from one


class BranchLost(Exception):
    """The analysis cannot follow its branch at a time (a message for the result)."""


@dataclass
class Passage:
    """A requested time (row INDEX) near a singular configuration: the times out of it its state
    and outputs are interpolated from, their states (one row each) and the weights."""

    index: int
    times: np.ndarray
    states: np.ndarray
    weights: np.ndarray


@dataclass
class KinematicStates:
    """The times reached, their states (n_state, n_t), why the analysis stopped early (or None),
    and the passages of singular configurations."""

    t: np.ndarray
    y: np.ndarray
    failure: str | None
    passages: list[Passage] = field(default_factory=list)


def hermite(known: list[tuple[float, np.ndarray]], t: float) -> np.ndarray:
    """The state at t predicted from the KNOWN (time, state) pairs (one or two; states
    interleaved q, dot(q)): the cubic Hermite curve through two, the tangent line of one."""
    (ta, ya), = known[:1]
    qa, va = ya[0::2], ya[1::2]
    out = np.empty_like(ya)
    if len(known) == 1:
        out[0::2], out[1::2] = qa + (t - ta) * va, va
        return out
    tb, yb = known[1]
    qb, vb = yb[0::2], yb[1::2]
    h = tb - ta
    s = (t - ta) / h
    h00, h10, h01, h11 = (2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2,
                          s**3 - s**2)
    d00, d10, d01, d11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
    out[0::2] = h00 * qa + h10 * h * va + h01 * qb + h11 * h * vb
    out[1::2] = (d00 * qa + d01 * qb) / h + d10 * va + d11 * vb
    return out


class BranchFollower:
    """The states of one kinematic analysis on its branch. ASSEMBLE(t, guess) is the state
    assembled at t from guess (or raises ModelError); CONDITIONING(t, y) is Phi_q's there, as
    the model's C measures it (R's smallest kept pivot over its largest, Phi_q^T = Q R), and its
    rank, which is RANK away from singular configurations."""

    def __init__(self, assemble: Callable[[float, np.ndarray], np.ndarray],
                 conditioning: Callable[[float, np.ndarray], tuple[float, int]], rank: int,
                 t0: float, y0: np.ndarray):
        self.assemble, self.measure, self.rank = assemble, conditioning, rank
        self.measured: tuple[float, bytes, tuple[float, int]] | None = None  # the last one
        self.times: list[float] = [t0]  # the known states' times, sorted, out of singularities
        self.states: list[np.ndarray] = [y0]

    def nearest(self, t: float) -> list[tuple[float, np.ndarray]]:
        """The (at most) two known states nearest t, nearest first; the second at least
        SEPARATION of the distance to t from the first (two states almost at one time, as a
        requested time and a passage's node can be, make a cubic that extrapolates them by
        their distance's inverse cubed)."""
        at = bisect.bisect_left(self.times, t)
        around = range(max(at - 3, 0), min(at + 3, len(self.times)))
        first, *others = sorted(around, key=lambda k: (abs(self.times[k] - t), -k))
        apart = SEPARATION * abs(t - self.times[first])
        second = [k for k in others if abs(self.times[k] - self.times[first]) >= apart][:1]
        return [(self.times[k], self.states[k]) for k in (first, *second)]

    def conditioning(self, t: float, y: np.ndarray) -> tuple[float, int]:
        """Phi_q's conditioning and rank at y at t (the last kept: a solution's branch check
        and the singularity check after it measure the same state)."""
        key = y.tobytes()
        if self.measured is None or self.measured[:2] != (t, key):
            self.measured = (t, key, self.measure(t, y))
        return self.measured[2]

    def remember(self, t: float, y: np.ndarray) -> None:
        """A state out of singular configurations, for the predictions that follow."""
        at = bisect.bisect_left(self.times, t)
        if at < len(self.times) and self.times[at] == t:
            return
        self.times.insert(at, t)
        self.states.insert(at, y)

    def singular(self, t: float, y: np.ndarray) -> bool:
        """Whether y at t is at or near a singular configuration (its values then
        interpolated): Phi_q ill-conditioned there, or of a rank below its generic one."""
        ratio, rank = self.conditioning(t, y)
        return ratio < KINEMATIC_WINDOW or rank < self.rank

    def solved(self, t: float, depth: int = 0) -> np.ndarray:
        """The state at t on the branch: assembled from the nearest known state, else from the
        prediction, else (and when the step moves more than LONGEST_STEP) after a state halfway
        there; BranchLost when none is near the prediction."""
        known = self.nearest(t)
        prediction, base = hermite(known, t), known[0][1]
        motion = np.abs(prediction[0::2] - base[0::2]).max()
        allowed = BRANCH_FRACTION * motion + BRANCH_FLOOR * (1.0 + np.abs(prediction[0::2]).max())
        unassembled = None
        for guess in (base, prediction) if motion <= LONGEST_STEP else ():
            try:
                state = self.assemble(t, guess)
            except ModelError as error:
                unassembled = error
                continue
            if self.near(t, state, prediction, allowed):
                return state
        if depth < REFINEMENTS:
            for fraction in SPLITS:  # a state on the way there (not at the singular instant)
                middle = known[0][0] + fraction * (t - known[0][0])
                if middle in (t, known[0][0]):
                    break
                halfway = self.solved(middle, depth + 1)
                if self.trusted(middle, halfway):
                    self.remember(middle, halfway)
                    return self.solved(t, depth + 1)
        if unassembled is not None:  # beyond the positions the branch reaches (a dead point)
            raise BranchLost(f"at t={t:.9g}: {unassembled}")
        raise BranchLost(f"at t={t:.9g}: the assembly leaves the branch the analysis is on and "
                         "no smaller step keeps it there (a dead point: the drives carry the "
                         "mechanism past the positions its branch reaches)")

    def near(self, t: float, state: np.ndarray, prediction: np.ndarray, allowed: float) -> bool:
        """Whether STATE lies on the branch of its PREDICTION: within ALLOWED of it, and near a
        singular configuration within BRANCH_FRACTION of Phi_q's conditioning there (the other
        branch lies about that far away: a step's motion can be larger, and its assembly from
        the state before then lands on the crossed branch within 5% of it)."""
        distance = np.abs(state[0::2] - prediction[0::2]).max()
        if not distance <= allowed:
            return False
        floor = BRANCH_FLOOR * (1.0 + np.abs(prediction[0::2]).max())
        return distance <= floor or distance <= BRANCH_FRACTION * self.conditioning(t, state)[0]

    def trusted(self, t: float, y: np.ndarray) -> bool:
        """Whether y at t may predict the states after it: Phi_q of full rank there, its
        conditioning at least TRUSTED (the rates' rounding small)."""
        ratio, rank = self.conditioning(t, y)
        return ratio >= TRUSTED and rank >= self.rank

    def passage(self, t: float) -> Passage | None:
        """The times around t (near a singular configuration) out of it, 4 on each side, their
        states on the branch and the weights interpolating them at t; None where the motion
        does not leave the configuration within EDGE_STEPS steps on a side (the loss of rank
        lasts) or no motion is there."""
        rates = hermite(self.nearest(t), t)[1::2]
        speed = float(np.sqrt(np.sum(rates**2)))
        if not speed > 0.0:
            return None
        step = SHIFT / speed
        times: list[float] = []
        states: list[np.ndarray] = []
        for direction in (-1.0, 1.0):  # before t, then after it (predicted from before)
            try:
                edge = self.edge(t, direction * step)
            except BranchLost:  # within the configuration: where it leaves it is not determined
                return None
            if edge is None:
                return None
            for k in range(NODES):
                s = edge + direction * k * step
                state = self.solved(s)
                if self.singular(s, state):
                    return None
                self.remember(s, state)
                times.append(s)
                states.append(state)
        order = np.argsort(times)
        nodes = np.array(times)[order]
        return Passage(-1, nodes, np.array(states)[order], lagrange_weights(nodes, t))

    def edge(self, t: float, step: float) -> float | None:
        """The first time t + k step (k = 1, 2, ...) out of the singular configuration at t;
        None past EDGE_STEPS steps."""
        for k in range(1, EDGE_STEPS + 1):
            s = t + k * step
            if not self.singular(s, self.solved(s)):
                return s
        return None


def lagrange_weights(nodes: np.ndarray, t: float) -> np.ndarray:
    """The weights of values at NODES whose sum is their interpolating polynomial at t."""
    weights = np.ones(len(nodes))
    for j, node in enumerate(nodes):
        for k, other in enumerate(nodes):
            if k != j:
                weights[j] *= (t - other) / (node - other)
    return weights


def kinematic_states(follower: BranchFollower, times: np.ndarray, lasting: Callable[
        [float, np.ndarray], str]) -> KinematicStates:
    """The states at TIMES on follower's branch (the first its known state's), the passages of
    singular configurations, and why the analysis stopped early (LASTING(t, y): the message of
    a loss of rank that lasts)."""
    rows: list[np.ndarray] = []
    passages: list[Passage] = []
    failure = None
    for t in times.astype(float):
        try:
            state = follower.solved(t)
        except BranchLost as lost:
            failure = str(lost)
            break
        if follower.singular(t, state):
            try:
                passage = follower.passage(t)
            except BranchLost as lost:
                failure = str(lost)
                break
            if passage is None:
                failure = lasting(t, state)
                break
            passage.index = len(rows)
            passages.append(passage)
            state = passage.weights @ passage.states
        else:
            follower.remember(t, state)
        rows.append(state)
    n_state = len(follower.states[0])
    y = np.array(rows).T.reshape(n_state, -1)
    return KinematicStates(times[:len(rows)], y, failure, passages)
