"""A free run's passages of singular configurations (a closed loop's constraints losing rank at
an instant, which the model's C passes by extrapolating along the motion: decision 0036), found
along the states the run returns, so that its message says which constraint and when.

The C passes them inside its right-hand side and keeps no record (it has no state of its own),
so they are found afterwards: Phi_q's conditioning (as the C measures it: R's smallest kept
pivot over its largest) is taken along the cubic Hermite curves through the positions and
rates of the returned states (the solver's steps, or t_eval's times, step over the instant
itself), at the states and every STRIDE of motion between them, and searched where it has a
local minimum. A minimum below PASSAGE_WINDOW, the C's two windows, or one where Phi_q's rank
falls below its generic rank, is a passage: its time is the minimum's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .kinematic import KINEMATIC_WINDOW

PASSAGE_WINDOW = KINEMATIC_WINDOW  # the C's two SINGULAR_WINDOWs: where it extrapolated
STRIDE = 0.5  # the motion (coordinate units) between the points the conditioning is taken at
MOST_PIECES = 1000  # the most points between two states (a run that flew off)
SEARCHED = 0.25  # a local minimum of the conditioning sampled above this is not searched: a
#                  sample lies within STRIDE / 2 of the minimum, and a pivot falling to 0 falls
#                  about as fast as the motion (a parallelogram's: |sin| of its angle from flat)
GRID = 16  # the points of the Hermite curve over the two intervals around a local minimum
REFINED = 4  # a grid's least conditioning below this many windows is refined...
ZOOMS = 5  # ...this many times, by GRID points between its neighbours (to 3e-5 of its spacing)


@dataclass(frozen=True)
class SingularPassage:
    """One passage: its time (to the Hermite curve's accuracy), the constraint of the smallest
    pivot there and the conditioning found."""

    t: float
    constraint: str
    conditioning: float


# (times (n,), states (n_state, n)) -> the conditioning, rank and constraint equation of the
# smallest pivot at each (three arrays (n,))
Measure = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


def hermite_between(t: np.ndarray, y: np.ndarray, k: np.ndarray | int, s: np.ndarray
                    ) -> np.ndarray:
    """The states (n_state, len(s)) at times S on the cubic Hermite curves through states k
    and k + 1 (interleaved q, dot(q); K one interval or one a time): kinematic.hermite,
    vectorized."""
    k = np.broadcast_to(k, np.shape(s))
    ya, yb = y[:, k], y[:, k + 1]
    qa, va, qb, vb = ya[0::2], ya[1::2], yb[0::2], yb[1::2]
    h = t[k + 1] - t[k]
    u = (s - t[k]) / h
    out = np.empty((y.shape[0], len(s)))
    out[0::2] = ((2 * u**3 - 3 * u**2 + 1) * qa + (u**3 - 2 * u**2 + u) * h * va
                 + (-2 * u**3 + 3 * u**2) * qb + (u**3 - u**2) * h * vb)
    out[1::2] = ((6 * u**2 - 6 * u) * (qa - qb) / h + (3 * u**2 - 4 * u + 1) * va
                 + (3 * u**2 - 2 * u) * vb)
    return out


def along(t: np.ndarray, y: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The states (n_state, len(s)) at times S (between t[0] and t[-1]) on the cubic Hermite
    curves through the states' positions and rates."""
    forward = t[-1] >= t[0]
    index = np.searchsorted(t if forward else -t, s if forward else -s, side="right") - 1
    return hermite_between(t, y, np.clip(index, 0, len(t) - 2), s)


def samples(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The states' times and states (n_state, n), with points of the Hermite curves between
    them where the positions move more than STRIDE (coordinate units) from one to the next."""
    moves = np.abs(np.diff(y[0::2], axis=1)).max(axis=0, initial=0.0)
    pieces = np.clip(np.ceil(moves / STRIDE), 1, MOST_PIECES).astype(int)
    interval = np.repeat(np.arange(len(t) - 1), pieces)
    first = np.cumsum(pieces) - pieces
    fraction = (np.arange(len(interval)) - first[interval]) / pieces[interval]
    times = t[interval] + fraction * (t[interval + 1] - t[interval])
    with np.errstate(divide="ignore", invalid="ignore"):  # a switch's repeated time: an
        states = hermite_between(t, y, interval, times)  # interval of length 0, its one
    exact = fraction == 0  # point the run's own state: the run's own states, as they are
    states[:, exact] = y[:, interval[exact]]
    return np.append(times, t[-1]), np.concatenate([states, y[:, -1:]], axis=1)


def lowest(measure: Measure, t: np.ndarray, y: np.ndarray, a: float, b: float
           ) -> tuple[float, tuple[float, int, int]]:
    """The time in [a, b] of the smallest conditioning along the states' Hermite curves (the
    best of GRID points, then where it is within REFINED windows the best of GRID points
    between its neighbours, ZOOMS times) and the measure there."""
    lo, hi = a, b
    for _ in range(ZOOMS + 1):
        grid = np.linspace(lo, hi, GRID)
        ratio, rank, where = measure(grid, along(t, y, grid))
        best = int(np.argmin(ratio))
        if ratio[best] >= REFINED * PASSAGE_WINDOW:  # a wider V cannot reach the window
            break
        lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, GRID - 1)]
    return float(grid[best]), (float(ratio[best]), int(rank[best]), int(where[best]))


def singular_passages(measure: Measure, rank: int, equations: tuple[str, ...], t: np.ndarray,
                      y: np.ndarray) -> list[SingularPassage]:
    """The singular configurations the run of states Y (n_state, n_t) at times T passed:
    Phi_q's conditioning (MEASURE) below PASSAGE_WINDOW or its rank below RANK at a local
    minimum of the conditioning along the motion (sampled every STRIDE, below SEARCHED
    there); EQUATIONS: the constraint of each equation. A failed run's states are taken up
    to its first one not finite."""
    finite = np.all(np.isfinite(y), axis=0)
    cut = int(np.argmin(finite)) if not finite.all() else y.shape[1]
    if cut < 2:
        return []
    t, y = t[:cut], y[:, :cut]
    times, states = samples(t, y)
    values = measure(times, states)[0]
    found: list[SingularPassage] = []
    for first, last in searched(values):
        s, (ratio, kept, where) = lowest(measure, t, y, times[max(first - 1, 0)],
                                         times[min(last + 1, len(times) - 1)])
        if ratio < PASSAGE_WINDOW or kept < rank:
            found.append(SingularPassage(s, equations[where], float(ratio)))
    return found


def searched(values: np.ndarray) -> list[tuple[int, int]]:
    """The runs (first, last sample) of the conditioning VALUES to search for a passage: each
    run of consecutive samples in the window, and each strict local minimum below SEARCHED
    out of it."""
    runs: list[tuple[int, int]] = []
    inside = values < PASSAGE_WINDOW
    last = len(values) - 1
    for k in range(len(values)):
        if inside[k]:
            if runs and runs[-1][1] == k - 1 and inside[k - 1]:
                runs[-1] = (runs[-1][0], k)
            else:
                runs.append((k, k))
        elif values[k] < SEARCHED and values[k] <= values[max(k - 1, 0)] \
                and values[k] <= values[min(k + 1, last)] \
                and values[k] < min(values[max(k - 1, 0)], values[min(k + 1, last)]):
            runs.append((k, k))
    return runs


def passages_message(found: list[SingularPassage]) -> str:
    """What a run's message says of the singular configurations it passed ('' for none)."""
    if not found:
        return ""
    named = sorted({passage.constraint for passage in found})
    at = ", ".join(f"{passage.t:.6g}" for passage in found[:8])
    more = f" and {len(found) - 8} more" if len(found) > 8 else ""
    return (f" It passed {len(found)} singular configuration{'s' if len(found) > 1 else ''} of "
            f"constraint{'s' if len(named) > 1 else ''} {', '.join(map(repr, named))} (near "
            f"t = {at}{more}), its right-hand side extrapolated along the motion there "
            "(decision 0036).")
