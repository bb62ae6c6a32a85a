"""Which native method is fastest for an ensemble (issue 19, the default method): nemc.DOP853,
nemc.Vern9, nemc.Taylor (in SIMD lanes) and the default ("auto", whose choice is printed) on the
same runs, 1 thread, interleaved rounds.

Run: `python benchmarks/ensemble_default.py [--rounds 3]` (about 1 minute). Prints a Markdown
table (median (min-max) seconds per ensemble) and the load average; writes nothing.
docs/decisions.md, "The ensembles' default method", quotes one run.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, chain_yaml  # noqa: E402

import nemc  # noqa: E402

METHODS = ("nemc.DOP853", "nemc.Vern9", "nemc.Taylor", "auto")  # auto: simulate_many's default
TOLERANCES = (1e-4, 1e-6, 1e-9)


def ensembles() -> list[tuple[str, object, np.ndarray, tuple[float, float]]]:
    """(label, model, initial states, span): the double pendulum's large swings, and gentle
    4- and 8-link chains (seeded)."""
    rng = np.random.default_rng(1)
    pendulum = nemc.compile(ROOT / "examples" / "double_pendulum.yaml")
    swings = np.zeros((2000, 4))
    swings[:, 0], swings[:, 2] = rng.uniform(-2, 2, 2000), rng.uniform(-2, 2, 2000)
    cases = [("2,000 double pendulums, ±2 rad, [0, 10]", pendulum, swings, (0.0, 10.0))]
    for n in (4, 8):
        chain = nemc.compile(text=chain_yaml(n))
        starts = np.tile(chain.initial_state(), (400, 1))
        starts[:, 0] += rng.uniform(-0.5, 0.5, 400)
        cases.append((f"400 {n}-link chains, ±0.5 rad, [0, 5]", chain, starts, (0.0, 5.0)))
    return cases


def runs_of_auto(model, y0s: np.ndarray, span, rtol: float) -> str:
    """The method simulate_many's default chooses for these runs."""
    return model.ensemble_method(span, y0s[0], rtol=rtol, runs=len(y0s))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print(f"load average at start: {os.getloadavg()}")
    print("| ensemble | rtol | " + " | ".join(METHODS) + " |")
    print("| --- | --- |" + " --- |" * len(METHODS))
    for label, model, y0s, span in ensembles():
        model.compiled_with("taylor"), model.compiled_with("lanes")  # builds, untimed
        times = np.linspace(*span, 51)
        for rtol in TOLERANCES:
            seconds: dict[str, list[float]] = {m: [] for m in METHODS}
            for round_ in range(args.rounds):
                for method in METHODS if round_ % 2 == 0 else METHODS[::-1]:
                    start = time.perf_counter()
                    runs = model.simulate_many(y0s, t_span=span, t_eval=times, method=method,
                                               rtol=rtol, atol=rtol * 1e-3, threads=1)
                    seconds[method].append(time.perf_counter() - start)
                    if not runs.success.all():
                        print(f"{label}: {method} at rtol {rtol:g}: a run failed")
            cells = [f"{np.median(v):.3f} s ({min(v):.3f}-{max(v):.3f})"
                     for v in seconds.values()]
            cells[-1] += f" ({runs_of_auto(model, y0s, span, rtol)})"
            print(f"| {label} | {rtol:g} | " + " | ".join(cells) + " |", flush=True)
    print(f"load average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
