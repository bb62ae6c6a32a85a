"""A sweep's results as an analyst reads them: `nemc.open_sweep(path)` is the stored dataset
with its grid as dimensions (q1 x q2 x draw) instead of one flat `run`.

The store itself stays flat along `run`: it is written and resumed in chunks of consecutive
runs (a chunk is one task, its status says it is done), and `nemc.sweep` takes any list of
runs, grid or not. A grid's runs are its product in order (the first axis slowest, the random
draws innermost), so this view is a reshape of each variable, lazy for a store read from disk.

This module imports xarray only inside the functions that need it.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .sweep_store import SweepStoreError, input_name, read_output

DRAW = "draw"  # the dimension of a grid point's random draws (`nemc sweep --runs K`)


def open_sweep(source: Any, grid: Sequence[str] | None = None) -> Any:
    """The sweep in SOURCE (a .zarr, .nc or .npz path, a SweepResult or its dataset) as an
    xarray Dataset whose runs are unstacked into the grid's dimensions: GRID names the inputs
    that form it, the first varying slowest (default: `nemc sweep`'s --grid axes, from the
    dataset's attributes). Runs that are no grid (random draws only, or GRID empty) keep the
    dimension `run`. A grid point's several runs (--runs K) are the dimension `draw`; the
    flat run number of each is the variable `run`."""
    dataset = getattr(source, "dataset", source)
    if isinstance(dataset, str | Path):
        dataset = read_output(Path(dataset))
    names = stored_grid(dataset) if grid is None else [input_name(n) for n in grid]
    return unstack(dataset, names) if names else dataset


def stored_grid(dataset: Any) -> list[str]:
    """The --grid axes `nemc sweep` recorded (the dataset's attribute "grid"), by the names
    of their coordinates."""
    axes = json.loads(dataset.attrs.get("grid", "[]") or "[]")
    return [input_name(axis["name"]) for axis in axes]


def grid_shape(dataset: Any, names: Sequence[str]) -> tuple[list[np.ndarray], int]:
    """Each grid axis's values and the runs per grid point; SweepStoreError when the runs
    are not the product of these axes in this order (the first slowest)."""
    runs = dataset.sizes["run"]
    columns = []
    for name in names:
        if name not in dataset.coords or dataset[name].dims != ("run",):
            raise SweepStoreError(f"open_sweep: {name!r} is not an input that varies along run"
                                  f" (those: {varying_inputs(dataset)})")
        columns.append(np.asarray(dataset[name].values))
    axes, inner = [], runs
    for column in columns:  # within one point of the axes before: this axis, then the rest
        part = column[:inner]
        changes = np.flatnonzero(part != part[0])
        inner = int(changes[0]) if changes.size else inner
        axes.append(part[::inner])
    count = int(np.prod([len(a) for a in axes])) * inner
    expected = [np.repeat(np.tile(a, int(np.prod([len(b) for b in axes[:i]]))),
                          int(np.prod([len(b) for b in axes[i + 1:]])) * inner)
                for i, a in enumerate(axes)]
    repeated = any(len(np.unique(a)) != len(a) for a in axes)
    differ = any(not np.array_equal(c, e) for c, e in zip(columns, expected))
    if repeated or differ or count != runs:
        raise SweepStoreError(f"open_sweep: the runs are not the grid {list(names)} (the "
                              "product of their distinct values, the first slowest)")
    return axes, inner


def varying_inputs(dataset: Any) -> list[str]:
    return [str(n) for n, c in dataset.coords.items() if c.dims == ("run",) and n != "run"]


def unstack(dataset: Any, names: Sequence[str]) -> Any:
    """DATASET with `run` reshaped into the grid NAMES (and `draw`, for several runs a
    point); each variable's data reshaped (a dask array stays lazy)."""
    xr = require_xarray()
    axes, draws = grid_shape(dataset, names)
    dims = [*names, *([DRAW] if draws > 1 else [])]
    shape = [len(a) for a in axes] + ([draws] if draws > 1 else [])
    variables = {}
    for name, variable in dataset.variables.items():
        if name in names or name == "run":
            continue
        if variable.dims[:1] == ("run",):
            data = variable.data.reshape(*shape, *variable.shape[1:])
            variables[name] = xr.Variable((*dims, *variable.dims[1:]), data, variable.attrs)
        else:
            variables[name] = variable
    runs = np.arange(dataset.sizes["run"]).reshape(shape)
    coords = {name: (name, axis, dataset[name].attrs) for name, axis in zip(names, axes)}
    if draws > 1:
        coords[DRAW] = np.arange(draws)
    data = {n: v for n, v in variables.items() if n not in dataset.coords}
    other = {n: v for n, v in variables.items() if n in dataset.coords}
    data["run"] = xr.Variable(dims, runs, {"long_name": "the run's number in the store"})
    return xr.Dataset(data, coords={**coords, **other}, attrs=dict(dataset.attrs))


def require_xarray() -> Any:
    from .sweep_store import require

    return require("xarray")
