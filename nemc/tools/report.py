"""What `nemc simulate` shows: the book's [ts, xs] table (plus outputs), CSV, MATLAB files and
figures."""

from __future__ import annotations

import csv
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..runtime.model import Model, SimulationResult


def columns(model: Model, result: SimulationResult, outputs: Sequence[str] | None = None
            ) -> tuple[list[str], np.ndarray]:
    """The table's column names and values: t, the state, the outputs (or those named)."""
    chosen = list(result.outputs) if outputs is None else list(outputs)
    names = ["t", *model.state_names, *chosen]
    data = [result.t, *result.y, *(result.outputs[name] for name in chosen)]
    return names, np.column_stack(data) if result.t.size else np.empty((0, len(names)))


def unit_of(model: Model, name: str) -> str:
    """The column's unit as the YAML's `units:` give it (values as computed: angles in rad)."""
    return model.metadata.get("unit_labels", {}).get(name, "")


def headers(model: Model, names: Sequence[str]) -> list[str]:
    """CSV headers: `name [unit]` where the unit is known, else the name."""
    return [f"{name} [{unit_of(model, name)}]" if unit_of(model, name) else name
            for name in names]


def rows_with_events(model: Model, result: SimulationResult,
                     outputs: Sequence[str] | None = None,
                     ) -> tuple[list[str], list[tuple[np.ndarray, str]]]:
    """The table's columns and rows in time order: the result's rows (label ""), and a row
    for each event that fired (its time, the state just before it, the outputs there; label
    its name). The label column is there only when the scene has events."""
    names, data = columns(model, result, outputs)
    chosen = names[1 + model.n_state:]
    rows = [(row, "") for row in data]
    fired = [(name, t, y) for name, (times, states) in result.events.items()
             for t, y in zip(times, states)]
    if not result.events:
        return names, rows
    for name, t, y in fired:
        there = model.outputs(t, y, result.params) if chosen else {}
        values = [t, *y, *(there[k] for k in chosen)]
        rows.append((np.array(values, dtype=float), name))
    rows.sort(key=lambda item: (item[0][0] if result.t.size < 2 or result.t[-1] >= result.t[0]
                                else -item[0][0]))
    return [*names, "event"], rows


def units_row(model: Model, names: Sequence[str]) -> list[str]:
    """Each column's unit in brackets (`[rad/s]`), as the CSV's headers give it; "" where
    none is known."""
    return [f"[{unit_of(model, name)}]" if unit_of(model, name) else "" for name in names]


def table(model: Model, result: SimulationResult, outputs: Sequence[str] | None = None) -> str:
    """The terminal table: the columns' names, beneath them their units where the YAML gives
    any (`units:`, an output expression's `unit:`; values as computed, angles in rad), a row a
    time (an event's row marked with its name) and a closing line on the run."""
    names, rows = rows_with_events(model, result, outputs)
    units = units_row(model, names)
    widths = [max(12, len(n), len(u)) for n, u in zip(names, units)]
    lines = [" ".join(f"{n:>{w}}" for n, w in zip(names, widths))]
    if any(units):
        lines.append(" ".join(f"{u:>{w}}" for u, w in zip(units, widths)).rstrip())
    lines += [" ".join([*(f"{v:>{w}.6g}" for v, w in zip(row, widths)),
                        *([f"{'<- ' + label if label else '':<{widths[-1]}}"]
                          if len(names) > row.size else [])]).rstrip()
              for row, label in rows]
    lines.append(
        f"# {model.name}: {result.method}, rtol {result.rtol:g}, atol {result.atol:g}, "
        f"{result.nfev} rhs calls, {result.message}"
    )
    return "\n".join(lines)


def write_csv(model: Model, result: SimulationResult, path: Path,
              outputs: Sequence[str] | None = None) -> None:
    names, rows = rows_with_events(model, result, outputs)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(headers(model, names))
        writer.writerows([*(repr(float(v)) for v in row),
                          *([label] if len(names) > row.size else [])] for row, label in rows)


def matlab_name(name: str) -> str:
    """A MATLAB variable name for a column: dot(q1) -> dot_q1, A.Fx -> A_Fx."""
    text = re.sub(r"\W+", "_", name).strip("_")
    return text if re.match(r"[A-Za-z]", text) else f"v_{text}"


MAT_RESERVED = frozenset({"ts", "xs", "variables", "names", "units", "description"})


def write_mat(model: Model, result: SimulationResult, path: Path,
              outputs: Sequence[str] | None = None) -> None:
    """A MATLAB file (scipy.io.savemat): the book's ts and xs (one row per time, the state in
    its columns), each column as a variable, and `names` and `units` (cell arrays) saying
    what each variable is; `units` as the YAML declares them (angles in rad)."""
    from scipy.io import savemat

    names, data = columns(model, result, outputs)
    variables = [matlab_name(name) for name in names]
    variables = [f"{v}_" if v in MAT_RESERVED else v for v in variables]
    if len(set(variables)) != len(variables):  # e.g. A.Fx and A_Fx: number them apart
        variables = [f"{v}_{k}" for k, v in enumerate(variables)]
    content: dict = {var: data[:, k] for k, var in enumerate(variables)}
    content |= {
        "ts": data[:, :1], "xs": data[:, 1 : 1 + model.n_state],
        "variables": np.array(variables, dtype=object),
        "names": np.array(names, dtype=object),
        "units": np.array([unit_of(model, name) for name in names], dtype=object),
        "description": f"{model.name}: {model.metadata.get('description', '')}",
    }
    savemat(path, content, do_compression=True, oned_as="column")


def plot(result: SimulationResult, path: Path, panels: Sequence[str] | None = None,
         outputs: Sequence[str] | None = None, x: str | None = None,
         **options: Any) -> None:
    """The report figure (nemc.figures): the book's layout of the state, outputs by kind;
    against X (a state entry or an output) instead of t when given; OPTIONS: figure()'s
    title, size and only."""
    from .figures import plot_result

    plot_result(result, path, panels=panels, outputs=outputs, x=x, **options)
