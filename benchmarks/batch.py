"""Ensembles in SIMD lanes: simulate_many(method="nemc.Taylor") in lanes against the same runs one
after the other, and heyoka's batch mode when it is installed (issue 19).

Run: `python benchmarks/batch.py [--quick | --smoke] [--out DIR]`; part of `make bench`.
Results: benchmarks/results/batch-latest.{json,md} (smoke: a temporary folder).

Systems (each scene's rtol and atol set to the ensembles'): the
book's double pendulum, `runs` random initial angles (seeded, uniform in
[-1.5, 1.5] rad, at rest) over [0, 10] (the ensemble of benchmarks/native.py and of issue 19's
table); in full and quick mode also `chain_runs` 8-link chains (`common.chain_yaml(8)`, angles
uniform in [-0.5, 0.5] rad, at rest) over [0, 5]. 101 output times, rtol 1e-8, atol 1e-10.
Contenders per system, each timed once per round, interleaved, the order rotating each round
(those on 1 thread on one CPU, the same for all: common.one_cpu):
- lanes: simulate_many(method="nemc.Taylor") (the part "lanes", built before timing);
- one by one: the same with lanes=False (integrate_many's loop);
each on 1 thread and on all the machine's cores. The lanes' states are checked equal to the
one-by-one runs bit for bit; nemc's lanes per batch are its build's (8 with AVX-512, else 4).
heyoka (when importable): taylor_adaptive_batch fed benchmarks/peers.py's straight-line program
(LDL^T), tol 1e-8, in its default mode at its recommended_simd_size and at 8 lanes, and in its
compact mode (the fastest is the comparison), propagate_grid batch by batch on 1 thread, its JIT
compile untimed. nemc and heyoka are checked against a reference
(nemc.Taylor at rtol 2.5e-14, atol 1e-15): each run's largest error over its states and times,
median and 90th percentile over the runs, so the ratio is one at equal error or says how far
from it. Reported: medians with min-max spread, ratios of medians (throughput), the load
average before and after.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
from common import ROOT, fmt_time, spread  # noqa: E402

PENDULUM = ROOT / "examples" / "double_pendulum.yaml"
SPAN, RTOL, ATOL = (0.0, 10.0), 1e-8, 1e-10
REFERENCE_RTOL, REFERENCE_ATOL = 2.5e-14, 1e-15  # rtol just above Taylor's floor of 100 eps


@dataclass(frozen=True)
class Config:
    runs: int
    rounds: int
    chain_runs: int


MODES = {"full": Config(10_000, 5, 1_000), "quick": Config(2_000, 3, 200),
         "smoke": Config(100, 2, 0)}


@dataclass(frozen=True)
class System:
    name: str
    path: Path
    span: tuple[float, float]
    runs: int
    bound: float  # initial angles uniform in [-bound, bound], at rest

    @property
    def times(self) -> np.ndarray:
        return np.linspace(*self.span, 101)


def systems(config: Config, folder: Path) -> list[System]:
    """The mechanisms, each with its scene's tolerances the ensembles'."""
    texts = {"double pendulum": PENDULUM.read_text()}
    if config.chain_runs:
        texts["8-link chain"] = common.chain_yaml(8)
    found = []
    for name, text in texts.items():
        path = folder / f"{name.replace(' ', '_')}.yaml"
        path.write_text(common.with_scene_tolerances(text, RTOL, ATOL))
        span, runs, bound = ((SPAN, config.runs, 1.5) if name == "double pendulum"
                             else ((0.0, 5.0), config.chain_runs, 0.5))
        found.append(System(name, path, span, runs, bound))
    return found


def initial_states(count: int, n_state: int, bound: float = 1.5) -> np.ndarray:
    """Random angles (seeded), rates 0."""
    rng = np.random.default_rng(0)
    y0s = np.zeros((count, n_state))
    y0s[:, 0::2] = rng.uniform(-bound, bound, (count, n_state // 2))
    return y0s


def heyoka_equations(system: System) -> tuple[Any, list[Any] | None, str]:
    """(heyoka, the system's equations for heyoka, "") or (None, None, why not): the
    straight-line program of benchmarks/peers.py (LDL^T), derived once for both modes."""
    try:
        import heyoka as hy
    except ImportError:
        return None, None, "not installed"
    try:
        import peers

        model = peers.mechanics_model(system.path)
        mass, forcing, qs, us = peers.plain_symbols(model)
        n = len(qs)
        hq = [hy.make_vars(f"q{k}") for k in range(n)]
        hu = [hy.make_vars(f"u{k}") for k in range(n)]
        smap = {**dict(zip(qs, hq)), **dict(zip(us, hu))}
        m = [[hy.from_sympy(mass[max(i, j), min(i, j)], s_dict=smap) for j in range(n)]
             for i in range(n)]
        f = [hy.from_sympy(forcing[i], s_dict=smap) for i in range(n)]
        qdd = peers.ldl_solve(m, f, lambda e: e)
    except Exception as error:  # noqa: BLE001 (recorded in the results, never hidden)
        return None, None, f"set-up failed: {type(error).__name__}: {error}"
    return hy, [eq for k in range(n) for eq in ((hq[k], hu[k]), (hu[k], qdd[k]))], ""


def heyoka_batch(hy: Any, equations: list[Any], system: System, y0s: np.ndarray,
                 compact: bool, batch: int) -> tuple[Callable[[], np.ndarray] | None, str]:
    """A call integrating every run in heyoka's batches of BATCH runs (states (k, n_state,
    n_t)) in its default or compact mode, or None and why not."""
    try:
        ta = hy.taylor_adaptive_batch(equations, np.zeros((len(equations), batch)), tol=RTOL,
                                      compact_mode=compact)
        grid = np.repeat(system.times[:, None], batch, axis=1)
    except Exception as error:  # noqa: BLE001 (recorded in the results, never hidden)
        return None, f"set-up failed: {type(error).__name__}: {error}"

    def run() -> np.ndarray:
        k = len(y0s)
        out = np.full((k, len(equations), system.times.size), np.nan)
        for start in range(0, k, batch):
            rows = y0s[start:start + batch]
            state = np.repeat(rows[-1:], batch, axis=0)  # a short last batch repeats a run
            state[:len(rows)] = rows
            ta.set_time(system.span[0])
            ta.state[:] = state.T
            result = ta.propagate_grid(grid)
            states = np.asarray(result[-1] if isinstance(result, tuple) else result)
            out[start:start + len(rows)] = states.transpose(2, 1, 0)[:len(rows)]
        return out

    return run, (f"taylor_adaptive_batch, {batch} lanes, tol {RTOL:g}, "
                 f"{'compact' if compact else 'default'} mode")


def heyoka_settings(hy: Any) -> list[tuple[bool, int]]:
    """(compact mode?, runs per batch) of each heyoka contender: its default mode at its
    recommended_simd_size and at 8 lanes (on this AVX-512 machine heyoka recommends 4, and 8
    is faster on the pendulum, slower on the chains: the faster is the comparison), its compact
    mode at the recommended size."""
    recommended = hy.recommended_simd_size()
    return [(False, size) for size in sorted({recommended, 8})] + [(True, recommended)]


def threads_label(threads: int) -> str:
    return f"{threads} thread" + ("s" if threads > 1 else "")


def contenders(system: System) -> tuple[dict[str, Callable[[], Any]], dict[str, Any]]:
    import nemc

    model = nemc.compile(system.path).compiled_with("lanes")  # the part built before timing
    y0s = initial_states(system.runs, model.n_state, system.bound)
    cores = os.cpu_count() or 1
    calls: dict[str, Callable[[], Any]] = {}
    for threads in sorted({1, cores}):
        for lanes in (True, False):
            name = f"{'lanes' if lanes else 'one by one'}, {threads_label(threads)}"
            calls[name] = lambda lanes=lanes, threads=threads: model.simulate_many(
                y0s, t_span=system.span, t_eval=system.times, method="nemc.Taylor", rtol=RTOL,
                atol=ATOL, threads=threads, lanes=lanes, progress=False)
    heyokas, notes = {}, []
    hy, equations, why_not = heyoka_equations(system)
    for compact, batch in heyoka_settings(hy) if equations else ():
        heyoka, note = heyoka_batch(hy, equations, system, y0s, compact, batch)
        notes.append(note)
        if heyoka is not None:
            mode = "compact" if compact else "default"
            heyokas[f"heyoka batch {mode} ({batch} lanes), 1 thread"] = heyoka
    calls.update(heyokas)
    lanes_result, one_by_one = calls["lanes, 1 thread"](), calls["one by one, 1 thread"]()
    checks: dict[str, Any] = {
        "lanes_equal_one_by_one": bool(np.array_equal(lanes_result.y, one_by_one.y,
                                                      equal_nan=True)),
        "all_succeeded": bool(lanes_result.success.all()),
        "steps_per_run": float(lanes_result.nfev.mean()),
        "heyoka": "; ".join(notes) or why_not,
        "lane_count": model.metadata["lane_count"],
    }
    reference = model.simulate_many(y0s, t_span=system.span, t_eval=system.times,
                                    method="nemc.Taylor", rtol=REFERENCE_RTOL,
                                    atol=REFERENCE_ATOL, progress=False).y
    checks["errors"] = {"lanes": common.run_errors(lanes_result.y, reference)}
    for name, heyoka in heyokas.items():
        checks["errors"][name.removesuffix(", 1 thread")] = common.run_errors(heyoka(), reference)
    return calls, checks


def measure(calls: dict[str, Callable[[], Any]], rounds: int,
            env: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Interleaved rounds, the order rotating; the contenders on 1 thread each on the same one
    CPU (common.one_cpu: this machine's two CPUs can run at different speeds)."""
    samples: dict[str, list[float]] = {name: [] for name in calls}
    names = list(calls)
    for r in range(rounds):
        for name in names[r % len(names):] + names[:r % len(names)]:
            with common.one_cpu(env) if name.endswith(", 1 thread") else contextlib.nullcontext():
                start = time.perf_counter()
                calls[name]()
                samples[name].append(time.perf_counter() - start)
        print(f"  round {r + 1}/{rounds}: " + ", ".join(
            f"{name} {fmt_time(samples[name][-1])}" for name in names), flush=True)
    return {name: common.summary(values) for name, values in samples.items()}


def ratio(times: dict[str, dict[str, Any]], slower: str, faster: str) -> dict[str, Any]:
    """How many times faster `faster` is: the ratio of medians, and the range over rounds."""
    return common.speedup(times[slower], times[faster])


def run(config: Config) -> dict[str, Any]:
    started = time.perf_counter()
    env = common.environment("")
    with tempfile.TemporaryDirectory(prefix="nemc-batch-") as folder:
        results = {system.name: run_system(system, config.rounds, env)
                   for system in systems(config, Path(folder))}
    common.finish_environment(env, started)
    return {"environment": env, "config": vars(config), "systems": results}


def run_system(system: System, rounds: int, env: dict[str, Any]) -> dict[str, Any]:
    print(f"{system.name}, {system.runs:,} runs:", flush=True)
    calls, checks = contenders(system)
    times = measure(calls, rounds, env)
    cores = os.cpu_count() or 1
    ratios = {"lanes vs one by one, 1 thread": ratio(times, "one by one, 1 thread",
                                                      "lanes, 1 thread")}
    if cores > 1:
        many = threads_label(cores)
        ratios[f"lanes vs one by one, {many}"] = ratio(times, f"one by one, {many}",
                                                       f"lanes, {many}")
        ratios[f"lanes, {many} vs 1"] = ratio(times, "lanes, 1 thread", f"lanes, {many}")
    heyokas = [name for name in times if name.startswith("heyoka")]
    for name in heyokas:
        ratios[f"lanes vs {name}"] = ratio(times, name, "lanes, 1 thread")
    if heyokas:  # the comparison: heyoka's fastest contender, by median
        fastest = min(heyokas, key=lambda name: times[name]["median"])
        ratios["lanes vs heyoka's fastest, 1 thread"] = ratios[f"lanes vs {fastest}"]
    return {"runs": system.runs, "t_span": list(system.span), "checks": checks, "times": times,
            "ratios": ratios}


def markdown(result: dict[str, Any]) -> str:
    lines = ["# Ensembles in SIMD lanes: nemc.Taylor", "",
             *common.md_environment(result["environment"])]
    for name, system in result["systems"].items():
        lines += md_system(name, system, result["config"]["rounds"])
    return "\n".join(lines) + "\n"


def md_system(name: str, result: dict[str, Any], rounds: int) -> list[str]:
    checks, runs = result["checks"], result["runs"]
    lines = ["", f"## {name}", "",
             f"{runs:,} runs over {result['t_span']}, 101 output times, rtol {RTOL:g}, atol "
             f"{ATOL:g}; {rounds} interleaved rounds; {checks['steps_per_run']:.0f} expansions "
             "per run.", "",
             f"- lanes equal to the one-by-one runs bit for bit: "
             f"{checks['lanes_equal_one_by_one']}; all succeeded: {checks['all_succeeded']};"
             f" {checks.get('lane_count', '?')} lanes per batch",
             f"- heyoka: {checks['heyoka']}",
             f"- errors against nemc.Taylor at rtol {REFERENCE_RTOL:g}, atol {REFERENCE_ATOL:g}"
             " (each run's largest over states and times; median, 90th percentile over the "
             "runs): " + "; ".join(f"{who} {e['median']:.1e}, {e['p90']:.1e}"
                                  for who, e in checks["errors"].items()), "",
             "| contender | time, median (min–max) | runs/s |", "| --- | --- | --- |"]
    for contender, t in result["times"].items():
        lines.append(f"| {contender} | {spread(t)} | {runs / t['median']:,.0f} |")
    lines += ["", "| ratio (throughput) | median | range over rounds |", "| --- | --- | --- |"]
    for ratio_name, r in result["ratios"].items():
        lines.append(f"| {ratio_name} | {r['median']:.2f}x | {r['min']:.2f}–{r['max']:.2f}x |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = common.mode_parser(__doc__.splitlines()[0],
                                "2,000 double pendulums, 200 8-link chains, 3 rounds",
                                "100 double pendulums, 2 rounds (seconds); a temporary folder")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    print(f"nemc ensembles in lanes benchmark, {mode} mode", flush=True)
    result = run(MODES[mode])
    result["environment"]["mode"] = mode
    common.write_results(result, common.results_folder(args, "nemc-bench-batch-"), "batch",
                         markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
