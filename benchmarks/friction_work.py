"""The work account of friction and contacts (issue 50; decision 0041's amendment): how well
the power balance closes, and what keeping the account costs a run.

Run: `python benchmarks/friction_work.py`; prints two tables, not in `make bench`.

Balance: the largest |energy.total - sum of NAME.friction_work + sum of NAME.impact_loss -
energy.total(0)| over a run, for the friction and contact examples with every method that runs
them, at the scene's times and at every step; the incline is tests/data/friction/
block_incline.yaml held at 0.6 rad (it slides). Cost: a run's best time of 5 with the account
and without it (the native run told to keep none), nemc.Vern9 and nemc.DOP853.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import ROOT  # noqa: E402 (the benchmarks folder is not a package)

import nemc  # noqa: E402
from nemc.runtime import native  # noqa: E402

EXAMPLES = ("coulomb_block", "ball_to_rest", "rocking_block")
METHODS = ("nemc.Vern9", "nemc.DOP853", "DOP853", "RK45")
INCLINE = ROOT / "tests" / "data" / "friction" / "block_incline.yaml"


def balance_error(result: nemc.SimulationResult) -> float:
    """The power balance's largest residual over the run (J)."""
    outputs = result.outputs
    total = outputs["energy.total"]
    taken = sum((-values if name.endswith(".friction_work") else values)
                for name, values in outputs.items()
                if name.endswith((".friction_work", ".impact_loss")))
    return float(np.max(np.abs(total + taken - total[0])))


def best_time(run: Callable[[], object], rounds: int = 5) -> float:
    """The best of ROUNDS runs' wall times (s)."""
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def without_account(model: nemc.Model, method: str) -> float:
    """best_time of a native run that keeps no account."""
    keep = native.account_buffer
    native.account_buffer = lambda *args: None
    try:
        return best_time(lambda: model.simulate(method=method))
    finally:
        native.account_buffer = keep


def main() -> None:
    print("| example | method | scene's times | every step |\n| --- | --- | --- | --- |")
    for name in EXAMPLES:
        model = nemc.compile(ROOT / "examples" / f"{name}.yaml")
        for method in METHODS:
            errors = [balance_error(model.simulate(method=method, **kw))
                      for kw in ({}, {"t_eval": "steps"})]
            print(f"| {name} | {method} | {errors[0]:.1e} J | {errors[1]:.1e} J |")
    incline = nemc.compile(INCLINE)
    for method in METHODS:
        run = incline.simulate(method=method, params={"w": 0.0, "alpha0": 0.6}, t_span=(0, 1))
        print(f"| block_incline at 0.6 rad | {method} | {balance_error(run):.1e} J | |")
    print("\n| example | method | with the account | without | ratio |\n| --- | --- | --- | --- "
          "| --- |")
    for name in (*EXAMPLES, "stick_slip"):
        model = nemc.compile(ROOT / "examples" / f"{name}.yaml")
        for method in METHODS[:2]:
            kept = best_time(lambda: model.simulate(method=method))  # noqa: B023
            bare = without_account(model, method)
            print(f"| {name} | {method} | {kept * 1e3:.2f} ms | {bare * 1e3:.2f} ms | "
                  f"{kept / bare:.2f} |")


if __name__ == "__main__":
    main()
