"""Sensitivities in ensembles (issue 47): simulate_many with sensitivities over 64 members of the
double pendulum against 64 single simulate(..., sensitivities=...) calls, against
simulate_many without them, and with nemc.Taylor (its members one after the other, not in SIMD
lanes).

Run: `python benchmarks/ensemble_sensitivities.py [--quick | --smoke] [--out DIR]`; part of
`make bench`. Results: benchmarks/results/ensemble_sensitivities-latest.{json,md} (smoke: a
temporary folder).

System: the book's double pendulum (5.2), 64 members (seed 47: m2 and L2 within 20 % of their
defaults, the initial state the scene's plus up to 0.2 in each entry), over [0, 20] at rtol
1e-10 (atol 1e-12) with nemc.Vern9, the 9 columns (its 4 initial values and 5 parameters), the
state at t = 20 only, one thread. The three contenders are timed interleaved
(common.interleaved: calibrated loops, rounds rotating the order) on one CPU (common.one_cpu),
the load average recorded at the start and the end; ratios of medians, with the range of the
per-round ratios. Before the timing, every member's columns are compared with its single run's
(the largest difference: 0 when they are the same to the bit), nemc.Taylor's with its single
nemc.Taylor runs'.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
from common import ROOT, fmt_time  # noqa: E402

import nemc  # noqa: E402

BOOK = ROOT / "examples" / "double_pendulum.yaml"
RTOL, ATOL, METHOD = 1e-10, 1e-12, "nemc.Vern9"
TAYLOR = "nemc.Taylor"  # the row of its ensemble's sensitivities
NAMES = ["y0", "m1", "m2", "L1", "L2", "g"]  # 4 initial values, 5 parameters: 9 columns
SEED = 47


@dataclass(frozen=True)
class Config:
    mode: str
    members: int
    t_end: float
    rounds: int
    sample_seconds: float


MODES = {
    "full": Config("full", 64, 20.0, 9, 0.5),
    "quick": Config("quick", 64, 20.0, 5, 0.2),
    "smoke": Config("smoke", 4, 1.0, 2, 0.01),
}


def members(model: Any, k: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """K members' initial states and parameters (seeded)."""
    rng = np.random.default_rng(SEED)
    params = {name: model.parameters[name] * rng.uniform(0.8, 1.2, k) for name in ("m2", "L2")}
    y0s = model.initial_state() + rng.uniform(-0.2, 0.2, (k, model.n_state))
    return y0s, params


def contenders(model: Any, y0s: np.ndarray, params: dict[str, np.ndarray],
               span: tuple[float, float]) -> dict[str, Any]:
    """The four calls timed: the ensemble with and without the columns, the single runs, and
    nemc.Taylor's ensemble with the columns."""
    options = {"method": METHOD, "rtol": RTOL, "atol": ATOL, "t_eval": [span[1]]}
    many = {"t_span": span, "threads": 1, "progress": False, **options}

    return {
        "simulate_many with sensitivities": lambda: model.simulate_many(
            y0s, params=params, sensitivities=NAMES, **many),
        "single runs with sensitivities": lambda: singles(model, y0s, params, span, METHOD),
        "simulate_many plain": lambda: model.simulate_many(y0s, params=params, **many),
        f"simulate_many with sensitivities, {TAYLOR}": lambda: model.simulate_many(
            y0s, params=params, sensitivities=NAMES, **{**many, "method": TAYLOR}),
    }


def singles(model: Any, y0s: np.ndarray, params: dict[str, np.ndarray],
            span: tuple[float, float], method: str) -> list[Any]:
    """The members' single runs with sensitivities by METHOD."""
    return [model.simulate(span, y0s[r], params={n: v[r] for n, v in params.items()},
                           sensitivities=NAMES, method=method, rtol=RTOL, atol=ATOL,
                           t_eval=[span[1]]) for r in range(len(y0s))]


def largest_difference(ensemble: Any, singles: list[Any]) -> float:
    """The largest difference between a member's columns and its single run's."""
    return max(float(np.abs(ensemble.sensitivities[name][r] - single.sensitivities[name])
                     .max()) for r, single in enumerate(singles) for name in NAMES)


def ratio(times: dict[str, Any], slower: str, faster: str) -> dict[str, Any]:
    """slower / faster: of the medians, and the range of the per-round ratios."""
    rounds = [s / f for s, f in zip(times[slower]["values"], times[faster]["values"])]
    return {"of": [slower, faster], "median": times[slower]["median"] /
            times[faster]["median"], "range": [min(rounds), max(rounds)]}


def run(config: Config) -> dict[str, Any]:
    env = common.environment(config.mode)
    started = time.perf_counter()
    model = nemc.compile(BOOK)
    span = (0.0, config.t_end)
    y0s, params = members(model, config.members)
    calls = contenders(model, y0s, params, span)
    ensemble = calls["simulate_many with sensitivities"]()  # the part and drivers built
    taylor = calls[f"simulate_many with sensitivities, {TAYLOR}"]()
    assert np.all(ensemble.success) and np.all(taylor.success), (ensemble.status, taylor.status)
    difference = largest_difference(ensemble, calls["single runs with sensitivities"]())
    taylor_difference = largest_difference(taylor, singles(model, y0s, params, span, TAYLOR))
    with common.one_cpu(env):
        times = common.interleaved({name: (call, 1) for name, call in calls.items()},
                                   config.rounds, config.sample_seconds)
    common.finish_environment(env, started)
    return {"environment": env, "config": config.__dict__, "times": times,
            "nfev": {"members with sensitivities": int(ensemble.nfev.sum()),
                     "members plain": int(calls["simulate_many plain"]().nfev.sum())},
            "largest_difference_from_single_runs": difference,
            "taylor_largest_difference_from_single_runs": taylor_difference,
            "ratios": [ratio(times, "single runs with sensitivities",
                             "simulate_many with sensitivities"),
                       ratio(times, "simulate_many with sensitivities",
                             "simulate_many plain"),
                       ratio(times, f"simulate_many with sensitivities, {TAYLOR}",
                             "simulate_many with sensitivities")]}


def markdown(result: dict[str, Any]) -> str:
    config = result["config"]
    lines = [f"# Sensitivities in ensembles: {config['members']} members of the double pendulum",
             "", *common.md_environment(result["environment"]), "",
             f"{config['members']} members (seed {SEED}) over [0, {config['t_end']:g}] with "
             f"{METHOD} (and {TAYLOR}, one member after the other, not in SIMD lanes) at rtol "
             f"{RTOL:g}, atol {ATOL:g}, 9 sensitivity columns, the state at the end only, one "
             "thread; medians (min–max) of the interleaved rounds.", "",
             "| contender | time | a member |", "| --- | --- | --- |"]
    for name, times in result["times"].items():
        lines.append(f"| {name} | {common.spread(times)} | "
                     f"{fmt_time(times['median'] / config['members'])} |")
    lines += ["", "| ratio | median | per-round range |", "| --- | --- | --- |"]
    for r in result["ratios"]:
        low, high = r["range"]
        lines.append(f"| {r['of'][0]} / {r['of'][1]} | {r['median']:.2f}x | "
                     f"{low:.2f}–{high:.2f}x |")
    nfev = result["nfev"]
    lines += ["", f"Right-hand sides over the members: {nfev['members with sensitivities']:,} "
              f"with the columns, {nfev['members plain']:,} without. Largest difference of a "
              "member's columns from its single run's: "
              f"{result['largest_difference_from_single_runs']:.1e} ({TAYLOR}'s from its single "
              f"{TAYLOR} runs': {result['taylor_largest_difference_from_single_runs']:.1e})."]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = common.mode_parser(__doc__.splitlines()[0], "fewer rounds",
                                "4 members over [0, 1] (tests)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    print(f"nemc ensemble sensitivities benchmark, {mode} mode", flush=True)
    result = run(MODES[mode])
    common.write_results(result, common.results_folder(args, "nemc-bench-ens-sens-"),
                         "ensemble_sensitivities", markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
