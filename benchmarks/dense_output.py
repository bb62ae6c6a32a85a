"""Dense output (issue 19): what many t_eval points cost nemc.Vern9 (Verner's interpolant) and
nemc.DOP853 (its 7th-order interpolant), against the same runs returning the end point only.

Run: `python benchmarks/dense_output.py [--rounds 5]` (about 20 s). The book's double pendulum
over [0, 20], 2,001 evenly spaced points, rtol 1e-6, 1e-9, 1e-12 (atol = rtol x 1e-3). Prints
a Markdown table: RHS calls, the time (median (min-max) of interleaved calibrated loops) and
the largest error at the points and at the method's own steps, both against nemc.Taylor at
rtol 2.5e-14 (another method); and the load average. Writes nothing; docs/decisions.md
("Vern9's dense output") and the README quote one run.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, interleaved, spread  # noqa: E402

import nemc  # noqa: E402

METHODS = ("nemc.Vern9", "nemc.DOP853")
TOLERANCES = (1e-6, 1e-9, 1e-12)
SPAN = (0.0, 20.0)
POINTS = np.linspace(*SPAN, 2001)


def largest_error(model, y0: np.ndarray, t: np.ndarray, y: np.ndarray) -> float:
    """max |y - reference| at times t, the reference nemc.Taylor at rtol 2.5e-14."""
    tight = model.simulate(SPAN, y0, method="nemc.Taylor", rtol=2.5e-14, atol=1e-16, t_eval=t)
    return float(np.abs(y - tight.y).max())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    print(f"load average at start: {os.getloadavg()}")
    model = nemc.compile(ROOT / "examples" / "double_pendulum.yaml", taylor=True)
    y0 = model.initial_state()
    print("| method | rtol | RHS calls: 2,001 points / end only | time: 2,001 points | "
          "time: end only | error at the points / at the steps |")
    print("| --- | --- | --- | --- | --- | --- |")
    for method in METHODS:
        for rtol in TOLERANCES:
            def run(times, m=method, r=rtol):
                return model.simulate(SPAN, y0, method=m, rtol=r, atol=r * 1e-3, t_eval=times)

            dense, end, steps = run(POINTS), run([SPAN[1]]), run("steps")
            times = interleaved({"dense": (lambda: run(POINTS), 1),
                                 "end": (lambda: run([SPAN[1]]), 1)}, args.rounds, 0.05)
            errors = (largest_error(model, y0, POINTS, dense.y),
                      largest_error(model, y0, steps.t, steps.y))
            print(f"| {method} | {rtol:g} | {dense.nfev:,} / {end.nfev:,} | "
                  f"{spread(times['dense'])} | {spread(times['end'])} | "
                  f"{errors[0]:.1e} / {errors[1]:.1e} |", flush=True)
    print(f"load average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
