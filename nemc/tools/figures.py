"""Figures of a run as an engineer puts them in a report.

The state as the book draws it: one coordinate -> its angle, its rate and the phase portrait
(Fig. 5.2); several -> each coordinate against time (Figs. 5.4, 5.8). Then the outputs in
panels by kind: reactions (ground frame, body frame, constraint couples), drives, energy, point
positions, velocities and paths, accelerations, each expression. Axis labels carry the units the
YAML declares (`units:`), angles in degrees when it says `angle: deg`; legends sit above their
panel, never on the data; colours are distinct within a panel. Curves come from a dense
sampling of the same run (several points per solver step), so fast motion does not alias.

A failed run is drawn the same way, from its dense output up to where it stopped, and marked:
its title says (in red) that it failed, at which time and why, and the time panels show where
it stopped and shade the part of its span it did not reach.

`nemc simulate --plot`, `res.plot()` and `make run` all draw through plot_result(). What it
returns is a `ShownFigure`: a notebook shows it as its image with no `%matplotlib inline`.
"""

from __future__ import annotations

import fnmatch
import io
import math
import os
import re
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ..runtime.model import SOLVER_STEPS, ModelError, SimulationResult
from ..runtime.runs import INTERRUPTED
from .typeset import math_label

PANEL_KINDS = ("state", "reactions", "drives", "loads", "energy", "points", "accelerations",
               "expressions")
POINTS_PER_STEP = 12  # dense sampling: curve points per solver step
MIN_POINTS, MAX_POINTS = 1500, 200_000
PANEL_SIZE = (6.4, 2.3)  # inches, one panel
MAX_ROWS, MAX_COLUMNS = 8, 4  # past MAX_ROWS rows of panels, more columns (up to MAX_COLUMNS)
MAX_HEIGHT = 18.0  # inches: a large mechanism's figure; its panels get lower, not the page longer
SEPARATE = 6  # past this many coordinates, several to a panel
PER_PANEL = 5  # coordinates to a panel then
DPI = 150
NOTEBOOK_DPI = 100  # a notebook's image: matplotlib's inline backend's size
FAILED_INK, UNREACHED = "#b00000", "#f2dede"  # a failed run's title and stop; its span not reached
REASON_CHARACTERS = 110  # a failure's reason in the title, shortened to this
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#7f7f7f", "#bcbd22")


class ShownFigure(Figure):
    """A matplotlib figure that a notebook shows as its image. nemc draws on figures of its
    own, not pyplot's, so no backend displays them: IPython asks `_repr_png_` instead (with
    `%matplotlib inline` its own formatter for figures answers first, with the same image)."""

    def _repr_png_(self) -> bytes:
        buffer = io.BytesIO()
        self.savefig(buffer, format="png", dpi=NOTEBOOK_DPI)
        return buffer.getvalue()


@dataclass
class Curve:
    label: str
    x: np.ndarray
    y: np.ndarray


@dataclass
class Panel:
    """One axes: its curves, axis labels, whether it is a path (equal scales, y vs x) and
    whether its curves need a legend (outputs: always; the state: the axis names it)."""

    ylabel: str
    curves: list[Curve] = field(default_factory=list)
    xlabel: str = ""
    path: bool = False
    legend: bool = True
    within: float | None = None  # every |value| below this tolerance: drawn as 0 with a note


# ---- dense sampling ---------------------------------------------------------------------------


def dense_times(steps: np.ndarray, per_step: int = POINTS_PER_STEP) -> np.ndarray:
    """Times through every solver step, per_step points in each, between MIN_ and MAX_POINTS."""
    steps = np.unique(np.asarray(steps, dtype=float))
    if steps.size < 2:
        return steps
    count = min(MAX_POINTS, max(MIN_POINTS, per_step * (steps.size - 1) + 1))
    fraction = np.linspace(0.0, steps.size - 1, count)
    return np.interp(fraction, np.arange(steps.size), steps)


def dense(result: SimulationResult) -> SimulationResult:
    """The same run sampled densely (through the integrator's dense output), when the result
    can rerun; else the result itself. A failed run stops again where it stopped, so it is
    sampled up to there (its solver's steps when the samples do not end there); a run
    interrupted by Ctrl-C is not rerun."""
    if result.rerun is None or result.status == INTERRUPTED:
        return result
    if result.success and result.t.size < 2:
        return result
    steps = result.rerun(SOLVER_STEPS)
    if steps.success != result.success:
        return result
    if steps.t.size < 2:  # a run that failed at its start: the one state it has
        return result if result.success else steps
    sampled = result.rerun(before_events(dense_times(steps.t), steps))
    if not result.success and (sampled.success or not sampled.t.size
                               or sampled.t[-1] != steps.t[-1]):
        return steps
    return sampled


def before_events(times: np.ndarray, steps: SimulationResult) -> np.ndarray:
    """TIMES with each that is an event's time moved a hair (1e-9 of the run) before it: a
    state sampled exactly there is the one before the event, whose crossing rounding may have
    left on the far side (a friction item's rate, read as the mode of the outputs)."""
    events = getattr(steps, "events", None) or {}
    at = [t for found, _ in events.values() for t in np.atleast_1d(found)]
    if not at or times.size < 2:
        return times
    hair = 1e-9 * abs(times[-1] - times[0])
    moved = times.copy()
    hits = np.isin(moved, at)
    hits[0] = hits[-1] = False  # the run's start and end stay
    moved[hits] -= np.sign(times[-1] - times[0]) * hair
    return np.unique(moved) if times[-1] > times[0] else np.unique(moved)[::-1]


@dataclass(frozen=True)
class Failure:
    """Where a failed run stopped (the last time it reached), why (its message, shortened) and
    the span it was asked to cover (None when unknown)."""

    t: float
    reason: str
    span: tuple[float, float] | None

    def line(self) -> str:
        asked = f" of {self.span[0]:g} .. {self.span[1]:g}" if self.span is not None else ""
        return f"run failed at t = {self.t:.6g}{asked}: {self.reason}"


def failure_of(res: SimulationResult, run: SimulationResult) -> Failure | None:
    """A failed result's Failure, its time the last one RUN (its dense sampling) reached."""
    if res.success or not run.t.size:
        return None
    return Failure(float(run.t[-1]), failure_reason(res.message), asked_span(res))


def failure_reason(message: str) -> str:
    """A run's failure message shortened for a title: no "integration failed: " or "at t=T: "
    prefix (the title says when), its first sentence, at most REASON_CHARACTERS long."""
    text = re.sub(r"^at t ?= ?[^:]*: ", "", message.removeprefix("integration failed: "))
    sentence = text.split(". ")[0].split("; ")[0]
    return textwrap.shorten(sentence, REASON_CHARACTERS, placeholder=" ...")


def asked_span(res: SimulationResult) -> tuple[float, float] | None:
    """The span the run was asked to cover (its arguments, the scene's, the default)."""
    if res.model is None or res.run_arguments is None:
        return None
    from ..runtime.simulation import run_spec

    try:
        start, end = run_spec(res.model, res.run_arguments, SOLVER_STEPS).span[:2]
    except (ModelError, ValueError):
        return None
    return float(start), float(end)


# ---- panels -----------------------------------------------------------------------------------


class Labels:
    """Axis labels and display scales from the model's metadata (units, kinds)."""

    def __init__(self, model: Any):
        meta = model.metadata
        self.kinds: dict[str, str] = meta.get("quantities", {})
        self.units: dict[str, str] = meta.get("unit_labels", {})
        self.degrees = meta.get("units", {}).get("angle") == "deg"

    def scale(self, name: str) -> float:
        angular = self.kinds.get(name, "").startswith("angular") or self.kinds.get(name) == "angle"
        return 180.0 / math.pi if angular and self.degrees else 1.0

    def unit(self, name: str) -> str:
        unit = self.units.get(name, "")
        if self.scale(name) != 1.0:
            unit = unit.replace("rad", "deg", 1) or "deg"
        return pretty_unit(unit)

    def axis(self, text: str, name: str) -> str:
        unit = self.unit(name)
        return f"{text} ({unit})" if unit else text


def pretty_unit(unit: str) -> str:
    return unit.replace("^2", "\u00b2").replace("^3", "\u00b3").replace("*", "\u00b7")


def driven_outputs(model: Any) -> list[str]:
    """The outputs that are driven coordinates (q1) and their rates (dot(q1)): known functions
    of t, drawn with the state."""
    kinds = model.metadata.get("quantities", {})
    names = set(model.output_names)
    driven = [n for n in model.output_names
              if kinds.get(n) in ("angle", "length") and "." not in n and "(" not in n]
    return [name for q in driven for name in (q, f"dot({q})") if name in names]


def state_panels(model: Any, res: SimulationResult, labels: Labels) -> list[Panel]:
    """The book's layout: angle, rate and phase portrait for one coordinate; else each
    coordinate against time; then each driven coordinate (its prescribed motion)."""
    tlabel = labels.axis("t", "t")
    driven = [Panel(labels.axis(math_label(q), q), [Curve(q, res.t, np.asarray(
        res.outputs[q]) * labels.scale(q))], tlabel, legend=False)
        for q in driven_outputs(model) if not q.startswith("dot(") and q in res.outputs]
    return free_state_panels(model, res, labels, tlabel) + driven


def free_state_panels(model: Any, res: SimulationResult, labels: Labels,
                      tlabel: str) -> list[Panel]:
    """The integrated state's panels (state_panels)."""
    coordinates = model.coordinate_names
    if len(coordinates) == 1:
        q, dq = model.state_names[:2]
        x, v = res.y[0] * labels.scale(q), res.y[1] * labels.scale(dq)
        return [Panel(labels.axis(math_label(q), q), [Curve(q, res.t, x)], tlabel, legend=False),
                Panel(labels.axis(math_label(dq), dq), [Curve(dq, res.t, v)], tlabel,
                      legend=False),
                Panel(labels.axis(math_label(dq), dq), [Curve(q, x, v)],
                      labels.axis(math_label(q), q), legend=False)]
    if len(coordinates) > SEPARATE:
        return grouped_coordinates(model, res, labels, tlabel)
    return [Panel(labels.axis(math_label(q), q), [Curve(q, res.t, res.y[2 * i] * labels.scale(q))],
                  tlabel, legend=False) for i, q in enumerate(coordinates)]


def grouped_coordinates(model: Any, res: SimulationResult, labels: Labels,
                        tlabel: str) -> list[Panel]:
    """Many coordinates: PER_PANEL to a panel (those of one unit together), with a legend."""
    coordinates = model.coordinate_names
    index = {q: 2 * i for i, q in enumerate(coordinates)}
    panels = []
    for unit in dict.fromkeys(labels.unit(q) for q in coordinates):
        same = [q for q in coordinates if labels.unit(q) == unit]
        for start in range(0, len(same), PER_PANEL):
            chunk = same[start:start + PER_PANEL]
            text = "angle" if labels.kinds.get(chunk[0]) == "angle" else "coordinate"
            panels.append(Panel(labels.axis(text, chunk[0]), [
                Curve(q, res.t, res.y[index[q]] * labels.scale(q)) for q in chunk], tlabel))
    return panels


def output_groups(model: Any, names: Sequence[str]) -> list[tuple[str, str, list[str]]]:
    """(kind, axis text, output names) for each output panel, in PANEL_KINDS order."""
    kinds = model.metadata.get("quantities", {})
    driven = set(driven_outputs(model))
    loads = set(model.metadata.get("load_outputs", ()))
    named_loads = [n for n in names if n in loads]
    names = [n for n in names if n not in driven and n not in loads]
    joints = {name.rpartition(".")[0] for name in names
              if kinds.get(name) in ("joint force", "couple")}
    groups: list[tuple[str, str, list[str]]] = []

    def add(kind: str, text: str, members: list[str]) -> None:
        if members:
            groups.append((kind, text, members))

    reaction = [n for n in names if n.rpartition(".")[0] in joints and not n.endswith(".drive")]
    add("reactions", "reaction, ground axes", [n for n in reaction if n[-3:] in (".Fx", ".Fy")])
    add("reactions", "reaction, body axes", [n for n in reaction if n[-3:] in (".Fn", ".Ft")])
    add("reactions", "constraint couple", [n for n in reaction if n.endswith(".M")])
    add("drives", "drive", [n for n in names if n.endswith(".drive")])
    for kind in dict.fromkeys(kinds.get(n, "") for n in named_loads):  # torques, forces apart
        add("loads", "load", [n for n in named_loads if kinds.get(n, "") == kind])
    add("energy", "energy", [n for n in names if n.startswith("energy.")])
    points = [n for n in names if kinds.get(n) in ("length", "speed") and n not in reaction]
    add("points", "position", [n for n in points if kinds[n] == "length"])
    add("points", "velocity", [n for n in points if kinds[n] == "speed"])
    add("accelerations", "acceleration", [n for n in names if n.startswith("ddot(")])
    grouped = {n for _, _, members in groups for n in members}
    for name in names:
        if name not in grouped:
            groups.append(("expressions", name, [name]))
    return groups


def output_panels(model: Any, res: SimulationResult, labels: Labels,
                  names: Sequence[str], kinds: Sequence[str]) -> list[Panel]:
    tlabel = labels.axis("t", "t")
    panels = []
    for kind, text, members in output_groups(model, names):
        if kind not in kinds:
            continue
        if kind == "accelerations":  # angular and linear accelerations do not share an axis
            for unit in dict.fromkeys(labels.unit(n) for n in members):
                same = [n for n in members if labels.unit(n) == unit]
                panels.append(Panel(labels.axis(text, same[0]), [
                    Curve(math_label(n), res.t, np.asarray(res.outputs[n]) * labels.scale(n))
                    for n in same], tlabel))
            continue
        curves = [Curve(n, res.t, np.asarray(res.outputs[n]) * labels.scale(n)) for n in members]
        panels.append(Panel(labels.axis(text, members[0]), curves, tlabel))
        if text == "position":
            panels.append(path_panel(res, members, labels))
    return panels


def path_panel(res: SimulationResult, members: list[str], labels: Labels) -> Panel:
    """The points' paths in the plane (y against x, equal scales)."""
    panel = Panel(labels.axis("y", members[0]), xlabel=labels.axis("x", members[0]), path=True)
    for name in members:
        if name.endswith(".x") and name[:-2] + ".y" in res.outputs:
            point = name[:-2]
            panel.curves.append(Curve(point, res.outputs[name], res.outputs[point + ".y"]))
    return panel


def selected_outputs(model: Any, patterns: Sequence[str] | None) -> list[str]:
    """The outputs matching any of the patterns (names or shell patterns such as A.*)."""
    names = list(model.output_names)
    if patterns is None:
        return names
    return [n for n in names if any(fnmatch.fnmatchcase(n, p) for p in patterns)]


# ---- drawing ----------------------------------------------------------------------------------


def grid(state: int, outputs: int) -> list[tuple[int, int]]:
    """(row, column) of each panel, state first: the state down the left column and the
    outputs beside it, then the remaining outputs two to a row; one group alone fills one
    column (two, row by row, past four panels)."""
    if state and outputs:
        beside = [(r, 1) for r in range(min(state, outputs))]
        rest = outputs - len(beside)
        below = [(state + k // 2, k % 2) for k in range(rest)]
        return [(r, 0) for r in range(state)] + beside + below
    count = state or outputs
    return [(k // 2, k % 2) for k in range(count)] if count > 4 else [(k, 0) for k in range(count)]


def capped(places: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The grid's places, or past MAX_ROWS rows the panels in order down up to MAX_COLUMNS
    columns (a large mechanism: the state first, down the first columns)."""
    rows = max(r for r, _ in places) + 1
    if rows <= MAX_ROWS:
        return places
    count = len(places)
    columns = min(MAX_COLUMNS, max(2, math.ceil(count / MAX_ROWS)))
    rows = math.ceil(count / columns)
    return [(k % rows, k // rows) for k in range(count)]


def draw(state: list[Panel], outputs: list[Panel], title: str,
         size: tuple[float, float] | None = None,
         failure: Failure | None = None) -> ShownFigure:
    """The report figure: panels on the grid above (capped), SIZE (inches) when given, else
    PANEL_SIZE a panel, the height at most MAX_HEIGHT; a failed run's marked (mark_failure)."""
    places = capped(grid(len(state), len(outputs)))
    rows = max(r for r, _ in places) + 1
    columns = max(c for _, c in places) + 1
    if size is None:
        size = (PANEL_SIZE[0] * columns, min(PANEL_SIZE[1] * rows + 0.4, MAX_HEIGHT))
    fig = ShownFigure(figsize=size, layout="constrained")
    if failure is None:
        fig.suptitle(title)
    else:  # the title's second line, wrapped to the figure's width
        line = textwrap.fill(failure.line(), max(40, int(size[0] * 11)))
        fig.suptitle(f"{title}\n{line}", color=FAILED_INK)
    for panel, (r, c) in zip(state + outputs, places):
        ax = fig.add_subplot(rows, columns, r * columns + c + 1)
        draw_panel(ax, panel)
        if failure is not None and against_time(panel):
            mark_failure(ax, failure)
    return fig


def against_time(panel: Panel) -> bool:
    """Whether the panel's curves are drawn against t (the axis a failure is marked on)."""
    return not panel.path and bool(panel.curves) and panel.xlabel.startswith("t")


def mark_failure(ax: Any, failure: Failure) -> None:
    """Where the run stopped (a red dashed line) and the part of its span it did not reach
    (shaded), the axis spanning the whole of what was asked."""
    ax.axvline(failure.t, color=FAILED_INK, ls="--", lw=1.2, zorder=3)
    if failure.span is None or failure.span[1] == failure.t:
        return
    start, end = failure.span
    ax.axvspan(failure.t, end, color=UNREACHED, zorder=0, lw=0)
    ax.set_xlim(min(start, end), max(start, end))


def draw_panel(ax: Any, panel: Panel) -> None:
    for k, curve in enumerate(panel.curves):
        style = "-" if k < len(COLOURS) else "--"
        y = curve.y if panel.within is None else np.zeros_like(curve.y)
        ax.plot(curve.x, y, style, color=COLOURS[k % len(COLOURS)], lw=1.4,
                label=curve.label, marker="o" if curve.x.size == 1 else None)
    if panel.within is not None:  # rounding noise: a flat 0, not autoscaled noise
        ax.set_ylim(-1.0, 1.0)
        ax.text(0.5, 0.5, f"0 within tolerance (|values| < atol {panel.within:g})",
                transform=ax.transAxes, ha="center", va="bottom", fontsize="small",
                color="#555555")
    if panel.path:
        for k, curve in enumerate(panel.curves):
            ax.plot(curve.x[:1], curve.y[:1], "o", color=COLOURS[k % len(COLOURS)], ms=4)
        ax.set_aspect("equal", adjustable="datalim")
    elif panel.xlabel.startswith("$") and panel.curves:  # phase portrait: mark the start
        ax.plot(panel.curves[0].x[:1], panel.curves[0].y[:1], "o", color=COLOURS[0], ms=4)
    ax.set_xlabel(panel.xlabel)
    ax.set_ylabel(panel.ylabel)
    ax.grid(True, lw=0.5, alpha=0.6)
    if against_time(panel) and panel.curves[0].x.size > 1:
        ax.set_xlim(panel.curves[0].x[0], panel.curves[0].x[-1])
    if panel.legend:  # above the axes: never on the data
        ax.legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=min(len(panel.curves), 5),
                  frameon=False, fontsize="small", borderaxespad=0.2, handlelength=1.8)


def against(panels: list[Panel], model: Any, res: SimulationResult, labels: Labels,
            x: str) -> list[Panel]:
    """The panels drawn against X (a state entry or an output) instead of t: each curve over
    time takes X's values at the same times; the paths and the phase portrait keep their axes,
    and a panel of X alone against itself is left out."""
    columns = {"t": res.t, **dict(zip(model.state_names, res.y)), **res.outputs}
    if x not in columns:
        raise ValueError(f"x: no state entry or output {x!r}; choose from "
                         f"{', '.join(columns)}")
    values = np.asarray(columns[x], dtype=float) * labels.scale(x)
    tlabel = labels.axis("t", "t")
    coordinate = x in model.state_names or x in driven_outputs(model)
    xlabel = labels.axis(math_label(x) if coordinate else x, x)
    drawn = []
    for panel in panels:
        if panel.path or panel.xlabel != tlabel:
            drawn.append(panel)
            continue
        curves = [Curve(c.label, values, c.y) for c in panel.curves if c.label != x]
        if curves:
            drawn.append(Panel(panel.ylabel, curves, xlabel, legend=panel.legend))
    return drawn


def only_curves(panels: list[Panel], patterns: Sequence[str]) -> list[Panel]:
    """The panels' curves of the names matching any pattern (q1, A.*); panels left empty are
    left out (a path panel follows its points' positions)."""
    kept = []
    for panel in panels:
        curves = [c for c in panel.curves
                  if any(fnmatch.fnmatchcase(c.label, p) for p in patterns)
                  or (panel.path and any(fnmatch.fnmatchcase(f"{c.label}.x", p)
                                         for p in patterns))]
        if curves:
            kept.append(Panel(panel.ylabel, curves, panel.xlabel, panel.path, panel.legend))
    return kept


def mark_noise(panels: list[Panel], atol: float) -> None:
    """A panel whose every value is below the run's atol (rounding noise, 1e-16) is drawn as 0
    within tolerance."""
    for panel in panels:
        values = [np.abs(c.y[np.isfinite(c.y)]) for c in panel.curves]
        if not panel.path and values and all(v.size and v.max() < atol for v in values):
            panel.within = atol


def figure(res: SimulationResult, *, panels: Sequence[str] | None = None,
           outputs: Sequence[str] | None = None, dense_curves: bool = True,
           x: str | None = None, title: str | None = None,
           size: tuple[float, float] | None = None,
           only: Sequence[str] | None = None) -> Figure:
    """The report figure of a run: the panels of the kinds asked for (default: all), only
    the curves named (names or patterns) when given, TITLE and SIZE (inches) when given."""
    model = res.model
    if model is None:
        raise ValueError("this result does not know its model: plot a result of simulate()")
    kinds = tuple(panels) if panels is not None else PANEL_KINDS
    unknown = [k for k in kinds if k not in PANEL_KINDS]
    if unknown:
        raise ValueError(f"unknown panel kind(s) {unknown}; choose from {', '.join(PANEL_KINDS)}")
    run = dense(res) if dense_curves else res
    labels = Labels(model)
    state = state_panels(model, run, labels) if "state" in kinds else []
    named = [n for n in selected_outputs(model, outputs) if n in run.outputs]  # a run that
    drawn = output_panels(model, run, labels, named, kinds)  # could not start has none
    if only is not None:
        state, drawn = only_curves(state, only), only_curves(drawn, only)
    if x is not None and x != "t":
        state, drawn = against(state, model, run, labels, x), against(drawn, model, run, labels, x)
    if not state and not drawn:
        raise ValueError("nothing to draw: no panel of the kinds asked for has data"
                         + (f" (only: {', '.join(only)})" if only is not None else ""))
    mark_noise(state + drawn, run.atol)
    if title is None:
        title = f"{model.name} ({run.method}, rtol {run.rtol:g}, atol {run.atol:g})"
    return draw(state, drawn, title, size, failure_of(res, run))


def plot_result(res: SimulationResult, path: str | os.PathLike | None = None,
                **options: Any) -> Figure:
    """figure(), written to PATH (PNG, PDF, SVG) when given."""
    fig = figure(res, **options)
    if path is not None:
        fig.savefig(path, dpi=DPI)
    return fig
