"""The model as a plant, linearized: A, B, C, D at a state, exact (the build's part
"linearization": the forward-mode derivative of the derived equations in C, no finite
differences), its modes, and their state-space forms for scipy and python-control.

A tree's A, B, C, D come whole from one C call. A closed loop's come from its pieces: the
derivatives of the accelerations' program's results (the tree's accelerations, M^-1 Phi_q^T,
G, Phi_q, Phi_t) along each entry of the state and each input, through the index-1 equations
(lambda = -K^-1 (G + Phi_q qdd_tree), K = Phi_q M^-1 Phi_q^T) differentiated here, on the
constraints' tangent space: in independent coordinates q_i, the others following from
Phi(q) = 0 and Phi_q dq/dt + Phi_t = 0. The independent coordinates are the user's, else the
columns of Phi_q that QR with column pivoting leaves out of its first m pivots (the dependent
ones best conditioned), in the file's order.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .failures import ModelError


@dataclass(frozen=True)
class Modes:
    """The eigenvalues of A with their natural frequencies |lambda| (rad/s, and Hz), damping
    ratios -Re(lambda) / |lambda| (nan for lambda = 0) and mode shapes (columns), sorted by
    frequency."""

    eigenvalues: np.ndarray
    frequencies: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray
    state_names: tuple[str, ...]

    @property
    def hertz(self) -> np.ndarray:
        return self.frequencies / (2 * np.pi)

    def __repr__(self) -> str:
        rows = [f"{'eigenvalue':>28}  {'f (Hz)':>10}  {'damping':>8}"]
        for value, hz, zeta in zip(self.eigenvalues, self.hertz, self.damping):
            rows.append(f"{value.real:>13.6g} {value.imag:+13.6g}j  {hz:>10.5g}  {zeta:>8.4g}")
        return "\n".join(rows)


def modes_of(a: np.ndarray, state_names: Sequence[str]) -> Modes:
    values, vectors = np.linalg.eig(a)
    frequency = np.abs(values)
    with np.errstate(invalid="ignore", divide="ignore"):
        damping = np.where(frequency > 0, -values.real / frequency, np.nan) + 0.0  # no -0
    order = np.lexsort((values.imag, frequency))
    shapes = vectors[:, order]
    biggest = shapes[np.abs(shapes).argmax(axis=0), np.arange(shapes.shape[1])]
    shapes = shapes / np.where(biggest == 0, 1, biggest)  # largest entry 1 in each mode
    return Modes(values[order], frequency[order], damping[order], shapes, tuple(state_names))


@dataclass(frozen=True)
class Linearization:
    """dx/dt = A x + B u, out = C x + D u about (t, y, u): x the deviation of the state from y
    (in STATE_NAMES: a closed loop's independent coordinates and their rates), u the inputs'
    from their values u."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    t: float
    y: np.ndarray  # the whole state it was taken at
    u: np.ndarray  # the inputs' values there
    full_state_names: tuple[str, ...] = ()  # the whole state's entries (y's)
    dependent: tuple[str, ...] = ()  # a closed loop's coordinates that follow the others
    tangent: np.ndarray | None = field(default=None, repr=False)
    # ^ a closed loop's: d(whole state)/d(state_names' entries), where the reduced state lies

    def modes(self) -> Modes:
        return modes_of(self.A, self.state_names)

    def to_scipy(self) -> Any:
        """scipy.signal.StateSpace(A, B, C, D)."""
        from scipy import signal

        return signal.StateSpace(self.A, self.B, self.C, self.D)

    def to_control(self) -> Any:
        """python-control's StateSpace with the states', inputs' and outputs' names (signal
        names there cannot hold '.', '(' or ')': A.Fx is A_Fx, dot(q1) is dot_q1)."""
        try:
            import control
        except ImportError:
            raise ImportError("to_control needs python-control (pip install control); "
                              "to_scipy() needs only scipy") from None
        return control.ss(self.A, self.B, self.C, self.D, states=signal_names(self.state_names),
                          inputs=signal_names(self.input_names),
                          outputs=signal_names(self.output_names))

    def feedback(self, K: Any) -> Any:
        """nemc.feedback(K) about this operating point, for simulate's inputs: u = u0 - K (x -
        x0), K a row per input and a column per entry of state_names."""
        from .inputs import feedback

        columns = [self.full_state_names.index(name) for name in self.state_names]
        return feedback(K, self.y[columns], self.u, states=self.state_names)


def signal_names(names: Sequence[str]) -> list[str]:
    """NAMES as python-control takes them: '.' and parentheses become '_' (ddot(q1) ddot_q1)."""
    return [name.replace(".", "_").replace("(", "_").replace(")", "") for name in names]


# ---- a tree: one call ------------------------------------------------------------------------


def tree_matrices(call: Callable[..., int], t: float, y: np.ndarray, p: np.ndarray,
                  n_inputs: int, n_outputs: int, buffer: Callable) -> tuple[np.ndarray, ...]:
    """A, B, C, D from the build's linearization(t, y, p, ab, cd)."""
    n = y.size
    ab = np.empty((n, n + n_inputs))
    cd = np.empty((n_outputs, n + n_inputs))
    status = call(t, buffer(y), buffer(p), buffer(ab), buffer(cd) if n_outputs else
                  buffer(np.empty(1)))
    if status:
        raise ModelError(f"the equations cannot be evaluated at this state (status {status})")
    return ab[:, :n], ab[:, n:], cd[:, :n], cd[:, n:]


# ---- a closed loop: its pieces, the index-1 equations' derivative, independent coordinates --


@dataclass(frozen=True)
class LoopPieces:
    """The accelerations' program's results at a state (model.h's ACC_* layout) and their
    derivatives along the linearization's columns (a row per column)."""

    n: int  # coordinates
    drives: int
    m: int  # constraint equations
    acc: np.ndarray
    dacc: np.ndarray  # (n_state + n_inputs) x N_ACC

    def split(self, acc: np.ndarray) -> dict[str, np.ndarray]:
        """One vector of results (or a matrix, a row per direction) by meaning."""
        n, d, m = self.n, self.drives, self.m
        block = n + d
        at = block * (m + 1)
        units = acc[..., block:at].reshape(*acc.shape[:-1], m, block)
        return {"qdd": acc[..., :n], "drive": acc[..., n:block],
                "unit_qdd": np.swapaxes(units[..., :n], -1, -2),  # n x m: M^-1 Phi_q^T
                "unit_drive": np.swapaxes(units[..., n:], -1, -2),
                "bias": acc[..., at: at + m], "phi": acc[..., at + m: at + 2 * m],
                "phi_q": acc[..., at + 2 * m: at + 2 * m + m * n].reshape(
                    *acc.shape[:-1], m, n),
                "phi_t": acc[..., at + 2 * m + m * n: at + 3 * m + m * n]}


@dataclass(frozen=True)
class Solved:
    """A closed loop's accelerations, drives and multipliers at a state, and their derivatives
    along directions (a row per direction)."""

    qdd: np.ndarray
    drive: np.ndarray
    multipliers: np.ndarray
    dqdd: np.ndarray
    ddrive: np.ndarray
    dmultipliers: np.ndarray


def solve_index_one(pieces: LoopPieces, directions: np.ndarray) -> Solved:
    """qdd = qdd_tree + W lambda, K lambda = -(G + Phi_q qdd_tree), K = Phi_q W (W = M^-1
    Phi_q^T), and their derivatives along DIRECTIONS (rows: weights of the columns)."""
    at = pieces.split(pieces.acc)
    d = pieces.split(directions @ pieces.dacc)
    w, phi_q, qdd_tree = at["unit_qdd"], at["phi_q"], at["qdd"]
    k = phi_q @ w
    if np.linalg.matrix_rank(k, tol=1e-12 * max(1.0, np.abs(k).max())) < k.shape[0]:
        raise ModelError("the constraints lose rank at this state (a singular configuration "
                         "or redundant constraints): no linearization there")
    lam = np.linalg.solve(k, -(at["bias"] + phi_q @ qdd_tree))
    dk = d["phi_q"] @ w + phi_q @ d["unit_qdd"]
    rhs = -(d["bias"] + np.einsum("cij,j->ci", d["phi_q"], qdd_tree)
            + np.einsum("ij,cj->ci", phi_q, d["qdd"]) + np.einsum("cij,j->ci", dk, lam))
    dlam = np.linalg.solve(k, rhs.T).T
    dqdd = (d["qdd"] + np.einsum("cij,j->ci", d["unit_qdd"], lam)
            + np.einsum("ij,cj->ci", w, dlam))
    ddrive = (d["drive"] + np.einsum("cij,j->ci", d["unit_drive"], lam)
              + np.einsum("ij,cj->ci", at["unit_drive"], dlam))
    return Solved(qdd_tree + w @ lam, at["drive"] + at["unit_drive"] @ lam, lam, dqdd, ddrive,
                  dlam)


def independent_coordinates(phi_q: np.ndarray, names: Sequence[str],
                            chosen: Sequence[str] | None) -> tuple[list[int], list[int]]:
    """(independent, dependent) coordinate indices: CHOSEN's, else QR with column pivoting's
    (its first m pivots are the dependent ones)."""
    from scipy.linalg import qr

    m, n = phi_q.shape
    rank = np.linalg.matrix_rank(phi_q, tol=1e-10 * max(1.0, np.abs(phi_q).max()))
    if chosen is not None:
        unknown = [name for name in chosen if name not in names]
        if unknown:
            raise ModelError(f"independent coordinates {unknown} are not coordinates "
                             f"{list(names)}")
        independent = sorted(names.index(name) for name in chosen)
        dependent = [i for i in range(n) if i not in independent]
        if len(dependent) != rank or np.linalg.matrix_rank(phi_q[:, dependent]) < rank:
            raise ModelError(f"{list(chosen)} cannot be the independent coordinates here: the "
                             f"others ({[names[i] for i in dependent]}) must be {rank} that "
                             "the constraints fix")
        return independent, dependent
    _, _, pivots = qr(phi_q, pivoting=True, mode="economic")
    dependent = sorted(int(i) for i in pivots[:rank])
    return [i for i in range(n) if i not in dependent], dependent


def loop_matrices(pieces: LoopPieces, y: np.ndarray, names: Sequence[str],
                  chosen: Sequence[str] | None, n_inputs: int,
                  outputs: Callable[[Solved, np.ndarray], np.ndarray] | None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[int],
                             list[int], np.ndarray]:
    """A, B, C, D in independent coordinates, the independent and dependent coordinates and
    the tangent map from the reduced state to the whole state. OUTPUTS(solved, directions):
    the outputs' derivatives along the directions (rows), or None."""
    n = pieces.n
    at = pieces.split(pieces.acc)
    phi_q, rates = at["phi_q"], y[1::2]
    independent, dependent = independent_coordinates(phi_q, names, chosen)
    f = len(independent)
    follow = -np.linalg.solve(phi_q[:, dependent], phi_q[:, independent])  # d q_dep / d q_ind
    t_q = np.zeros((n, f))
    t_q[independent, np.arange(f)] = 1.0
    t_q[dependent] = follow
    n_state, columns = 2 * n, 2 * n + n_inputs
    along_q = np.zeros((f, columns))  # directions in the C's columns: position perturbations
    along_q[:, 0:n_state:2] = t_q.T
    moved = pieces.split(along_q @ pieces.dacc)  # d Phi_q, d Phi_t along them (rates fixed)
    drift = np.einsum("cij,j->ci", moved["phi_q"], rates) + moved["phi_t"]
    dependent_rates = -np.linalg.solve(phi_q[:, dependent], drift.T).T  # f x m
    along_q[:, [2 * i + 1 for i in dependent]] = dependent_rates
    along_u = np.zeros((f, columns))
    along_u[:, 1:n_state:2] = t_q.T
    inputs = np.zeros((n_inputs, columns))
    inputs[:, n_state:] = np.eye(n_inputs)
    directions = np.vstack([along_q, along_u, inputs])
    solved = solve_index_one(pieces, directions)
    reduced = np.zeros((2 * f, 2 * f))
    reduced[0::2, 2 * np.arange(f) + 1] = np.eye(f)  # d q_i / dt = dot(q_i)
    reduced[1::2, 0::2] = solved.dqdd[:f][:, independent].T
    reduced[1::2, 1::2] = solved.dqdd[f: 2 * f][:, independent].T
    b = np.zeros((2 * f, n_inputs))
    b[1::2] = solved.dqdd[2 * f:][:, independent].T
    tangent = np.zeros((n_state, 2 * f))  # d y / d reduced state
    tangent[:, 0::2] = along_q[:, :n_state].T
    tangent[:, 1::2] = along_u[:, :n_state].T
    if outputs is None:
        return reduced, b, np.zeros((0, 2 * f)), np.zeros((0, n_inputs)), independent, \
            dependent, tangent
    dout = outputs(solved, directions)
    c = np.zeros((dout.shape[1], 2 * f))
    c[:, 0::2], c[:, 1::2] = dout[:f].T, dout[f: 2 * f].T
    return reduced, b, c, dout[2 * f:].T, independent, dependent, tangent
