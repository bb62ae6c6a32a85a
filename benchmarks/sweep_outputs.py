"""What storing the scene's outputs costs a sweep (issue 52): nemc.sweep of the double
pendulum (random angles, [0, 2] s, nemc.DOP853 at its default tolerances, 21 output times,
one thread, in memory) with and without outputs, interleaved and repeated; shared parameters
(one C call of the outputs per chunk) and a mass per run (one C call per run).

    python benchmarks/sweep_outputs.py [--runs N] [--repeats R]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import nemc
from nemc.tools.sweeps import sweep

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "double_pendulum.yaml"


def timed(model: nemc.Model, y0s: np.ndarray, params: dict, outputs: bool) -> float:
    """Seconds of one sweep."""
    started = time.perf_counter()
    sweep(model, y0s, params=params, t_span=(0.0, 2.0), t_eval=np.linspace(0.0, 2.0, 21),
          method="nemc.DOP853", threads=1, progress=False, outputs=outputs)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    model = nemc.compile(EXAMPLE)
    rng = np.random.default_rng(0)
    y0s = np.zeros((args.runs, 4))
    y0s[:, 0], y0s[:, 2] = rng.uniform(-2.0, 2.0, (2, args.runs))
    cases = {"shared parameters": {}, "a mass per run": {"m2": np.linspace(0.5, 1.5,
                                                                             args.runs)}}
    for name, params in cases.items():
        timed(model, y0s, params, True)  # warm
        seconds: dict[bool, list[float]] = {False: [], True: []}
        for _ in range(args.repeats):
            for outputs in (False, True):
                seconds[outputs].append(timed(model, y0s, params, outputs))
        states, both = (statistics.median(seconds[k]) for k in (False, True))
        print(f"{name}: states only {1e6 * states / args.runs:.1f} us a run, with outputs "
              f"{1e6 * both / args.runs:.1f} us a run (+{1e6 * (both - states) / args.runs:.1f}"
              f" us; medians of {args.repeats})")


if __name__ == "__main__":
    main()
