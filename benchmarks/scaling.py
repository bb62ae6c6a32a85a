"""Scaling with the number of bodies: chains of n uniform rods, revolute and prismatic joints mixed,
with joint springs (issue 5's targets), n = 2 ... 64.

Per n: nemc's cold compile by phase in a fresh process with a fresh cache, the cached load, the
generated C size, and the RHS cost in C (`rhs_many` over many states, per state) and from Python
(the closure `simulate` hands to solve_ivp), the two interleaved and repeated. The same run times
sympy.physics.mechanics' derivation of the same chain (KanesMethod, a fresh process) and, when
installed, the peers (PyDy Cython, JiTCODE, heyoka; benchmarks/peers.py workers: build and RHS
cost, each interleaved with nemc's closure in its own process). Each cost gets a power-law fit
c * n^p (least squares in log-log). A stage past its time budget, measured or extrapolated from the
smaller n, is skipped for that n and larger ones, with the reason in the notes.

Run: `python benchmarks/scaling.py [--quick] [--sizes 2,4,8,16,32,64] [--out DIR]`; part of
`make bench`. Results: benchmarks/results/scaling-latest.{json,md}, scaling_*.png.

The full mode also compiles long chains (200, 500 and 1000 bodies, issue 19's target: 1000 under
60 s and 2 GB) cold, once each, and records their phases and the peak memory of the compiling
process (`--long-sizes` to choose; a compiler job of a unit file takes up to about 150 MB).
`--long-jacobian`: the long chains name nemc.Radau as their method, so that their build has
the analytic Jacobian too (its tangent program and its C).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
import peers  # noqa: E402
from common import RESULTS, StageFailed, fmt_time, spread  # noqa: E402

# issue 5's targets for 32 bodies, on the project's 2-core machine
TARGETS_32 = {"cold compile (derive + emit + compile)": 20.0,
              "cached load: first call in a fresh process (imports included)": 0.05,
              "cached load: second call": 0.05, "RHS in C": 2e-6}
MECHANICS_SCRIPT = (
    "import json, sys; sys.path.insert(0, sys.argv[2]); import peers;"
    " print(json.dumps(peers.mechanics_model(__import__('pathlib').Path(sys.argv[1]))"
    ".derive_seconds))"
)


@dataclass(frozen=True)
class Config:
    mode: str
    sizes: tuple[int, ...]
    compile_budget: float  # cold compile of one n (seconds)
    mechanics_budget: float  # sympy.physics.mechanics derivation of one n
    peer_budget: float  # one peer on one n (build, check, RHS cost)
    cached_repeats: int
    rounds: int
    sample_seconds: float
    many_states: int
    peers: bool
    long_sizes: tuple[int, ...] = ()  # cold compile only (phases, peak memory), once each
    long_jacobian: bool = False  # the long chains' builds with the Jacobian (method nemc.Radau)


MODES = {
    "smoke": Config("smoke", (2, 3), 60.0, 30.0, 60.0, 1, 2, 0.005, 256, False),
    "quick": Config("quick", (2, 4, 8), 60.0, 30.0, 60.0, 3, 5, 0.02, 1000, False),
    "full": Config("full", (2, 4, 8, 16, 32, 64), 300.0, 300.0, 300.0, 5, 7, 0.05, 1000, True,
                   (200, 500, 1000)),
}


def rhs_costs(package: Path, config: Config) -> dict[str, Any]:
    """Per-state cost of nemc's C loop and per-call cost of the Python closure, interleaved.

    The C loop gets `many_states` (about 1000) states as C-contiguous rows, passed as the
    transposed view rhs_many takes, so no copy is made per call and the data stays in cache, as
    in an integrator: the figure is the generated C's cost per state."""
    from nemc.runtime.load import load_package

    model = load_package(package)
    states = common.random_states(model.n_state, config.many_states, bound=1.0)
    y = np.ascontiguousarray(states[:, 0])
    closure = model.compiled.integrator_rhs(model.parameter_vector())
    calls = {"C (rhs_many, per state)": (lambda: model.rhs_many(0.0, states), states.shape[1]),
             "Python (closure per call)": (lambda: closure(0.0, y), 1)}
    return common.interleaved(calls, config.rounds, config.sample_seconds)


class Budget:
    """A stage's cost against n: skip n (and larger) when measured or extrapolated past budget."""

    def __init__(self, name: str, seconds: float, notes: list[str]):
        self.name, self.seconds, self.notes = name, seconds, notes
        self.known: list[tuple[int, float]] = []
        self.stopped = False

    def allows(self, n: int) -> bool:
        if self.stopped:
            return False
        guess = common.predicted_next(self.known, n)
        if guess is not None and guess > self.seconds:
            self.notes.append(f"n = {n} and larger: {self.name} skipped, extrapolated to about "
                              f"{guess:.0f} s, over its {self.seconds:.0f} s budget")
            self.stopped = True
        return not self.stopped

    def failed(self, n: int, why: str) -> None:
        self.notes.append(f"n = {n}: {self.name} {why}; larger n skipped")
        self.stopped = True


def measure_nemc(n: int, path: Path, cache: Path, config: Config, budget: Budget,
                 row: dict[str, Any]) -> None:
    if not budget.allows(n):
        return
    try:
        phases = common.compile_phases(path, config.compile_budget, config.cached_repeats, cache)
    except StageFailed as error:
        budget.failed(n, f"cold compile {error}")
        return
    budget.known.append((n, phases["cold_total"]))
    package = Path(phases["cold"].pop("package"))
    row["nemc"] = {**phases, "rhs": rhs_costs(package, config)}
    rhs = row["nemc"]["rhs"]
    print(f"  nemc: cold {phases['cold_total']:.2f} s, C {phases['cold']['c_bytes'] / 1e3:.0f} "
          f"kB, cached load {fmt_time(phases['cached_load']['median'])}, RHS C "
          f"{fmt_time(rhs['C (rhs_many, per state)']['median'])}, Python "
          f"{fmt_time(rhs['Python (closure per call)']['median'])}", flush=True)


def measure_long(n: int, path: Path, cache: Path, config: Config, budget: Budget
                 ) -> dict[str, Any] | None:
    """A long chain's cold compile in a fresh process: phases, C size, peak memory."""
    if not budget.allows(n):
        return None
    try:
        phases = common.compile_phases(path, config.compile_budget, 0, cache)
    except StageFailed as error:
        budget.failed(n, f"cold compile {error}")
        return None
    budget.known.append((n, phases["cold_total"]))
    cold = phases["cold"]
    cold.pop("package")
    print(f"  nemc: cold {phases['cold_total']:.1f} s (process {cold['process_wall']:.1f} s), "
          f"C {cold['c_bytes'] / 1e6:.1f} MB, peak memory {cold['peak_rss_kb'] / 1e3:.0f} MB",
          flush=True)
    return {"cold": cold, "cold_total": phases["cold_total"], "loadavg": common.load_average()}


def measure_mechanics(n: int, path: Path, config: Config, budget: Budget,
                      row: dict[str, Any]) -> None:
    if not budget.allows(n):
        return
    here = str(Path(__file__).resolve().parent)
    try:
        out, wall = common.python_run(MECHANICS_SCRIPT, [str(path), here], config.mechanics_budget)
    except StageFailed as error:
        budget.failed(n, str(error))
        return
    row["sympy.physics.mechanics"] = {"derive_seconds": float(out), "process_wall": wall}
    budget.known.append((n, wall))
    print(f"  sympy.physics.mechanics: KanesMethod {float(out):.2f} s", flush=True)


def measure_peer(name: str, n: int, path: Path, config: Config, budget: Budget,
                 row: dict[str, Any]) -> None:
    if not budget.allows(n):
        return
    spec = {"peer": name, "path": str(path), "reference_file": None, "rounds": config.rounds,
            "sample_seconds": config.sample_seconds}
    run = peers.run_worker(spec, config.peer_budget)
    row.setdefault("peers", {})[name] = run
    if "failure" in run:
        budget.failed(n, f"failed: {run['failure']}")
        return
    budget.known.append((n, run["wall_seconds"]))
    print(f"  {name}: build {sum(run['build_seconds'].values()):.2f} s, RHS "
          f"{fmt_time(run['rhs_seconds'][peers.PEER_NAMES[name]]['median'])}", flush=True)


def fits(rows: dict[int, dict[str, Any]]) -> dict[str, Any]:
    """Power-law exponents of every cost measured at two or more n."""
    series: dict[str, list[tuple[int, float]]] = {}

    def add(label: str, n: int, value: float | None) -> None:
        if value:
            series.setdefault(label, []).append((n, value))

    for n, row in sorted(rows.items()):
        ours = row.get("nemc")
        if ours:
            add("nemc cold compile total (s)", n, ours["cold_total"])
            for stage, seconds in ours["cold"]["timings"].items():
                if stage in ("derive", "optimize", "emit", "build"):
                    add(f"nemc {stage} (s)", n, seconds)
            add("nemc cached load (s)", n, ours["cached_load"]["median"])
            add("nemc generated C (bytes)", n, ours["cold"]["c_bytes"])
            for label, t in ours["rhs"].items():
                add(f"nemc RHS {label} (s)", n, t["median"])
        if "sympy.physics.mechanics" in row:
            add("sympy.physics.mechanics KanesMethod (s)", n,
                row["sympy.physics.mechanics"]["derive_seconds"])
        for name, run in row.get("peers", {}).items():
            if "rhs_seconds" in run:
                add(f"{peers.PEER_NAMES[name]} RHS per call (s)", n,
                    run["rhs_seconds"][peers.PEER_NAMES[name]]["median"])
                add(f"{peers.PEER_NAMES[name]} build (s)", n, sum(run["build_seconds"].values()))
    return {label: {**(common.power_fit([n for n, _ in pts], [v for _, v in pts]) or {}),
                    "points": pts} for label, pts in series.items() if len(pts) >= 2}


def run(config: Config) -> dict[str, Any]:
    result: dict[str, Any] = {"environment": common.environment(config.mode),
                              "config": asdict(config), "rows": {}, "notes": [],
                              "peers": peers.installed()}
    result["notes"].append(f"octave: {peers.octave_note()}")
    notes = result["notes"]
    budgets = {"nemc": Budget("nemc cold compile", config.compile_budget, notes),
               "mechanics": Budget("sympy.physics.mechanics derivation", config.mechanics_budget,
                                   notes)}
    for name, version in result["peers"].items():
        if config.peers and version:
            budgets[name] = Budget(f"peer {name}", config.peer_budget, notes)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nemc-bench-scaling-") as folder:
        paths = common.write_chains(config.sizes, Path(folder), mixed=True)
        for name, path in paths.items():
            n = common.chain_size(name)
            print(f"{name}:", flush=True)
            row: dict[str, Any] = {"n_state": 2 * n}
            cache = Path(folder) / f"cache{n}"
            cache.mkdir()
            measure_nemc(n, path, cache, config, budgets["nemc"], row)
            measure_mechanics(n, path, config, budgets["mechanics"], row)
            for peer in [p for p in peers.PEER_NAMES if p in budgets]:
                measure_peer(peer, n, path, config, budgets[peer], row)
            result["rows"][n] = row
        result["long"] = long_chains(config, Path(folder), notes)
    result["fits"] = fits(result["rows"])
    points = [(n, row["cold_total"]) for n, row in result["long"].items()]
    if len(points) >= 2:
        result["fits"]["nemc cold compile, long chains (s)"] = {
            **(common.power_fit([n for n, _ in points], [v for _, v in points]) or {}),
            "points": points}
    common.finish_environment(result["environment"], start)
    return result


def long_chains(config: Config, folder: Path, notes: list[str]) -> dict[int, dict[str, Any]]:
    """Cold compiles of the long chains (config.long_sizes), under the compile budget."""
    budget, found = Budget("nemc cold compile (long chains)", config.compile_budget, notes), {}
    (folder / "long").mkdir(exist_ok=True)
    method = "nemc.Radau" if config.long_jacobian else "DOP853"  # implicit: with the Jacobian
    chains = common.write_chains(config.long_sizes, folder / "long", mixed=True, method=method)
    for name, path in chains.items():
        n = common.chain_size(name)
        print(f"{name} (cold compile only):", flush=True)
        cache = folder / f"long-cache{n}"
        cache.mkdir()
        row = measure_long(n, path, cache, config, budget)
        if row is not None:
            found[n] = row
    return found


# -- output -------------------------------------------------------------------------------------


def md_table(rows: dict[int, dict[str, Any]]) -> list[str]:
    stages = ("derive", "optimize", "emit", "build")
    lines = ["## nemc, per n (cold: fresh process and cache; RHS: median, min–max)", "",
             "| n | " + " | ".join(stages) + " | cold total | cached load: first call in a fresh "
             "process (imports included) | cached load: second call | C source | RHS in C "
             "(per state) | RHS from Python (per call) | sympy.physics.mechanics derive |",
             "|" + " --- |" * (len(stages) + 8)]
    for n, row in sorted(rows.items()):
        ours, mech = row.get("nemc"), row.get("sympy.physics.mechanics")
        mech_cell = f"{mech['derive_seconds']:.2f} s" if mech else "–"
        if not ours:
            lines.append(f"| {n} |" + " – |" * (len(stages) + 6) + f" {mech_cell} |")
            continue
        t = ours["cold"]["timings"]
        lines.append(
            f"| {n} | " + " | ".join(f"{t.get(s, 0):.3f}" for s in stages)
            + f" | {ours['cold_total']:.2f} s | {spread(ours['cached_load'])} | "
            f"{spread(ours['cached_load_again'])} | "
            f"{ours['cold']['c_bytes'] / 1e3:.0f} kB | "
            f"{spread(ours['rhs']['C (rhs_many, per state)'])} | "
            f"{spread(ours['rhs']['Python (closure per call)'])} | {mech_cell} |")
    return lines + [""]


def md_long(long: dict[int, dict[str, Any]], jacobian: bool = False) -> list[str]:
    if not long:
        return []
    stages = ("validate", "derive", "optimize", "emit", "build")
    what = ", with the analytic Jacobian (method nemc.Radau)" if jacobian else ""
    lines = [f"## Long chains: cold compile{what} (fresh process and cache, once each)", "",
             "| n | " + " | ".join(stages) + " | cold total | process wall | C source | peak "
             "memory (the compiling process) | load average |",
             "|" + " --- |" * (len(stages) + 6)]
    for n, row in sorted(long.items()):
        cold, t = row["cold"], row["cold"]["timings"]
        lines.append(f"| {n} | " + " | ".join(f"{t.get(s, 0):.2f}" for s in stages)
                     + f" | {row['cold_total']:.1f} s | {cold['process_wall']:.1f} s | "
                     f"{cold['c_bytes'] / 1e6:.1f} MB | {cold['peak_rss_kb'] / 1e3:.0f} MB | "
                     f"{row['loadavg']} |")
    return lines + [""]


def md_peers(rows: dict[int, dict[str, Any]]) -> list[str]:
    runs = [(n, name, run) for n, row in sorted(rows.items())
            for name, run in row.get("peers", {}).items()]
    if not runs:
        return []
    lines = ["## Peers, per n (RHS per call from Python, interleaved with nemc's closure in the "
             "peer's process)", "", "| n | peer | build | peer RHS | nemc closure | peer / nemc |",
             "| --- | --- | --- | --- | --- | --- |"]
    for n, name, run in runs:
        label = peers.PEER_NAMES[name]
        if "failure" in run:
            lines.append(f"| {n} | {label} | failed: {run['failure']} | – | – | – |")
            continue
        theirs, ours = run["rhs_seconds"][label], run["rhs_seconds"]["nemc closure"]
        lines.append(f"| {n} | {label} | {sum(run['build_seconds'].values()):.2f} s | "
                     f"{spread(theirs)} | {spread(ours)} | "
                     f"{theirs['median'] / ours['median']:.1f} |")
    return lines + [""]


def md_fits(fitted: dict[str, Any]) -> list[str]:
    lines = ["## Growth with n: cost ~ c n^p (least squares in log-log)", "",
             "| quantity | p | c | n fitted | rms log residual |",
             "| --- | --- | --- | --- | --- |"]
    for label, f in fitted.items():
        lines.append(f"| {label} | {f['exponent']:.2f} | {f['prefactor']:.3g} | "
                     f"{', '.join(str(n) for n in f['n'])} | {f['rms_log_residual']:.2f} |")
    return lines + [""]


def md_targets(rows: dict[int, dict[str, Any]]) -> list[str]:
    ours = rows.get(32, {}).get("nemc")
    if not ours:
        return ["## Issue 5's targets at 32 bodies: not measured (see the notes)", ""]
    measured = {"cold compile (derive + emit + compile)": ours["cold_total"],
                "cached load: first call in a fresh process (imports included)":
                    ours["cached_load"]["median"],
                "cached load: second call": ours["cached_load_again"]["median"],
                "RHS in C": ours["rhs"]["C (rhs_many, per state)"]["median"]}
    lines = ["## Issue 5's targets at 32 bodies (this run, this machine)", "",
             "| quantity | target | measured |", "| --- | --- | --- |"]
    lines += [f"| {k} | {fmt_time(TARGETS_32[k])} | {fmt_time(v)} |" for k, v in measured.items()]
    return lines + [""]


def markdown(result: dict[str, Any]) -> str:
    rows = {int(n): r for n, r in result["rows"].items()}
    lines = ["# nemc scaling benchmark", ""] + common.md_environment(result["environment"])
    lines += ["", "Chains of n uniform rods (m = 1, L = 1), every third joint prismatic, the "
              "others revolute (relative angles), each with a damped joint spring; gravity.", ""]
    long = {int(n): r for n, r in result.get("long", {}).items()}
    jacobian = result["config"].get("long_jacobian", False)
    lines += (md_table(rows) + md_long(long, jacobian) + md_targets(rows) + md_peers(rows)
              + md_fits(result["fits"]))
    if result["notes"]:
        lines += ["## Notes", ""] + [f"- {n}" for n in result["notes"]] + [""]
    return "\n".join(lines)


def plot(result: dict[str, Any], folder: Path) -> list[Path]:
    import plots

    fitted = result["fits"]
    groups = {
        "scaling_compile.png": ("Compile and derive time vs n", "seconds",
                                [k for k in fitted if k.endswith("(s)") and "RHS" not in k]),
        "scaling_rhs.png": ("RHS cost vs n", "seconds per evaluation",
                            [k for k in fitted if "RHS" in k]),
        "scaling_size.png": ("Generated C size vs n", "bytes",
                             [k for k in fitted if "bytes" in k]),
    }
    paths = []
    for filename, (title, ylabel, labels) in groups.items():
        if not labels:
            continue
        fig, ax = plots.plt.subplots(figsize=(7.5, 5.5))
        for k, label in enumerate(labels):
            f = fitted[label]
            ns, values = zip(*f["points"])
            ax.plot(ns, values, "-o", color=f"C{k % 10}", markersize=4,
                    label=f"{label}: n^{f['exponent']:.2f}")
        plots.log_axes(ax, "bodies n", ylabel,
                       f"{title} (mixed chain, {result['environment']['mode']} run)")
        paths.append(plots.save(fig, folder / filename))
    return paths


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = common.mode_parser(
        __doc__.splitlines()[0], "n in {2, 4, 8}, no peers", "n in {2, 3}, for tests"
    )
    parser.add_argument("--long-jacobian", action="store_true",
                        help="the long chains built with the analytic Jacobian (nemc.Radau)")
    parser.add_argument("--long-sizes", type=lambda s: tuple(int(v) for v in s.split(",") if v),
                        help="long chains compiled cold only, comma-separated (default: the "
                        "mode's; full: 200,500,1000)")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    config = MODES[mode] if args.sizes is None else replace(MODES[mode], sizes=args.sizes)
    if args.long_sizes is not None:
        config = replace(config, long_sizes=args.long_sizes)
    config = replace(config, long_jacobian=args.long_jacobian)
    print(f"nemc scaling benchmark, {mode} mode", flush=True)
    result = run(config)
    folder = args.out or RESULTS
    folder.mkdir(parents=True, exist_ok=True)
    name = f"scaling-{common.stamp()}-{mode}"
    common.write_json(result, folder / f"{name}.json")
    (folder / "scaling-latest.json").write_text(json.dumps(result, indent=1, default=float))
    text = markdown(result)
    (folder / "scaling-latest.md").write_text(text)
    written = [folder / f"{name}.json", folder / "scaling-latest.json",
               folder / "scaling-latest.md", *plot(result, folder)]
    print(text)
    print("written: " + ", ".join(str(p) for p in written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
