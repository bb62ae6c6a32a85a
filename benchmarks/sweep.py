"""The sweep machinery (issue 18): what Dask workers buy and what nemc.sweep costs.

On the same runs of the double pendulum (random initial angles, [0, 10], nemc.Taylor at rtol
1e-8, 10 output times), interleaved and repeated, warm (clusters started, models loaded):

- scaling: nemc.sweep on a LocalCluster of 2 worker processes against 1 (one thread each):
  the throughput ratio (target >= 1.8x on this 2-core machine);
- overhead: nemc.sweep on this machine's threads (into memory and into a zarr store) against
  one plain simulate_many call on the same threads (target <= 5%); and the 2-worker cluster
  against the same simulate_many. The sweeps store the states only (outputs=False), as
  simulate_many returns them; what the outputs cost: benchmarks/sweep_outputs.py.

Results: benchmarks/results/sweep-latest.{json,md}, with the load average of every round.

    python benchmarks/sweep.py [--quick | --smoke] [--out DIR]
"""

from __future__ import annotations

import os
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402 (the benchmarks folder is not a package)
from common import RESULTS, ROOT, load_average, summary  # noqa: E402

EXAMPLE = ROOT / "examples" / "double_pendulum.yaml"
SIZES = {"smoke": (400, 2), "quick": (10_000, 3), "full": (40_000, 7)}  # runs, rounds
SETTINGS = dict(t_span=(0.0, 10.0), t_eval=np.linspace(1.0, 10.0, 10), method="nemc.Taylor",
                rtol=1e-8)
THREADS = 2


def initial_states(count: int) -> np.ndarray:
    """Random initial angles in [-2, 2] rad (some regular, some chaotic runs), at rest."""
    rng = np.random.default_rng(18)
    y0s = np.zeros((count, 4))
    y0s[:, 0], y0s[:, 2] = rng.uniform(-2, 2, count), rng.uniform(-2, 2, count)
    return y0s


def contenders(model: Any, y0s: np.ndarray, clients: dict[str, Any], scratch: Path,
               chunk: int, busy: dict[str, list[float]]) -> dict[str, Callable[[], Any]]:
    """The contenders; a cluster's sweeps add their chunks' seconds on the workers to BUSY."""
    from nemc.tools.sweeps import sweep

    def on_cluster(name: str, client: Any) -> Callable[[], Any]:
        def call() -> Any:
            busy[name].append(0.0)
            return sweep(model, y0s, client=client, chunk_runs=chunk, progress=False,
                         on_chunk=lambda report: add(busy[name], report.seconds),
                         outputs=False, **SETTINGS)
        return call

    def into_zarr() -> Any:
        out = scratch / "runs.zarr"
        shutil.rmtree(out, ignore_errors=True)
        return sweep(model, y0s, out=out, threads=THREADS, chunk_runs=chunk, progress=False,
                     outputs=False, **SETTINGS)

    return {
        "simulate_many": lambda: model.simulate_many(y0s, threads=THREADS, **SETTINGS),
        "sweep (memory)": lambda: sweep(model, y0s, threads=THREADS, chunk_runs=chunk,
                                        progress=False, outputs=False, **SETTINGS),
        "sweep (zarr)": into_zarr,
        **{f"sweep on {name}": on_cluster(name, client) for name, client in clients.items()},
    }


def add(totals: list[float], seconds: float) -> None:
    totals[-1] += seconds


def rounds(calls: dict[str, Callable[[], Any]], count: int) -> tuple[dict, list]:
    """Seconds of each contender per round, the order rotated every round; the load average
    before each round."""
    samples: dict[str, list[float]] = {name: [] for name in calls}
    loads = []
    names = list(calls)
    for r in range(count):
        loads.append(load_average())
        for name in names[r % len(names):] + names[:r % len(names)]:
            start = time.perf_counter()
            calls[name]()
            samples[name].append(time.perf_counter() - start)
    return {name: summary(values) for name, values in samples.items()}, loads


def ratio(samples: dict, numerator: str, denominator: str) -> dict[str, float]:
    """Median of the per-round ratios (each round's pair ran close together) and their spread;
    and the ratio of the fastest times, the least disturbed by other work on the machine."""
    a, b = samples[numerator], samples[denominator]
    pairs = [x / y for x, y in zip(a["values"], b["values"])]
    return {"median": statistics.median(pairs), "min": min(pairs), "max": max(pairs),
            "of_fastest": a["min"] / b["min"]}


def measure(mode: str) -> dict[str, Any]:
    from distributed import Client, LocalCluster

    import nemc
    from nemc.tools.sweeps import default_chunk_runs

    runs, count = SIZES[mode]
    model = nemc.compile(EXAMPLE, taylor=True)
    y0s = initial_states(runs)
    chunk = default_chunk_runs(runs, 4, len(SETTINGS["t_eval"]))  # what a user gets
    with tempfile.TemporaryDirectory() as scratch, \
            LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=":0") as one, \
            LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as two, \
            Client(one) as client1, Client(two) as client2:
        clients = {"1 worker": client1, "2 workers": client2}
        busy: dict[str, list[float]] = {name: [] for name in clients}
        calls = contenders(model, y0s, clients, Path(scratch), chunk, busy)
        warm = {name: call() for name, call in calls.items()}  # workers load the model
        reference = warm.pop("simulate_many").y
        identical = {name: bool(np.array_equal(np.asarray(r.y), reference, equal_nan=True))
                     for name, r in warm.items()}
        for seconds in busy.values():
            seconds.clear()
        samples, loads = rounds(calls, count)
    return {
        "workers_busy": {name: busy_fraction(seconds, samples[f"sweep on {name}"]["values"],
                                             workers=int(name.split()[0]))
                         for name, seconds in busy.items()},
        "runs": runs, "rounds": count, "chunk_runs": chunk, "threads": THREADS,
        "settings": {k: (v.tolist() if isinstance(v, np.ndarray) else v)
                     for k, v in SETTINGS.items()},
        "identical_to_simulate_many": identical, "seconds": samples,
        "loadavg_per_round": loads,
        "ratios": {
            "2 workers vs 1 (throughput)": ratio(samples, "sweep on 1 worker",
                                                 "sweep on 2 workers"),
            "sweep (memory) / simulate_many": ratio(samples, "sweep (memory)", "simulate_many"),
            "sweep (zarr) / simulate_many": ratio(samples, "sweep (zarr)", "simulate_many"),
            "sweep on 2 workers / simulate_many": ratio(samples, "sweep on 2 workers",
                                                        "simulate_many"),
        },
    }


def busy_fraction(task_seconds: list[float], wall: list[float], workers: int) -> dict:
    """How much of the sweep's time its workers spent in chunks (median and spread over the
    rounds): what Dask and nemc leave idle, apart from what other work on the machine takes."""
    fractions = [s / (workers * w) for s, w in zip(task_seconds, wall)]
    return {"median": statistics.median(fractions), "min": min(fractions),
            "max": max(fractions)}


def markdown(result: dict[str, Any]) -> str:
    env = result["environment"]
    lines = ["# Sweeps: Dask workers and the sweep machinery's cost", "",
             *common.md_environment(env), "",
             f"{result['runs']} double-pendulum runs, {result['settings']['method']} at rtol "
             f"{result['settings']['rtol']}, t in [0, 10], 10 output times; chunks of "
             f"{result['chunk_runs']} runs; {result['rounds']} interleaved rounds, warm.", "",
             "| contender | seconds, median (min–max) | runs/s (median) |", "| --- | --- | --- |"]
    for name, s in result["seconds"].items():
        lines.append(f"| {name} | {s['median']:.2f} ({s['min']:.2f}–{s['max']:.2f}) | "
                     f"{result['runs'] / s['median']:.0f} |")
    same = all(result["identical_to_simulate_many"].values())
    lines += ["", f"Every sweep's results identical to simulate_many's (bit for bit): {same}."]
    lines += ["", "| ratio of times | median of rounds | min–max | of the fastest |",
              "| --- | --- | --- | --- |"]
    for name, r in result["ratios"].items():
        lines.append(f"| {name} | {r['median']:.3f} | {r['min']:.3f}–{r['max']:.3f} | "
                     f"{r['of_fastest']:.3f} |")
    busy = ", ".join(f"{name}: {b['median']:.3f} ({b['min']:.3f}–{b['max']:.3f})"
                     for name, b in result["workers_busy"].items())
    lines += ["", f"Share of the cluster sweeps' time the workers spent integrating chunks "
              f"(the rest: Dask, nemc, idle workers): {busy}."]
    lines += ["", f"Load average before each round: {result['loadavg_per_round']}. The "
              "machine has 2 cores shared with other developers: a busy neighbour shows in "
              "the spreads and lowers the 2-worker ratio.", ""]
    return "\n".join(lines)


def main() -> int:
    parser = common.mode_parser(__doc__.splitlines()[0], "10,000 runs, 3 rounds (about 2 minutes)",
                         "400 runs, 2 rounds (seconds)")
    args = parser.parse_args()
    mode = common.mode_of(args)
    started = time.perf_counter()
    env = common.environment(mode)
    result = {"environment": env, **measure(mode)}
    common.finish_environment(env, started)
    out = args.out or RESULTS
    common.write_json(result, out / "sweep-latest.json")
    (out / "sweep-latest.md").write_text(markdown(result))
    print(markdown(result))
    return 0


if __name__ == "__main__":
    os.environ.setdefault("NEMC_CACHE", str(ROOT / ".nemc-cache"))
    sys.exit(main())
