"""What the benchmark scripts share: the environment record, timing helpers, the generated chains,
compile phases in fresh processes, power-law fits and the Markdown formatting of times.

Every script records the machine, versions and git commit with its results (`environment`), times
contenders interleaved and repeated (`interleaved`), and reports medians with the min-max.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as dt
import gc
import importlib
import importlib.metadata
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
GENERATED = ROOT / "generated"
PEERS = ("pydy", "jitcode", "heyoka")
CORE_MODULES = ("numpy", "scipy", "sympy", "cffi", "nemc", "matplotlib")


# -- environment ------------------------------------------------------------------------------


def version_of(module: str) -> str | None:
    """The module's version (its __version__, else its distribution's), or None when it does
    not import."""
    try:
        imported = importlib.import_module(module)
    except Exception:  # noqa: BLE001 (absent or broken: recorded as None)
        return None
    try:
        return str(getattr(imported, "__version__", None) or importlib.metadata.version(module))
    except importlib.metadata.PackageNotFoundError:
        return "unknown version"


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
    return {"commit": git("rev-parse", "HEAD"),
            "dirty": bool(status) if status is not None else None}


def load_average() -> list[float] | None:
    try:
        return [round(v, 2) for v in os.getloadavg()]
    except OSError:
        return None


def environment(mode: str) -> dict[str, Any]:
    """Machine, versions (the peers' too, None when absent), git commit, load average."""
    affinity = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return {
        "mode": mode,
        "started": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "platform": platform.platform(),
        "cpu": cpu_model(),
        "cpu_count": os.cpu_count(),
        "cpus_usable": affinity,
        "python": platform.python_version(),
        "versions": {m: version_of(m) for m in CORE_MODULES + PEERS},
        "c_compiler": c_compiler_version(),
        "git": git_commit(),
        "nemc_cache": os.environ.get("NEMC_CACHE", "(default)"),
        "loadavg_start": load_average(),
    }


@contextlib.contextmanager
def one_cpu(env: dict[str, Any]) -> Iterator[int | None]:
    """Timed work on one CPU, and the worker processes started meanwhile (they inherit it).
    The two CPUs of this shared machine run at different speeds at times (measured: the same
    nemc.Taylor run 1.7-2.3x slower on one than on the other, for minutes; likely a neighbour
    on a sibling thread), so contenders in two processes on two CPUs compared the CPUs. The CPU
    is recorded in ENV; the affinity is restored after."""
    if not hasattr(os, "sched_setaffinity"):
        yield None
        return
    before = os.sched_getaffinity(0)
    cpu = min(before)
    os.sched_setaffinity(0, {cpu})
    env["pinned_cpu"] = cpu
    try:
        yield cpu
    finally:
        os.sched_setaffinity(0, before)


def c_compiler_version() -> str | None:
    import sysconfig

    compiler = (sysconfig.get_config_var("CC") or "cc").split()[0]
    try:
        done = subprocess.run([compiler, "--version"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout.splitlines()[0] if done.returncode == 0 and done.stdout else None


def finish_environment(env: dict[str, Any], started: float) -> None:
    env["total_seconds"] = time.perf_counter() - started
    env["loadavg_end"] = load_average()


# -- timing -----------------------------------------------------------------------------------


def summary(values: Sequence[float]) -> dict[str, Any]:
    return {"median": statistics.median(values), "min": min(values), "max": max(values),
            "n": len(values), "values": list(values)}


def speedup(slower: dict[str, Any], faster: dict[str, Any]) -> dict[str, float]:
    """How many times faster `faster` is than `slower` (summary()s of interleaved rounds): the
    ratio of medians, and the range of the per-round ratios."""
    per_round = [a / b for a, b in zip(slower["values"], faster["values"])]
    return {"median": slower["median"] / faster["median"], "min": min(per_round),
            "max": max(per_round)}


def run_errors(y: np.ndarray, reference: np.ndarray) -> dict[str, float]:
    """An ensemble's error: each run's largest error over its states and times (y: (k, n_state,
    n_t)), its median and 90th percentile over the runs."""
    per_run = np.abs(y - reference).max(axis=(1, 2))
    return {"median": float(np.median(per_run)), "p90": float(np.percentile(per_run, 90))}


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
    """Per-call seconds of each contender (callable, calls per invocation): calibrated loops,
    `rounds` rounds each running every contender once, rotating the order each round."""
    loops = {name: loop_count(call, target) for name, (call, _) in calls.items()}
    samples: dict[str, list[float]] = {name: [] for name in calls}
    names = list(calls)
    for r in range(rounds):
        for name in names[r % len(names):] + names[:r % len(names)]:
            call, per = calls[name]
            samples[name].append(time_loop(call, loops[name]) / per)
    return {name: {**summary(v), "loops": loops[name]} for name, v in samples.items()}


def timed(call: Callable[[], Any]) -> tuple[float, Any]:
    start = time.perf_counter()
    out = call()
    return time.perf_counter() - start, out


def random_states(n_state: int, count: int, seed: int = 1, bound: float = 1.5) -> np.ndarray:
    """`count` random states, uniform in [-bound, bound], as the (n_state, count) array that
    `Model.rhs_many` takes, but a view (`.T`) of C-contiguous (count, n_state) rows: rhs_many hands
    those rows to its C loop without a transposed copy, so a timing measures the C loop itself."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-bound, bound, size=(count, n_state)).T


def native_methods(explicit_only: bool = False) -> tuple[str, ...]:
    """nemc's own integrators (C loops), as nemc.runtime.model lists them (a new one is picked up);
    explicit_only: without those that take the Jacobian (nemc.Radau)."""
    from nemc.runtime import model as runtime

    methods = tuple(getattr(runtime, "NATIVE_METHODS", ()))
    implicit = set(getattr(runtime, "IMPLICIT_METHODS", ())) if explicit_only else set()
    return tuple(m for m in methods if m not in implicit)


# -- systems ----------------------------------------------------------------------------------


def chain_yaml(n: int, mixed: bool = False, method: str = "DOP853") -> str:
    """An n-link chain of uniform rods (m = 1, L = 1) under gravity.

    Plain: revolute joints, relative angles. Mixed (the scaling benchmark): every third joint
    prismatic along its parent's axis, the others revolute, each with a damped joint spring.
    """
    kind = "mixed revolute/prismatic with joint springs" if mixed else "revolute"
    lines = [
        f"name: {chain_name(n, mixed)}",
        f"description: {n}-link chain of uniform rods, {kind} (nemc benchmark)",
        "parameters:", "  m: 1", "  L: 1", "  g: 9.81",
    ]
    if mixed:
        lines += ["  k: 20", "  c: 0.05", "  ks: 200"]
    lines += ["gravity: [0, -g]", "bodies:"]
    for i in range(1, n + 1):
        lines += [f"  link{i}:", "    mass: m", "    inertia: m*L**2/12", "    com: [L/2, 0]",
                  "    points: {tip: [L, 0]}"]
    lines.append("joints:")
    initial, springs = [], []
    for i in range(1, n + 1):
        parent, at = ("ground", "[0, 0]") if i == 1 else (f"link{i - 1}", "tip")
        prismatic = mixed and i % 3 == 0
        head = f"  J{i}: {{parent: {parent}, child: link{i}, at: {at}, "
        if prismatic:
            lines.append(head + f"type: prismatic, coordinate: s{i}}}")
            initial.append(f"s{i}: 0.05")
            springs.append(f"  - joint_spring: {{joint: J{i}, k: ks, damping: c}}")
        else:
            lines.append(head + f"type: revolute, coordinate: q{i}, angle: relative}}")
            initial.append(f"q{i}: {'-pi/4' if i == 1 else '0.1'}")
            if mixed:
                springs.append(f"  - joint_spring: {{joint: J{i}, k: k, damping: c}}")
    if springs:
        lines += ["loads:"] + springs
    lines += ["simulation:", "  t_span: [0, 5]", f"  initial: {{{', '.join(initial)}}}",
              f"  method: {method}"]
    return "\n".join(lines) + "\n"


def with_scene_tolerances(text: str, rtol: float, atol: float) -> str:
    """A mechanism's YAML with its scene's rtol and atol set."""
    import yaml

    document = yaml.safe_load(text)
    document.setdefault("simulation", {}).update(rtol=rtol, atol=atol)
    return yaml.safe_dump(document, sort_keys=False)


def chain_name(n: int, mixed: bool = False) -> str:
    return f"{'mixed' if mixed else 'chain'}{n}"


def chain_size(name: str) -> int | None:
    """n of a generated chain's name ('chain8', 'mixed32'), None for other systems."""
    digits = name.lstrip("abcdefghijklmnopqrstuvwxyz")
    return int(digits) if digits.isdigit() and name.startswith(("chain", "mixed")) else None


def write_chains(ns: Iterable[int], folder: Path, mixed: bool = False, method: str = "DOP853"
                 ) -> dict[str, Path]:
    paths = {}
    for n in sorted(set(ns)):
        name = chain_name(n, mixed)
        path = folder / f"{name}.yaml"
        path.write_text(chain_yaml(n, mixed, method))
        paths[name] = path
    return paths


# -- compile phases (fresh processes) ---------------------------------------------------------

COLD_SCRIPT = """
import json, resource, sys, time
from pathlib import Path
t = time.perf_counter()
from nemc.pipeline import compile_mechanism
imported = time.perf_counter() - t
c = compile_mechanism(sys.argv[1])
total = time.perf_counter() - t
sources = sorted(Path(c.package).glob("*.c"))
print(json.dumps({"timings": c.timings, "cached": c.cached, "import": imported,
                  "total_in_process": total, "c_bytes": sum(p.stat().st_size for p in sources),
                  "c_lines": sum(p.read_text().count(chr(10)) for p in sources),
                  "package": str(c.package),
                  "peak_rss_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))
"""
CACHED_SCRIPT = (
    "import nemc, sys, time; t=time.perf_counter(); nemc.compile(sys.argv[1]);"
    " first=time.perf_counter()-t; t=time.perf_counter(); nemc.compile(sys.argv[1]);"
    " print(first, time.perf_counter()-t)"
)


class StageFailed(RuntimeError):
    """A benchmark stage failed or ran past its budget; the message says which and why."""


def python_run(code: str, args: Sequence[str], timeout: float,
               env: dict[str, str] | None = None) -> tuple[str, float]:
    """Run `python -c code args` in a fresh process; its last stdout line and the wall time."""
    start = time.perf_counter()
    try:
        done = subprocess.run([sys.executable, "-c", code, *args], env=env or dict(os.environ),
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise StageFailed(f"did not finish in {timeout:.0f} s (time budget)") from None
    wall = time.perf_counter() - start
    if done.returncode != 0:
        last = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "no message"
        raise StageFailed(f"failed (exit {done.returncode}): {last}")
    return done.stdout.strip().splitlines()[-1], wall


def compile_phases(path: Path, timeout: float, cached_repeats: int,
                   cache: Path | None = None) -> dict[str, Any]:
    """Cold build in a fresh process with a fresh NEMC_CACHE (phases from `Compiled.timings`,
    generated C size, peak memory), then cached loads in fresh processes on that cache (none
    when cached_repeats is 0). CACHE: an empty
    folder to build in and keep (cold["package"] is the build), else a temporary one."""
    with tempfile.TemporaryDirectory(prefix="nemc-bench-cache-") as scratch:
        env = dict(os.environ, NEMC_CACHE=str(cache or scratch))
        out, wall = python_run(COLD_SCRIPT, [str(path)], timeout, env)
        cold = json.loads(out)
        cold["process_wall"] = wall
        loads, again, walls = [], [], []
        for _ in range(cached_repeats):
            out, wall = python_run(CACHED_SCRIPT, [str(path)], 120.0, env)
            first, second = (float(v) for v in out.split())
            loads.append(first)
            again.append(second)
            walls.append(wall)
    found: dict[str, Any] = {"cold": cold, "cold_total": sum(cold["timings"].values())}
    if cached_repeats:
        found.update(cached_load=summary(loads), cached_load_again=summary(again),
                     cached_process_wall=summary(walls))
    return found


def predicted_next(known: Sequence[tuple[int, float]], n: int) -> float | None:
    """A cost at n extrapolated from the last two (n, cost) points (at least linear growth)."""
    known = sorted(known)
    if len(known) < 2 or known[-1][0] >= n:
        return None
    (n0, t0), (n1, t1) = known[-2:]
    growth = math.log(max(t1, 1e-3) / max(t0, 1e-3)) / math.log(n1 / n0)
    return t1 * (n / n1) ** max(growth, 1.0)


# -- fits -------------------------------------------------------------------------------------


def power_fit(ns: Sequence[float], values: Sequence[float]) -> dict[str, Any] | None:
    """Least squares of log(value) = log(c) + p log(n): value ~ c n^p (None under 2 points)."""
    import numpy as np

    points = [(n, v) for n, v in zip(ns, values) if v is not None and v > 0]
    if len(points) < 2:
        return None
    x = np.log([n for n, _ in points])
    y = np.log([v for _, v in points])
    slope, intercept = np.polyfit(x, y, 1)
    residual = y - (slope * x + intercept)
    return {"exponent": float(slope), "prefactor": float(math.exp(intercept)),
            "n": [n for n, _ in points], "rms_log_residual": float(np.sqrt(np.mean(residual**2)))}


# -- Markdown ---------------------------------------------------------------------------------


def fmt_time(seconds: float) -> str:
    if seconds < 1e-6:
        return f"{seconds * 1e9:.0f} ns"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.2f} µs"
    if seconds < 1:
        return f"{seconds * 1e3:.1f} ms"
    return f"{seconds:.2f} s"


def spread(s: dict[str, Any]) -> str:
    if s["n"] == 1:
        return fmt_time(s["median"])
    return f"{fmt_time(s['median'])} ({fmt_time(s['min'])}–{fmt_time(s['max'])})"


def spread_of(values: Sequence[float]) -> str:
    """Times as `median (min-max)`."""
    return (f"{fmt_time(statistics.median(values))} "
            f"({fmt_time(min(values))}–{fmt_time(max(values))})")


def md_environment(env: dict[str, Any]) -> list[str]:
    versions = ", ".join(f"{k} {v}" for k, v in env["versions"].items() if v is not None)
    absent = [k for k, v in env["versions"].items() if v is None]
    git = env["git"]
    commit = (git["commit"] or "unknown")[:12] + (" (dirty)" if git["dirty"] else "")
    return [
        f"- mode **{env['mode']}**, started {env['started']}, took {env['total_seconds']:.0f} s",
        f"- {env['platform']}; {env['cpu']}; {env['cpu_count']} CPUs "
        f"({env['cpus_usable']} usable); C compiler: {env['c_compiler']}",
        f"- Python {env['python']}; {versions}" + (f"; not installed: {', '.join(absent)}"
                                                   if absent else ""),
        f"- git commit {commit}; NEMC_CACHE {env['nemc_cache']}",
        f"- load average (1, 5, 15 min) at start {env['loadavg_start']}, at end "
        f"{env.get('loadavg_end')}: other work on the machine shows here and in the spreads",
    ] + ([f"- single-thread contenders compared with each other ran on CPU {env['pinned_cpu']}"
          " alone, worker processes started meanwhile too (`common.one_cpu`)"]
         if "pinned_cpu" in env else [])


def write_json(result: dict[str, Any], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=1, default=float))


def stamp() -> str:
    return dt.datetime.now().strftime("%Y%m%d-%H%M%S")


def mode_parser(description: str, quick_help: str, smoke_help: str) -> argparse.ArgumentParser:
    """The options every benchmark script takes: --quick | --smoke, --sizes, --out."""
    parser = argparse.ArgumentParser(description=description)
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--quick", action="store_true", help=quick_help)
    group.add_argument("--smoke", action="store_true", help=smoke_help)
    parser.add_argument("--sizes", type=lambda s: tuple(int(v) for v in s.split(",")),
                        help="chain sizes, comma-separated (default: the mode's)")
    parser.add_argument("--out", type=Path, help="results folder (benchmarks/results)")
    return parser


def mode_of(args: argparse.Namespace) -> str:
    """The mode mode_parser's options chose: smoke, quick or full."""
    return "smoke" if args.smoke else "quick" if args.quick else "full"


def results_folder(args: argparse.Namespace, prefix: str) -> Path:
    """Where a script writes: --out, else a temporary folder in smoke mode, else RESULTS
    (RESULTS/quick in quick mode: a quick run never overwrites the full suite's results)."""
    if args.out:
        return args.out
    if args.smoke:
        return Path(tempfile.mkdtemp(prefix=prefix))
    return RESULTS / "quick" if getattr(args, "quick", False) else RESULTS


def write_results(result: dict[str, Any], folder: Path, stem: str, text: str) -> None:
    """STEM-latest.json and STEM-latest.md in FOLDER; the Markdown printed too."""
    folder.mkdir(parents=True, exist_ok=True)
    write_json(result, folder / f"{stem}-latest.json")
    (folder / f"{stem}-latest.md").write_text(text)
    print(text)
    print(f"written: {folder / f'{stem}-latest.json'}, {folder / f'{stem}-latest.md'}")


def run_script(doc: str, helps: tuple[str, str], modes: dict[str, Any], stem: str,
               run: Callable[[Any], dict[str, Any]], markdown: Callable[[dict[str, Any]], str],
               ) -> int:
    """A benchmark script's main: its modes (--quick, --smoke; --sizes replaces the mode's
    config's `chains`), its run, its results written as STEM-latest.{json,md}. HELPS: the
    --quick and --smoke help texts."""
    import dataclasses

    title = doc.splitlines()[0].rstrip(".")
    args = mode_parser(title, *helps).parse_args()
    mode = mode_of(args)
    config = modes[mode]
    if args.sizes:
        config = dataclasses.replace(config, chains=args.sizes)
    print(f"{title} ({mode} mode)", flush=True)
    result = run(config)
    result["environment"]["mode"] = mode
    write_results(result, results_folder(args, f"nemc-bench-{stem}-"), stem, markdown(result))
    return 0

