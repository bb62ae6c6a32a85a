"""The command line's plan of a sweep (`nemc sweep`): its --grid and --random axes, the runs
they make (the grid's points, each with seeded random draws) and the output times of --times;
`nemc.sweep` (sweeps.py) then runs them."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..runtime.checks import MAX_STEP_TIMES, within_budget
from ..runtime.model import Model, ModelError


@dataclass(frozen=True)
class Axis:
    """One --grid NAME=START:STOP:N or --random NAME=LOW:HIGH."""

    name: str
    low: float
    high: float
    count: int = 0  # grid points; 0 for a random input

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "low": self.low, "high": self.high, "count": self.count}


def parse_axis(text: str, grid: bool) -> Axis:
    """NAME=START:STOP:N (grid) or NAME=LOW:HIGH (random); ValueError says what is wrong."""
    form = "NAME=START:STOP:N" if grid else "NAME=LOW:HIGH"
    name, sep, rest = text.partition("=")
    parts = rest.split(":")
    if not sep or not name.strip() or len(parts) != (3 if grid else 2):
        raise ValueError(f"expected {form}, got {text!r}")
    try:
        low, high = float(parts[0]), float(parts[1])
        count = int(parts[2]) if grid else 0
    except ValueError:
        raise ValueError(f"{name.strip()}: expected numbers in {form}, got {text!r}") from None
    if not (np.isfinite(low) and np.isfinite(high)) or (grid and count < 1):
        raise ValueError(f"{name.strip()}: finite bounds and N >= 1 expected, got {text!r}")
    return Axis(name.strip(), low, high, count)


def plan_runs(model: Model, grids: Sequence[Axis], randoms: Sequence[Axis], runs: int | None,
              seed: int, shared: Mapping[str, float]) -> tuple[dict, dict, dict]:
    """The runs of `nemc sweep`: the grid's points (the first --grid varies slowest), each
    with RUNS random draws of the --random inputs (uniform, seeded). Returns the initial-state
    columns, the parameters (both by name) and the attributes that describe the plan."""
    names = [a.name for a in [*grids, *randoms]] + list(shared)
    for name in names:
        if names.count(name) > 1:
            raise ModelError(f"{name!r} is given more than once")
        if name not in model.state_names and name not in model.parameter_names:
            raise ModelError(f"{name!r} is neither a parameter {list(model.parameter_names)} "
                             f"nor a state {list(model.state_names)}")
    if runs is not None and not randoms:
        raise ModelError("--runs counts random draws: give --random NAME=LOW:HIGH")
    draws = runs or 1
    total = math.prod(a.count for a in grids) * draws
    within_budget(f"--grid and --runs: {total} runs", total * (len(names) + len(grids)))
    axes = [np.linspace(a.low, a.high, a.count) for a in grids]
    columns: dict[str, Any] = dict(shared)
    points = np.meshgrid(*axes, indexing="ij") if axes else []
    for axis, values in zip(grids, points):
        columns[axis.name] = np.repeat(values.reshape(-1), draws)
    rng = np.random.default_rng(seed)
    for axis in randoms:
        columns[axis.name] = axis.low + (axis.high - axis.low) * rng.random(total)
    y0 = {n: v for n, v in columns.items() if n in model.state_names}
    params = {n: v for n, v in columns.items() if n not in model.state_names}
    attrs = {"grid": json.dumps([a.describe() for a in grids]),
             "random": json.dumps([a.describe() for a in randoms]), "draws_per_point": draws,
             "seed": seed}
    return y0, params, attrs


def output_times(t_span: Sequence[float], count: int) -> np.ndarray:
    """`--times COUNT`: COUNT output times equally spaced from the start to the end, both
    included (the start is the initial state, as simulate_many's default times and `nemc
    simulate --t-eval STEP` include it); COUNT 1: the end only; at most MAX_STEP_TIMES, as a
    t_eval step may give."""
    if count > MAX_STEP_TIMES:
        raise ModelError(f"--times: at most {MAX_STEP_TIMES} output times, got {count}")
    t0, t1 = float(t_span[0]), float(t_span[1])
    return np.array([t1]) if count == 1 else np.linspace(t0, t1, count)
