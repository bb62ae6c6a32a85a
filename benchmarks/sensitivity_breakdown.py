"""Where a run with sensitivities spends its time (issue 47), for benchmarks/sensitivities.py.

A native run's time is its right-hand side calls times (one call's cost + the drivers' own work
per call). Measured: the calls (nfev, with and without the columns), one call of the model's
`rhs` and of its `sensitivity_rhs` with all the columns and with none, each timed in a C loop
(a small cffi module compiled here: a loop of calls through the function pointer, timed with
clock_gettime, so no Python in the way), interleaved with the runs themselves. Derived: the
drivers' work per call, the run's median time less its calls' (their stage sums, error norm
and step control, on 4 states or on the system's 40), and the floor: the sensitivity run's
steps and drivers with its columns free.
"""

from __future__ import annotations

import tempfile
from typing import Any

import numpy as np

TIMER_C = r"""
#include <stdint.h>
#include <time.h>
typedef int (*rhs_fn)(double, const double *, const double *, double *);
static double timed_calls(clockid_t clock, uintptr_t address, int count, const double *y,
                          const double *p, double *out)
{
    rhs_fn f = (rhs_fn)address;
    struct timespec start, end;
    clock_gettime(clock, &start);
    for (int i = 0; i < count; ++i)
        f(1e-9 * i, y, p, out);
    clock_gettime(clock, &end);
    return ((end.tv_sec - start.tv_sec) * 1e9 + (end.tv_nsec - start.tv_nsec)) / count;
}
double ns_per_call(uintptr_t address, int count, const double *y, const double *p, double *out)
{
    return timed_calls(CLOCK_MONOTONIC, address, count, y, p, out);
}
double cpu_ns_per_call(uintptr_t address, int count, const double *y, const double *p,
                       double *out)
{
    return timed_calls(CLOCK_THREAD_CPUTIME_ID, address, count, y, p, out);
}
"""
TIMER_CDEF = ("double ns_per_call(uintptr_t address, int count, const double *y, "
              "const double *p, double *out);\n"
              "double cpu_ns_per_call(uintptr_t address, int count, const double *y, "
              "const double *p, double *out);")
_timer: list[Any] = []


def call_timer() -> Any:
    """The C loop timing a right-hand side (compiled once per process, in a temporary folder)."""
    if not _timer:
        import importlib.util

        import cffi

        ffi = cffi.FFI()
        ffi.cdef(TIMER_CDEF)
        ffi.set_source("_nemc_bench_call_timer", TIMER_C, extra_compile_args=["-O2"])
        library = ffi.compile(tmpdir=tempfile.mkdtemp(prefix="nemc-bench-timer-"),
                              verbose=False)
        spec = importlib.util.spec_from_file_location("_nemc_bench_call_timer", library)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        _timer.append(module)
    return _timer[0]


def address(build: Any, name: str) -> int:
    """The build's C function NAME as an integer address."""
    compiled = build.compiled
    return int(compiled.ffi.cast("uintptr_t", compiled.ffi.addressof(
        compiled.lib, compiled.prefix + name)))


def call_loops(model: Any, names: list[str], count: int = 100_000, cpu: bool = False
               ) -> dict[str, tuple[Any, int]]:
    """common.interleaved's contenders for one call's cost, each COUNT calls in the C loop:
    the plain rhs, the sensitivity system's with the NAMES' columns and with none (the
    state's part and J alone). CPU: each returns the loop's CPU time per call in ns (the
    thread's clock: on a loaded machine, the time another process held the CPU left out)
    instead of calling the loop (common.interleaved's wall-clock timing)."""
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
    buffer = timer.ffi.from_buffer
    arguments = {"rhs": (address(model, "rhs"), y, p),
                 "system": (address(build, "sensitivity_rhs"), z, full),
                 "system_no_columns": (address(build, "sensitivity_rhs"), z, none)}

    def loop(where: int, state: np.ndarray, params: np.ndarray) -> Any:
        held = (buffer("double[]", state), buffer("double[]", params), buffer("double[]", out))
        timed = timer.lib.cpu_ns_per_call if cpu else timer.lib.ns_per_call
        return lambda: timed(where, count, *held)

    return {name: (loop(*args), count) for name, args in arguments.items()}


def breakdown(contender: str, times: dict[str, dict[str, Any]], nfev: list[int],
              columns: int) -> dict[str, Any]:
    """A run's ratio split into its factors: the calls (NFEV plain, with), one call's cost
    and the drivers' work per call, from TIMES (common.interleaved's: the runs and the
    call_loops, timed in the same rounds); and the floor with the columns free."""
    nfev_plain, nfev_with = nfev
    ns = {name: value["median"] * 1e9 for name, value in times.items()}
    drivers_plain = ns["plain"] / nfev_plain - ns["rhs"]
    drivers_with = ns["sensitivities"] / nfev_with - ns["system"]
    floor = nfev_with * (ns["system_no_columns"] + drivers_with) / ns["plain"]
    return {"contender": contender, "calls_ratio": nfev_with / nfev_plain,
            "rhs_ns": ns["rhs"], "system_ns": ns["system"],
            "system_no_columns_ns": ns["system_no_columns"],
            "column_ns": (ns["system"] - ns["system_no_columns"]) / columns,
            "drivers_ns_plain": drivers_plain, "drivers_ns_with": drivers_with,
            "rhs_share_with": ns["system"] * nfev_with / ns["sensitivities"],
            "floor_ratio": floor, "ratio": ns["sensitivities"] / ns["plain"]}


def markdown_lines(parts: list[dict[str, Any]]) -> list[str]:
    """The breakdown as a table and what it says."""
    lines = ["## Where the time goes", "",
             "The runs again, with one call timed in a C loop (100,000 calls), interleaved in "
             "the same rounds (medians); the drivers' work per call = the run's time / its "
             "calls - one call (the C loop's call is cache-warm: a lower bound of a call in "
             "the run). Floor: the sensitivity run's calls and drivers with the columns free "
             "(the system's call without columns: the state's right-hand side and J).", "",
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

