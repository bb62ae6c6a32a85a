"""What runs return: one run's SimulationResult (as scipy's OdeResult, plus the scene's outputs,
computed when first read, and the user's views of it: tables, figures, animation, notebooks) and
an ensemble's EnsembleResult."""

from __future__ import annotations

import functools
import importlib
import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .failures import ModelError

SUCCESS_MESSAGE = "The solver successfully reached the end of the integration interval."


class LazyOutputs(Mapping[str, np.ndarray]):
    """The scene's outputs along a result, computed from its t and y on first access: a caller
    that never reads them (a sweep, a benchmark) does not pay for them."""

    __slots__ = ("_compute", "_arguments", "_values")

    def __init__(self, compute: Callable[..., dict[str, np.ndarray]], *arguments: Any):
        self._compute: Callable[..., dict[str, np.ndarray]] | None = compute
        self._arguments = arguments  # compute's (no closure made per result: issue 19)
        self._values: dict[str, np.ndarray] = {}

    def _get(self) -> dict[str, np.ndarray]:
        if self._compute is not None:
            self._values, self._compute = self._compute(*self._arguments), None
            self._arguments = ()
        return self._values

    def __getitem__(self, name: str) -> np.ndarray:
        return self._get()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())

    def __repr__(self) -> str:
        return repr(self._get())


NO_OUTPUTS = LazyOutputs(dict)  # the outputs of a result without any (nothing to compute)


def merged_outputs(outputs: Mapping[str, np.ndarray], more: Mapping[str, np.ndarray]
                   ) -> dict[str, np.ndarray]:
    """OUTPUTS (computed now, where lazy) followed by MORE."""
    return {**outputs, **more}


def with_outputs(outputs: Mapping[str, np.ndarray], more: Mapping[str, np.ndarray]
                 ) -> LazyOutputs:
    """OUTPUTS and then MORE (a run's own outputs: the work account), still computed when
    first read."""
    return LazyOutputs(merged_outputs, outputs, more)


@dataclass
class SimulationResult:
    """As scipy's OdeResult, plus the scene's outputs at every returned time (computed when
    first read)."""

    t: np.ndarray
    y: np.ndarray
    outputs: Mapping[str, np.ndarray]
    nfev: int
    njev: int
    nlu: int
    status: int
    message: str
    success: bool
    method: str
    rtol: float
    atol: float
    params: dict[str, float] = field(default_factory=dict)
    # name -> (times, states just before each, shape (k, n_state)): the scene's events that
    # fired, then simulate(events=...)'s callables by their __name__
    events: Mapping[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    # simulate(..., sensitivities=[...])'s: name -> d y(t) / d name, (n_state, n_t) ("y0":
    # (n_state, n_state, n_t)); and the outputs': name -> output -> (n_t,) ("y0": (n_state, n_t))
    sensitivities: Mapping[str, np.ndarray] = field(default_factory=dict)
    # and the event times' own: event -> name -> k arrays, as event_times (each run's kept
    # events), (count,) ("y0": (n_state, count)) each
    event_sensitivities: Mapping[str, Mapping[str, list]] = field(default_factory=dict)
    output_sensitivities: Mapping[str, Mapping[str, np.ndarray]] = field(default_factory=dict)
    # and the scene's events' times': event -> name -> d t_event / d name, (k,) for the k times
    # the event fired ("y0": (n_state, k))
    event_sensitivities: Mapping[str, Mapping[str, np.ndarray]] = field(default_factory=dict)

    @property
    def t_events(self) -> list[np.ndarray]:
        """As solve_ivp's: each event's times, in res.events' order."""
        return [times for times, _ in self.events.values()]

    @property
    def y_events(self) -> list[np.ndarray]:
        """As solve_ivp's: each event's states, (k, n_state) each."""
        return [states for _, states in self.events.values()]

    # the model that ran it, and its simulate() call's arguments (rerun)
    model: Any = field(default=None, repr=False, compare=False)
    run_arguments: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def rerun(self) -> Callable[[Any], SimulationResult] | None:
        """The same run at other times: rerun(t_eval) (dense curves for figures); None for a
        result that simulate() did not return. Made when asked for: simulate() only keeps
        its arguments (0.2 us less per call, issue 19)."""
        if self.model is None or self.run_arguments is None:
            return None
        return functools.partial(self.model._rerun, self.run_arguments)

    # -- the user's view: tables, figures, animation, notebooks (issue 20) ------------------

    def columns(self) -> dict[str, np.ndarray]:
        """t, the state and the outputs by name, in the table's order."""
        names = self.model.state_names if self.model is not None else [
            f"y{i}" for i in range(len(self.y))]
        return {"t": self.t, **dict(zip(names, self.y)), **self.outputs}

    def to_pandas(self) -> Any:
        """A pandas DataFrame indexed by t, a column per state and output (pandas is optional:
        imported here); the unit of each column, where the YAML declares units, in
        df.attrs["units"]."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("to_pandas() needs pandas: pip install pandas") from None
        columns = self.columns()
        frame = pd.DataFrame({k: v for k, v in columns.items() if k != "t"},
                             index=pd.Index(columns["t"], name="t"))
        labels = self.model.metadata.get("unit_labels", {}) if self.model is not None else {}
        frame.attrs["units"] = {name: labels.get(name, "") for name in columns}
        frame.attrs["method"] = self.method
        return frame

    def plot(self, path: str | os.PathLike | None = None, **options: Any) -> Any:
        """The report figure of this run (nemc.figures: state as in the book, outputs grouped
        by kind, units from the YAML); written to PATH when given. Returns the figure."""
        return user_view("figures", "plot()").plot_result(self, path, **options)

    def animate(self, path: str | os.PathLike | None = None, **options: Any) -> Any:
        """The mechanism moving (nemc.animate): written to PATH (.gif, .mp4, .html) when
        given, else returned for display (inline in a notebook)."""
        return user_view("animate", "animate()").animate_result(self, path, **options)

    def to_html(self) -> str:
        """A notebook's view of this run (its _repr_html_): the method, tolerances, RHS calls
        and outcome, and the table of t, states and outputs (the first and last 5 rows of a
        long one)."""
        import html  # here, as difflib and concurrent.futures: a cached load imports neither

        name = self.model.name if self.model is not None else "simulation"
        status = "success" if self.success else "failed"
        head = (f"<p><b>{html.escape(name)}</b>: {html.escape(self.method)}, rtol {self.rtol:g},"
                f" atol {self.atol:g}, {self.nfev} RHS calls, {len(self.t)} times, {status}: "
                f"{html.escape(self.message)}</p>")
        units = self.model.metadata.get("unit_labels", {}) if self.model is not None else {}
        return head + html_table(self.columns(), rows=preview_rows(len(self.t)), units=units)

    _repr_html_ = to_html  # IPython's display protocol


@dataclass
class EnsembleResult:
    """simulate_many's results: y[r] is run r's states at t (NaN after a run stopped)."""

    t: np.ndarray
    y: np.ndarray  # (k, n_state, n_t)
    status: np.ndarray  # (k,): as SimulationResult.status (0 the end, 1 a stop event, < 0 not)
    success: np.ndarray
    nfev: np.ndarray
    njev: np.ndarray
    nlu: np.ndarray
    method: str
    rtol: float
    atol: float
    event_names: tuple[str, ...] = ()  # the scene's events, in the order event_which counts
    event_t: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))  # (k, max_events)
    event_which: np.ndarray = field(default_factory=lambda: np.empty((0, 0), dtype=np.intc))
    event_count: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=int))  # (k,)
    # simulate_many(sensitivities=...): name -> (k, n_state, n_t) ("y0": (k, n_state, n_state,
    # n_t)); [r] is run r's, as its single run's res.sensitivities[name]
    sensitivities: Mapping[str, np.ndarray] = field(default_factory=dict)
    # and the event times' own: event -> name -> k arrays, as event_times (each run's kept
    # events), (count,) ("y0": (n_state, count)) each
    event_sensitivities: Mapping[str, Mapping[str, list]] = field(default_factory=dict)

    def event_times(self, name: str) -> list[np.ndarray]:
        """Each run's times of event NAME (the first max_events events of each run)."""
        if name not in self.event_names:
            raise ModelError(f"no event {name!r}; the scene's events: {list(self.event_names)}")
        k = self.event_names.index(name)
        return [times[which == k] for times, which in zip(self.event_t, self.event_which)]


def user_view(module: str, what: str) -> Any:
    """nemc's module for figures or animation; a standalone package without nemc says what to
    install instead of failing deep inside."""
    try:
        return importlib.import_module(f"nemc.tools.{module}")
    except ImportError as error:
        raise ImportError(f"{what} needs nemc and matplotlib installed (pip install nemc, or "
                          f"use the nemc checkout): {error}") from None


def preview_rows(count: int, head: int = 5) -> list[int]:
    """The rows a notebook's preview shows: all of a short table, else its first and last
    HEAD with an ellipsis row (-1) between."""
    return list(range(count)) if count <= 2 * head else [
        *range(head), -1, *range(count - head, count)]


def html_table(columns: Mapping[str, np.ndarray], rows: list[int],
               units: Mapping[str, str] | None = None) -> str:
    """An HTML table of the columns at these rows (-1: an ellipsis row), each column's unit
    under its name where UNITS gives one (as the terminal's table and the CSV's headers)."""
    import html

    names = list(columns)
    units = units or {}
    head = "".join(f"<th>{html.escape(n)}" + (f"<br>[{html.escape(units[n])}]"
                                                if units.get(n) else "") + "</th>"
                   for n in names)
    body = []
    for row in rows:
        cells = ["&hellip;"] * len(names) if row < 0 else [
            f"{float(columns[n][row]):.6g}" for n in names]
        body.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def model_html(model: Any) -> str:
    """A model's notebook view (Model._repr_html_ is this function): its name, description and
    a table of its state, parameters (with their defaults) and outputs, with their units."""
    import html

    labels = model.metadata.get("unit_labels", {})
    description = model.metadata.get("description", "")
    sections = [("state", [(n, "") for n in model.state_names]),
                ("parameters", [(n, f"{v:g}") for n, v in model.parameters.items()]),
                ("outputs", [(n, "") for n in model.output_names])]

    def row(name: str, value: str = "") -> str:
        unit = labels.get(name, "")
        return (f"<tr><td>{html.escape(name)}</td><td>{html.escape(value)}</td>"
                f"<td>{html.escape(unit)}</td></tr>")

    body = "".join(f"<tr><th colspan='3'>{title}</th></tr>" + "".join(row(*r) for r in rows)
                   for title, rows in sections if rows)
    return (f"<p><b>nemc model {html.escape(model.name)}</b>: {html.escape(description)}</p>"
            f"<table><thead><tr><th>name</th><th>default</th><th>unit</th></tr></thead>"
            f"<tbody>{body}</tbody></table>")
