"""nemc's native integrators against solve_ivp and heyoka at equal final error (issue 9's table).

Run: `python benchmarks/native.py [--quick | --smoke] [--sizes 4,8,16] [--out DIR]`; part of
`make bench`. Results: benchmarks/results/native-latest.{json,md} (smoke: a temporary folder).

1. Equal error. Systems: the book's double pendulum over [0, 20] and chains of n uniform rods
   (`common.chain_yaml(n)`, full: n = 4, 8, 16; quick: 4, 8) over [0, 5] (over [0, 10] the
   16-link chain's tight solutions agree only to about 4e-10, so a 1e-12 target could not be
   resolved). Targets: final
   errors 1e-6, 1e-9, 1e-12, error = max |y(t_end) - reference|. Each contender runs at the
   loosest rtol of a quarter-decade ladder (1e-3 ... 10^-13.5; atol = rtol x 1e-3) whose error
   is at most the target, found for that contender itself. Contenders:
   - solve_ivp DOP853 + lambdify(cse): benchmarks/baseline.py's baseline (sympy lambdify of M and
     f with CSE, numpy.linalg.solve), built in a fresh process under a time budget; DOP853 is
     scipy's best method at these errors (benchmarks/run.py's work-precision: RK45 needs many
     more steps, the implicit methods far more time);
   - solve_ivp DOP853 + nemc's C RHS (`Model.simulate(method="DOP853")`);
   - every native explicit method of nemc (`nemc.runtime.model.NATIVE_METHODS` without the implicit
     ones: nemc.DOP853, nemc.Vern9, and any added later);
   - heyoka's Taylor integrator (benchmarks/peers.py, in a worker process of its own, when
     installed), tol from the same ladder (each tol JIT-compiled once, untimed); on the double
     pendulum and the 4-link chain (the cells of issue 19's targets), in full mode also on
     the 8- and 16-link chains.
   The nemc and lambdify contenders of a cell are timed interleaved in this process (medians over
   rounds; a run longer than `cell_cap` is timed once); heyoka is timed in its worker (median of
   repeated runs). Speed-up = lambdify(cse) time / contender time; vs heyoka = heyoka time /
   contender time (above 1: faster than heyoka).
2. The book's 5.4 (stiff two-link arm) over [0, 15] at rtol 1e-8, atol 1e-10: nemc.Radau, solve_ivp
   Radau with nemc's C RHS and C Jacobian, nemc.DOP853; error = max over t = 0, 0.1, ..., 15.
3. Ensemble: simulate_many of 10,000 double pendulums (random angles, seeded) over [0, 10], 101
   output times, rtol 1e-8, each native explicit method on 1 thread and on all; checked against
   `simulate` on a few of the runs.
Reference (per system): nemc.Vern9 at rtol 10^-13.5, atol 1e-3 x rtol; checked against itself at
rtol 1e-13 and against scipy's DOP853 with nemc's C RHS at the tight tolerances (another method,
another implementation): both differences are recorded.
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
import peers  # noqa: E402
from baseline import LABELS, build_baselines  # noqa: E402
from common import ROOT, fmt_time, spread  # noqa: E402

PENDULUM = ("double_pendulum", ROOT / "examples" / "double_pendulum.yaml", (0.0, 20.0))
ARM = ROOT / "examples" / "two_link_robot_arm.yaml"
ARM_SPAN, ARM_TOL = (0.0, 15.0), (1e-8, 1e-10)
CHAIN_SPAN = (0.0, 5.0)
LADDER = tuple(10.0 ** (-k / 4) for k in range(12, 55))  # rtol 1e-3 ... 10^-13.5
REFERENCE_RTOL, SELF_CHECK_RTOL = LADDER[-1], 1e-13
REFERENCE_METHOD = "nemc.Vern9"
ATOL_FACTOR = 1e-3
LAMBDIFY = f"solve_ivp DOP853 + {LABELS['cse']}"
SCIPY_C = "solve_ivp DOP853 + nemc C RHS"
HEYOKA = "heyoka taylor_adaptive"
SCIPY_FOLLOWS = "nemc.DOP853"  # solve_ivp DOP853's ladder search starts one step above its rtol

Solver = Callable[[float], tuple[np.ndarray, int]]  # rtol -> (y at the output times, nfev)


@dataclass(frozen=True)
class Config:
    mode: str
    chain_ns: tuple[int, ...]
    targets: tuple[float, ...]
    rounds: int
    sample_seconds: float
    cell_cap: float  # a contender whose run takes longer is timed once
    baseline_timeout: float
    heyoka_systems: tuple[str, ...]  # heyoka runs on these (when installed)
    peer_timeout: float
    ensemble_runs: int


MODES = {
    # smoke: its budgets only guard against a hang (a test runs it, on machines of any load)
    "smoke": Config("smoke", (), (1e-6,), 1, 0.01, 1.0, 600.0, ("double_pendulum",), 600.0, 100),
    "quick": Config("quick", (4, 8), (1e-6, 1e-9, 1e-12), 3, 0.05, 2.0, 60.0,
                    ("double_pendulum", "chain4"), 120.0, 1000),
    "full": Config("full", (4, 8, 16), (1e-6, 1e-9, 1e-12), 5, 0.1, 10.0, 300.0,
                   ("double_pendulum", "chain4", "chain8", "chain16"), 600.0, 10000),
}


# -- runs ---------------------------------------------------------------------------------------


def nemc_solver(model, method: str, span, times) -> Solver:
    """Model.simulate with METHOD (native, or scipy's with nemc's C RHS and Jacobian)."""
    y0 = model.initial_state()

    def solve(rtol: float) -> tuple[np.ndarray, int]:
        res = model.simulate(span, y0, method=method, rtol=rtol, atol=rtol * ATOL_FACTOR,
                             t_eval=times)
        return (res.y if res.success else None), res.nfev

    return solve


def lambdify_solver(rhs, model, span, times) -> Solver:
    from scipy.integrate import solve_ivp

    y0 = model.initial_state()

    def solve(rtol: float) -> tuple[np.ndarray, int]:
        sol = solve_ivp(rhs, span, y0, method="DOP853", rtol=rtol, atol=rtol * ATOL_FACTOR,
                        t_eval=times)
        return (sol.y if sol.success else None), sol.nfev

    return solve


def error_of(y: np.ndarray | None, ref: np.ndarray) -> float:
    return float(np.max(np.abs(y - ref))) if y is not None else math.inf


def reference(model, span, times) -> dict[str, Any]:
    """The tight solution at TIMES, and its differences to two checks."""
    ref, _ = nemc_solver(model, REFERENCE_METHOD, span, times)(REFERENCE_RTOL)
    looser, _ = nemc_solver(model, REFERENCE_METHOD, span, times)(SELF_CHECK_RTOL)
    scipy_y, _ = nemc_solver(model, "DOP853", span, times)(REFERENCE_RTOL)
    record = {"method": REFERENCE_METHOD, "rtol": REFERENCE_RTOL,
              "atol": REFERENCE_RTOL * ATOL_FACTOR, "y": ref,
              "self_check": f"{REFERENCE_METHOD} at rtol {SELF_CHECK_RTOL:g}",
              "self_check_difference": error_of(looser, ref),
              "cross_check": "solve_ivp DOP853 + nemc C RHS at the same tolerances",
              "cross_check_difference": error_of(scipy_y, ref)}
    print(f"  reference: {record['self_check']} differs by "
          f"{record['self_check_difference']:.1e}, {record['cross_check']} by "
          f"{record['cross_check_difference']:.1e}", flush=True)
    return record


@dataclass
class Found:
    """The loosest rtol of the ladder reaching a target (or the best tried when none did)."""

    rtol: float
    error: float
    nfev: int
    seconds: float  # of that search run
    reached: bool


def loosest_rtol(solve: Solver, ref: np.ndarray, target: float, start: int = 0,
                 give_up: float = math.inf) -> Found:
    """Walk down the ladder from LADDER[start] until the error is at most the target; stop early
    when one run takes longer than `give_up` seconds (the best run so far is returned)."""
    best: Found | None = None
    for rtol in LADDER[start:]:
        seconds, (y, nfev) = common.timed(lambda r=rtol: solve(r))
        found = Found(rtol, error_of(y, ref), int(nfev), seconds, False)
        if found.error <= target:
            found.reached = True
            return found
        if best is None or found.error < best.error:
            best = found
        if seconds > give_up:
            break
    assert best is not None
    return best


def time_contenders(solvers: dict[str, Solver], found: dict[str, Found],
                    config: Config) -> dict[str, dict[str, Any]]:
    """Interleaved medians at each contender's rtol; runs over cell_cap timed once."""
    def calls(slow: bool) -> dict[str, tuple[Callable[[], Any], int]]:
        return {name: (lambda s=solvers[name], r=f.rtol: s(r), 1) for name, f in found.items()
                if (f.seconds > config.cell_cap) == slow}

    times = {}
    for slow, rounds in ((False, config.rounds), (True, 1)):
        if calls(slow):
            times.update(common.interleaved(calls(slow), rounds, config.sample_seconds))
    return times


# -- 1. equal error -----------------------------------------------------------------------------


def contenders(model, baselines, span, times) -> dict[str, Solver]:
    solvers = {}
    if LABELS["cse"] in baselines.rhs:
        solvers[LAMBDIFY] = lambdify_solver(baselines.rhs[LABELS["cse"]], model, span, times)
    solvers[SCIPY_C] = nemc_solver(model, "DOP853", span, times)
    for method in common.native_methods(explicit_only=True):
        solvers[method] = nemc_solver(model, method, span, times)
    return solvers


def search_all(solvers: dict[str, Solver], ref: np.ndarray, target: float,
               previous: dict[str, Found], config: Config) -> dict[str, Found]:
    """Each contender's loosest rtol for the target: native methods from the ladder's start (or
    the looser target's rtol), solve_ivp DOP853 from one step above nemc.DOP853's rtol."""
    found: dict[str, Found] = {}
    order = [n for n in solvers if n.startswith("nemc.")] + \
        [n for n in solvers if not n.startswith("nemc.")]
    for name in order:
        start = LADDER.index(previous[name].rtol) if name in previous else 0
        if name in (LAMBDIFY, SCIPY_C) and SCIPY_FOLLOWS in found:
            start = max(start, LADDER.index(found[SCIPY_FOLLOWS].rtol) - 1)
        # smoke mode (tests/test_bench_smoke.py): the ladder never gives up by the clock, so
        # that what it finds does not depend on the machine's load (a first run that builds
        # nemc.Taylor's code took over 5 s on a busy machine)
        give_up = math.inf if config.mode == "smoke" else config.cell_cap * 5
        found[name] = loosest_rtol(solvers[name], ref, target, start, give_up)
    return found


def equal_error_rows(system: str, model, path: Path, baselines, span,
                     config: Config) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    times = list(span)  # y(t0) = y0 exactly for every contender: the error is the final one
    ref = reference(model, span, times)
    solvers = contenders(model, baselines, span, times)
    rows, previous = [], {}
    for target in sorted(config.targets, reverse=True):
        found = search_all(solvers, ref["y"], target, previous, config)
        previous = found
        timings = time_contenders(solvers, found, config)
        for name, f in ((n, found[n]) for n in solvers):
            rows.append({"section": "equal error", "system": system, "t_span": list(span),
                         "target_error": target, "contender": name, "rtol": f.rtol,
                         "atol": f.rtol * ATOL_FACTOR, "error": f.error, "reached": f.reached,
                         "nfev": f.nfev, **timings[name]})
        print(f"  target {target:g}: " + ", ".join(
            f"{n} {fmt_time(timings[n]['median'])} (rtol {f.rtol:.2g})" for n, f in found.items()),
            flush=True)
    return rows, {k: v for k, v in ref.items() if k != "y"} | {"y": ref["y"].tolist()}


def heyoka_rows(system: str, path: Path, span, ref_y: list[list[float]],
                config: Config) -> tuple[list[dict[str, Any]], str]:
    """heyoka in a worker process over the ladder: per target its loosest tol reaching it."""
    with tempfile.TemporaryDirectory(prefix="nemc-bench-native-") as folder:
        ref_file = Path(folder) / "reference.json"
        ref_file.write_text(json.dumps({"t": list(span), "y": ref_y}))
        start = max(t for t in config.targets) * 100
        spec = {"peer": "heyoka", "path": str(path), "reference_file": str(ref_file),
                "rtols": [r for r in LADDER if r <= start * (1 + 1e-9)],
                "stop_below": min(config.targets), "rounds": config.rounds,
                "sample_seconds": config.sample_seconds, "repeats": max(config.rounds, 3),
                "cell_cap": config.cell_cap}
        run = peers.run_worker(spec, config.peer_timeout)
    if "failure" in run:
        return [], f"heyoka on {system}: {run['failure']}"
    rows = []
    tried = [r for r in run.get("work_precision", []) if r["seconds"]]
    for target in sorted(config.targets, reverse=True):
        reaching = [r for r in tried if r["error"] is not None and r["error"] <= target]
        best = max(reaching, key=lambda r: r["rtol"], default=None) or \
            min(tried, key=lambda r: r["error"] if r["error"] is not None else math.inf,
                default=None)
        if best is None:
            continue
        rows.append({"section": "equal error", "system": system, "t_span": list(span),
                     "target_error": target, "contender": HEYOKA, "rtol": best["rtol"],
                     "atol": None, "error": best["error"], "reached": best in reaching,
                     "nfev": None, **best["seconds"]})
    build = sum(v for k, v in run["build_seconds"].items())
    edge = any(r["rtol"] == spec["rtols"][0] and r["reached"] for r in rows)
    return rows, (f"heyoka on {system}: {len(tried)} tolerances tried in its worker process "
                  f"(wall {run['wall_seconds']:.0f} s, JIT builds {build:.1f} s, untimed); RHS "
                  f"agrees with nemc's to {run['agreement']:.1e} (relative)"
                  + ("; a target was reached at the loosest tol tried (a looser one might be "
                     "faster)" if edge else ""))


def add_ratios(rows: list[dict[str, Any]]) -> None:
    """speedup_vs_lambdify and vs_heyoka of every row, against the same system and target."""
    def base(row: dict[str, Any], contender: str) -> float | None:
        return next((r["median"] for r in rows if r["contender"] == contender
                     and r["system"] == row["system"]
                     and r["target_error"] == row["target_error"]), None)

    for row in rows:
        lam, hey = base(row, LAMBDIFY), base(row, HEYOKA)
        row["speedup_vs_lambdify"] = lam / row["median"] if lam else None
        row["vs_heyoka"] = hey / row["median"] if hey else None


# -- 2. the book's 5.4 --------------------------------------------------------------------------


def arm_rows(config: Config) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    import nemc

    model = nemc.compile(ARM)
    times = np.linspace(ARM_SPAN[0], ARM_SPAN[1], 151)  # the arm settles: worst error over time
    ref = reference(model, ARM_SPAN, times)
    rtol, atol = ARM_TOL
    y0 = model.initial_state()
    methods = {"nemc.Radau": "nemc.Radau", "solve_ivp Radau + nemc C RHS, C Jacobian": "Radau",
               "nemc.DOP853": "nemc.DOP853"}

    def solver(method: str) -> Callable[[], Any]:
        return lambda: model.simulate(ARM_SPAN, y0, method=method, rtol=rtol, atol=atol,
                                      t_eval=times)

    runs = {name: solver(method) for name, method in methods.items()}
    results = {name: run() for name, run in runs.items()}  # first: builds the C Jacobian, untimed
    timings = common.interleaved({n: (run, 1) for n, run in runs.items()}, config.rounds,
                                 config.sample_seconds)
    base = timings["solve_ivp Radau + nemc C RHS, C Jacobian"]["median"]
    rows = []
    for name, res in results.items():
        rows.append({"section": "5.4", "system": "5.4 two-link arm", "t_span": list(ARM_SPAN),
                     "contender": name, "rtol": rtol, "atol": atol,
                     "error": error_of(res.y if res.success else None, ref["y"]),
                     "nfev": int(res.nfev), **timings[name],
                     "speedup_vs_scipy_radau": base / timings[name]["median"]})
    return rows, {k: v for k, v in ref.items() if k != "y"}


# -- 3. ensemble --------------------------------------------------------------------------------


def ensemble_rows(config: Config) -> list[dict[str, Any]]:
    import nemc

    model = nemc.compile(PENDULUM[1])
    count, span, times = config.ensemble_runs, (0.0, 10.0), np.linspace(0.0, 10.0, 101)
    rng = np.random.default_rng(0)
    y0s = np.zeros((count, model.n_state))
    y0s[:, 0], y0s[:, 2] = rng.uniform(-1.5, 1.5, count), rng.uniform(-1.5, 1.5, count)
    rows = []
    for method in common.native_methods(explicit_only=True):
        check = [0, count // 2, count - 1]
        singles = [model.simulate(span, y0s[k], method=method, rtol=1e-8, atol=1e-10,
                                  t_eval=times).y for k in check]
        model.simulate_many(y0s[:8], t_span=span, t_eval=times, method=method, rtol=1e-8,
                            atol=1e-10)  # warm: builds the part it runs (Taylor's lanes) untimed
        for threads in sorted({1, os.cpu_count() or 1}):
            seconds, res = common.timed(lambda m=method, n=threads: model.simulate_many(
                y0s, t_span=span, t_eval=times, method=m, rtol=1e-8, atol=1e-10, threads=n))
            difference = max(error_of(res.y[k], y) for k, y in zip(check, singles))
            rows.append({"section": "ensemble",
                         "system": f"{count} double pendulums, 101 times", "t_span": list(span),
                         "contender": f"simulate_many {method}, {threads} thread(s)",
                         "rtol": 1e-8, "atol": 1e-10, "runs": count, "threads": threads,
                         "all_succeeded": bool(res.success.all()),
                         "nfev": int(res.nfev.sum()), "error": difference,
                         "error_is": "max difference to simulate() on 3 of the runs",
                         **common.summary([seconds]), "per_run": seconds / count})
            print(f"  {rows[-1]['contender']}: {fmt_time(seconds)}", flush=True)
    return rows


# -- the run ------------------------------------------------------------------------------------


def systems(config: Config, folder: Path) -> list[tuple[str, Path, tuple[float, float]]]:
    chains = common.write_chains(config.chain_ns, folder)
    return [PENDULUM] + [(name, path, CHAIN_SPAN) for name, path in chains.items()]


def run_system(name: str, path: Path, span, config: Config, result: dict[str, Any]) -> None:
    import nemc

    print(f"{name} over {list(span)}:", flush=True)
    model = nemc.compile(path)
    baselines = build_baselines(path, ("cse",), config.baseline_timeout)
    result["notes"] += [f"{name}: {label} {why}" for label, why in baselines.notes.items()]
    result["setup"][name] = {"baseline": baselines.seconds, "equations": baselines.equations}
    rows, ref = equal_error_rows(name, model, path, baselines, span, config)
    result["references"][name] = ref
    if name in config.heyoka_systems and result["peers"]["heyoka"]:
        print("  heyoka (worker process):", flush=True)
        peer_rows, note = heyoka_rows(name, path, span, ref["y"], config)
        rows += peer_rows
        result["notes"].append(note)
    add_ratios(rows)
    result["rows"] += sorted(rows, key=lambda r: -r["target_error"])  # stable: contender order


def run(config: Config) -> dict[str, Any]:
    result: dict[str, Any] = {"environment": common.environment(config.mode),
                              "config": asdict(config), "ladder": list(LADDER),
                              "peers": {"heyoka": peers.installed()["heyoka"]}, "setup": {},
                              "references": {}, "rows": [], "notes": []}
    if not result["peers"]["heyoka"]:
        result["notes"].append("heyoka: skipped: not installed (pip install '.[peers]')")
    start = time.perf_counter()
    with (tempfile.TemporaryDirectory(prefix="nemc-bench-native-") as folder,
          common.one_cpu(result["environment"])):  # heyoka's worker on nemc's CPU
        for name, path, span in systems(config, Path(folder)):
            run_system(name, path, span, config, result)
    print("5.4 two-link arm:", flush=True)
    arm, result["references"]["5.4 two-link arm"] = arm_rows(config)
    result["rows"] += arm
    print("ensemble:", flush=True)
    result["rows"] += ensemble_rows(config)
    common.finish_environment(result["environment"], start)
    return result


# -- output -------------------------------------------------------------------------------------


def ratio(value: float | None) -> str:
    if value is None:
        return "–"
    return f"**{value:.0f}x**" if value >= 10 else f"**{value:.2g}x**"


def md_equal_error(result: dict[str, Any]) -> list[str]:
    rows = [r for r in result["rows"] if r["section"] == "equal error"]
    heyoka = any(r["contender"] == HEYOKA for r in rows)
    lines = ["## 1. Equal final error", "",
             "Each contender at the loosest rtol of the ladder (quarter decades, atol = rtol x "
             "1e-3) whose final error is at most the target (*not reached*: its best error). "
             "Time: median (min–max) of interleaved rounds in this process (heyoka: repeated "
             "runs in its worker process). Speed-up: lambdify(cse)'s time / this time"
             + ("; vs heyoka: heyoka's time / this time (above 1: faster than heyoka)."
                if heyoka else "."), ""]
    for system in dict.fromkeys(r["system"] for r in rows):
        ref = result["references"][system]
        span = next(r["t_span"] for r in rows if r["system"] == system)
        lines += [f"### {system} over {span}", "",
                  f"Reference {ref['method']} rtol {ref['rtol']:.2g}: {ref['self_check']} "
                  f"differs by {ref['self_check_difference']:.1e}, {ref['cross_check']} by "
                  f"{ref['cross_check_difference']:.1e}.", "",
                  "| target | contender | rtol | final error | nfev | time | speed-up vs "
                  "lambdify(cse) |" + (" vs heyoka |" if heyoka else ""),
                  "|" + " --- |" * (7 + heyoka)]
        for r in (r for r in rows if r["system"] == system):
            error = f"{r['error']:.1e}" + ("" if r["reached"] else " *not reached*")
            lines.append(f"| {r['target_error']:.0e} | {r['contender']} | {r['rtol']:.2g} | "
                         f"{error} | {r['nfev'] if r['nfev'] is not None else '–'} | "
                         f"{spread(r)} | {ratio(r['speedup_vs_lambdify'])} |"
                         + (f" {ratio(r['vs_heyoka'])} |" if heyoka else ""))
        lines.append("")
    return lines


def md_arm(result: dict[str, Any]) -> list[str]:
    ref = result["references"]["5.4 two-link arm"]
    lines = ["## 2. The book's 5.4 (stiff two-link arm) over [0, 15], rtol 1e-8, atol 1e-10", "",
             f"Error: max over t = 0, 0.1, ..., 15 against {ref['method']} at rtol "
             f"{ref['rtol']:.2g} ({ref['self_check']}: {ref['self_check_difference']:.1e}; "
             f"{ref['cross_check']}: {ref['cross_check_difference']:.1e}). Speed-up: solve_ivp "
             "Radau's time / this time.", "",
             "| contender | error | nfev | time | speed-up |", "| --- | --- | --- | --- | --- |"]
    lines += [f"| {r['contender']} | {r['error']:.1e} | {r['nfev']} | {spread(r)} | "
              f"{ratio(r['speedup_vs_scipy_radau'])} |"
              for r in result["rows"] if r["section"] == "5.4"]
    return lines + [""]


def md_ensemble(result: dict[str, Any]) -> list[str]:
    rows = [r for r in result["rows"] if r["section"] == "ensemble"]
    lines = ["## 3. Ensemble: simulate_many over [0, 10], rtol 1e-8, atol 1e-10", "",
             "Random initial angles (seeded); one timed call each. Check: max difference to "
             "`simulate` on 3 of the runs.", "",
             "| runs | contender | all succeeded | total nfev | time | per run | check |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    lines += [f"| {r['runs']} | {r['contender']} | {r['all_succeeded']} | {r['nfev']} | "
              f"{fmt_time(r['median'])} | {fmt_time(r['per_run'])} | {r['error']:.1e} |"
              for r in rows]
    return lines + [""]


def markdown(result: dict[str, Any]) -> str:
    lines = ["# nemc native integrators at equal error", ""]
    lines += common.md_environment(result["environment"]) + [""]
    lines += md_equal_error(result) + md_arm(result) + md_ensemble(result)
    if result["notes"]:
        lines += ["## Notes", ""] + [f"- {n}" for n in result["notes"]] + [""]
    return "\n".join(lines)


def parse_args(argv: Sequence[str]):
    parser = common.mode_parser(
        __doc__.splitlines()[0],
        "double pendulum and chain8, heyoka on the double pendulum, 1000-run ensemble; < 2 min",
        "double pendulum at 1e-6 only, 100-run ensemble (seconds); a temporary folder",
    )
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    config = MODES[mode] if args.sizes is None else replace(MODES[mode], chain_ns=args.sizes)
    print(f"nemc native integrators benchmark, {mode} mode", flush=True)
    result = run(config)
    folder = common.results_folder(args, "nemc-bench-native-")
    folder.mkdir(parents=True, exist_ok=True)
    common.write_json(result, folder / "native-latest.json")
    text = markdown(result)
    (folder / "native-latest.md").write_text(text)
    print(text)
    print(f"written: {folder / 'native-latest.json'}, {folder / 'native-latest.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
