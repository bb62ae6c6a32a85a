"""The baseline of issue 50's speed target: the belt-driven stick-slip oscillator with a smooth,
tanh-regularized friction law integrated by scipy's solve_ivp, over 100 periods of its limit
cycle at rtol 1e-9, with its error in the stick phases against the closed form.

The oscillator and its closed form are tests/contact_reference.py's (``StickSlip``: m = 1,
k = 100, g = 9.81, mu_s = 0.4, mu_k = 0.3, belt at 0.1; started stuck at x = 0). The smooth law
is Brown and McPhee's (2016) tanh law with a static peak, so that mu_s > mu_k has a meaning:

    F(v) = -N (mu_k tanh(4 v / v0) + c (v / v0) / ((v / v0)^2 / 4 + 3 / 4)^2),

v = x' - v_belt, N = m g; |F| peaks near |v| = v0 and tends to mu_k N beyond. Brown and McPhee
take c = mu_s - mu_k, which puts the peak 2e-4 mu_s below mu_s here: the stick phases would
end early by as much, a drift of 0.02 s over 100 periods whatever v0. Here c is solved so that
the peak is mu_s exactly (to rounding), so the law's only error is its regularization. It
cannot stick: while "stuck" it creeps at a relative speed about v0 times the holding force's
fraction of the peak, and its stick-slip period differs from the exact one, so
its phase drifts over the run. Both show in the error measured here: the largest |x' - v_belt|
at 9 points inside each of the closed form's stick intervals (their middle 80%), relative to
v_belt; and the position error in the middle of the last slip arc, relative to its amplitude,
which shows the drift sooner. The drift is the law's, not the integrator's: near its flat peak
the block leaves the belt late, by a time that shrinks only as v0^(2/3) (over 20 periods, the
slip error is 2.3e-2 at v0 = 1e-6 and 4.9e-3 at 1e-7, the same at rtol 1e-9 and 1e-12). A
smaller v0 lowers the creep and the drift and makes the equations stiffer (dF/dv about
4 mu_k N / v0 in the stick phases): the cost of equal error is the comparison.

Run: .venv/bin/python benchmarks/stick_slip_tanh.py [--v0 1e-3,1e-4] [--methods Radau,LSODA]
`run_tanh(v0, rtol)` is what a side-by-side benchmark imports. Not in `make bench`.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

ROOT = Path(__file__).resolve().parent.parent
PERIODS = 100
SAMPLES = np.linspace(0.1, 0.9, 9)  # where in each stick interval the error is sampled


def _reference() -> ModuleType:
    """tests/contact_reference.py, loaded by path (it is not a package module), or the one
    already imported (the tests import it by name)."""
    if "contact_reference" in sys.modules:
        return sys.modules["contact_reference"]
    spec = importlib.util.spec_from_file_location(
        "contact_reference", ROOT / "tests" / "contact_reference.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


REF = _reference()


def _shape(mu_k: float, c: float, z: np.ndarray | float) -> np.ndarray | float:
    """The law's coefficient of friction at relative speed z = v / v0."""
    return mu_k * np.tanh(4.0 * z) + c * z / (0.25 * z * z + 0.75) ** 2


def bump_coefficient(mu_s: float, mu_k: float) -> float:
    """c such that the law's largest coefficient is mu_s (it does not depend on v0)."""

    def peak(c: float) -> float:
        best = minimize_scalar(lambda z: -_shape(mu_k, c, z), bounds=(0.5, 2.0),
                               method="bounded", options={"xatol": 1e-12})
        return -float(best.fun) - mu_s

    return brentq(peak, 0.5 * (mu_s - mu_k), mu_s, xtol=1e-15, rtol=1e-15)


def friction(p: Any, v_rel: np.ndarray | float, v0: float, c: float) -> np.ndarray | float:
    """Brown-McPhee's smooth Coulomb law on p (a REF.StickSlip), its static peak mu_s N."""
    return -p.m * p.g * _shape(p.mu_k, c, v_rel / v0)


def _rhs_and_jacobian(p: Any, v0: float) -> tuple[Callable[..., np.ndarray],
                                                   Callable[..., np.ndarray]]:
    c = bump_coefficient(p.mu_s, p.mu_k)

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        return np.array([y[1], (-p.k * y[0] + friction(p, y[1] - p.v_belt, v0, c)) / p.m])

    def jac(_t: float, y: np.ndarray) -> np.ndarray:
        h = 1e-7 * v0
        v = y[1] - p.v_belt
        slope = (friction(p, v + h, v0, c) - friction(p, v - h, v0, c)) / (2.0 * h)
        return np.array([[0.0, 1.0], [-p.k / p.m, slope / p.m]])

    return rhs, jac


def stick_phase_error(p: Any, t_end: float,
                      velocity: Callable[[np.ndarray], np.ndarray]) -> float:
    """Largest |x'(t) - v_belt| / v_belt at the sample points inside the closed form's stick
    intervals over [0, t_end]; `velocity` maps an array of times to x' there."""
    times = np.concatenate([a + (b - a) * SAMPLES
                            for a, b in REF.stick_slip_stick_intervals(p, t_end)])
    return float(np.max(np.abs(velocity(times) - p.v_belt)) / p.v_belt)


def run_tanh(v0: float, rtol: float, method: str = "LSODA", periods: int = PERIODS,
             atol: float | None = None) -> dict[str, float | int | str]:
    """One run of the smooth law over `periods` limit-cycle periods (after the first stick):
    wall time of solve_ivp alone, accepted steps, RHS and Jacobian calls, the stick-phase error
    (relative to v_belt) and the position error in the middle of the last slip arc (relative to
    the arc's amplitude). LSODA is the default: of Radau, LSODA and RK45 it is the fastest at
    v0 down to 1e-8 (the steps are alike; Radau's cost per step in Python is ~20x, and RK45
    turns stiff in the stick phases as v0 shrinks); from v0 = 1e-9 LSODA fails (repeated
    convergence failures, `success` False) where Radau still succeeds. `p` in these functions
    is a contact_reference.StickSlip (Any: that module is loaded by path)."""
    p = REF.StickSlip()
    t_end = p.x_static / p.v_belt + periods * REF.stick_slip_cycle(p).period
    rhs, jac = _rhs_and_jacobian(p, v0)
    atol = rtol * 1e-3 if atol is None else atol
    options = {"jac": jac} if method in ("Radau", "BDF", "LSODA") else {}
    start = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, p.v_belt], method=method, rtol=rtol, atol=atol,
                    dense_output=True, **options)
    elapsed = time.perf_counter() - start
    cycle = REF.stick_slip_cycle(p)
    t_mid = t_end - cycle.period + 0.5 * cycle.slip_time
    x_mid, _, _ = REF.stick_slip_closed_form(p, t_mid)
    return {
        "method": method, "v0": v0, "rtol": rtol, "time_s": elapsed, "steps": len(sol.t) - 1,
        "nfev": sol.nfev, "njev": sol.njev, "success": bool(sol.success),
        "stick_error": stick_phase_error(p, t_end, lambda t: sol.sol(t)[1]),
        "slip_error": float(abs(sol.sol(t_mid)[0] - x_mid) / cycle.amplitude),
    }


def run_exact(rtol: float, periods: int = PERIODS) -> dict[str, float | int | str]:
    """The event-driven reference (tests/contact_reference.py, solve_ivp's DOP853 per slip arc,
    its stick phases in closed form) over the same run, timed the same way, for scale."""
    p = REF.StickSlip()
    t_end = p.x_static / p.v_belt + periods * REF.stick_slip_cycle(p).period
    start = time.perf_counter()
    run = REF.stick_slip_run(p, t_end)
    elapsed = time.perf_counter() - start
    return {"method": "event-driven DOP853 (rtol 1e-12)", "v0": 0.0, "rtol": REF.RTOL,
            "time_s": elapsed, "switches": len(run.switches),
            "stick_error": stick_phase_error(
                p, t_end, lambda ts: np.array([run.state(t)[1] for t in ts]))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--v0", default="1e-3,1e-4,1e-5,1e-6,1e-7",
                        help="regularization speeds, comma-separated (default %(default)s)")
    parser.add_argument("--methods", default="LSODA,Radau,RK45")
    parser.add_argument("--rtol", type=float, default=1e-9)
    parser.add_argument("--periods", type=int, default=PERIODS)
    parser.add_argument("--rk45-max-v0", type=float, default=1e-3,
                        help="skip RK45 below this v0 (it needs ~ 1/v0 steps per stick phase)")
    args = parser.parse_args()
    print(f"stick-slip oscillator, {args.periods} periods, rtol {args.rtol:g}; error: the largest"
          " |x' - v_belt| / v_belt inside the exact stick phases")
    print(f"{'method':<10} {'v0':>8} {'time s':>9} {'steps':>8} {'nfev':>9} {'stick error':>12}"
          f" {'slip error':>12}  success")
    for v0 in (float(v) for v in args.v0.split(",")):
        for method in args.methods.split(","):
            if method in ("RK45", "RK23", "DOP853") and v0 < args.rk45_max_v0:
                continue
            r = run_tanh(v0, args.rtol, method, args.periods)
            print(f"{method:<10} {v0:>8.0e} {r['time_s']:>9.3f} {r['steps']:>8d} {r['nfev']:>9d}"
                  f" {r['stick_error']:>12.2e} {r['slip_error']:>12.2e}  {r['success']}")
    exact = run_exact(args.rtol, args.periods)
    print(f"exact reference (event-driven, {exact['switches']} switches): {exact['time_s']:.3f} s,"
          f" stick error {exact['stick_error']:.1e}")


if __name__ == "__main__":
    main()
