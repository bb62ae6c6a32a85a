"""A run's inputs: what `simulate(..., inputs=...)` accepts, checked, and written into the
parameter vector as the coefficients of each input's law (nemc/derive/inputs.py):

    u = scale * yaml(t, p) + value + slope (t - start) + gains . y

- not given: the YAML's expression (the scene's value, else the default): scale 1;
- a number: value;
- a table (times, values): linear between samples and held beyond them; the C moves each
  table's law from segment to segment at the samples, which become tstops (nemc_run's tables);
- nemc.feedback(K, y_ref, u_ref): u = u_ref - K (y - y_ref): value u_ref + K y_ref, gains -K;
- a Python callable f(t, y): its value at every evaluation, with scipy's methods only.

Everything but the callable runs in C inside every native method and ensembles: a closed loop
costs a few multiply-adds per evaluation of the right-hand side.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .failures import ModelError

SCALE, VALUE, SLOPE, START = range(4)  # a law's coefficients; its gains follow
GAINS = 4


@dataclass(frozen=True)
class Feedback:
    """u = u_ref - K (y - y_ref), a linear state feedback evaluated in C (nemc.feedback). For one
    input K is a row of the state's length (or of STATES' length: the entries of the state it
    names, as a closed loop's linearization's independent coordinates); for every input at once
    (inputs=nemc.feedback(...)) a matrix, a row per input."""

    gain: np.ndarray
    y_ref: np.ndarray | None = None
    u_ref: np.ndarray | None = None
    states: tuple[str, ...] | None = None  # the state entries K's columns are, else all


def feedback(K: Any, y_ref: Any = None, u_ref: Any = None,
             states: Sequence[str] | None = None) -> Feedback:
    """A linear state feedback u = u_ref - K (y - y_ref) for simulate's inputs (y_ref, u_ref
    default 0). K: a row per input it sets, a column per entry of the state (or of STATES)."""
    gain = real_matrix(K, "feedback gain K")
    y = None if y_ref is None else real_vector(y_ref, "feedback y_ref")
    u = None if u_ref is None else real_vector(np.atleast_1d(u_ref), "feedback u_ref")
    return Feedback(gain, y, u, None if states is None else tuple(states))


@dataclass(frozen=True)
class Table:
    """Samples of an input: linear between them, held beyond them."""

    times: np.ndarray
    values: np.ndarray


@dataclass
class RunInputs:
    """A run's inputs, resolved: the parameter vector's laws set, the tables the C moves along,
    and the Python callables (scipy's methods only)."""

    p: np.ndarray
    tables: list[tuple[int, Table]] = field(default_factory=list)  # (law's value's index)
    callables: list[tuple[int, Callable]] = field(default_factory=list)  # (law's index, f)

    @property
    def tstops(self) -> np.ndarray:
        """Every table's sample times."""
        if not self.tables:
            return np.empty(0)
        return np.unique(np.concatenate([table.times for _, table in self.tables]))

    def at(self, t: float, y: np.ndarray | None = None) -> np.ndarray:
        """The parameter vector at (t, y): the tables' laws for the segment from t (forward),
        the callables' values."""
        if not self.tables and not self.callables:
            return self.p
        p = self.p.copy()
        for index, table in self.tables:
            p[index: index + 3] = segment_law(table, t)  # value, slope, start
        for index, function in self.callables:
            p[index] = call_input(function, t, y)
        return p

    def keep(self, p: np.ndarray) -> None:
        """Keep what an event wrote into P, a vector `at` made (a friction switch's mode in
        the run's parameter tail) as the run's own: later `at`s start from it. The inputs'
        own places are set anew by every `at`."""
        self.p[:] = p


class InputLayout:
    """Where each input's law lives in the parameter vector (model.json's "inputs")."""

    def __init__(self, metadata: Mapping[str, Any], state_names: Sequence[str]):
        layout = metadata.get("inputs") or {"names": [], "offset": 0, "stride": 0,
                                            "defaults": []}
        self.names: tuple[str, ...] = tuple(layout["names"])
        self.offset: int = layout["offset"]
        self.stride: int = layout["stride"]
        self.defaults = np.array(layout["defaults"], dtype=float)
        self.state_names = tuple(state_names)

    def law(self, k: int) -> int:
        """The index in p of input k's law's first coefficient."""
        return self.offset + k * self.stride

    def value_index(self, name: str) -> int:
        return self.law(self.names.index(name)) + VALUE

    def resolve(self, p: np.ndarray, given: Any) -> RunInputs:
        """P (the parameters, then the laws at their defaults) with GIVEN's inputs set."""
        p = p.copy()
        run = RunInputs(p)
        if given is None:
            return run
        if is_feedback(given):
            self._feedback(p, self.names, given)
            return run
        if not isinstance(given, Mapping):
            raise ModelError(f"inputs: expected a mapping input name -> value, table, "
                             f"nemc.feedback(...) or function, or nemc.feedback(...) for every "
                             f"input; got {type(given).__name__}")
        for name, value in given.items():
            if name not in self.names:
                known = ", ".join(self.names) or "none (the YAML declares no inputs:)"
                raise ModelError(f"unknown input {name!r}; this model's inputs: {known}")
            self._one(run, name, value)
        return run

    def _one(self, run: RunInputs, name: str, value: Any) -> None:
        law = self.law(self.names.index(name))
        run.p[law: law + self.stride] = 0.0
        if is_feedback(value):
            self._feedback(run.p, (name,), value)
        elif callable(value):
            run.callables.append((law + VALUE, value))
        elif isinstance(value, tuple | list) and len(value) == 2 and not np.isscalar(value[0]):
            table = checked_table(name, value)
            run.tables.append((law + VALUE, table))
            run.p[law + VALUE: law + START + 1] = segment_law(table, table.times[0])
        else:
            run.p[law + VALUE] = input_number(name, value)

    def _feedback(self, p: np.ndarray, names: Sequence[str], rule: Any) -> None:
        columns = self._columns(rule)
        gain = rule.gain.reshape(1, -1) if rule.gain.ndim == 1 else rule.gain
        if gain.shape != (len(names), len(columns)):
            raise ModelError(f"feedback gain K of shape {rule.gain.shape}: expected "
                             f"({len(names)}, {len(columns)}), a row per input "
                             f"({', '.join(names)}) and a column per state entry "
                             f"({', '.join(self.state_names[c] for c in columns)})")
        y_ref = np.zeros(len(columns)) if rule.y_ref is None else rule.y_ref
        if y_ref.shape != (len(columns),):
            raise ModelError(f"feedback y_ref of shape {y_ref.shape}: expected "
                             f"({len(columns)},), a value per state entry")
        u_ref = np.zeros(len(names)) if rule.u_ref is None else rule.u_ref.reshape(-1)
        if u_ref.shape != (len(names),):
            raise ModelError(f"feedback u_ref of shape {rule.u_ref.shape}: expected "
                             f"({len(names)},), a value per input")
        for row, name in enumerate(names):
            law = self.law(self.names.index(name))
            p[law: law + self.stride] = 0.0
            p[law + VALUE] = u_ref[row] + gain[row] @ y_ref
            p[law + GAINS + np.asarray(columns)] = -gain[row]

    def _columns(self, rule: Feedback) -> list[int]:
        if rule.states is None:
            return list(range(len(self.state_names)))
        unknown = [name for name in rule.states if name not in self.state_names]
        if unknown:
            raise ModelError(f"feedback states {unknown} are not in the state "
                             f"{list(self.state_names)}")
        return [self.state_names.index(name) for name in rule.states]


def is_feedback(value: Any) -> bool:
    """A Feedback, nemc's or the copy's in an exported package (another class of the same
    fields: a package's model takes nemc.feedback's too)."""
    return isinstance(value, Feedback) or type(value).__name__ == "Feedback" and all(
        hasattr(value, name) for name in ("gain", "y_ref", "u_ref", "states"))


def segment_law(table: Table, t: float) -> tuple[float, float, float]:
    """(value, slope, start) of a table's law on the segment from t forward, as the C computes
    them (templates/run_control.c.tmpl, set_table_law); held beyond the samples."""
    times, values = table.times, table.values
    i = int(np.searchsorted(times, t, side="right")) - 1
    if i < 0 or i + 1 >= times.size:
        return float(values[0 if i < 0 else -1]), 0.0, 0.0
    slope = (values[i + 1] - values[i]) / (times[i + 1] - times[i])
    return float(values[i]), float(slope), float(times[i])


def checked_table(name: str, table: Any) -> Table:
    times = real_vector(table[0], f"input {name}'s table times")
    values = real_vector(table[1], f"input {name}'s table values")
    if times.size != values.size or times.size == 0:
        raise ModelError(f"input {name}'s table: {times.size} times and {values.size} values; "
                         "expected as many of each, at least one")
    if times.size > 1 and not np.all(np.diff(times) > 0):
        raise ModelError(f"input {name}'s table: its times must increase")
    return Table(times, values)


def input_number(name: str, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"input {name}: expected a number, a table (times, values), "
                         f"nemc.feedback(...) or a function f(t, y); got "
                         f"{type(value).__name__}") from None
    if not np.isfinite(number):
        raise ModelError(f"input {name}: {number} is not a finite number")
    return number


def call_input(function: Callable, t: float, y: np.ndarray | None) -> float:
    value = function(t, y)
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"an input function returned {type(value).__name__}, not a "
                         "number") from None
    if not np.isfinite(number):
        raise ModelError(f"an input function returned {number} at t = {t:g}")
    return number


def real_vector(value: Any, what: str) -> np.ndarray:
    array = real_matrix(value, what)
    if array.ndim != 1:
        raise ModelError(f"{what}: expected a 1-D array, got shape {array.shape}")
    return array


def real_matrix(value: Any, what: str) -> np.ndarray:
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{what}: expected real numbers, got {type(value).__name__}") from None
    if array.ndim not in (1, 2):
        raise ModelError(f"{what}: expected a vector or a matrix, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ModelError(f"{what}: not every entry is finite")
    return array
