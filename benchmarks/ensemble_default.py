"""Which native method is fastest for an ensemble at equal error (issue 19, the default
method): nemc.DOP853, nemc.Vern9 and nemc.Taylor (in SIMD lanes, at the lane count given, default
the machine's), 1 thread, with simulate_many's default choice beside them.

Run: `python benchmarks/ensemble_default.py [--rounds 3] [--lanes 4|8] [--chains 4,8]` (about
2 minutes; longer chains take longer to build).
Prints a Markdown table and the load average; writes nothing. docs/decisions.md, "The
ensembles' default method", quotes one run.

Ensembles: 2,000 double pendulums with angles uniform in ±2 rad over [0, 10], 400 4- and 8-link
chains with the first angle uniform in ±0.5 rad over [0, 5] (seeded), 51 output times. Error of
an ensemble: the median over its runs of each run's largest error over states and times,
against nemc.Taylor at rtol 2.5e-14, atol 1e-15. Each method runs a ladder of tolerances
(rtol 10^-2.5 ... 10^-12 by half decades, atol = rtol x 1e-3) until its error is at most each
target (1e-3, 1e-5, 1e-7); the loosest rtol that reaches a target is then timed, the methods
interleaved, `rounds` rounds, median and min-max. "auto": the method simulate_many chooses with
the lanes at hand (they are built first), at nemc.Taylor's rtol for that target.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, chain_yaml, run_errors  # noqa: E402

from nemc.build.builder import Source, lane_count  # noqa: E402
from nemc.pipeline import compile_source  # noqa: E402

METHODS = ("nemc.DOP853", "nemc.Vern9", "nemc.Taylor")
LADDER = tuple(10 ** (-e / 2) for e in range(5, 25))  # 10^-2.5 ... 10^-12
TARGETS = (1e-3, 1e-5, 1e-7)
REFERENCE_RTOL, REFERENCE_ATOL = 2.5e-14, 1e-15


def with_lanes(name: str, text: str, width: int):
    """The mechanism built with nemc.Taylor's code and WIDTH lanes per batch (untimed)."""
    return compile_source(Source(f"{name}.yaml", text.encode()), None, taylor=True,
                          lanes=width).model


def ensembles(width: int, links: tuple[int, ...] = (4, 8)
              ) -> list[tuple[str, object, np.ndarray, tuple[float, float]]]:
    """(label, model with its lanes, initial states, span): the double pendulum's large swings,
    and gentle chains of these many links (seeded)."""
    rng = np.random.default_rng(1)
    swings = np.zeros((2000, 4))
    swings[:, 0], swings[:, 2] = rng.uniform(-2, 2, 2000), rng.uniform(-2, 2, 2000)
    pendulum = (ROOT / "examples" / "double_pendulum.yaml").read_text()
    cases = [("2,000 double pendulums, ±2 rad, [0, 10]",
              with_lanes("double_pendulum", pendulum, width), swings, (0.0, 10.0))]
    for n in links:
        chain = with_lanes(f"chain{n}", chain_yaml(n), width)
        starts = np.tile(chain.initial_state(), (400, 1))
        starts[:, 0] += rng.uniform(-0.5, 0.5, 400)
        cases.append((f"400 {n}-link chains, ±0.5 rad, [0, 5]", chain, starts, (0.0, 5.0)))
    return cases


def loosest_tolerances(model, y0s, span, times, reference) -> dict[str, dict[float, float]]:
    """method -> target -> the loosest rtol of LADDER whose ensemble error is within it."""
    found: dict[str, dict[float, float]] = {}
    for method in METHODS:
        found[method] = {}
        for rtol in LADDER:
            runs = model.simulate_many(y0s, t_span=span, t_eval=times, method=method, rtol=rtol,
                                       atol=rtol * 1e-3, threads=1, progress=False)
            error = run_errors(runs.y, reference)["median"] if runs.success.all() else np.inf
            for target in TARGETS:
                if error <= target:
                    found[method].setdefault(target, rtol)
            if len(found[method]) == len(TARGETS):
                break
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--lanes", type=int, choices=(4, 8), default=None,
                        help="lanes per batch (default: this machine's)")
    parser.add_argument("--chains", default="4,8", help="the chains' links, comma-separated")
    args = parser.parse_args()
    links = tuple(int(n) for n in args.chains.split(","))
    width = args.lanes or lane_count()
    print(f"load average at start: {os.getloadavg()}; {width} lanes per batch")
    print("| ensemble | median error | " + " | ".join(METHODS) + " | auto (lanes at hand) |")
    print("| --- | --- |" + " --- |" * (len(METHODS) + 1))
    for label, model, y0s, span in ensembles(width, links):
        times = np.linspace(*span, 51)
        reference = model.simulate_many(y0s, t_span=span, t_eval=times, method="nemc.Taylor",
                                        rtol=REFERENCE_RTOL, atol=REFERENCE_ATOL,
                                        progress=False).y
        found = loosest_tolerances(model, y0s, span, times, reference)
        for target in TARGETS:
            seconds: dict[str, list[float]] = {m: [] for m in METHODS if target in found[m]}
            for round_ in range(args.rounds):
                for method in list(seconds)[::1 if round_ % 2 == 0 else -1]:
                    rtol = found[method][target]
                    start = time.perf_counter()
                    model.simulate_many(y0s, t_span=span, t_eval=times, method=method,
                                        rtol=rtol, atol=rtol * 1e-3, threads=1, progress=False)
                    seconds[method].append(time.perf_counter() - start)
            cells = [f"{np.median(seconds[m]):.3f} s ({min(seconds[m]):.3f}-"
                     f"{max(seconds[m]):.3f}) at rtol {found[m][target]:.1e}"
                     if m in seconds else "not reached" for m in METHODS]
            rtol = found["nemc.Taylor"].get(target, 1e-8)
            auto = model.ensemble_method(span, y0s[0], rtol=rtol, runs=len(y0s))
            print(f"| {label} | {target:g} | " + " | ".join(cells) + f" | {auto} |", flush=True)
    print(f"load average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
