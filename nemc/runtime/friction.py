"""Coulomb friction at run time (format v3 `friction`; decision 0039), and contacts, whose
forces and modes are friction's items too (`contacts`; decision 0041): which methods can run a
mechanism with friction, each run's start (its own parameter vector, whose last entries are
the items' modes, and the items at rest that cannot be held set slipping), and the modes read
from the states for the outputs.

A stuck joint's rate is held at exactly 0 by the right-hand side's exact zeros, which an
explicit Runge-Kutta step keeps (its increments are sums of zeros): nemc's Vern9 and DOP853,
whose drivers switch in C, and scipy's RK45, RK23 and DOP853, whose switches
scipy_switches.py applies around solve_ivp (the same C laws, the solver restarted, and the
switch events looked at inside each step on its dense output too). An implicit method's
Newton iteration mixes the state's entries (the rate's zero is lost to the iteration's
rounding, and its Jacobian has no switch) and nemc.Taylor's series has no switch: those are
refused by name.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .compiled import Compiled
from .failures import FRICTION_UNSOLVABLE, ModelError, failure_cause

FRICTION_METHODS = ("nemc.Vern9", "nemc.DOP853")  # explicit, their events in C
SCIPY_FRICTION_METHODS = ("RK45", "RK23", "DOP853")  # explicit, driven by scipy_switches.py
FRICTION_METHOD = "nemc.Vern9"  # method "auto"'s choice with friction
COULOMB_LAW, CONTACT_LAW, TANGENT_LAW, GUIDE_LAW = 0, 1, 2, 3  # an item's law (friction.c.tmpl's)


class Friction:
    """A build's friction items, by joint name (none: `present` is False)."""

    def __init__(self, metadata: Mapping[str, Any], compiled: Compiled):
        self.items: tuple[str, ...] = tuple(metadata.get("friction", ()))
        self.laws: tuple[int, ...] = tuple(metadata.get("friction_laws", ()))
        self.rates: list[int] = list(metadata.get("friction_rates", ()))
        self.present = bool(self.items)
        self.compiled = compiled

    def check_method(self, method: str) -> None:
        """Refuse a method that cannot keep a stuck joint's rate exactly 0."""
        if self.present and method not in FRICTION_METHODS + SCIPY_FRICTION_METHODS:
            raise ModelError(
                f"{method} cannot run a mechanism with Coulomb friction or contacts (on "
                f"{', '.join(self.items)}): a stuck joint's rate is held at exactly 0, which "
                "only an explicit Runge-Kutta step keeps (nemc's "
                f"{', '.join(FRICTION_METHODS)}; scipy's {', '.join(SCIPY_FRICTION_METHODS)}; "
                "method auto takes nemc.Vern9), switching modes at the events located, also "
                "inside long steps; an implicit method's Newton iteration mixes the state's "
                "entries (Radau, BDF, LSODA, nemc.Radau) and nemc.Taylor's series has no "
                "switch")

    def refuse(self, what: str) -> None:
        """Refuse WHAT (the model as a plant, an FMU) with friction, which switches modes."""
        if self.present:
            raise ModelError(
                f"{what}: a mechanism with Coulomb friction or contacts (on "
                f"{', '.join(self.items)}) switches between modes (stuck, slipping either way; "
                "a contact open or lasting) at events, so its "
                "right-hand side has no derivative there; refused rather than answered for "
                "one mode")

    def started_runs(self, t0: float, y0s: np.ndarray, ps: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
        """An ensemble's initial states (k, n_state) and parameter rows, one per run (each
        run's modes its own), each started as `started` does."""
        rows = np.repeat(ps, len(y0s), axis=0) if len(ps) == 1 else np.array(ps, dtype=float)
        starts = np.array(y0s, dtype=float)
        for k in range(len(starts)):
            starts[k], rows[k] = self.started(t0, starts[k], rows[k])
        return np.ascontiguousarray(starts), np.ascontiguousarray(rows)

    def started(self, t0: float, y0: np.ndarray, p: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """A run's start: Y0 with every item at rest that its static friction cannot hold set
        slipping, and a copy of P with each item's mode (what the switches then write).
        Painleve's paradox there is refused; where the equations themselves fail (a singular
        mass matrix), the run's first step fails the same way, a failed result with its state
        as a run without friction gives."""
        y, p = np.array(y0, dtype=float), np.array(p, dtype=float)
        buffer = self.compiled.buffer
        status = self.compiled.function("friction_start")(t0, buffer(y), buffer(p))
        if status == FRICTION_UNSOLVABLE:
            raise ModelError(f"the friction at the start (t = {t0:g}) cannot be solved: "
                             f"{failure_cause(y, status, self.compiled.state_names)}")
        return y, p

    def account_outputs(self, work: np.ndarray) -> dict[str, np.ndarray]:
        """The work account as outputs, from each item's work up to each time (n_t, items;
        templates/run_control.c.tmpl): a joint's or a guide's NAME.friction_work (its
        friction's work, <= 0 where it dissipates); a contact's NAME.friction_work (its
        friction's, in the lasting contact and the impacts' tangent impulses; 0 without mu) and
        NAME.impact_loss (the energy its normal impulses took)."""
        named: dict[str, np.ndarray] = {}
        for k, (name, law) in enumerate(zip(self.items, self.laws)):
            if law in (COULOMB_LAW, GUIDE_LAW):
                named[f"{name}.friction_work"] = work[:, k].copy()
            elif law == CONTACT_LAW:
                tangent = k + 1 < len(self.laws) and self.laws[k + 1] == TANGENT_LAW
                named[f"{name}.friction_work"] = work[:, k + 1].copy() if tangent else \
                    np.zeros(work.shape[0])
                named[f"{name}.impact_loss"] = -work[:, k]
        return named

    def inferring(self, p: np.ndarray) -> np.ndarray:
        """P with the modes read from the state (NaN): what a run's outputs are computed with,
        the states along it saying each point's mode."""
        if not self.present:
            return p
        p = np.array(p, dtype=float)
        p[len(p) - len(self.items):] = np.nan
        return p

    def held(self, raw: np.ndarray, projected: np.ndarray) -> np.ndarray:
        """PROJECTED (a closed loop's states brought onto its constraints: one run's
        (n_state, n_t), or an ensemble's (k, n_t, n_state) with the state last) with each stuck
        joint's rate exactly 0 where the run's RAW states have it so: the mode kept."""
        if not self.present or not projected.size:
            return projected
        for i in self.rates:
            rate, was = (projected[i], raw[i]) if projected.ndim == 2 else \
                (projected[..., i], raw[..., i])
            rate[was == 0.0] = 0.0
        return projected
