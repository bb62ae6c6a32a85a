"""The inverse dynamics linear in the inertial parameters: tau = Y(q, qd, qdd) phi - Q, its base
parameters and their estimate by linear least squares (Model.regressor, nemc.identify).

phi holds per body (m, m cx, m cy, I_O) (named "BODY.m", "BODY.mx", "BODY.my", "BODY.I": mass,
first moments in the body frame, inertia about the body's origin), then the load coefficients
named as linear; Q the loads' other generalized forces (nemc/derive/regressor.py). A tree's rows
are its coordinates (every joint's, a driven one's too): tau the generalized force its joint's
actuator supplies. A closed loop's rows are its driven joints' drives, the constraint forces
eliminated: [Phi_q^T  B] [lambda; tau] = Y phi - Q, square when every degree of freedom is
driven (otherwise refused).

The base parameters are the combinations of phi the data identify (Gautier, Khalil): the
columns of Y stacked over the samples, scaled to unit norm, kept in a preferred order when
independent of those kept before (a QR factorization's diagonal: the inertias and first
moments body by body, then the linear coefficients, then the masses, so that a body's mass is
regrouped into the bodies it hangs from, "link1.I + L1**2*link2.m"), every other column written
in the kept ones (least squares, exact: it is dependent), its coefficients named in the
parameters where they are monomials of them (regressor_names.py).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import scipy.linalg

from .regressor_names import coefficient_texts

RANK_TOLERANCE = 1e-8  # a scaled column with |R_kk| below this (relative) is dependent
ZERO_COLUMN = 1e-12  # a column this small (relative to the largest) is rounding: zero
COEFFICIENT_TOLERANCE = 1e-9  # a combination's coefficient this small (relative) is 0
LOOP_CONDITION = 1e12  # [Phi_q^T B] this ill-conditioned: a singular configuration
SAMPLES = 64  # Model.base_parameters' random states (trees)


class RegressorSource(Protocol):
    """The regressor's code (nemc/emit/regressor_code.py's RegressorCode)."""

    names: tuple[str, ...]
    coordinate_names: tuple[str, ...]
    driven: tuple[int, ...]
    equations: int
    columns: Callable[..., list]
    loads: Callable[..., list]
    constraints: Callable[..., list]
    values: Callable[..., list]


@dataclass(frozen=True)
class BaseParameters:
    """The identifiable combinations of phi: base = combination @ phi."""

    names: tuple[str, ...]  # readable: "link1.I + L1**2*link2.m" (or "+ 0.25*link2.m")
    combination: np.ndarray  # (r, len(phi))
    independent: tuple[int, ...]  # phi's entries kept, one per base parameter
    parameter_names: tuple[str, ...]  # phi's

    @property
    def rank(self) -> int:
        return len(self.names)


@dataclass(frozen=True)
class Identification:
    """nemc.identify's estimate of the base parameters, with standard errors."""

    names: tuple[str, ...]  # the base parameters'
    values: np.ndarray
    stderr: np.ndarray
    covariance: np.ndarray
    residual: np.ndarray  # tau + Q - Y_base values, stacked sample by sample
    expected: np.ndarray  # the base parameters at the model's parameters (combination @ phi)
    base: BaseParameters
    sigma: float  # the noise's standard deviation used (given, or from the residual)

    @property
    def rank(self) -> int:
        return self.base.rank

    def __repr__(self) -> str:
        rows = [f"  {name} = {value:.6g} ± {err:.2g} (model: {exp:.6g})" for name, value, err,
                exp in zip(self.names, self.values, self.stderr, self.expected)]
        return "Identification(\n" + "\n".join(rows) + f"\n  sigma = {self.sigma:.3g})"


class Regressor:
    """A model's regressor at one parameter vector p (Model.regressor_at)."""

    def __init__(self, code: RegressorSource, p: np.ndarray,
                 parameter_names: Sequence[str] = ()):
        self.code, self.p = code, [float(v) for v in p]
        self.parameter_names = tuple(parameter_names)  # p's first entries' (the base's names)
        self.names: tuple[str, ...] = code.names
        self.coordinate_names: tuple[str, ...] = code.coordinate_names
        n, loops = len(code.coordinate_names), code.equations
        if loops and loops + len(code.driven) != n:
            raise ValueError(
                f"a closed loop's regressor needs every degree of freedom driven: "
                f"{n} coordinates, {loops} constraint equations, {len(code.driven)} driven")
        self.row_names: tuple[str, ...] = tuple(
            code.coordinate_names[i] for i in code.driven) if loops else code.coordinate_names

    def at(self, p: np.ndarray) -> Regressor:
        """The same regressor at another parameter vector."""
        return Regressor(self.code, p, self.parameter_names)

    def base(self, t: Any, q: Any, qd: Any, qdd: Any) -> BaseParameters:
        """The base parameters these samples identify, named in the parameters where their
        coefficients are monomials of them (regressor_names.py)."""
        def restack(p: np.ndarray) -> np.ndarray:
            return self.at(p).matrix(t, q, qd, qdd)[0].reshape(-1, len(self.names))

        base = base_parameters(restack(np.array(self.p)), self.names)
        texts = coefficient_texts(base.combination, base.independent, restack,
                                  np.array(self.p), self.parameter_names)
        if not texts:
            return base
        names = tuple(combination_name(row, self.names, {k: text for (i, k), text
                                                          in texts.items() if i == r})
                      for r, row in enumerate(base.combination))
        return dataclasses.replace(base, names=names)

    def values(self) -> np.ndarray:
        """phi at the parameters."""
        zeros = [0.0] * len(self.coordinate_names)
        return np.array(self.code.values(0.0, zeros, zeros, zeros, self.p), dtype=float)

    def matrix(self, t: Any, q: Any, qd: Any, qdd: Any) -> tuple[np.ndarray, np.ndarray]:
        """(Y, Q) over the samples: (n_t, rows, len(phi)) and (n_t, rows); q, qd, qdd of shape
        (coordinates,) or (coordinates, n_t), t a number or (n_t,)."""
        t, q, qd, qdd = samples(t, q, qd, qdd, len(self.coordinate_names))
        count, n = t.size, len(self.coordinate_names)
        args = (t, list(q), list(qd), list(qdd), self.p)
        y = entries(self.code.columns, args, count).reshape(count, n, len(self.names))
        loads = entries(self.code.loads, args, count)
        if not self.code.equations:
            return y, loads
        phi_q = entries(self.code.constraints, args, count).reshape(count, -1, n)
        return drives(phi_q, self.code.driven, y, loads)


def samples(t: Any, q: Any, qd: Any, qdd: Any, n: int
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """t as (n_t,), q, qd, qdd as (n, n_t), checked: ValueError naming what is wrong."""
    arrays = []
    for name, value in (("q", q), ("qd", qd), ("qdd", qdd)):
        array = np.asarray(value, dtype=float)
        array = array.reshape(n, 1) if array.ndim == 1 and array.size == n else array
        if array.ndim != 2 or array.shape[0] != n:
            raise ValueError(f"{name}: expected shape ({n},) or ({n}, n_t), got "
                             f"{np.shape(value)} (one row per coordinate, driven ones too)")
        arrays.append(array)
    count = arrays[0].shape[1]
    times = np.asarray(t, dtype=float).reshape(-1)
    times = np.full(count, times[0]) if times.size == 1 else times
    for name, array in (("t", times), ("q", arrays[0]), ("qd", arrays[1]),
                        ("qdd", arrays[2])):
        if array.shape[-1] != count:
            raise ValueError(f"{name}: {array.shape[-1]} samples where q has {count}")
        if not np.all(np.isfinite(array)):
            raise ValueError(f"{name}: not finite (NaN or inf) at sample "
                             f"{int(np.argwhere(~np.isfinite(array))[0][-1])}")
    return times, arrays[0], arrays[1], arrays[2]


def entries(function: Callable[..., list], args: tuple, count: int) -> np.ndarray:
    """FUNCTION's entries at ARGS as (count, entries): constants broadcast over the samples."""
    values = function(*args)
    if not values:
        return np.zeros((count, 0))
    return np.stack([np.broadcast_to(np.asarray(v, dtype=float), (count,)) for v in values],
                    axis=1)


def drives(phi_q: np.ndarray, driven: Sequence[int], y: np.ndarray, loads: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """A closed loop's rows: [Phi_q^T B] [lambda; tau] = Y phi - Q solved for tau, sample by
    sample. ValueError: a sample where the system is singular."""
    count, equations, n = phi_q.shape
    select = np.zeros((n, len(driven)))
    select[list(driven), range(len(driven))] = 1.0
    system = np.concatenate([phi_q.transpose(0, 2, 1), np.broadcast_to(
        select, (count, n, len(driven)))], axis=2)
    conditions = np.linalg.cond(system)
    if np.any(~(conditions < LOOP_CONDITION)):
        bad = int(np.argmax(~(conditions < LOOP_CONDITION)))
        raise ValueError(f"sample {bad}: the loop is at a singular configuration (its "
                         "constraint forces and drives are not determined there)")
    right = np.concatenate([y, loads[:, :, None]], axis=2)
    solved = np.linalg.solve(system, right)[:, equations:, :]
    return solved[:, :, :-1], solved[:, :, -1]


def base_parameters(stacked: np.ndarray, names: Sequence[str]) -> BaseParameters:
    """The base parameters of the stacked regressor STACKED (samples x len(names)): module
    docstring. ValueError: the data identify nothing."""
    norms = np.linalg.norm(stacked, axis=0)
    if not np.any(norms > 0):
        raise ValueError("the regressor is zero over these data: they identify no parameter")
    alive = norms > ZERO_COLUMN * norms.max()
    order = [k for k in preferred_order(names) if alive[k]]
    scaled = stacked[:, order] / norms[order]
    r_diagonal = np.abs(np.diag(scipy.linalg.qr(scaled, mode="r")[0]))
    kept = sorted(k for k, d in zip(order, r_diagonal) if d > RANK_TOLERANCE)
    others = [k for k in order if k not in kept]  # dependent; a zero column is in none
    combination = np.zeros((len(kept), len(names)))
    combination[range(len(kept)), kept] = 1.0
    if others:
        beta = np.linalg.lstsq(stacked[:, kept], stacked[:, others], rcond=None)[0]
        small = np.abs(beta) * norms[kept][:, None] <= COEFFICIENT_TOLERANCE * norms[others]
        combination[:, others] = np.where(small, 0.0, beta)
    return BaseParameters(tuple(combination_name(row, names) for row in combination),
                          combination, tuple(kept), tuple(names))


def preferred_order(names: Sequence[str]) -> list[int]:
    """phi's entries in the order they are kept when independent: the inertias and first
    moments in file order, then the linear coefficients, then the masses."""
    def rank(k: int) -> int:
        name = names[k]
        return 2 if name.endswith(".m") else 1 if "." not in name else 0
    return sorted(range(len(names)), key=lambda k: (rank(k), k))


def combination_name(row: np.ndarray, names: Sequence[str],
                     texts: Mapping[int, str] | None = None) -> str:
    """A base parameter's readable name: "link1.I + 0.25*link2.m", coefficients to 6 digits
    (at the parameters' values), or as TEXTS gives their magnitudes by column ("L1**2")."""
    text = ""
    for k, (coefficient, name) in enumerate(zip(row, names)):
        if coefficient == 0.0:
            continue
        size = (texts or {}).get(k, f"{abs(coefficient):.6g}")
        term = name if size == "1" else f"{size}*{name}"
        sign = "-" if coefficient < 0 else "+"
        text = f"{text} {sign} {term}" if text else (term if sign == "+" else f"-{term}")
    return text


def identify(regressor: Regressor, t: Any, q: Any, qd: Any, qdd: Any, tau: Any,
             sigma: float | None = None) -> Identification:
    """The base parameters from measured (t, q, qd, qdd, tau) by linear least squares (module
    docstring); tau of shape (rows, n_t) (or (n_t,) for one row). Standard errors from SIGMA,
    the noise's standard deviation on tau, else from the residual."""
    y, loads = regressor.matrix(t, q, qd, qdd)
    count, rows, columns = y.shape
    measured = np.asarray(tau, dtype=float)
    measured = measured.reshape(1, -1) if measured.ndim == 1 and rows == 1 else measured
    if measured.shape != (rows, count):
        raise ValueError(f"tau: expected shape ({rows}, {count}) (rows "
                         f"{', '.join(regressor.row_names)}; samples), got {np.shape(tau)}")
    if not np.all(np.isfinite(measured)):
        raise ValueError("tau: not finite (NaN or inf)")
    stacked = y.reshape(count * rows, columns)
    target = (measured.T + loads).reshape(-1)
    base = regressor.base(t, q, qd, qdd)
    kept = stacked[:, list(base.independent)]
    values = np.linalg.lstsq(kept, target, rcond=None)[0]
    residual = target - kept @ values
    if sigma is None:
        freedom = target.size - base.rank
        if freedom <= 0:
            raise ValueError(f"{target.size} equations for {base.rank} base parameters: "
                             "more samples needed for standard errors (or give sigma)")
        sigma = float(np.sqrt(residual @ residual / freedom))
    covariance = sigma**2 * np.linalg.inv(kept.T @ kept)
    return Identification(base.names, values, np.sqrt(np.diag(covariance)), covariance,
                          residual, base.combination @ regressor.values(), base, float(sigma))


def random_states(n: int, count: int, seed: int) -> tuple[np.ndarray, ...]:
    """COUNT seeded random (t, q, qd, qdd): angles over a turn, rates and accelerations
    normal."""
    rng = np.random.default_rng(seed)
    return (rng.uniform(0.0, 1.0, count), rng.uniform(-np.pi, np.pi, (n, count)),
            rng.standard_normal((n, count)), rng.standard_normal((n, count)))
