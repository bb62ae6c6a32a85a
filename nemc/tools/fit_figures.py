"""The figure of a fit (FitResult.plot, `nemc fit --plot`): for each observed signal, the data
as points and the fitted model's curve (its runs at the estimate, sampled densely as a run's
figure is), and below it the fit's residuals (model - data, weighted as the fit weighed them)
at the data's times; an experiment a colour, a shot's run drawn on its own span. Units and
degrees as in a run's figure (figures.Labels); weighted residuals are in sigmas and unscaled.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from .figures import COLOURS, DPI, PANEL_SIZE, Labels, ShownFigure, dense

DATA_MARKER_SIZE = 3.0  # points: the measurements


def experiment_residuals(result: Any) -> list[np.ndarray]:
    """The fit's residuals cut per experiment, each n_t x observed (the fit's data order:
    experiment by experiment, time by time, observed by observed)."""
    parts, start = [], 0
    for experiment in result.experiments:
        size = experiment.data.size
        parts.append(result.residual[start:start + size].reshape(experiment.data.shape))
        start += size
    return parts


def experiment_runs(result: Any) -> list[list[Any]]:
    """Each experiment's runs at the estimate: one, or with shots its shots' in order."""
    per = len(result.runs) // max(len(result.experiments), 1)
    return [result.runs[k * per:(k + 1) * per] for k in range(len(result.experiments))]


def model_curve(run: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    """NAME (a state entry or an output) along RUN, sampled densely."""
    sampled, model = dense(run), run.model
    if name in model.state_names:
        return sampled.t, sampled.y[model.state_names.index(name)]
    return sampled.t, sampled.outputs[name]


def weighted(result: Any) -> bool:
    """Whether any datum's weight differs from 1 (its residual is then in sigmas)."""
    return any(np.any(e.weights != 1.0) for e in result.experiments)


def fit_figure(result: Any, title: str | None = None,
               size: tuple[float, float] | None = None) -> ShownFigure:
    """The figure: a pair of panels (data with the model above, residuals below) per
    observed signal, side by side."""
    if not result.runs or not result.experiments:
        raise ValueError("this fit holds no runs to draw: plot a result of nemc.fit")
    model = result.runs[0].model
    labels = Labels(model)
    columns = len(result.observed)
    if size is None:
        size = (PANEL_SIZE[0] * min(columns, 3), 2 * PANEL_SIZE[1] * -(-columns // 3) + 0.5)
    fig = ShownFigure(figsize=size, layout="constrained")
    rows = 2 * -(-columns // 3)
    width = min(columns, 3)
    residuals, runs = experiment_residuals(result), experiment_runs(result)
    for j, name in enumerate(result.observed):
        place = 2 * (j // 3) * width + j % 3 + 1
        top = fig.add_subplot(rows, width, place)
        bottom = fig.add_subplot(rows, width, place + width, sharex=top)
        draw_signal(top, bottom, result, name, j, labels, residuals, runs)
    fig.suptitle(title or f"{model.name}: fit of {', '.join(result.names)} "
                 f"(rms residual {result.rms:.3g})")
    return fig


def draw_signal(top: Any, bottom: Any, result: Any, name: str, j: int, labels: Labels,
                residuals: Sequence[np.ndarray], runs: Sequence[list[Any]]) -> None:
    """Observed signal NAME (column J of the data): data and model on TOP, residuals BOTTOM."""
    scale = labels.scale(name)
    several = len(result.experiments) > 1
    for k, (experiment, residual) in enumerate(zip(result.experiments, residuals)):
        colour = COLOURS[k % len(COLOURS)]
        where = f"experiment {k}: " if several else ""
        top.plot(experiment.t, scale * experiment.data[:, j], "o", color=colour,
                 ms=DATA_MARKER_SIZE, alpha=0.6, label=f"{where}data")
        for shot, run in enumerate(runs[k]):
            t, y = model_curve(run, name)
            top.plot(t, scale * y, "-", color=colour, lw=1.3,
                     label=f"{where}fitted model" if shot == 0 else None)
        shown = residual[:, j] * (1.0 if weighted(result) else scale)
        bottom.plot(experiment.t, shown, "o", color=colour, ms=DATA_MARKER_SIZE,
                    label=f"{where}residual")
    bottom.axhline(0.0, color="#555555", lw=0.8)
    top.set_ylabel(labels.axis(name, name))
    bottom.set_ylabel("weighted residual (σ)" if weighted(result)
                      else labels.axis("residual", name))
    bottom.set_xlabel(labels.axis("t", "t"))
    for ax in (top, bottom):
        ax.grid(True, lw=0.5, alpha=0.6)
    if j == 0:  # one legend, above the first panel: an experiment a row
        top.legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=2, frameon=False,
                   fontsize="small", borderaxespad=0.2)


def plot_fit(result: Any, path: str | os.PathLike | None = None, **options: Any) -> ShownFigure:
    """fit_figure(), written to PATH (PNG, PDF, SVG) when given."""
    fig = fit_figure(result, **options)
    if path is not None:
        fig.savefig(path, dpi=DPI)
    return fig
