"""The mode switches of a run with Coulomb friction or contacts, counted by kind, and the rule
that flags chattering (issue 50): what `nemc stress` reports for such a mechanism.

Modes change only at the run's events (`res.events`: each `J.stick_slip`, `NAME.contact` and
`NAME.stick_slip` with the state just before it), so the outputs `J.stuck` and `NAME.active`
evaluated at each event's state give every item's mode before it, and the next event's (or the
run's last state's) give the mode after it. Counted across each event:

- stick: a `J.stuck` going 0 -> 1; slip: 1 -> 0; reversal: a `J.stick_slip` event with the
  joint slipping before and after (its speed passed 0 and holding it would take more than
  static friction);
- impact: a `NAME.contact` event with the contact open before it; closing: `NAME.active`
  0 -> 1 (a plastic impact, or the accumulation rule's); release: 1 -> 0 (its normal force
  reaching 0, or lifted by another contact's impulse);
- a contact's own friction (`NAME.stick_slip`) has no mode output: its events are counted as
  one kind, "contact stick/slip";
- friction along a constraint's guide (its outputs NAME.stuck and NAME.speed): the state at a
  switch says no mode (its sliding speed is about 0 on both sides of it), so its events are
  counted as one kind, "guide stick/slip".

Chattering: an event chatters where CHATTER_COUNT of its consecutive occurrences fall within
CHATTER_FRACTION of the run's length (impacts accumulating, a stick lasting nanoseconds).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..runtime.model import Model, SimulationResult

CHATTER_COUNT = 5  # consecutive occurrences of one event ...
CHATTER_FRACTION = 1e-3  # ... within this share of the run's length: chattering
KINDS = ("stick", "slip", "reversal", "impact", "closing", "release", "contact stick/slip",
         "guide stick/slip")


@dataclass(frozen=True)
class Burst:
    """The tightest CHATTER_COUNT consecutive occurrences of one event: where they start, and
    the time they span."""

    event: str
    start: float
    span: float


@dataclass(frozen=True)
class Switching:
    """A run's switches: counts[item][kind], the tightest burst of each event with at least
    CHATTER_COUNT occurrences, and the chattering window (CHATTER_FRACTION of the run)."""

    counts: Mapping[str, Mapping[str, int]]
    bursts: tuple[Burst, ...]
    window: float

    @property
    def chattering(self) -> tuple[Burst, ...]:
        """The bursts within the window: the events that chatter."""
        return tuple(b for b in self.bursts if b.span <= self.window)

    def total(self, kind: str) -> int:
        """The count of KIND summed over every item."""
        return sum(c.get(kind, 0) for c in self.counts.values())


def mode_names(model: Model) -> dict[str, str]:
    """Each item's mode output: joint J -> 'J.stuck', contact C -> 'C.active' (a guide's
    'G.stuck' left out: guide_items)."""
    names = [n for n in model.output_names if n.endswith((".stuck", ".active"))]
    guides = guide_items(model)
    return {n.rsplit(".", 1)[0]: n for n in names if n.rsplit(".", 1)[0] not in guides}


def guide_items(model: Model) -> set[str]:
    """The friction items along constraints' guides: those with NAME.stuck and NAME.speed."""
    names = set(model.output_names)
    return {n.rsplit(".", 1)[0] for n in names
            if n.endswith(".stuck") and n.removesuffix(".stuck") + ".speed" in names}


def ordered_events(result: SimulationResult) -> list[tuple[float, str, np.ndarray]]:
    """Every event of the run as (time, name, state before), in time order."""
    found = [(float(t), name, y) for name, (times, states) in result.events.items()
             for t, y in zip(times, states)]
    return sorted(found, key=lambda e: e[0])


def modes_at(model: Model, t: float, y: np.ndarray, names: Mapping[str, str],
             params: Mapping[str, float] | None) -> dict[str, float]:
    """Every item's mode output at the state Y."""
    out = model.outputs(t, y, params)
    return {item: float(out[name]) for item, name in names.items()}


def count_switches(model: Model, result: SimulationResult,
                   params: Mapping[str, float] | None = None) -> Switching:
    """RESULT's switches by item and kind, and its events' tightest bursts (module doc)."""
    names = mode_names(model)
    joints = {item for item, name in names.items() if name.endswith(".stuck")}
    events = ordered_events(result)
    before = [modes_at(model, t, y, names, params) for t, _, y in events]
    final = modes_at(model, float(result.t[-1]), result.y[:, -1], names, params)
    counts: dict[str, dict[str, int]] = {item: dict.fromkeys(KINDS, 0) for item in names}
    guides = guide_items(model)
    counts.update({item: dict.fromkeys(KINDS, 0) for item in guides})
    for k, (_, name, _) in enumerate(events):
        after = before[k + 1] if k + 1 < len(events) else final
        if name.rsplit(".", 1)[0] in guides:
            counts[name.rsplit(".", 1)[0]]["guide stick/slip"] += 1
        else:
            add_switches(counts, joints, name, before[k], after)
    length = abs(float(result.t[-1] - result.t[0]))
    return Switching({i: {k: n for k, n in c.items() if n} for i, c in counts.items()},
                     tightest_bursts(events), CHATTER_FRACTION * length)


def add_switches(counts: dict[str, dict[str, int]], joints: set[str], event: str,
                 before: Mapping[str, float], after: Mapping[str, float]) -> None:
    """Count what one event switched: an impact or a reversal by its own name, and every
    item's mode change across it (JOINTS: the friction joints' items, the rest contacts)."""
    item, kind = event.rsplit(".", 1)
    if item in joints and kind == "stick_slip" and before[item] == 0 == after[item]:
        counts[item]["reversal"] += 1
    elif item in counts and item not in joints and kind == "stick_slip":
        counts[item]["contact stick/slip"] += 1
    elif item in counts and kind == "contact" and before[item] == 0:
        counts[item]["impact"] += 1
    for other, mode in before.items():
        if mode != after[other]:
            counts[other][changed(other in joints, after[other])] += 1


def changed(joint: bool, now: float) -> str:
    """The kind of a mode change to NOW: a joint sticks (1) or slips (0); a contact closes (1)
    or is released (0)."""
    return ("stick" if now else "slip") if joint else ("closing" if now else "release")


def tightest_bursts(events: list[tuple[float, str, np.ndarray]]) -> tuple[Burst, ...]:
    """For each event with at least CHATTER_COUNT occurrences, its tightest run of
    CHATTER_COUNT consecutive ones."""
    times: dict[str, list[float]] = {}
    for t, name, _ in events:
        times.setdefault(name, []).append(t)
    bursts = []
    for name, ts in times.items():
        if len(ts) >= CHATTER_COUNT:
            spans = np.subtract(ts[CHATTER_COUNT - 1:], ts[:1 - CHATTER_COUNT or None])
            k = int(np.argmin(spans))
            bursts.append(Burst(name, ts[k], float(spans[k])))
    return tuple(bursts)
