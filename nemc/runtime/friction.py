"""Coulomb friction at run time (format v3 `friction`; decision 0039): which methods can run a
mechanism with friction, and each run's start (the items at rest that cannot be held slip).

The state is the mode: a stuck joint's rate is exactly 0, held there by the right-hand side's
exact zeros, which an explicit Runge-Kutta step keeps (its increments are sums of zeros). An
implicit method's Newton iteration mixes the state's entries (and differences of the
right-hand side across a rate of 0 cross the switch), and nemc.Taylor's series has no switch:
those are refused by name.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .compiled import Compiled
from .failures import IntegrationFailure, ModelError

FRICTION_METHODS = ("nemc.Vern9", "nemc.DOP853", "RK45", "RK23", "DOP853")  # explicit
FRICTION_METHOD = "nemc.Vern9"  # method "auto"'s choice with friction


class Friction:
    """A build's friction items, by joint name (none: `present` is False)."""

    def __init__(self, metadata: Mapping[str, Any], compiled: Compiled):
        self.items: tuple[str, ...] = tuple(metadata.get("friction", ()))
        self.rates: list[int] = list(metadata.get("friction_rates", ()))
        self.present = bool(self.items)
        self.compiled = compiled

    def check_method(self, method: str) -> None:
        """Refuse a method that cannot keep a stuck joint's rate exactly 0."""
        if self.present and method not in FRICTION_METHODS:
            raise ModelError(
                f"{method} cannot run a mechanism with Coulomb friction (friction on "
                f"{', '.join(self.items)}): a stuck joint's rate is held at exactly 0, which "
                f"the explicit methods keep ({', '.join(FRICTION_METHODS)}; method auto "
                "takes nemc.Vern9), switching modes at the events they locate; an implicit "
                "method's Newton iteration and nemc.Taylor's series do not")

    def refuse(self, what: str) -> None:
        """Refuse WHAT (the model as a plant, an FMU) with friction, which switches modes."""
        if self.present:
            raise ModelError(
                f"{what}: a mechanism with Coulomb friction (on {', '.join(self.items)}) "
                "switches between modes (stuck, slipping either way) at events, so its "
                "right-hand side has no derivative there; refused rather than answered for "
                "one mode")

    def started_runs(self, t0: float, y0s: np.ndarray, ps: np.ndarray) -> np.ndarray:
        """An ensemble's initial states (k, n_state), each started as `started` does, with
        its run's parameters (ps: one row, or one per run)."""
        if not self.present:
            return y0s
        return np.ascontiguousarray([self.started(t0, y0, ps[min(k, len(ps) - 1)])
                                     for k, y0 in enumerate(y0s)])

    def started(self, t0: float, y0: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Y0 with every item at rest that its static friction cannot hold set slipping."""
        if not self.present:
            return y0
        y = np.array(y0, dtype=float)
        buffer = self.compiled.buffer
        status = self.compiled.function("friction_start")(t0, buffer(y), buffer(p))
        if status:
            cause = self.compiled.status_cause(status)
            raise IntegrationFailure(f"the friction at the start (t = {t0:g}) cannot be "
                                     f"solved: {cause}")
        return y

    def held(self, raw: np.ndarray, projected: np.ndarray) -> np.ndarray:
        """PROJECTED (a closed loop's states brought onto its constraints) with each stuck
        joint's rate exactly 0 where the run's RAW states have it so: the mode kept."""
        if not self.present or not projected.size:
            return projected
        for i in self.rates:
            projected[i, raw[i] == 0.0] = 0.0
        return projected

    def held_runs(self, raw: np.ndarray, projected: np.ndarray) -> np.ndarray:
        """`held` for an ensemble's states (k, n_t, n_state)."""
        if not self.present or not projected.size:
            return projected
        for i in self.rates:
            projected[..., i][raw[..., i] == 0.0] = 0.0
        return projected
