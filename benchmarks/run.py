"""nemc's benchmark suite: RHS cost, work-precision, compile phases, against sympy lambdify.

Run: `nemc bench [--quick]`, `make bench`, or `python benchmarks/run.py [--quick | --smoke]`.

Every contender is measured in the same run, interleaved with the others and repeated; tables give
medians with the min-max over rounds, and ratios are only ever formed between numbers of one run.
The baseline is sympy `lambdify` of the very M(q) and f(t, q, dq) that `nemc.derive.derive` hands
to nemc's C emitter (parameters folded to their defaults), with M qdd = f solved by
`numpy.linalg.solve`. Results: benchmarks/results/ (JSON, Markdown, PNG); see benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import datetime as dt
import gc
import importlib
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
DOUBLE_PENDULUM = ROOT / "examples" / "double_pendulum.yaml"
REFERENCE_TOL = (1e-13, 1e-15)  # DOP853 rtol, atol of the reference solutions
PEERS = ("pydy", "jitcode", "heyoka")

RHS_CONTENDERS = (
    "nemc model.rhs",
    "nemc closure",
    "nemc rhs_many (per state)",
    "lambdify(cse)",
    "lambdify (no cse)",
)
BASELINE = "lambdify(cse)"


@dataclass(frozen=True)
class Config:
    """What one mode measures."""

    mode: str
    chain_ns: tuple[int, ...]
    rhs_rounds: int
    sample_seconds: float  # each timeit sample runs its loop for about this long
    many_states: int
    wp_systems: tuple[str, ...]
    wp_methods: tuple[str, ...]
    wp_rtols: tuple[float, ...]
    wp_repeats: int
    wp_cell_cap: float  # a run longer than this is not repeated (its repeats are recorded)
    wp_skip_after: float  # a tighter rtol is skipped when the looser one took longer than this
    phase_ns: tuple[int, ...]
    cached_repeats: int
    compile_timeout: float  # a cold compile past this (measured or predicted) is skipped
    runtime_budget: float  # no runtime benchmarks for a system whose cold compile took longer


MODES = {
    "smoke": Config(
        "smoke", (2,), 2, 0.005, 64, ("double_pendulum",), ("RK45",), (1e-6,), 1, 5.0, 5.0,
        (2,), 1, 60.0, 60.0,
    ),
    "quick": Config(
        "quick", (2, 4, 8), 5, 0.02, 1000, ("double_pendulum",), ("RK45", "DOP853", "Radau"),
        (1e-3, 1e-6, 1e-9, 1e-12), 3, 4.0, 2.0, (2, 4, 8), 3, 120.0, 60.0,
    ),
    "full": Config(
        "full", (2, 4, 8, 16), 5, 0.05, 1000, ("double_pendulum", "chain8"),
        ("RK45", "DOP853", "Radau", "BDF", "LSODA"), (1e-3, 1e-6, 1e-9, 1e-12), 5, 8.0,
        10.0, (2, 4, 8, 16), 5, 150.0, 60.0,
    ),
}


# -- environment ------------------------------------------------------------------------------


def version_of(module: str) -> str | None:
    try:
        return str(importlib.import_module(module).__version__)
    except Exception:  # noqa: BLE001 (absent or broken: recorded as None)
        return None


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def git_commit() -> dict[str, Any]:
    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True,
                                  timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    status = git("status", "--porcelain", "--untracked-files=no")
    return {"commit": git("rev-parse", "HEAD"), "dirty": bool(status) if status is not None
            else None}


def environment(config: Config) -> dict[str, Any]:
    affinity = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return {
        "mode": config.mode,
        "started": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "platform": platform.platform(),
        "cpu": cpu_model(),
        "cpu_count": os.cpu_count(),
        "cpus_usable": affinity,
        "python": platform.python_version(),
        "versions": {m: version_of(m) for m in ("numpy", "scipy", "sympy", "cffi", "nemc")},
        "git": git_commit(),
        "nemc_cache": os.environ.get("NEMC_CACHE", "(default)"),
        "loadavg_start": load_average(),
    }


def load_average() -> list[float] | None:
    try:
        return [round(v, 2) for v in os.getloadavg()]
    except OSError:
        return None


# -- systems ----------------------------------------------------------------------------------


def chain_yaml(n: int) -> str:
    """An n-link chain of uniform rods under gravity, revolute joints, relative angles."""
    lines = [
        f"name: chain{n}",
        f"description: {n}-link chain of uniform rods, relative angles (nemc benchmark)",
        "parameters:", "  m: 1", "  L: 1", "  g: 9.81",
        "gravity: [0, -g]",
        "bodies:",
    ]
    for i in range(1, n + 1):
        lines += [f"  link{i}:", "    mass: m", "    inertia: m*L**2/12", "    com: [L/2, 0]",
                  "    points: {tip: [L, 0]}"]
    lines.append("joints:")
    for i in range(1, n + 1):
        parent, at = ("ground", "[0, 0]") if i == 1 else (f"link{i - 1}", "tip")
        lines.append(f"  J{i}: {{type: revolute, parent: {parent}, child: link{i}, at: {at},"
                     f" coordinate: q{i}, angle: relative}}")
    initial = ", ".join(["q1: -pi/4"] + [f"q{i}: 0.1" for i in range(2, n + 1)])
    lines += ["simulation:", "  t_span: [0, 5]", f"  initial: {{{initial}}}", "  method: DOP853"]
    return "\n".join(lines) + "\n"


def system_paths(config: Config, folder: Path) -> dict[str, Path]:
    """Name -> YAML path: the book's double pendulum and the chains this mode needs."""
    ns = set(config.chain_ns) | set(config.phase_ns)
    ns |= {int(s[5:]) for s in config.wp_systems if s.startswith("chain")}
    paths = {"double_pendulum": DOUBLE_PENDULUM}
    for n in sorted(ns):
        path = folder / f"chain{n}.yaml"
        path.write_text(chain_yaml(n))
        paths[f"chain{n}"] = path
    return paths


# -- compile phases (fresh processes) ---------------------------------------------------------

COLD_SCRIPT = """
import json, sys, time
t = time.perf_counter()
from nemc.pipeline import compile_mechanism
imported = time.perf_counter() - t
c = compile_mechanism(sys.argv[1])
total = time.perf_counter() - t
print(json.dumps({"timings": c.timings, "cached": c.cached, "import": imported,
                  "total_in_process": total, "package": str(c.package)}))
"""
CACHED_SCRIPT = (
    "import nemc, sys, time; t=time.perf_counter(); nemc.compile(sys.argv[1]);"
    " first=time.perf_counter()-t; t=time.perf_counter(); nemc.compile(sys.argv[1]);"
    " print(first, time.perf_counter()-t)"
)


def python_run(code: str, path: Path, cache: Path, timeout: float) -> tuple[str, float]:
    env = dict(os.environ, NEMC_CACHE=str(cache))
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code, str(path)], env=env, capture_output=True,
                          text=True, timeout=timeout)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(done.stderr.strip().splitlines()[-1] if done.stderr else "failed")
    return done.stdout.strip().splitlines()[-1], wall


def compile_phases(path: Path, config: Config) -> dict[str, Any]:
    """Cold build in a fresh process with a fresh NEMC_CACHE, then cached loads in fresh ones."""
    with tempfile.TemporaryDirectory(prefix="nemc-bench-cache-") as cache:
        out, wall = python_run(COLD_SCRIPT, path, Path(cache), config.compile_timeout)
        cold = json.loads(out)
        cold["process_wall"] = wall
        cold.pop("package", None)
        loads, again, walls = [], [], []
        for _ in range(config.cached_repeats):
            out, wall = python_run(CACHED_SCRIPT, path, Path(cache), 60.0)
            first, second = (float(v) for v in out.split())
            loads.append(first)
            again.append(second)
            walls.append(wall)
    return {"cold": cold, "cached_load": summary(loads), "cached_load_again": summary(again),
            "cached_process_wall": summary(walls)}


# -- timing helpers ---------------------------------------------------------------------------


def summary(values: Sequence[float]) -> dict[str, Any]:
    return {"median": statistics.median(values), "min": min(values), "max": max(values),
            "n": len(values), "values": list(values)}


def loop_count(call: Callable[[], Any], target: float) -> int:
    """timeit-style: the number of calls that takes about `target` seconds."""
    number = 1
    while True:
        start = time.perf_counter()
        for _ in range(number):
            call()
        elapsed = time.perf_counter() - start
        if elapsed >= target / 5 or number >= 10**7:
            return max(1, int(number * target / max(elapsed, 1e-9)))
        number *= 10


def time_loop(call: Callable[[], Any], number: int) -> float:
    gc_was = gc.isenabled()
    gc.disable()
    try:
        start = time.perf_counter()
        for _ in range(number):
            call()
        return (time.perf_counter() - start) / number
    finally:
        if gc_was:
            gc.enable()


def interleaved(calls: dict[str, tuple[Callable[[], Any], int]], rounds: int,
                target: float) -> dict[str, dict[str, Any]]:
    """Per-call seconds of each contender: calibrated loops, rounds rotating the order."""
    loops = {name: loop_count(call, target) for name, (call, _) in calls.items()}
    samples: dict[str, list[float]] = {name: [] for name in calls}
    names = list(calls)
    for r in range(rounds):
        for name in names[r % len(names):] + names[:r % len(names)]:
            call, per = calls[name]
            samples[name].append(time_loop(call, loops[name]) / per)
    return {name: {**summary(v), "loops": loops[name]} for name, v in samples.items()}


# -- the lambdify baseline --------------------------------------------------------------------


@dataclass
class Baseline:
    """sympy lambdify of nemc's M and f, and what producing it cost."""

    rhs_cse: Callable[[float, np.ndarray], np.ndarray]
    rhs_plain: Callable[[float, np.ndarray], np.ndarray] | None
    seconds: dict[str, float] = field(default_factory=dict)


def lambdify_rhs(function: Callable, q_index: np.ndarray, u_index: np.ndarray):
    """dy/dt from a lambdified (t, q..., dq...) -> (M, f), with numpy.linalg.solve."""
    n_state = len(q_index) + len(u_index)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, u = y[q_index], y[u_index]
        mass, forcing = function(t, *q, *u)
        dy = np.empty(n_state)
        dy[q_index] = u
        dy[u_index] = np.linalg.solve(mass, np.ravel(forcing))
        return dy

    return rhs


def make_baseline(path: Path, state_names: Sequence[str], plain: bool) -> Baseline:
    import sympy

    from nemc.derive import derive
    from nemc.model import TIME
    from nemc.validate import load_mechanism

    seconds: dict[str, float] = {}
    start = time.perf_counter()
    eqs = derive(load_mechanism(path))
    seconds["derive"] = time.perf_counter() - start
    fold = {s: sympy.Float(v) for s, v in zip(eqs.parameters, eqs.parameter_defaults)}
    exprs = [eqs.mass_matrix.xreplace(fold), eqs.forcing.xreplace(fold)]
    args = [TIME, *eqs.coordinates, *eqs.speeds]
    q_index = np.array([state_names.index(str(s)) for s in eqs.coordinates])
    u_index = np.array([state_names.index(str(s)) for s in eqs.speeds])
    start = time.perf_counter()
    with_cse = sympy.lambdify(args, exprs, modules="numpy", cse=partial(sympy.cse, order="none"))
    seconds["lambdify(cse)"] = time.perf_counter() - start
    without = None
    if plain:
        start = time.perf_counter()
        without = sympy.lambdify(args, exprs, modules="numpy")
        seconds["lambdify (no cse)"] = time.perf_counter() - start
    return Baseline(
        lambdify_rhs(with_cse, q_index, u_index),
        lambdify_rhs(without, q_index, u_index) if without else None,
        seconds,
    )


# -- 1. RHS cost --------------------------------------------------------------------------------


def test_states(model, count: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.5, 1.5, size=(model.n_state, count))


def rhs_contenders(model, baseline: Baseline, config: Config) -> dict[str, tuple[Callable, int]]:
    states = test_states(model, config.many_states)
    y = np.ascontiguousarray(states[:, 0])
    closure = model._rhs_function(model.parameter_vector())
    calls = {
        "nemc model.rhs": (partial(model.rhs, 0.0, y), 1),
        "nemc closure": (partial(closure, 0.0, y), 1),
        "nemc rhs_many (per state)": (partial(model.rhs_many, 0.0, states), states.shape[1]),
        "lambdify(cse)": (partial(baseline.rhs_cse, 0.0, y), 1),
    }
    if baseline.rhs_plain is not None:
        calls["lambdify (no cse)"] = (partial(baseline.rhs_plain, 0.0, y), 1)
    return calls


def rhs_agreement(model, baseline: Baseline) -> dict[str, float]:
    """Largest relative difference to nemc's RHS over a few states (the contenders must agree)."""
    states = test_states(model, 16, seed=2)
    ours = model.rhs_many(0.0, states)
    diffs = {}
    for name, rhs in (("lambdify(cse)", baseline.rhs_cse), ("lambdify (no cse)",
                                                              baseline.rhs_plain)):
        if rhs is None:
            continue
        theirs = np.column_stack([rhs(0.0, states[:, k]) for k in range(states.shape[1])])
        diffs[name] = float(np.max(np.abs(theirs - ours)) / max(1.0, np.max(np.abs(ours))))
    diffs["rhs_many vs closure"] = float(np.max(np.abs(
        ours[:, 0] - model._rhs_function(model.parameter_vector())(0.0, states[:, 0]))))
    return diffs


def bench_rhs(name: str, model, baseline: Baseline, config: Config) -> dict[str, Any]:
    calls = rhs_contenders(model, baseline, config)
    timings = interleaved(calls, config.rhs_rounds, config.sample_seconds)
    base = timings[BASELINE]["median"]
    for t in timings.values():
        t["ratio_vs_lambdify_cse"] = base / t["median"]
    print(f"  rhs {name}: " + ", ".join(f"{k} {v['median'] * 1e9:.0f} ns"
                                        for k, v in timings.items()), flush=True)
    return {"n_state": model.n_state, "per_call_seconds": timings,
            "agreement": rhs_agreement(model, baseline), "setup_seconds": baseline.seconds}


# -- 2. work-precision --------------------------------------------------------------------------


def final_error(y: np.ndarray, reference: np.ndarray) -> float:
    return float(np.max(np.abs(y - reference)))


def wp_runners(model, baseline: Baseline, span, y0, method: str, rtol: float):
    """The two contenders for one cell: nemc's simulate and solve_ivp + lambdify(cse)."""
    from scipy.integrate import solve_ivp

    atol = rtol * 1e-3
    t_eval = [span[1]]

    def nemc_run():
        res = model.simulate(span, y0, method=method, rtol=rtol, atol=atol, t_eval=t_eval)
        return res.y[:, -1], res.nfev, res.njev, res.success

    def lambdify_run():
        sol = solve_ivp(baseline.rhs_cse, span, y0, method=method, rtol=rtol, atol=atol,
                        t_eval=t_eval)
        return sol.y[:, -1], sol.nfev, sol.njev, sol.success

    return {"nemc": nemc_run, "lambdify(cse)": lambdify_run}


def references(model, baseline: Baseline, span, y0) -> dict[str, Any]:
    """DOP853 at rtol 1e-13 with nemc's RHS, cross-checked with the lambdify RHS."""
    rtol, atol = REFERENCE_TOL
    ours = model.simulate(span, y0, method="DOP853", rtol=rtol, atol=atol, t_eval=[span[1]])
    from scipy.integrate import solve_ivp

    theirs = solve_ivp(baseline.rhs_cse, span, y0, method="DOP853", rtol=rtol, atol=atol,
                       t_eval=[span[1]])
    reference = ours.y[:, -1]
    return {"y": reference.tolist(), "method": "DOP853", "rtol": rtol, "atol": atol,
            "nfev": int(ours.nfev),
            "cross_check": "solve_ivp DOP853 (same tolerances) with the lambdify(cse) RHS",
            "cross_check_difference": final_error(theirs.y[:, -1], reference)}


def timed_run(run: Callable[[], tuple]) -> tuple[float, tuple]:
    start = time.perf_counter()
    out = run()
    return time.perf_counter() - start, out


def warm_jacobian(model, config: Config) -> float:
    """nemc builds the C Jacobian on first need: do it before any timed implicit run."""
    if not set(config.wp_methods) & {"Radau", "BDF", "LSODA"}:
        return 0.0
    start = time.perf_counter()
    model._jacobian_function(model.parameter_vector())
    return time.perf_counter() - start


def too_slow(records: dict[tuple, dict[str, Any]], method: str, rtol: float,
             config: Config) -> bool:
    """True when a looser rtol of this method already took longer than wp_skip_after."""
    looser = [r for r in config.wp_rtols if r > rtol]
    return any(max(rec["times"][0] for (m, r, _), rec in records.items()
                   if m == method and r == loose) > config.wp_skip_after
               for loose in looser if any(k[:2] == (method, loose) for k in records))


def work_precision_rounds(model, baseline: Baseline, span, y0, reference: np.ndarray,
                          name: str, config: Config) -> tuple[dict[tuple, dict], list[str]]:
    records: dict[tuple, dict[str, Any]] = {}
    skipped: list[str] = []
    for rep in range(config.wp_repeats):
        for method in config.wp_methods:
            for rtol in sorted(config.wp_rtols, reverse=True):
                if rep == 0 and too_slow(records, method, rtol, config):
                    skipped.append(f"{name}: {method} rtol {rtol:g} skipped (rtol "
                                   f"{rtol * 1e3:g} took over {config.wp_skip_after:g} s)")
                    break
                if rep > 0 and (method, rtol, "nemc") not in records:
                    break
                runners = wp_runners(model, baseline, span, y0, method, rtol)
                order = list(runners) if rep % 2 == 0 else list(runners)[::-1]
                for contender in order:
                    record = records.setdefault((method, rtol, contender), {"times": []})
                    if rep > 0 and record["times"][-1] > config.wp_cell_cap:
                        continue
                    seconds, (y, nfev, njev, success) = timed_run(runners[contender])
                    record["times"].append(seconds)
                    record.update(error=final_error(y, reference), nfev=int(nfev),
                                  njev=int(njev), success=bool(success))
        print(f"  work-precision {name}: round {rep + 1}/{config.wp_repeats}", flush=True)
    return records, skipped


def bench_work_precision(name: str, model, baseline: Baseline, span, config: Config):
    y0 = model.initial_state()
    jac_seconds = warm_jacobian(model, config)
    ref = references(model, baseline, span, y0)
    records, skipped = work_precision_rounds(model, baseline, span, y0, np.array(ref["y"]),
                                             name, config)
    rows = []
    for (method, rtol, contender), rec in records.items():
        rows.append({"method": method, "rtol": rtol, "atol": rtol * 1e-3,
                     "contender": contender, "seconds": summary(rec.pop("times")), **rec})
    return {"t_span": list(span), "y0": y0.tolist(), "reference": ref, "rows": rows,
            "skipped": skipped, "jacobian_first_need_seconds": jac_seconds}


# -- 4. peers ---------------------------------------------------------------------------------


def peers() -> dict[str, str]:
    notes = {}
    for name in PEERS:
        try:
            module = importlib.import_module(name)
        except Exception as error:  # noqa: BLE001 (any import failure means: not measured)
            notes[name] = f"skipped: not importable ({type(error).__name__})"
            continue
        version = getattr(module, "__version__", "?")
        notes[name] = f"importable ({version}); no adapter in this suite yet: not measured"
    return notes


# -- the run ------------------------------------------------------------------------------------


def load_model(path: Path):
    import nemc

    start = time.perf_counter()
    model = nemc.compile(path)
    return model, time.perf_counter() - start


def run_system(name: str, path: Path, config: Config, result: dict[str, Any]) -> None:
    """Everything measured on one system, in this process after its build exists."""
    wp = name in config.wp_systems
    rhs = name == "double_pendulum" or (name.startswith("chain") and
                                        int(name[5:]) in config.chain_ns)
    if not (wp or rhs):
        return
    model, seconds = load_model(path)
    result["setup"][name] = {"nemc.compile_seconds": seconds}
    baseline = make_baseline(path, model.state_names, plain=rhs)
    result["setup"][name].update(baseline.seconds)
    if rhs:
        result["rhs"][name] = bench_rhs(name, model, baseline, config)
    if wp:
        span = (0.0, 20.0) if name == "double_pendulum" else (0.0, 5.0)
        wp_result = bench_work_precision(name, model, baseline, span, config)
        result["work_precision"][name] = wp_result
        result["notes"] += wp_result["skipped"]
        result["setup"][name]["jacobian (first need)"] = wp_result["jacobian_first_need_seconds"]


def run_phases(name: str, path: Path, config: Config, result: dict[str, Any]) -> bool:
    """Cold and cached compile of one system; False when it failed or ran out of time."""
    try:
        result["phases"][name] = compile_phases(path, config)
    except subprocess.TimeoutExpired:
        result["notes"].append(f"{name}: cold compile did not finish in "
                               f"{config.compile_timeout:.0f} s; it and larger systems skipped")
        return False
    except RuntimeError as error:
        result["notes"].append(f"{name}: compile failed ({error}); skipped")
        return False
    cold = result["phases"][name]["cold"]
    stages = ", ".join(f"{k} {v:.2f}" for k, v in cold["timings"].items())
    print(f"  phases {name}: {stages} s; cached load "
          f"{result['phases'][name]['cached_load']['median'] * 1e3:.1f} ms", flush=True)
    return True


def predicted_compile(result: dict[str, Any], n: int) -> float | None:
    """Cold compile time of chain n from the last two chains measured (same growth per step)."""
    known = sorted((int(k[5:]), sum(v["cold"]["timings"].values()))
                   for k, v in result["phases"].items() if k.startswith("chain"))
    if len(known) < 2 or known[-1][0] >= n:
        return None
    (n0, t0), (n1, t1) = known[-2:]
    growth = math.log(max(t1, 1e-3) / max(t0, 1e-3)) / math.log(n1 / n0)
    return t1 * (n / n1) ** max(growth, 1.0)


def compile_step(name: str, path: Path, config: Config, result: dict[str, Any]) -> str:
    """'ok', 'skip' (this system only) or 'stop' (this and larger chains)."""
    is_chain = name.startswith("chain")
    if not config.phase_ns or (is_chain and int(name[5:]) not in config.phase_ns):
        return "ok"
    guess = predicted_compile(result, int(name[5:])) if is_chain else None
    if guess is not None and guess > config.compile_timeout:
        result["notes"].append(
            f"{name}: skipped with larger chains: its cold compile would take about "
            f"{guess:.0f} s (extrapolated from the smaller chains), over the "
            f"{config.compile_timeout:.0f} s allowed")
        return "stop"
    print(f"{name}: compile phases", flush=True)
    if not run_phases(name, path, config, result):
        return "stop" if is_chain else "skip"
    cold = sum(result["phases"][name]["cold"]["timings"].values())
    if cold > config.runtime_budget:
        result["notes"].append(f"{name}: cold compile took {cold:.0f} s; runtime benchmarks "
                               f"skipped (each needs its own derive and build in this process)")
        return "skip"
    return "ok"


def run(config: Config) -> dict[str, Any]:
    result: dict[str, Any] = {"environment": environment(config), "config": asdict(config),
                              "setup": {}, "rhs": {}, "work_precision": {}, "phases": {},
                              "notes": [], "peers": peers()}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nemc-bench-") as folder:
        for name, path in system_paths(config, Path(folder)).items():
            step = compile_step(name, path, config, result)
            if step == "stop":
                break
            if step == "ok":
                print(f"{name}: runtime", flush=True)
                run_system(name, path, config, result)
    result["environment"]["total_seconds"] = time.perf_counter() - start
    result["environment"]["loadavg_end"] = load_average()
    return result


# -- output -------------------------------------------------------------------------------------


def fmt_time(seconds: float) -> str:
    if seconds < 1e-6:
        return f"{seconds * 1e9:.0f} ns"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.2f} µs"
    if seconds < 1:
        return f"{seconds * 1e3:.1f} ms"
    return f"{seconds:.2f} s"


def spread(s: dict[str, Any]) -> str:
    return f"{fmt_time(s['median'])} ({fmt_time(s['min'])}–{fmt_time(s['max'])})"


def md_environment(env: dict[str, Any]) -> list[str]:
    versions = ", ".join(f"{k} {v}" for k, v in env["versions"].items())
    git = env["git"]
    commit = (git["commit"] or "unknown")[:12] + (" (dirty)" if git["dirty"] else "")
    return [
        f"- mode **{env['mode']}**, started {env['started']}, took {env['total_seconds']:.0f} s",
        f"- {env['platform']}; {env['cpu']}; {env['cpu_count']} CPUs "
        f"({env['cpus_usable']} usable)",
        f"- Python {env['python']}; {versions}",
        f"- git commit {commit}; NEMC_CACHE {env['nemc_cache']}",
        f"- load average (1, 5, 15 min) at start {env['loadavg_start']}, at end "
        f"{env.get('loadavg_end')}: other work on the machine shows here and in the spreads",
    ]


def md_rhs(rhs: dict[str, Any]) -> list[str]:
    lines = ["## 1. RHS cost per call (median, min–max over rounds)", "",
             "Ratio: lambdify(cse) time / this contender's time (higher is faster).", ""]
    head = "| system | states | " + " | ".join(RHS_CONTENDERS) + " |"
    lines += [head, "|" + " --- |" * (2 + len(RHS_CONTENDERS))]
    for name, r in rhs.items():
        cells = []
        for c in RHS_CONTENDERS:
            t = r["per_call_seconds"].get(c)
            cells.append("–" if t is None else
                         f"{spread(t)}, **{t['ratio_vs_lambdify_cse']:.1f}x**")
        lines.append(f"| {name} | {r['n_state']} | " + " | ".join(cells) + " |")
    lines += ["", "Agreement with nemc's RHS (max relative difference over 16 random states): "
              + "; ".join(f"{n}: " + ", ".join(f"{k} {v:.1e}" for k, v in r["agreement"].items())
                          for n, r in rhs.items()), ""]
    return lines


def md_work_precision(wp: dict[str, Any]) -> list[str]:
    lines = ["## 2. Work-precision (time to the end, error of the final state)", "",
             "Speedup: lambdify(cse) median / nemc median at the same method and tolerance. "
             "Error: max |y(T) - reference|. atol = rtol x 1e-3.", ""]
    for name, w in wp.items():
        ref = w["reference"]
        lines += [f"### {name} over {w['t_span']}", "",
                  f"Reference: DOP853 rtol {ref['rtol']:g}, atol {ref['atol']:g} with nemc's RHS; "
                  f"{ref['cross_check']} differs by {ref['cross_check_difference']:.1e}.", "",
                  "| method | rtol | nemc time | lambdify(cse) time | speedup | nemc error "
                  "| lambdify error | nfev (nemc / lambdify) |",
                  "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        rows = {(r["method"], r["rtol"], r["contender"]): r for r in w["rows"]}
        for method, rtol, _ in [k for k in rows if k[2] == "nemc"]:
            a, b = rows[(method, rtol, "nemc")], rows[(method, rtol, "lambdify(cse)")]
            speed = b["seconds"]["median"] / a["seconds"]["median"]
            lines.append(f"| {method} | {rtol:g} | {spread(a['seconds'])} | "
                         f"{spread(b['seconds'])} | **{speed:.1f}x** | {a['error']:.1e} | "
                         f"{b['error']:.1e} | {a['nfev']} / {b['nfev']} |")
        lines.append("")
    return lines


def md_phases(phases: dict[str, Any], setup: dict[str, Any]) -> list[str]:
    stages = ("validate", "derive", "optimize", "emit", "build", "load")
    lines = ["## 3. Compile phases (cold: fresh process, fresh NEMC_CACHE; seconds)", "",
             "| system | " + " | ".join(stages) + " | cold total | cached: first compile call "
             "| cached: second call | cached: whole process |", "|" + " --- |" * (len(stages) + 5)]
    for name, p in phases.items():
        t = p["cold"]["timings"]
        cells = [f"{t[s]:.3f}" if s in t else "–" for s in stages]
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {sum(t.values()):.2f} | "
                     f"{spread(p['cached_load'])} | {spread(p['cached_load_again'])} | "
                     f"{spread(p['cached_process_wall'])} |")
    lines += ["", "Set-up in the benchmark process (seconds; the lambdify baseline derives again): "
              + "; ".join(f"{n}: " + ", ".join(f"{k} {v:.2f}" for k, v in s.items())
                          for n, s in setup.items()), ""]
    return lines


def markdown(result: dict[str, Any]) -> str:
    lines = ["# nemc benchmark results", ""] + md_environment(result["environment"]) + [""]
    lines += md_rhs(result["rhs"]) if result["rhs"] else []
    lines += md_work_precision(result["work_precision"]) if result["work_precision"] else []
    lines += md_phases(result["phases"], result["setup"]) if result["phases"] else []
    lines += ["## 4. Peers", ""] + [f"- {k}: {v}" for k, v in result["peers"].items()] + [""]
    if result["notes"]:
        lines += ["## Notes", ""] + [f"- {n}" for n in result["notes"]] + [""]
    return "\n".join(lines)


def plot_work_precision(result: dict[str, Any], folder: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    paths = []
    for name, w in result["work_precision"].items():
        fig, ax = plt.subplots(figsize=(7, 5))
        methods = sorted({r["method"] for r in w["rows"]}, key=result["config"]["wp_methods"].index)
        for k, method in enumerate(methods):
            for contender, style in (("nemc", "-o"), ("lambdify(cse)", "--s")):
                rows = sorted((r for r in w["rows"] if r["method"] == method
                               and r["contender"] == contender), key=lambda r: -r["rtol"])
                errors = [max(r["error"], 1e-16) for r in rows]
                times = [r["seconds"]["median"] for r in rows]
                ax.loglog(errors, times, style, color=f"C{k}", label=f"{method}, {contender}")
        ax.set_xlabel("error of the final state (max abs)")
        ax.set_ylabel("wall time, median (s)")
        ax.set_title(f"{name}, t in {w['t_span']} ({result['environment']['mode']} run)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        path = folder / f"work_precision_{name}.png"
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def plot_rhs(result: dict[str, Any], folder: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    chains = {int(k[5:]): v for k, v in result["rhs"].items() if k.startswith("chain")}
    if not chains:
        return []
    ns = sorted(chains)
    fig, ax = plt.subplots(figsize=(7, 5))
    for k, contender in enumerate(RHS_CONTENDERS):
        points = [(n, chains[n]["per_call_seconds"][contender]) for n in ns
                  if contender in chains[n]["per_call_seconds"]]
        if points:
            ax.errorbar([n for n, _ in points], [t["median"] * 1e9 for _, t in points],
                        yerr=[[(t["median"] - t["min"]) * 1e9 for _, t in points],
                              [(t["max"] - t["median"]) * 1e9 for _, t in points]],
                        fmt="-o", color=f"C{k}", label=contender, capsize=3)
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("links n (chain of uniform rods)")
    ax.set_ylabel("ns per RHS evaluation (median, min-max)")
    ax.set_title(f"RHS cost vs n ({result['environment']['mode']} run)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    path = folder / "rhs_cost.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def write_outputs(result: dict[str, Any], folder: Path, latest: bool) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    folder.mkdir(parents=True, exist_ok=True)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    text = json.dumps(result, indent=1, default=float)
    written = [folder / f"run-{stamp}-{result['environment']['mode']}.json"]
    written[0].write_text(text)
    md = markdown(result)
    if latest:
        (folder / "latest.json").write_text(text)
        (folder / "latest.md").write_text(md)
        written += [folder / "latest.json", folder / "latest.md"]
    else:
        (folder / f"run-{stamp}.md").write_text(md)
        written.append(folder / f"run-{stamp}.md")
    written += plot_work_precision(result, folder) + plot_rhs(result, folder)
    return written


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--quick", action="store_true", help="n in {2, 4, 8}; under 2 minutes")
    group.add_argument("--smoke", action="store_true",
                       help="a tiny subset (< 20 s) for tests; writes to a temporary folder")
    parser.add_argument("--out", type=Path, help="results folder (benchmarks/results)")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    mode = "smoke" if args.smoke else "quick" if args.quick else "full"
    config = MODES[mode]
    print(f"nemc benchmarks, {mode} mode", flush=True)
    result = run(config)
    if args.out is not None:
        folder, latest = args.out, True
    elif args.smoke:
        folder, latest = Path(tempfile.mkdtemp(prefix="nemc-bench-smoke-")), False
    else:
        folder, latest = RESULTS, True
    written = write_outputs(result, folder, latest)
    print(markdown(result))
    print("written: " + ", ".join(str(p) for p in written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
