"""What a call from Python costs beyond the C it runs (issue 19, the lean driver): model.rhs
against the C right-hand side itself (rhs_many over 1,000 states, per state), and simulate()
over a step-sized interval (its fixed cost: checks, settings, the interrupt flag, the result),
each native method, on the book's double pendulum; and over an empty interval [0, 0], where
the C returns the initial state at once and what is timed is simulate()'s fixed cost alone,
also with method "auto" (its choice included).
Method "auto"'s choice (`Model.auto_method`: its look at the start, one C call) on the double
pendulum (no Jacobian in its build: differences, the trace alone) and the book's stiff 5.4 arm
(its exact Jacobian, and the eigenvalues).
model.rhs through cffi (the way without the build's _rhs_call extension) is timed beside it,
and the closure simulate hands to solve_ivp.
The drivers' own work: each explicit method over [0, 200] at rtol 1e-10 (long runs: the fixed
cost vanishes), per right-hand-side call, against the C right-hand side alone at 1,000 states
along that run (the pendulum's angles there cost sincos more than random states in [-1.5, 1.5]:
41 against 37 ns), two ways: over independent states (rhs_many: calls overlap in the CPU), and
chained as a run's stages are, each call's state waiting for the last call's derivative (a C
loop compiled here, calling the model's `<name>_rhs` through a pointer as the drivers do): the
RHS's latency, what a run cannot go below. The excess over the chained calls is the driver's
per-step work (stage sums, error norm, step control). Interleaved calibrated loops.

Run: `python benchmarks/overhead.py [--rounds 5]` (about 30 s). Prints a Markdown table
(median (min-max) per call) and the load average; writes nothing. The README quotes one run.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402
from common import ROOT, interleaved, native_methods, random_states, spread  # noqa: E402

import nemc  # noqa: E402
from nemc.build.builder import DRIVERS_CFLAGS, compiler  # noqa: E402

STATES = 1000
ALONG = "C right-hand side at the run's states (rhs_many along [0, 200], per state)"
CHAINED = "C right-hand side at the run's states, chained (each state waits for the last call)"

# RHS calls chained as a run's stages are: each state is one of the run's, plus 0.0 times the
# last derivative, so that it waits for that call (0.0 * x is not folded away without
# -ffast-math); called through a pointer, as the drivers call it
CHAIN_C = r"""
typedef int (*rhs_fn)(double t, const double *y, const double *p, double *dy);

int chained_rhs(const void *function, int n, int count, const double *states,
                const double *p, long calls)
{
    rhs_fn rhs = (rhs_fn)function;
    double y[64], dy[64] = {0};
    const double *state = states, *end = states + (long)count * n;
    int status = 0;
    for (long c = 0; c < calls; ++c) {
        for (int i = 0; i < n; ++i)
            y[i] = state[i] + 0.0 * dy[i];
        status |= rhs(0.0, y, p, dy);
        state = state + n == end ? states : state + n;
    }
    return status;
}
"""


def chained_calls(model: nemc.Model, states: np.ndarray, folder: Path) -> tuple[Any, int]:
    """A call of CHAIN_C over STATES (rows of `states`) and the calls it makes: the model's
    RHS chained, compiled with the drivers' flags."""
    import cffi

    assert model.n_state <= 64
    source, library = folder / "chain.c", folder / "chain.so"
    source.write_text(CHAIN_C)
    subprocess.run([*compiler(), *DRIVERS_CFLAGS, "-shared", str(source), "-o", str(library)],
                   check=True)
    ffi = cffi.FFI()
    ffi.cdef("int chained_rhs(const void *, int, int, const double *, const double *, long);")
    chain = ffi.dlopen(str(library))
    c = model.compiled
    address = c.ffi.cast("uintptr_t", c.ffi.addressof(c.lib, c.prefix + "rhs"))
    function = ffi.cast("const void *", int(address))
    rows = np.ascontiguousarray(states)
    p = model.parameter_vector()
    pointers = ffi.from_buffer("double[]", rows), ffi.from_buffer("double[]", p)
    calls = len(rows)

    def call() -> None:
        if chain.chained_rhs(function, model.n_state, len(rows), *pointers, calls):
            raise RuntimeError("the right-hand side failed")
    return call, calls


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    model = nemc.compile(ROOT / "examples" / "double_pendulum.yaml")
    y0 = model.initial_state()
    states = random_states(model.n_state, STATES)  # (n_state, STATES)
    through_cffi = model.compiled.checked_rhs(model.parameter_vector())
    closure = model.compiled.integrator_rhs(model.parameter_vector())
    calls = {
        "C right-hand side (rhs_many, per state)": (lambda: model.rhs_many(0.0, states), STATES),
        "model.rhs(t, y)": (lambda: model.rhs(0.0, y0), 1),
        # the way model.rhs takes without the build's _rhs_call (CPython 3.10), and for any
        # argument that extension does not take as it is: cffi's call
        "model.rhs(t, y) through cffi": (lambda: through_cffi(0.0, y0), 1),
        # the closure solve_ivp calls (simulate with scipy's methods)
        "solve_ivp's closure(t, y)": (lambda: closure(0.0, y0), 1),
    }
    arm = nemc.compile(ROOT / "examples" / "two_link_robot_arm.yaml")
    for label, chooser in (("double pendulum", model), ("stiff 5.4 arm", arm)):
        start, p = chooser.initial_state(), chooser.parameter_vector()
        calls[f"auto's choice (auto_method), {label}"] = (
            lambda chooser=chooser, start=start, p=p: chooser.auto_method((0.0, 15.0), start,
                                                                          1e-6, p), 1)
    for method in native_methods():
        model.simulate((0.0, 1e-3), y0, method=method, t_eval=[1e-3])  # its parts built here
        calls[f"simulate over [0, 1e-3], {method}"] = (
            lambda method=method: model.simulate((0.0, 1e-3), y0, method=method,
                                                 t_eval=[1e-3]), 1)
        # an empty interval: the C returns y0 at once, what is left is the fixed cost
        calls[f"simulate over [0, 0], {method}"] = (
            lambda method=method: model.simulate((0.0, 0.0), y0, method=method,
                                                 t_eval=[0.0]), 1)
    along = np.ascontiguousarray(model.simulate(
        (0.0, 200.0), y0, method="nemc.DOP853", rtol=1e-10, atol=1e-12,
        t_eval=np.linspace(0.0, 200.0, STATES)).y)
    calls[ALONG] = (lambda: model.rhs_many(0.0, along), STATES)
    folder = tempfile.TemporaryDirectory(prefix="nemc-overhead-")
    calls[CHAINED] = chained_calls(model, along.T, Path(folder.name))
    chosen = model.simulate((0.0, 0.0), y0, method="auto", t_eval=[0.0]).method
    calls[f"simulate over [0, 0], auto (chose {chosen})"] = (
        lambda: model.simulate((0.0, 0.0), y0, method="auto", t_eval=[0.0]), 1)
    for method in ("nemc.DOP853", "nemc.Vern9", "nemc.Taylor"):
        nfev = model.simulate((0.0, 200.0), y0, method=method, rtol=1e-10, atol=1e-12,
                              t_eval=[200.0]).nfev
        calls[f"per RHS call (expansion for Taylor), {method} over [0, 200]"] = (
            lambda method=method: model.simulate((0.0, 200.0), y0, method=method, rtol=1e-10,
                                                 atol=1e-12, t_eval=[200.0]), nfev)
    print(f"load average at start: {os.getloadavg()}")
    times = interleaved(calls, args.rounds, target=0.2)
    print("| call | time per call, median (min-max) |\n| --- | --- |")
    for name, summary in times.items():
        print(f"| {name} | {spread(summary)} |")
    for method in ("nemc.DOP853", "nemc.Vern9"):
        per_call = times[f"per RHS call (expansion for Taylor), {method} over [0, 200]"]["median"]
        shares = [f"{(per_call - times[rhs]['median']) / times[rhs]['median']:.0%} {how}"
                  for rhs, how in ((CHAINED, "of the RHS's chained calls (its latency)"),
                                   (ALONG, "of its calls over independent states"))]
        print(f"- {method}: the driver adds {shares[0]} per call; {shares[1]}")
    folder.cleanup()
    print(f"load average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
