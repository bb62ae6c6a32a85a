"""nemc's native integrators against solve_ivp, at equal final error (issue 9's table).

Run: `python benchmarks/native.py [--rounds 5] [--ensemble 10000]` (about 2 minutes).

Contenders, measured in one run, interleaved, medians over rounds (benchmarks/run.py's timing):
- solve_ivp DOP853 + lambdify(cse): the baseline of benchmarks/run.py (sympy lambdify of nemc's
  own M and f, numpy.linalg.solve), scipy's best method at these errors;
- solve_ivp DOP853 + nemc's C RHS (`Model.simulate(method="DOP853")`);
- nemc.DOP853: the same algorithm and steps, the loop in C;
- nemc.Vern9: Verner's 9(8) pair in C, at the loosest rtol of the ladder that reaches the
  same error (its own).
Systems: the book's double pendulum over [0, 20] at final errors near 1e-9 and 1e-12 (the
loosest rtol of a ladder that reaches the error; atol = rtol * 1e-3; the DOP853 contenders take
the same steps, so one rtol serves all three); the book's stiff 5.4 over [0, 15] at rtol 1e-8;
an ensemble of double-pendulum runs over [0, 10] at rtol 1e-8. Errors: max |y(t_end) - ref|
(5.4: max over t = 0, 0.1, ..., 15) against nemc.DOP853 at rtol 1e-13, atol 1e-15,
cross-checked with scipy's DOP853 at the same.
Results: benchmarks/results/native-latest.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run import RESULTS, ROOT, environment, interleaved, make_baseline  # noqa: E402

import nemc  # noqa: E402

PENDULUM = ROOT / "examples" / "double_pendulum.yaml"
ARM = ROOT / "examples" / "two_link_robot_arm.yaml"
REFERENCE = (1e-13, 1e-15)
LADDER = tuple(10.0 ** (-k / 4) for k in range(20, 53))  # rtol 1e-5 ... 1e-13


def final_state(model, method: str, span, y0, rtol: float, atol: float, rhs=None, jac=None,
                times=None):
    """y at times (default: t_end): nemc's simulate, or solve_ivp with this RHS (and Jacobian)."""
    times = [span[1]] if times is None else times
    if rhs is None:
        res = model.simulate(span, y0, method=method, rtol=rtol, atol=atol, t_eval=times)
        return res.y, res.nfev
    extra = {"jac": jac} if jac is not None else {}
    sol = solve_ivp(rhs, span, y0, method=method, rtol=rtol, atol=atol, t_eval=times, **extra)
    return sol.y, sol.nfev


def reference(model, span, y0, times=None) -> np.ndarray:
    ours = final_state(model, "nemc.DOP853", span, y0, *REFERENCE, times=times)[0]
    theirs = final_state(model, "DOP853", span, y0, *REFERENCE, times=times)[0]
    print(f"  reference: nemc.DOP853 vs scipy DOP853 at rtol 1e-13 differ by"
          f" {np.abs(ours - theirs).max():.1e}")
    return ours


def rtol_for(model, span, y0, ref: np.ndarray, target: float,
             method: str = "nemc.DOP853") -> float:
    """The loosest rtol of the ladder whose error with the method is at most target."""
    for rtol in LADDER:
        y = final_state(model, method, span, y0, rtol, rtol * 1e-3)[0]
        if np.abs(y - ref).max() <= target:
            return rtol
    return LADDER[-1]


def time_cells(calls: dict[str, Any], rounds: int) -> dict[str, dict[str, Any]]:
    runs = {name: (call, 1) for name, call in calls.items()}
    return interleaved(runs, rounds, target=0.3)


def pendulum_rows(rounds: int) -> list[dict[str, Any]]:
    model = nemc.compile(PENDULUM)
    span, y0 = (0.0, 20.0), model.initial_state()
    baseline = make_baseline(PENDULUM, model.state_names, plain=False)
    c_rhs = model._rhs_function(model.parameter_vector())
    ref = reference(model, span, y0)
    rows = []
    for target in (1e-9, 1e-12):
        rtol = rtol_for(model, span, y0, ref, target)
        contenders = {
            "solve_ivp DOP853 + lambdify(cse)": ("DOP853", baseline.rhs_cse, rtol),
            "solve_ivp DOP853 + nemc C RHS": ("DOP853", c_rhs, rtol),
            "nemc.DOP853": ("nemc.DOP853", None, rtol),
            "nemc.Vern9": ("nemc.Vern9", None,
                           rtol_for(model, span, y0, ref, target, "nemc.Vern9")),
        }
        rtols = {name: r_tol for name, (_, _, r_tol) in contenders.items()}
        calls = {name: partial(final_state, model, m, span, y0, r_tol, r_tol * 1e-3, r)
                 for name, (m, r, r_tol) in contenders.items()}
        times = time_cells(calls, rounds)
        base = times["solve_ivp DOP853 + lambdify(cse)"]["median"]
        for name, call in calls.items():
            y, nfev = call()
            rows.append({
                "system": "double pendulum [0, 20]", "target_error": target,
                "rtol": rtols[name],
                "contender": name, "error": float(np.abs(y - ref).max()), "nfev": int(nfev),
                "seconds": times[name]["median"], "min": times[name]["min"],
                "max": times[name]["max"], "speedup_vs_lambdify": base / times[name]["median"],
            })
    return rows


def arm_rows(rounds: int) -> list[dict[str, Any]]:
    model = nemc.compile(ARM)
    span, y0 = (0.0, 15.0), model.initial_state()
    p = model.parameter_vector()
    c_rhs, c_jac = model._rhs_function(p), model._jacobian_function(p)
    times = np.linspace(0.0, 15.0, 151)  # the arm settles: the error is the worst over time
    ref = reference(model, span, y0, times)
    rtol, atol = 1e-8, 1e-10
    contenders = {
        "solve_ivp Radau + nemc C RHS, C Jacobian": ("Radau", c_rhs, c_jac),
        "nemc.Radau": ("nemc.Radau", None, None),
        "nemc.DOP853": ("nemc.DOP853", None, None),
    }
    calls = {name: partial(final_state, model, m, span, y0, rtol, atol, r, j, times)
             for name, (m, r, j) in contenders.items()}
    times = time_cells(calls, rounds)
    base = times["solve_ivp Radau + nemc C RHS, C Jacobian"]["median"]
    rows = []
    for name, call in calls.items():
        y, nfev = call()
        rows.append({
            "system": "5.4 two-link arm [0, 15]", "target_error": None, "rtol": rtol,
            "contender": name, "error": float(np.abs(y - ref).max()), "nfev": int(nfev),
            "seconds": times[name]["median"], "min": times[name]["min"],
            "max": times[name]["max"], "speedup_vs_scipy_radau": base / times[name]["median"],
        })
    return rows


def ensemble_rows(count: int) -> list[dict[str, Any]]:
    model = nemc.compile(PENDULUM)
    rng = np.random.default_rng(0)
    y0s = np.zeros((count, model.n_state))
    y0s[:, 0], y0s[:, 2] = rng.uniform(-1.5, 1.5, count), rng.uniform(-1.5, 1.5, count)
    rows = []
    for threads in (1, os.cpu_count() or 1):
        start = time.perf_counter()
        result = model.simulate_many(y0s, t_span=(0, 10), t_eval=np.linspace(0, 10, 101),
                                     method="nemc.DOP853", rtol=1e-8, atol=1e-10,
                                     threads=threads)
        seconds = time.perf_counter() - start
        rows.append({"system": f"ensemble: {count} double pendulums [0, 10], 101 times",
                     "contender": f"simulate_many nemc.DOP853, {threads} thread(s)",
                     "rtol": 1e-8, "seconds": seconds, "all_succeeded": bool(result.success.all()),
                     "nfev_total": int(result.nfev.sum())})
    return rows


def markdown(rows: list[dict[str, Any]]) -> str:
    lines = ["| system | target error | rtol | contender | final error | nfev | time (ms) |"
             " speed-up |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        speedup = r.get("speedup_vs_lambdify", r.get("speedup_vs_scipy_radau"))
        target = f"{r['target_error']:.0e}" if r.get("target_error") else ""
        error = f"{r['error']:.1e}" if "error" in r else ""
        lines.append(
            f"| {r['system']} | {target} | {r['rtol']:.2g} | {r['contender']} | {error} |"
            f" {r.get('nfev', r.get('nfev_total', ''))} | {r['seconds'] * 1e3:.3g} |"
            f" {f'{speedup:.0f}x' if speedup else ''} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--ensemble", type=int, default=10000, help="runs in the ensemble")
    args = parser.parse_args()
    print("double pendulum:")
    rows = pendulum_rows(args.rounds)
    print("5.4:")
    rows += arm_rows(args.rounds)
    print("ensemble:")
    rows += ensemble_rows(args.ensemble)
    table = markdown(rows)
    print(table)
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "native-latest.md").write_text(
        "Speed-ups: against solve_ivp + lambdify(cse) (double pendulum), against solve_ivp"
        " Radau with nemc's C RHS and Jacobian (5.4); medians of interleaved rounds.\n\n"
        + table)
    env = environment(argparse.Namespace(mode="native"))  # type: ignore[arg-type]
    (RESULTS / "native-latest.json").write_text(
        json.dumps({"environment": env, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
