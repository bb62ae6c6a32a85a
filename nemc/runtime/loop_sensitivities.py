"""A closed loop's sensitivities' start (decision 0035's amendment): the run's initial state
assembled as simulate assembles it, and each column started in the constraints' tangent space,
the assembly's sensitivity to what is given. A given entry's column is its unit vector (a
parameter's: d y0 / d p there, 0 for a given y0); the solved coordinates come from

    Phi_q s_q = -Phi_p e,

the solved rates from the rates' equation differentiated,

    Phi_q s_qdot + (Phi_q qdot + Phi_t)_q s_q + (Phi_q qdot + Phi_t)_p e = 0,

least squares where the given values over-determine the loop, as the assembly. The pieces'
derivatives along (s, e) come from the build's loop_sensitivity_pieces (exact, in C). An entry
the assembly solves has no column (its value is discarded): refused by name, as "y0" is.
The columns are then integrated by the build's sensitivity_rhs (templates/
loop_sensitivities.c.tmpl), never projected.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .built import BuiltModel
from .failures import ModelError
from .linear import LoopPieces
from .outcome import RunSpec
from .results import SimulationResult


def assembled_spec(model: BuiltModel, spec: RunSpec, y0: Any) -> tuple[RunSpec, np.ndarray]:
    """SPEC with its initial state assembled as simulate assembles it (the entries Y0 or the
    scene gives kept), and the given mask."""
    given = model.loops.given_mask(y0)
    state0, _ = model.loops.assembled(spec.span[0], spec.state0, given, spec.p)
    return dataclasses.replace(spec, state0=state0), given


def refused_entries(model: BuiltModel, names: tuple[str, ...], given: np.ndarray) -> None:
    """Refuse by name "y0" and the initial values the assembly solves (no column), and a y0
    giving every coordinate (nothing left to solve: no column is in the tangent space)."""
    kept = [name for name, held in zip(model.state_names, given) if held]
    if all(given[0::2]):
        raise ModelError("sensitivities: y0 gives every coordinate of a closed loop, so none is "
                         "solved and no column can stay on the constraints: give the independent"
                         " initial values as a dict (y0={name: value, ...}), the others solved")
    for name in names:
        if name == "y0" or (name in model.state_names
                            and not given[model.state_names.index(name)]):
            what = ("\"y0\" asks for every initial value" if name == "y0" else
                    f"the initial value {name!r} is solved by the assembly (its value is "
                    "discarded)")
            raise ModelError(f"sensitivities: {what}, but a closed loop's solved entries have "
                             f"no sensitivity: name the given ones {kept}")


def pieces(build: BuiltModel, t: float, y: np.ndarray, p: np.ndarray, seed: np.ndarray,
           seed_p: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The loop's pieces at (t, y) and their derivative along (SEED, SEED_P), by meaning."""
    at, moved = pieces_along(build, t, y, p, seed[:, None], seed_p[None, :])
    return at, {name: value[0] for name, value in moved.items()}


def pieces_along(build: BuiltModel, t: float, y: np.ndarray, p: np.ndarray, seeds: np.ndarray,
                 seeds_p: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The loop's pieces at (t, y) and their derivatives along each column j, (SEEDS[:, j],
    SEEDS_P[j]), by meaning (a row per column)."""
    meta = build.metadata
    n, drives = len(build.coordinate_names), len(meta["drive_names"])
    m = len(meta["constraint_equations"])
    size = (m + 1) * (n + drives) + m * (n + 3)
    acc, dacc = np.empty(size), np.empty((seeds.shape[1], size))
    compiled = build.compiled
    buffer = compiled.buffer
    call = compiled.function("loop_sensitivity_pieces")
    if call is None:
        raise ModelError("sensitivities: this package was built by an nemc without a closed "
                         "loop's sensitivities: compile it again (nemc compile --sensitivities)")
    at_y, at_p, out = buffer(np.ascontiguousarray(y)), buffer(p), buffer(acc)
    for j in range(seeds.shape[1]):
        status = call(float(t), at_y, at_p, buffer(np.ascontiguousarray(seeds[:, j])),
                      buffer(np.ascontiguousarray(seeds_p[j])), out, buffer(dacc[j]))
        if status:
            raise ModelError(f"sensitivities: the closed loop's pieces failed at the start "
                             f"({compiled.status_cause(status)})")
    layout = LoopPieces(n, drives, m, acc, dacc)
    return layout.split(acc), layout.split(dacc)


def start_columns(build: BuiltModel, spec: RunSpec, given: np.ndarray, starts: np.ndarray,
                  directions: np.ndarray) -> np.ndarray:
    """Every column's start (n_state x k) from its given start and its direction, at the run's
    assembled start."""
    return start_columns_at(build, (spec.span[0], spec.state0, spec.p), given, starts,
                            directions)


def start_columns_at(build: BuiltModel, at: tuple[float, np.ndarray, np.ndarray],
                     given: np.ndarray, starts: np.ndarray, directions: np.ndarray
                     ) -> np.ndarray:
    """Every column's start (n_state x k) in the tangent space at the assembled state AT (t0,
    y0, p; an ensemble's run's own), from its given start STARTS[:, j] (its given entries
    kept) and its direction DIRECTIONS[j]: the solved coordinates then the solved rates, every
    column's in one least-squares solve."""
    t0, y0, p = at
    s = np.where(given[:, None], starts, 0.0)
    solved_q = [i for i in range(y0.size // 2) if not given[2 * i]]
    solved_u = [i for i in range(y0.size // 2) if not given[2 * i + 1]]
    if not s.shape[1]:
        return s
    at, moved = pieces_along(build, t0, y0, p, s, directions)
    phi_q = at["phi_q"]
    if solved_q:
        s[[2 * i for i in solved_q]] = np.linalg.lstsq(phi_q[:, solved_q], -moved["phi"].T,
                                                       rcond=None)[0]
        at, moved = pieces_along(build, t0, y0, p, s, directions)
    rates = phi_q @ s[1::2] + (moved["phi_q"] @ y0[1::2] + moved["phi_t"]).T
    if solved_u:
        s[[2 * i + 1 for i in solved_u]] = np.linalg.lstsq(phi_q[:, solved_u], -rates,
                                                           rcond=None)[0]
    return s


def singular_noted(model: BuiltModel, result: SimulationResult) -> SimulationResult:
    """A failed run's RESULT, its message saying why a closed loop's run with sensitivities
    ends at a singular configuration the plain run passes."""
    if model.has_loops and "loses rank here" in result.message:
        result.message += ("; a run with sensitivities ends within a singular configuration's "
                           "window: its passage (decision 0036) is not differentiated")
    return result
