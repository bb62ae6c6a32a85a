"""What a fit costs (issue 47's target: the 4-link chain's 12 parameters from 1 %-noise data of
several runs in < 2 s on one core): examples/chain4_fit.py's fit, timed, and where its time goes.

Run: `python benchmarks/fitting.py [--quick | --smoke] [--out DIR]`; part of `make bench`.
Results: benchmarks/results/fitting-latest.{json,md} (smoke: a temporary folder).

The fit: the example's 4 swings x 101 times x 4 angles (seed 47), its 12 parameters (4 centres
of mass, 4 inertias, 4 joint dampers) from the drawing's uniform rods, within bounds, rtol 1e-10
(nemc.fit's default). Timed on one CPU (common.one_cpu), the model's build cached: the first fit
in a fresh process (it loads the part "sensitivities" and the drivers for its size, and imports
scipy.optimize) and repeated fits in one process (median, min-max). Where the time goes, in one
fit: the evaluations (one run with the 12 sensitivity columns per swing, and the residuals and
Jacobian assembled from them) against the rest (least_squares' iterations and nemc.fit's checks,
rank and covariance), and one swing's run with its sensitivities against the plain run at the
estimate. Smoke mode: one swing from the true values (a run-through, for the tests).
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
from common import ROOT, fmt_time  # noqa: E402

import nemc  # noqa: E402
from nemc.runtime import fitting  # noqa: E402

EXAMPLE = ROOT / "examples" / "chain4_fit.py"
TARGET = 2.0  # seconds: the bound on the chain's fit
SEED = 47  # the example's


@dataclass(frozen=True)
class Config:
    mode: str
    swings: int
    rounds: int
    from_truth: bool  # start at the true values (smoke: a few runs) instead of the drawing


MODES = {
    "full": Config("full", 4, 7, False),
    "quick": Config("quick", 4, 3, False),
    "smoke": Config("smoke", 1, 1, True),
}

MEASURE = """
import json, sys
sys.path.insert(0, {folder!r})
import fitting as bench  # this script, as a module
print(json.dumps(bench.measured({swings}, {from_truth}, {rounds})))
"""


def example() -> ModuleType:
    spec = importlib.util.spec_from_file_location("chain4_fit", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def prepared(swings: int, from_truth: bool) -> tuple[Any, Any]:
    """The compiled chain and a call making the example's fit (data made beforehand)."""
    chain = example()
    model = nemc.compile(chain.EXAMPLE)
    data = chain.experiments(model, SEED, swings)
    start = ({name: model.parameters[name] for name in chain.FITTED} if from_truth
             else chain.drawing(model))

    def fit() -> Any:
        return nemc.fit(model, fit=chain.FITTED, observed=chain.ANGLES, experiments=data,
                        start=start, bounds=chain.bounds(model), absolute_sigma=True)

    return model, fit


def in_fresh_process(config: Config) -> dict[str, Any]:
    """measured() in a fresh process started on the one CPU: numpy's BLAS then starts one
    thread (pinning a process that has started two made least_squares' small SVDs 100x
    slower: the threads spun against each other on one CPU)."""
    code = MEASURE.format(folder=str(Path(__file__).resolve().parent), swings=config.swings,
                          from_truth=config.from_truth, rounds=config.rounds)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=1800)
    if done.returncode != 0:
        raise RuntimeError(f"the measuring process failed: {done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def measured(swings: int, from_truth: bool, rounds: int) -> dict[str, Any]:
    """The first fit in this process (the build cached), ROUNDS fits more, one fit's share of
    evaluations, one swing's runs with and without sensitivities."""
    model, fit = prepared(swings, from_truth)
    began = time.perf_counter()
    fit()
    first = time.perf_counter() - began
    seconds, found = [], None
    for _ in range(rounds):
        began = time.perf_counter()
        found = fit()
        seconds.append(time.perf_counter() - began)
    return {"first_fit": first, "fits": common.summary(seconds), "nfev": found.nfev,
            "rank": found.rank, "share": evaluation_share(fit),
            "runs": run_costs(model, found, rounds)}


def evaluation_share(fit: Any) -> dict[str, Any]:
    """One fit with nemc.fit's evaluations timed: their seconds (runs with sensitivities and
    the residuals and Jacobian assembled) and the fit's."""
    spent: list[float] = []
    evaluate = fitting.Evaluations.evaluate

    def timed_evaluate(self: Any, x: Any, first: bool) -> Any:
        began = time.perf_counter()
        try:
            return evaluate(self, x, first)
        finally:
            spent.append(time.perf_counter() - began)

    fitting.Evaluations.evaluate = timed_evaluate
    try:
        began = time.perf_counter()
        found = fit()
        total = time.perf_counter() - began
    finally:
        fitting.Evaluations.evaluate = evaluate
    return {"fit_seconds": total, "evaluations": len(spent),
            "evaluation_seconds": sum(spent), "nfev": found.nfev}


def run_costs(model: Any, found: Any, rounds: int) -> dict[str, Any]:
    """One swing's run at the estimate with the 12 sensitivity columns and without
    (common.interleaved)."""
    run = found.runs[0]
    span, y0, t = (run.t[0], run.t[-1]), run.y[:, 0].copy(), run.t
    names = list(found.names)

    def call(sensitivities: list[str] | None) -> Any:
        return lambda: model.simulate(span, y0, t_eval=t, params=found.values,
                                      sensitivities=sensitivities, rtol=1e-10, atol=1e-12)

    return common.interleaved({"plain": (call(None), 1), "sensitivities": (call(names), 1)},
                              rounds=max(3, rounds), target=0.05)


def run(config: Config) -> dict[str, Any]:
    env = common.environment(config.mode)
    started = time.perf_counter()
    prepared(config.swings, config.from_truth)  # the build cached before anything is timed
    with common.one_cpu(env):
        result = in_fresh_process(config)
    print(f"  first fit in a process: {result['first_fit']:.2f} s, repeated fits: "
          f"{result['fits']['median']:.2f} s", flush=True)
    common.finish_environment(env, started)
    return {"environment": env, "config": config.__dict__, "target": TARGET,
            "experiments": config.swings, **result}


def markdown(result: dict[str, Any]) -> str:
    config, share, runs = result["config"], result["share"], result["runs"]
    rest = share["fit_seconds"] - share["evaluation_seconds"]
    plain, with_sens = runs["plain"]["median"], runs["sensitivities"]["median"]
    lines = ["# Fitting: the 4-link chain's 12 parameters (examples/chain4_fit.py)", "",
             *common.md_environment(result["environment"]), "",
             f"{config['swings']} swing(s) x 101 times x 4 angles, seed {SEED}, 1 % noise; "
             f"12 parameters from {'the true values' if config['from_truth'] else 'the drawing'}"
             f", rank {result['rank']}, {result['nfev']} evaluations ({result['nfev']} x "
             f"{result['experiments']} runs with sensitivities). The issue's target: < "
             f"{TARGET:g} s on one core.", "",
             "| what | time |", "| --- | --- |",
             f"| first fit in a fresh process (build cached) | "
             f"{fmt_time(result['first_fit'])} |",
             f"| a fit, repeated in one process | {common.spread(result['fits'])} |",
             f"| of one fit: its {share['evaluations']} evaluations (runs with sensitivities, "
             f"residuals, Jacobian) | {fmt_time(share['evaluation_seconds'])} "
             f"({share['evaluation_seconds'] / share['fit_seconds']:.0%}) |",
             f"| of one fit: the rest (least_squares, checks, rank, covariance) | "
             f"{fmt_time(rest)} ({rest / share['fit_seconds']:.0%}) |",
             f"| one swing's run, plain | {common.spread(runs['plain'])} |",
             f"| one swing's run with its 12 sensitivity columns | "
             f"{common.spread(runs['sensitivities'])} ({with_sens / plain:.1f}x) |"]
    return "\n".join(lines) + "\n"


def main() -> int:
    return common.run_script(__doc__, ("3 rounds", "one swing from the true values (tests)"),
                             MODES, "fitting", run, markdown)


if __name__ == "__main__":
    sys.exit(main())
