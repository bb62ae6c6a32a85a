"""What `nemc simulate` shows: the book's [ts, xs] table (plus outputs), CSV, and figures."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .runtime import Model, SimulationResult


def columns(model: Model, result: SimulationResult) -> tuple[list[str], np.ndarray]:
    names = ["t", *model.state_names, *result.outputs]
    data = [result.t, *result.y, *result.outputs.values()]
    return names, np.column_stack(data) if result.t.size else np.empty((0, len(names)))


def rows_with_events(model: Model, result: SimulationResult
                     ) -> tuple[list[str], list[tuple[np.ndarray, str]]]:
    """The table's columns and rows in time order: the result's rows (label ""), and a row
    for each event that fired (its time, the state just before it, the outputs there; label
    its name). The label column is there only when the scene has events."""
    names, data = columns(model, result)
    rows = [(row, "") for row in data]
    fired = [(name, t, y) for name, (times, states) in result.events.items()
             for t, y in zip(times, states)]
    if not result.events:
        return names, rows
    for name, t, y in fired:
        outputs = model.outputs(t, y, result.params) if result.outputs else {}
        values = [t, *y, *(outputs[k] for k in result.outputs)]
        rows.append((np.array(values, dtype=float), name))
    rows.sort(key=lambda item: (item[0][0] if result.t.size < 2 or result.t[-1] >= result.t[0]
                                else -item[0][0]))
    return [*names, "event"], rows


def table(model: Model, result: SimulationResult) -> str:
    names, rows = rows_with_events(model, result)
    widths = [max(12, len(n)) for n in names]
    lines = [" ".join(f"{n:>{w}}" for n, w in zip(names, widths))]
    lines += [" ".join([*(f"{v:>{w}.6g}" for v, w in zip(row, widths)),
                        *([f"{'<- ' + label if label else '':<{widths[-1]}}"]
                          if len(names) > row.size else [])]).rstrip()
              for row, label in rows]
    lines.append(
        f"# {model.name}: {result.method}, rtol {result.rtol:g}, atol {result.atol:g}, "
        f"{result.nfev} rhs calls, {result.message}"
    )
    return "\n".join(lines)


def write_csv(model: Model, result: SimulationResult, path: Path) -> None:
    names, rows = rows_with_events(model, result)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(names)
        writer.writerows([*(repr(float(v)) for v in row),
                          *([label] if len(names) > row.size else [])] for row, label in rows)


def dense_times(result: SimulationResult, count: int = 600) -> np.ndarray:
    return np.linspace(result.t[0], result.t[-1], count) if result.t.size else result.t


def plot(model: Model, result: SimulationResult, path: Path) -> None:
    """The book's figures: one coordinate -> q, dq and the phase plot (Fig. 5.2); several ->
    each coordinate against t, angles in degrees (Figs. 5.4, 5.8); then the outputs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(model.coordinate_names)
    panels = 3 if n == 1 else n
    panels += 1 if result.outputs else 0
    fig, axes = plt.subplots(panels, 1, figsize=(7, 2.4 * panels), squeeze=False)
    axes = axes[:, 0]
    if n == 1:
        _single_coordinate(model, result, axes)
    else:
        _coordinates(model, result, axes)
    if result.outputs:
        for name, values in result.outputs.items():
            axes[-1].plot(result.t, values, label=name)
        axes[-1].set_xlabel("t")
        axes[-1].legend(fontsize="small", ncol=3)
        axes[-1].grid(True)
    fig.suptitle(f"{model.name} ({result.method}, rtol {result.rtol:g})")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _single_coordinate(model: Model, result: SimulationResult, axes) -> None:
    q, dq = model.state_names
    axes[0].plot(result.t, result.y[0], "r")
    axes[0].set(xlabel="t", ylabel=q)
    axes[1].plot(result.t, result.y[1], "g")
    axes[1].set(xlabel="t", ylabel=dq)
    axes[2].plot(result.y[0], result.y[1])
    axes[2].set(xlabel=q, ylabel=dq)
    for ax in axes[:3]:
        ax.grid(True)


def _coordinates(model: Model, result: SimulationResult, axes) -> None:
    kinds = model.metadata["coordinate_kinds"]
    for i, (name, kind) in enumerate(zip(model.coordinate_names, kinds)):
        values = result.y[2 * i]
        label = name
        if kind == "angle":
            values, label = np.degrees(values), f"{name} (deg)"
        axes[i].plot(result.t, values, "rb"[i % 2])
        axes[i].set(xlabel="t (s)", ylabel=label)
        axes[i].grid(True)
