"""Where a run with sensitivities spends its time (issue 47), for benchmarks/sensitivities.py.

A native run's time is its right-hand side calls times (one call's cost + the drivers' own work
per call). Measured: the calls (nfev, with and without the columns), one call of the model's
`rhs` and of its `sensitivity_rhs` with all the columns and with none, each timed in a C loop
(a small cffi module compiled here: a loop of calls through the function pointer, timed with
clock_gettime, so no Python in the way). Derived: the drivers' work per call, the run's median
time less its calls' (their stage sums, error norm and step control, on 4 states or on the
system's 40), and the floor: the sensitivity run's steps and drivers with its columns free.
"""

from __future__ import annotations

import sys
import tempfile
from typing import Any

import numpy as np

TIMER_C = r"""
#include <stdint.h>
#include <time.h>
typedef int (*rhs_fn)(double, const double *, const double *, double *);
double ns_per_call(uintptr_t address, int count, const double *y, const double *p, double *out)
{
    rhs_fn f = (rhs_fn)address;
    struct timespec start, end;
    clock_gettime(CLOCK_MONOTONIC, &start);
    for (int i = 0; i < count; ++i)
        f(1e-9 * i, y, p, out);
    clock_gettime(CLOCK_MONOTONIC, &end);
    return ((end.tv_sec - start.tv_sec) * 1e9 + (end.tv_nsec - start.tv_nsec)) / count;
}
"""
TIMER_CDEF = ("double ns_per_call(uintptr_t address, int count, const double *y, "
              "const double *p, double *out);")
_timer: list[Any] = []


def call_timer() -> Any:
    """The C loop timing a right-hand side (compiled once per process, in a temporary folder)."""
    if not _timer:
        import cffi

        ffi = cffi.FFI()
        ffi.cdef(TIMER_CDEF)
        ffi.set_source("_nemc_bench_call_timer", TIMER_C, extra_compile_args=["-O2"])
        folder = tempfile.mkdtemp(prefix="nemc-bench-timer-")
        ffi.compile(tmpdir=folder, verbose=False)
        sys.path.insert(0, folder)
        import _nemc_bench_call_timer as module  # type: ignore[import-not-found]

        _timer.append(module)
    return _timer[0]


def address(build: Any, name: str) -> int:
    """The build's C function NAME as an integer address."""
    compiled = build.compiled
    return int(compiled.ffi.cast("uintptr_t", compiled.ffi.addressof(
        compiled.lib, compiled.prefix + name)))


def call_costs(model: Any, names: list[str], rounds: int, count: int = 400_000
               ) -> dict[str, float]:
    """Median ns of one call: the plain rhs, the sensitivity system's with the NAMES' columns
    and with none (the state's part and J alone), interleaved over ROUNDS."""
    from nemc.runtime.sensitivities import columns, sensitivity_build

    timer = call_timer()
    build = sensitivity_build(model)
    p = model.parameter_vector()
    y = model.initial_state()
    cols = columns(model, names, p, None)
    rng = np.random.default_rng(47)
    z = np.concatenate([y, rng.standard_normal(y.size * cols.count)])
    full, none = cols.parameters(p), cols.parameters(p)
    none[p.size] = 0.0  # no column
    out = np.empty(z.size)
    buffer = lambda array: timer.ffi.from_buffer("double[]", array)  # noqa: E731
    calls = {"rhs": (address(model, "rhs"), y, p),
             "system": (address(build, "sensitivity_rhs"), z, full),
             "system_no_columns": (address(build, "sensitivity_rhs"), z, none)}
    samples: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(rounds):
        for name, (where, state, params) in calls.items():
            samples[name].append(timer.lib.ns_per_call(where, count, buffer(state),
                                                       buffer(params), buffer(out)))
    return {name: float(np.median(values)) for name, values in samples.items()}


def breakdown(row: dict[str, Any], costs: dict[str, float], columns: int) -> dict[str, Any]:
    """ROW's ratio (benchmarks/sensitivities.py's nemc_pair) split into its factors: the calls,
    one call's cost, the drivers' work per call; and the floor with the columns free."""
    nfev_plain, nfev_with = row["nfev"]
    plain_ns = row["plain"]["median"] * 1e9
    with_ns = row["sensitivities"]["median"] * 1e9
    drivers_plain = plain_ns / nfev_plain - costs["rhs"]
    drivers_with = with_ns / nfev_with - costs["system"]
    floor = nfev_with * (costs["system_no_columns"] + drivers_with) / plain_ns
    return {"contender": row["contender"], "calls_ratio": nfev_with / nfev_plain,
            "rhs_ns": costs["rhs"], "system_ns": costs["system"],
            "system_no_columns_ns": costs["system_no_columns"],
            "column_ns": (costs["system"] - costs["system_no_columns"]) / columns,
            "drivers_ns_plain": drivers_plain, "drivers_ns_with": drivers_with,
            "rhs_share_with": costs["system"] * nfev_with / with_ns,
            "floor_ratio": floor, "ratio": row["ratio"]}


def markdown_lines(parts: list[dict[str, Any]]) -> list[str]:
    """The breakdown as a table and what it says."""
    lines = ["## Where the time goes", "",
             "One call timed in a C loop (median of the rounds); the drivers' work per call = "
             "the run's median time / its calls - one call. Floor: the sensitivity run's calls "
             "and drivers with the columns free (the system's call without columns: the state's "
             "right-hand side and J).", "",
             "| method | calls with / plain | rhs plain | system: none / 9 columns (per column) "
             "| drivers per call plain / with | floor | ratio |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for part in parts:
        lines.append(
            f"| {part['contender']} | {part['calls_ratio']:.2f}x | {part['rhs_ns']:.0f} ns | "
            f"{part['system_no_columns_ns']:.0f} / {part['system_ns']:.0f} ns "
            f"({part['column_ns']:.1f}) | {part['drivers_ns_plain']:.0f} / "
            f"{part['drivers_ns_with']:.0f} ns | {part['floor_ratio']:.2f}x | "
            f"{part['ratio']:.2f}x |")
    return lines

