"""Coulomb friction's and contacts' mode switches with scipy's explicit methods (RK45, RK23,
DOP853; decisions 0039 and 0041): what the native drivers' run_control.c.tmpl does for a
switch event (NEMC_SWITCH), done around solve_ivp.

- A switch is an impact-like event of solve_ivp's (terminal): at its root the C impact
  function applies friction_switch (or contact_switch), which writes the item's new mode into
  the run's own parameter vector (the one the right-hand side reads), and the run restarts
  from the new state: the step controller starts anew.
- Each switch event's side after a switch follows cut_step's rules: a contact's falling-only
  value kept on the positive side, a value within the motion's reach of 0 on the side the
  motion takes it to, each switched event not looked at for the chattering window.
- A mode switch is also looked for inside each accepted step, on its dense output at 1/4, 1/2
  and 3/4 (switch_inside): a mechanism at rest takes long steps over which a holding margin
  driven by a time-varying load may dip below 0 and come back. Found there, the step is taken
  again, ending at that sample, and solve_ivp's own search at the step's end locates the root.
- The work account (account.py): each segment's steps on their dense output, each impact's
  impulses' work after its law.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .account import Account
from .runs import SWITCH_WINDOW, ScipyOutcome, _Segments

SWITCH_SAMPLES = 4  # as run_control.c.tmpl: also at 1/4, 1/2 and 3/4 of each step
EPS = np.finfo(float).eps


class SwitchingSegments(_Segments):
    """_Segments with friction's switch events (action "switch") handled as the native
    drivers handle them."""

    def __init__(self, *args: Any, account: Account | None = None, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.account = account
        if account is not None:
            self.options = {**self.options, "dense_output": True}
        events = self.model_events
        assert events is not None
        self.switches = [k for k, action in enumerate(events.actions) if action == "switch"]
        self.control.inside = self.inside

    def chatter_window(self, k: int, t: float) -> float:
        """A mode switch's window at most SWITCH_WINDOW (1 + |t|), as run_control.c.tmpl's:
        a long run does not take the impacts the accumulation rule closes for chattering."""
        window = super().chatter_window(k, t)
        if k in self.switches:
            return min(window, SWITCH_WINDOW * (1 + abs(t)))
        return window

    def signs(self, t: float, y: np.ndarray) -> np.ndarray:
        """The switch events' signs at (t, y) as solve_ivp sees them (a cooldown's side)."""
        values = self.model_events.values(t, y)  # type: ignore[union-attr]
        signs = np.sign(values[self.switches])
        for i, k in enumerate(self.switches):
            until_side = self.cooldown.get(k)
            if until_side and self.direction * (until_side[0] - t) >= 0:
                signs[i] = until_side[1]
        return signs

    def segment(self, t0: float, t1: float, y0: np.ndarray, first: bool) -> Any:
        """_Segments.segment, and the work account along it."""
        sol = super().segment(t0, t1, y0, first)
        if self.account is not None:
            self.account.segment(sol, self.ts[-1])
        return sol

    def after_termination(self, sol: Any) -> tuple[float, np.ndarray] | ScipyOutcome:
        """_Segments.after_termination, and the impacts' work added to the account."""
        after = super().after_termination(sol)
        if self.account is not None:
            self.account.impacts()
        return after

    def outcome(self, status: int, message: str) -> ScipyOutcome:
        """_Segments.outcome, with the work account at the returned times."""
        done = super().outcome(status, message)
        if self.account is not None:
            done.work = self.account.along()
        return done

    def inside(self, solver: Any, t_old: float) -> float | None:
        """The step just accepted (from t_old to solver.t): the length of the step to take
        instead where a switch event's sign changed at one of its inner samples, else None."""
        if not self.switches or self.control.stop:
            return None
        at_start = self.signs(t_old, solver.y_old)
        kept, solver.t_old = solver.t_old, t_old
        try:
            dense = solver.dense_output()
        finally:
            solver.t_old = kept
        for j in range(1, SWITCH_SAMPLES):
            t = t_old + (solver.t - t_old) * j / SWITCH_SAMPLES
            now = self.signs(t, dense(t))
            if np.any((now != 0) & (at_start != 0) & (now != at_start)):
                return abs(t - t_old)
        return None

    def set_cooldowns(self, impacted: list[int], t: float, before: np.ndarray,
                      y: np.ndarray) -> int | None:
        """After the impacts or switches at t (state before, y after): the scene's impacts as
        _Segments, then every switch event's side as cut_step sets it."""
        actions = self.model_events.actions  # type: ignore[union-attr]
        plain = [k for k in impacted if actions[k] != "switch"]
        refire = super().set_cooldowns(plain, t, before, y)
        if refire is not None or not self.switches:
            return refire
        h = 1e-7 * (abs(t) + abs(self.span[1] - self.span[0])) * self.direction
        now, later = self.event_values_ahead(t, y, h)
        window = self.chatter_window(self.switches[0], t)
        directions = self.model_events.directions  # type: ignore[union-attr]
        for k in self.switches:
            change = later[k] - now[k]
            moving = int(np.sign(change))
            near = abs(now[k]) < abs(change)
            kept_above = directions[k] == -1  # falling only: its mode keeps it >= 0
            leave = 2 * abs(now[k] / change * h) if change else 0.0
            lifted = kept_above and now[k] < 0 and moving > 0
            pad = 64 * EPS * abs(t)
            if k not in impacted:
                if kept_above and now[k] < 0:  # below only by a drift
                    if lifted:
                        self.cooldown[k] = (t + self.direction * (leave + pad), 1)
                elif now[k] != 0 and near and moving and moving != np.sign(now[k]):
                    self.cooldown[k] = (t + self.direction * (window + pad), moving)
                continue
            side = 1 if kept_above else int(np.sign(now[k])) if now[k] != 0 and not near \
                else moving
            if side:
                self.cooldown[k] = (t + self.direction * (max(leave if lifted else 0.0, window)
                                                          + pad), side)
        return None
