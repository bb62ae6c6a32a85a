"""The work account of a run of scipy's methods with Coulomb friction or contacts (issue 50):
what templates/run_control.c.tmpl keeps for the native methods, kept around solve_ivp
(scipy_switches.py): each item's friction power integrated over each accepted step by
Gauss-Legendre's rule on 7 nodes of the step's dense output (the power is smooth inside a
step: the switches and impacts end the segments), the work at a returned time inside a step
the integral of the power's interpolant through those nodes, and each impact's impulses' work
read from the run's own parameter vector, where the generated C's impact adds it."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .compiled import Compiled
from .failures import IntegrationFailure

_X, _W = np.polynomial.legendre.leggauss(7)
NODES, WEIGHTS = (1 + _X) / 2, _W / 2  # on [0, 1]: exact to degree 13
# the interpolant's coefficients in theta (increasing powers) from the powers at the nodes
COEFFICIENTS = np.linalg.inv(np.vander(NODES, len(NODES), increasing=True))
ORDERS = np.arange(1, len(NODES) + 1)


def fractions(theta: float) -> np.ndarray:
    """Each node's weight in the integral from 0 to THETA of the interpolant through them."""
    return (theta ** ORDERS / ORDERS) @ COEFFICIENTS


class Account:
    """One run's work account: each item's work so far, advanced segment by segment."""

    def __init__(self, compiled: Compiled, p: np.ndarray, items: int,
                 state_names: Sequence[str]):
        self.compiled, self.p, self.state_names = compiled, p, state_names
        self.powers = compiled.function("friction_powers")
        self.work = np.zeros(items)
        self.rows: list[np.ndarray] = []  # the work at each returned time, segment by segment

    def power_at(self, t: float, y: np.ndarray) -> np.ndarray:
        """Each item's power at (t, y) with the run's modes."""
        out = np.empty(self.work.size)
        buffer = self.compiled.buffer
        status = self.powers(t, buffer(np.ascontiguousarray(y, dtype=float)), buffer(self.p),
                             buffer(out))
        if status:  # the run ends there, its states so far kept (_Segments.run)
            raise IntegrationFailure(t, y, status, self.state_names,
                                     self.compiled.status_cause(status))
        return out

    def segment(self, sol: Any, times: np.ndarray) -> None:
        """A solve_ivp segment (its dense output, sol.sol): the work at its returned TIMES,
        then the account advanced to its end."""
        dense = sol.sol
        rows = np.repeat(self.work[None, :], times.size, axis=0)
        if dense is not None:
            edges = np.asarray(dense.ts)
            for a, b in zip(edges[:-1], edges[1:]):
                if a == b:
                    continue
                h = b - a
                nodes = a + h * NODES
                values = np.array([self.power_at(t, dense(t)) for t in nodes])
                inside = (times - a) * (times - b) <= 0
                for row in np.nonzero(inside & ((times - a) != 0))[0]:
                    rows[row] = self.work + h * fractions((times[row] - a) / h) @ values
                self.work = self.work + h * WEIGHTS @ values
        self.rows.append(rows)

    def impacts(self) -> None:
        """The impulses' work of the impacts just applied, added (and zeroed in p)."""
        out = np.empty(self.work.size)
        buffer = self.compiled.buffer
        self.compiled.function("friction_taken")(buffer(self.p), buffer(out))
        self.work = self.work + out

    def along(self) -> np.ndarray:
        """The work at every returned time (n_t, items)."""
        return np.concatenate(self.rows) if self.rows else np.zeros((0, self.work.size))
