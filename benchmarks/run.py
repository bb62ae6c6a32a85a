"""nemc's benchmark suite: RHS cost, work-precision, compile phases, vs sympy lambdify and peers.

Run: `nemc bench [--quick]`, `make bench`, or `python benchmarks/run.py [--quick | --smoke]
[--sizes 2,4,8] [--out DIR]`.

Every contender is measured in the same run, interleaved with the others and repeated; tables give
medians with the min-max over rounds, and ratios are only ever formed between numbers of one run.
The baseline is sympy `lambdify` of M(q) and f(t, q, dq) (benchmarks/baseline.py, built in a fresh
process under a time budget), with M qdd = f solved by `numpy.linalg.solve`. Peers (PyDy, JiTCODE,
heyoka) run in worker processes of their own (benchmarks/peers.py) when installed.
Results: benchmarks/results/ (JSON, Markdown, PNG); see benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
from baseline import LABELS, Baselines, build_baselines  # noqa: E402
from common import (  # noqa: E402
    GENERATED,
    RESULTS,
    ROOT,
    StageFailed,
    fmt_time,
    interleaved,
    native_methods,
    spread,
    summary,
    timed,
)

from nemc.runtime.runs import interrupts_raise  # noqa: E402
from nemc.runtime.scipy_run import integrator_jacobian  # noqa: E402

DOUBLE_PENDULUM = ROOT / "examples" / "double_pendulum.yaml"
BOOK_SYSTEMS = {
    "double_pendulum": DOUBLE_PENDULUM,
    "compound_pendulum": ROOT / "examples" / "compound_pendulum.yaml",
    "robot_arm": ROOT / "examples" / "robot_arm.yaml",
    "two_link_robot_arm": ROOT / "examples" / "two_link_robot_arm.yaml",
}
REFERENCE_TOL = (1e-13, 1e-15)  # DOP853 rtol, atol of the reference solutions
CROSS_CHECK_METHOD = "LSODA"  # the second method of the reference (analytic Jacobian)
REFERENCE_CACHE = GENERATED / "bench-references"
SCIPY_WP_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
IMPLICIT = ("Radau", "BDF", "LSODA")
BASELINE = LABELS["cse"]
NEMC_RHS = ("nemc model.rhs", "nemc closure", "nemc rhs_many (per state)")
RHS_CONTENDERS = NEMC_RHS + tuple(LABELS.values())
ERROR_TARGETS = (1e-9, 1e-12)
NEAR = 5.0  # "an error near the target": at most NEAR x target


@dataclass(frozen=True)
class Config:
    """What one mode measures. Budgets are seconds; a stage past its budget is skipped and the
    reason recorded in the notes, never waited on."""

    mode: str
    book_systems: tuple[str, ...]
    chain_ns: tuple[int, ...]  # chains of uniform rods for RHS cost and compile phases
    rhs_rounds: int
    sample_seconds: float  # each timeit sample runs its loop for about this long
    many_states: int
    baseline_variants: tuple[str, ...]
    baseline_timeout: float  # derive + lambdify of all variants of one system
    explicit_max_n: int  # the explicit symbolic RHS only up to this many coordinates
    wp_systems: tuple[str, ...]
    wp_methods: tuple[str, ...]  # scipy methods; nemc's native methods are added when present
    wp_rtols: tuple[float, ...]
    wp_points: int  # t_eval points of the trajectory error
    wp_repeats: int
    wp_cell_cap: float  # a run longer than this is not repeated
    wp_skip_after: float  # a tighter rtol is skipped when the looser one took longer than this
    cached_repeats: int
    compile_timeout: float  # a cold compile past this (measured or predicted) is skipped
    runtime_budget: float  # no runtime benchmarks for a system whose cold compile took longer
    peers: bool
    peer_timeout: float  # one peer on one system (build, check, RHS cost, work-precision)


MODES = {
    # smoke: its budgets only guard against a hang (a test runs it, on machines of any load)
    "smoke": Config(
        "smoke", ("double_pendulum",), (2,), 2, 0.005, 64, ("cse",), 600.0, 2, ("double_pendulum",),
        ("RK45",), (1e-6,), 11, 1, 5.0, 600.0, 1, 600.0, 600.0, False, 600.0,
    ),
    "quick": Config(
        "quick", ("double_pendulum",), (2, 4, 8), 5, 0.02, 1000, ("cse", "plain", "explicit"),
        40.0, 4, ("double_pendulum",), ("RK45", "DOP853", "LSODA"), (1e-3, 1e-6, 1e-9, 1e-12), 21,
        3, 2.0, 2.0, 3, 60.0, 30.0, False, 60.0,
    ),
    "full": Config(
        "full", tuple(BOOK_SYSTEMS), (2, 4, 8, 16, 32), 5, 0.05, 1000,
        ("cse", "plain", "explicit"), 300.0, 8, ("double_pendulum", "chain8", "chain32"),
        SCIPY_WP_METHODS, (1e-3, 1e-6, 1e-9, 1e-12), 101, 5, 8.0, 10.0, 5, 300.0, 120.0, True,
        600.0,
    ),
}


# -- 1. RHS cost --------------------------------------------------------------------------------


def test_states(model, count: int, seed: int = 1) -> np.ndarray:
    """(n_state, count), a view of C-contiguous rows: rhs_many times its C loop, not a copy."""
    return common.random_states(model.n_state, count, seed)


def rhs_contenders(model, baselines: Baselines, config: Config) -> dict[str, tuple[Callable, int]]:
    states = test_states(model, config.many_states)
    y = np.ascontiguousarray(states[:, 0])
    closure = model.compiled.integrator_rhs(model.parameter_vector())
    calls = {
        "nemc model.rhs": (partial(model.rhs, 0.0, y), 1),
        "nemc closure": (partial(closure, 0.0, y), 1),
        "nemc rhs_many (per state)": (partial(model.rhs_many, 0.0, states), states.shape[1]),
    }
    calls.update({name: (partial(rhs, 0.0, y), 1) for name, rhs in baselines.rhs.items()})
    return calls


def rhs_agreement(model, baselines: Baselines) -> dict[str, float]:
    """Largest relative difference to nemc's RHS over a few states (the contenders must agree)."""
    states = test_states(model, 16, seed=2)
    ours = model.rhs_many(0.0, states)
    scale = max(1.0, float(np.max(np.abs(ours))))
    diffs = {}
    for name, rhs in baselines.rhs.items():
        theirs = np.column_stack([rhs(0.0, states[:, k]) for k in range(states.shape[1])])
        diffs[name] = float(np.max(np.abs(theirs - ours)) / scale)
    closure = model.compiled.integrator_rhs(model.parameter_vector())
    diffs["rhs_many vs closure"] = float(np.max(np.abs(ours[:, 0] - closure(0.0, states[:, 0]))))
    return diffs


def bench_rhs(name: str, model, baselines: Baselines, config: Config) -> dict[str, Any]:
    timings = interleaved(rhs_contenders(model, baselines, config), config.rhs_rounds,
                          config.sample_seconds)
    base = timings.get(BASELINE, {}).get("median")
    for t in timings.values():
        t["ratio_vs_lambdify_cse"] = base / t["median"] if base else None
    print(f"  rhs {name}: " + ", ".join(f"{k} {fmt_time(v['median'])}"
                                        for k, v in timings.items()), flush=True)
    return {"n_state": model.n_state, "per_call_seconds": timings,
            "agreement": rhs_agreement(model, baselines), "not_measured": baselines.notes,
            "baseline_equations": baselines.equations}


# -- 2. work-precision --------------------------------------------------------------------------


def max_error(y: np.ndarray, reference: np.ndarray) -> float:
    return float(np.max(np.abs(np.asarray(y) - reference)))


def reference_key(path: Path, span, t_eval: np.ndarray) -> str:
    digest = hashlib.sha256(path.read_bytes())
    digest.update(json.dumps([list(span), t_eval.tolist(), REFERENCE_TOL,
                              CROSS_CHECK_METHOD]).encode())
    return digest.hexdigest()[:24]


def reference(model, path: Path, span, t_eval: np.ndarray) -> dict[str, Any]:
    """DOP853 at rtol 1e-13 with nemc's RHS, cross-checked by LSODA at the same tolerances;
    cached on disk (generated/bench-references/, keyed by the YAML text, span and times)."""
    file = REFERENCE_CACHE / f"{path.stem}-{reference_key(path, span, t_eval)}.json"
    if file.is_file():
        record = json.loads(file.read_text())
        record.update(cached=f"cached: {file.relative_to(ROOT)}", file=str(file))
        return record
    rtol, atol = REFERENCE_TOL
    y0 = model.initial_state()
    seconds, ours = timed(lambda: model.simulate(span, y0, method="DOP853", rtol=rtol, atol=atol,
                                                 t_eval=t_eval))
    check_seconds, check = timed(lambda: model.simulate(
        span, y0, method=CROSS_CHECK_METHOD, rtol=rtol, atol=atol, t_eval=t_eval))
    record = {"y": ours.y.tolist(), "t": t_eval.tolist(), "method": "DOP853", "rtol": rtol,
              "atol": atol, "nfev": ours.nfev, "seconds": seconds,
              "cross_check": f"{CROSS_CHECK_METHOD} (same tolerances, analytic Jacobian)",
              "cross_check_seconds": check_seconds,
              "cross_check_final_difference": max_error(check.y[:, -1], ours.y[:, -1]),
              "cross_check_trajectory_difference": max_error(check.y, ours.y)}
    REFERENCE_CACHE.mkdir(parents=True, exist_ok=True)
    file.write_text(json.dumps(record))
    record.update(cached="computed in this run", file=str(file))
    return record


def wp_runners(model, baselines: Baselines, span, y0, t_eval, method: str, rtol: float):
    """The contenders of one cell: nemc's simulate and, for scipy methods, solve_ivp with the
    lambdify(cse) RHS (finite-difference Jacobian for the implicit methods)."""
    from scipy.integrate import solve_ivp

    atol = rtol * 1e-3
    runners = {"nemc": lambda: model.simulate(span, y0, method=method, rtol=rtol, atol=atol,
                                              t_eval=t_eval)}
    if BASELINE in baselines.rhs and method in SCIPY_WP_METHODS:
        runners[BASELINE] = lambda: solve_ivp(baselines.rhs[BASELINE], span, y0, method=method,
                                              rtol=rtol, atol=atol, t_eval=t_eval)
    return runners


def warm_parts(model, methods: Sequence[str]) -> dict[str, float]:
    """nemc builds the C Jacobian (implicit methods) and nemc.Taylor's coefficients on first
    need: both are built here, before any timed run (their seconds are reported apart)."""
    seconds = {"jacobian": 0.0, "taylor": 0.0}
    if set(methods) & set(IMPLICIT):
        seconds["jacobian"], _ = timed(lambda: integrator_jacobian(model, model.parameter_vector()))
    if "nemc.Taylor" in methods:
        seconds["taylor"], _ = timed(lambda: model.compiled_with("taylor"))
    return seconds


def too_slow(records: dict[tuple, dict[str, Any]], method: str, rtol: float,
             config: Config) -> bool:
    """True when a looser rtol of this method already took longer than wp_skip_after."""
    return any(rec["times"][0] > config.wp_skip_after for (m, r, _), rec in records.items()
               if m == method and r > rtol)


def run_cell(record: dict[str, Any], run: Callable[[], Any], ref: dict[str, Any]) -> None:
    seconds, sol = timed(run)
    record["times"].append(seconds)
    ok = bool(sol.success) and np.shape(sol.y) == np.shape(ref["y"])
    record.update(
        success=ok, nfev=int(sol.nfev), njev=int(getattr(sol, "njev", 0)),
        error=max_error(sol.y[:, -1], ref["y"][:, -1]) if ok else None,
        trajectory_error=max_error(sol.y, ref["y"]) if ok else None,
    )


def work_precision_rounds(model, baselines: Baselines, span, reference_: dict[str, Any],
                          methods: Sequence[str], name: str,
                          config: Config) -> tuple[dict[tuple, dict], list[str]]:
    y0, t_eval = model.initial_state(), np.asarray(reference_["t"])
    ref = {"y": np.asarray(reference_["y"])}
    records: dict[tuple, dict[str, Any]] = {}
    skipped: list[str] = []
    for rep in range(config.wp_repeats):
        for method in methods:
            for rtol in sorted(config.wp_rtols, reverse=True):
                if rep == 0 and too_slow(records, method, rtol, config):
                    skipped.append(f"{name}: {method} rtol {rtol:g} and tighter skipped (a "
                                   f"looser rtol took over {config.wp_skip_after:g} s)")
                    break
                if rep > 0 and (method, rtol, "nemc") not in records:
                    break
                runners = wp_runners(model, baselines, span, y0, t_eval, method, rtol)
                order = list(runners) if rep % 2 == 0 else list(runners)[::-1]
                for contender in order:
                    record = records.setdefault((method, rtol, contender), {"times": []})
                    if rep > 0 and record["times"][-1] > config.wp_cell_cap:
                        continue
                    try:
                        run_cell(record, runners[contender], ref)
                    except Exception as error:  # noqa: BLE001 (a failing method is a result)
                        record.update(success=False, failure=f"{type(error).__name__}: {error}")
                        record["times"].append(float("nan"))
        print(f"  work-precision {name}: round {rep + 1}/{config.wp_repeats}", flush=True)
    return records, skipped


def bench_work_precision(name: str, path: Path, model, baselines: Baselines,
                         config: Config) -> dict[str, Any]:
    span = (0.0, 20.0) if name == "double_pendulum" else (0.0, 5.0)
    t_eval = np.linspace(span[0], span[1], config.wp_points)
    methods = tuple(config.wp_methods) + native_methods()
    first_need = warm_parts(model, methods)
    ref = reference(model, path, span, t_eval)
    records, skipped = work_precision_rounds(model, baselines, span, ref, methods, name, config)
    rows = []
    for (method, rtol, contender), rec in records.items():
        times = [t for t in rec.pop("times") if t == t]
        rows.append({"method": method, "rtol": rtol, "atol": rtol * 1e-3, "contender": contender,
                     "seconds": summary(times) if times else None, **rec})
    ref_summary = {k: v for k, v in ref.items() if k not in ("y", "t")}
    return {"t_span": list(span), "t_eval_points": config.wp_points, "methods": list(methods),
            "reference": ref_summary, "rows": rows, "skipped": skipped,
            "first_need_seconds": first_need}


def best_at(rows: Sequence[dict[str, Any]], target: float) -> dict[str, Any] | None:
    """The fastest run with final error near the target (at most NEAR x target)."""
    fit = [r for r in rows if r.get("seconds") and r.get("error") is not None
           and r["error"] <= NEAR * target]
    return min(fit, key=lambda r: r["seconds"]["median"], default=None)


def contender_table(wp: dict[str, Any], peer_rows: Sequence[dict[str, Any]]) -> list[dict]:
    """Per contender (nemc per method, lambdify(cse), each peer) the fastest run reaching each
    error target."""
    groups: dict[str, list[dict[str, Any]]] = {}
    for row in wp["rows"]:
        label = f"nemc {row['method']}" if row["contender"] == "nemc" else \
            f"solve_ivp {row['method']} + {row['contender']}"
        groups.setdefault(label, []).append(row)
    for row in peer_rows:
        groups.setdefault(row["contender"], []).append(row)
    table = []
    for label, rows in groups.items():
        for target in ERROR_TARGETS:
            best = best_at(rows, target)
            table.append({"contender": label, "target": target,
                          "best": None if best is None else
                          {k: best.get(k) for k in ("method", "rtol", "seconds", "error",
                                                    "trajectory_error", "nfev")}})
    return table


# -- the run ------------------------------------------------------------------------------------


def load_model(path: Path):
    import nemc

    return timed(lambda: nemc.compile(path))


def run_system(name: str, path: Path, config: Config, result: dict[str, Any]) -> None:
    """Everything measured on one system in this process, after its build exists."""
    wp = name in config.wp_systems
    seconds, model = load_model(path)
    result["setup"][name] = {"nemc.compile (cached)": seconds}
    variants = config.baseline_variants if name in config.book_systems or \
        common.chain_size(name) in config.chain_ns else ("cse",)
    if model.n_state // 2 > config.explicit_max_n and "explicit" in variants:
        variants = tuple(v for v in variants if v != "explicit")
        result["notes"].append(f"{name}: {LABELS['explicit']} not tried: over "
                               f"{config.explicit_max_n} coordinates in this mode (FIELD-NOTES: "
                               "infeasible at 8 links)")
    baselines = build_baselines(path, variants, config.baseline_timeout)
    result["setup"][name].update(baselines.seconds)
    for label, why in baselines.notes.items():
        result["notes"].append(f"{name}: {label} {why}")
    result["rhs"][name] = bench_rhs(name, model, baselines, config)
    if wp:
        wp_result = bench_work_precision(name, path, model, baselines, config)
        result["work_precision"][name] = wp_result
        result["notes"] += wp_result["skipped"]
        for part, seconds in wp_result["first_need_seconds"].items():
            result["setup"][name][f"{part} (first need)"] = seconds


def compile_step(name: str, path: Path, config: Config, result: dict[str, Any]) -> str:
    """Cold and cached compile of one system: 'ok', 'skip' (its runtime benchmarks) or 'stop'
    (this and larger chains: over the compile budget, measured or extrapolated)."""
    n = common.chain_size(name)
    known = [(common.chain_size(k), v["cold_total"]) for k, v in result["phases"].items()
             if common.chain_size(k)]
    guess = common.predicted_next(known, n) if n else None
    if guess is not None and guess > config.compile_timeout:
        result["notes"].append(
            f"{name}: skipped with larger chains: its cold compile would take about "
            f"{guess:.0f} s (extrapolated from the smaller chains), over the "
            f"{config.compile_timeout:.0f} s budget")
        return "stop"
    print(f"{name}: compile phases", flush=True)
    try:
        phases = common.compile_phases(path, config.compile_timeout, config.cached_repeats)
    except StageFailed as error:
        result["notes"].append(f"{name}: cold compile {error}; it and larger chains skipped")
        return "stop" if n else "skip"
    phases["cold"].pop("package", None)  # a temporary folder, gone
    result["phases"][name] = phases
    stages = ", ".join(f"{k} {v:.2f}" for k, v in phases["cold"]["timings"].items())
    print(f"  {stages} s; C {phases['cold']['c_bytes'] / 1e3:.0f} kB; cached load "
          f"{fmt_time(phases['cached_load']['median'])}", flush=True)
    if phases["cold_total"] > config.runtime_budget:
        result["notes"].append(f"{name}: cold compile took {phases['cold_total']:.0f} s, over "
                               f"the {config.runtime_budget:.0f} s runtime budget: runtime "
                               "benchmarks skipped (the baseline would derive again)")
        return "skip"
    return "ok"


def systems(config: Config, folder: Path) -> dict[str, Path]:
    """Name -> YAML path: the book's systems, then the chains in increasing size."""
    paths = {name: BOOK_SYSTEMS[name] for name in config.book_systems}
    ns = set(config.chain_ns) | {common.chain_size(s) for s in config.wp_systems
                                 if common.chain_size(s)}
    paths.update(common.write_chains(ns, folder))
    return paths


def run(config: Config) -> dict[str, Any]:
    import peers

    result: dict[str, Any] = {"environment": common.environment(config.mode),
                              "config": asdict(config), "setup": {}, "rhs": {},
                              "work_precision": {}, "phases": {}, "peers": {}, "notes": []}
    start = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory(prefix="nemc-bench-") as folder, interrupts_raise():
            for name, path in systems(config, Path(folder)).items():
                step = compile_step(name, path, config, result)
                if step == "stop":
                    break
                if step == "ok":
                    print(f"{name}: runtime", flush=True)
                    run_system(name, path, config, result)
            result["peers"] = peers.run_peers(DOUBLE_PENDULUM, result, config.peer_timeout) \
                if config.peers else peers.availability()
    except KeyboardInterrupt:  # keep what is measured: the results are written as they are
        result["interrupted"] = True
        result["notes"].append("interrupted (Ctrl-C): only what was measured until then")
        result["peers"] = result["peers"] or peers.availability()
    common.finish_environment(result["environment"], start)
    return result


# -- output -------------------------------------------------------------------------------------


def ratio(t: dict[str, Any]) -> str:
    return f", **{t['ratio_vs_lambdify_cse']:.1f}x**" if t.get("ratio_vs_lambdify_cse") else ""


def md_rhs(rhs: dict[str, Any]) -> list[str]:
    lines = ["## 1. RHS cost per call (median, min–max over rounds)", "",
             "Ratio: lambdify(cse) time / this contender's time (higher is faster). "
             "`rhs_many` is nemc's C loop over 1000 states (rows in place, no copy), per state: "
             "the C cost itself.", ""]
    lines += ["| system | states | " + " | ".join(RHS_CONTENDERS) + " |",
              "|" + " --- |" * (2 + len(RHS_CONTENDERS))]
    for name, r in rhs.items():
        cells = []
        for c in RHS_CONTENDERS:
            t = r["per_call_seconds"].get(c)
            cells.append("–" if t is None else f"{spread(t)}{ratio(t)}")
        lines.append(f"| {name} | {r['n_state']} | " + " | ".join(cells) + " |")
    lines += ["", "Agreement with nemc's RHS (max relative difference over 16 random states):", ""]
    lines += [f"- {n}: " + ", ".join(f"{k} {v:.1e}" for k, v in r["agreement"].items())
              for n, r in rhs.items()]
    missing = [f"- {n}: {k}: {v}" for n, r in rhs.items() for k, v in r["not_measured"].items()]
    if missing:
        lines += ["", "Not measured (–):", ""] + missing
    equations = {r["baseline_equations"] for r in rhs.values() if r["baseline_equations"]}
    return lines + ["", f"Baseline equations: {', '.join(sorted(equations))}.", ""]


def fmt_error(value: float | None) -> str:
    return "–" if value is None else f"{value:.1e}"


def md_wp_system(name: str, w: dict[str, Any]) -> list[str]:
    ref = w["reference"]
    lines = [f"### {name} over {w['t_span']}", "",
             f"Reference: DOP853 rtol {ref['rtol']:g}, atol {ref['atol']:g} with nemc's RHS "
             f"({ref['cached']}); {ref['cross_check']} differs by "
             f"{ref['cross_check_final_difference']:.1e} at the end, "
             f"{ref['cross_check_trajectory_difference']:.1e} over the trajectory: errors below "
             "that are not resolved.", "",
             "| method | rtol | nemc time | lambdify(cse) time | speedup | nemc error (end / "
             "trajectory) | lambdify error (end / trajectory) | nfev (nemc / lambdify) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    rows = {(r["method"], r["rtol"], r["contender"]): r for r in w["rows"]}
    for method, rtol, _ in [k for k in rows if k[2] == "nemc"]:
        a, b = rows[(method, rtol, "nemc")], rows.get((method, rtol, BASELINE))
        if not a.get("seconds"):
            lines.append(f"| {method} | {rtol:g} | failed: {a.get('failure', '?')} |" +
                         " – |" * 5)
            continue
        b_time = spread(b["seconds"]) if b and b.get("seconds") else "–"
        speed = (f"**{b['seconds']['median'] / a['seconds']['median']:.1f}x**"
                 if b and b.get("seconds") else "–")
        b_err = f"{fmt_error(b.get('error'))} / {fmt_error(b.get('trajectory_error'))}" \
            if b else "–"
        lines.append(f"| {method} | {rtol:g} | {spread(a['seconds'])} | {b_time} | {speed} | "
                     f"{fmt_error(a.get('error'))} / {fmt_error(a.get('trajectory_error'))} | "
                     f"{b_err} | {a.get('nfev')} / {b.get('nfev') if b else '–'} |")
    return lines + [""]


def md_work_precision(wp: dict[str, Any]) -> list[str]:
    lines = ["## 2. Work-precision (wall time of the whole solve against its error)", "",
             "Speedup: lambdify(cse) median / nemc median at the same method and tolerance. "
             "atol = rtol x 1e-3. Error: max abs difference to the reference at the end "
             "and over the trajectory (the t_eval points, the same for every contender).", ""]
    for name, w in wp.items():
        lines += md_wp_system(name, w)
    return lines


def md_contenders(name: str, table: Sequence[dict[str, Any]]) -> list[str]:
    lines = [f"### Fastest run reaching an error target: {name}", "",
             "Per contender, the fastest configuration of the sweep whose final error is near "
             f"the target (at most {NEAR:g}x it; – : none reached it). Ratio: lambdify(cse)'s "
             "best / this. Peers were timed in their own processes, in this run.", "",
             "| contender | " + " | ".join(f"error near {t:g}" for t in ERROR_TARGETS) + " |",
             "|" + " --- |" * (1 + len(ERROR_TARGETS))]
    base = {t: min((e["best"]["seconds"]["median"] for e in table if e["target"] == t
                    and e["best"] and BASELINE in e["contender"]), default=None)
            for t in ERROR_TARGETS}
    for contender in dict.fromkeys(e["contender"] for e in table):
        cells = []
        for t in ERROR_TARGETS:
            best = next(e["best"] for e in table if e["contender"] == contender
                        and e["target"] == t)
            if best is None:
                cells.append("–")
                continue
            rel = f", {base[t] / best['seconds']['median']:.1f}x" if base[t] else ""
            cells.append(f"{fmt_time(best['seconds']['median'])} (rtol {best['rtol']:g}, "
                         f"error {best['error']:.0e}{rel})")
        lines.append(f"| {contender} | " + " | ".join(cells) + " |")
    return lines + [""]


def md_phases(phases: dict[str, Any], setup: dict[str, Any]) -> list[str]:
    stages = ("validate", "derive", "optimize", "emit", "build", "load")
    lines = ["## 3. Compile phases (cold: fresh process, fresh NEMC_CACHE; seconds)", "",
             "| system | " + " | ".join(stages) + " | cold total | C source | cached: first "
             "compile call | cached: second call | cached: whole process |",
             "|" + " --- |" * (len(stages) + 6)]
    for name, p in phases.items():
        t = p["cold"]["timings"]
        cells = [f"{t[s]:.3f}" if s in t else "–" for s in stages]
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {p['cold_total']:.2f} | "
                     f"{p['cold']['c_bytes'] / 1e3:.0f} kB, {p['cold']['c_lines']} lines | "
                     f"{spread(p['cached_load'])} | {spread(p['cached_load_again'])} | "
                     f"{spread(p['cached_process_wall'])} |")
    lines += ["", "Set-up in the benchmark process (seconds; the lambdify baseline derives again "
              "in its own process):", ""]
    lines += [f"- {n}: " + ", ".join(f"{k} {v:.2f}" for k, v in s.items())
              for n, s in setup.items()]
    return lines + [""]


def markdown(result: dict[str, Any]) -> str:
    import peers

    lines = ["# nemc benchmark results", ""] + common.md_environment(result["environment"])
    lines += [""]
    lines += md_rhs(result["rhs"]) if result["rhs"] else []
    lines += md_work_precision(result["work_precision"]) if result["work_precision"] else []
    for name, w in result["work_precision"].items():
        peer_rows = result["peers"].get("work_precision", []) if name == "double_pendulum" \
            else []
        lines += md_contenders(name, contender_table(w, peer_rows))
    lines += md_phases(result["phases"], result["setup"]) if result["phases"] else []
    lines += peers.markdown(result["peers"])
    if result["notes"]:
        lines += ["## Notes", ""] + [f"- {n}" for n in result["notes"]] + [""]
    return "\n".join(lines)


def write_outputs(result: dict[str, Any], folder: Path, latest: bool) -> list[Path]:
    import plots

    name = f"run-{common.stamp()}-{result['environment']['mode']}"
    written = [folder / f"{name}.json", folder / ("latest.md" if latest else f"{name}.md")]
    common.write_json(result, written[0])
    written[1].write_text(markdown(result))
    if latest:
        shutil.copyfile(written[0], folder / "latest.json")
        written.append(folder / "latest.json")
    return written + plots.suite_plots(result, folder)


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = common.mode_parser(
        __doc__.splitlines()[0], "n in {2, 4, 8}; under 2 minutes",
        "a tiny subset (< 20 s) for tests; writes to a temporary folder",
    )
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    config = MODES[mode] if args.sizes is None else replace(MODES[mode], chain_ns=args.sizes)
    print(f"nemc benchmarks, {mode} mode", flush=True)
    result = run(config)
    if args.out is not None:
        folder, latest = args.out, True
    elif args.smoke:
        folder, latest = Path(tempfile.mkdtemp(prefix="nemc-bench-smoke-")), False
    else:  # --quick keeps its own files: the full suite's stay as committed
        folder, latest = (RESULTS / "quick" if mode == "quick" else RESULTS), True
    folder.mkdir(parents=True, exist_ok=True)
    written = write_outputs(result, folder, latest)
    print(markdown(result))
    print("written: " + ", ".join(str(p) for p in written))
    return 130 if result.get("interrupted") else 0


if __name__ == "__main__":
    sys.exit(main())
