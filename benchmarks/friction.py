"""Exact Coulomb friction's cost (issue 50): the belt-driven stick-slip oscillator over 100
periods, nemc's friction (stick and slip switched at located events) against solve_ivp with a
smooth tanh law (benchmarks/stick_slip_tanh.py, Brown and McPhee's law with its static peak).

Run: `python benchmarks/friction.py [--quick | --smoke] [--out DIR]`; part of `make bench`.
Results: benchmarks/results/friction-latest.{json,md} (smoke: a temporary folder).

System: tests/contact_reference.py's StickSlip (m 1, k 100, mu_s 0.4, mu_k 0.3, belt at 0.1 m/s,
started stuck at x = 0), in nemc as examples/stick_slip.yaml with mu_s = 0.4, v_b = 0.1 (the
belt's frame). Error: the largest |x' - v_belt| / v_belt at 9 points inside each of the closed
form's stick phases (the smooth law creeps there; nemc's is exactly 0), and for nemc the largest
switch-time error against the closed form. Timing: in each of `rounds` rounds every contender
once, one after the other under the same load (nemc's runs in calibrated loops, each tanh run
once: it takes about a second); medians; the ratio is tanh's median over nemc.Vern9's, its range
that of the per-round ratios. The load average is recorded at the start and the end.
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
import stick_slip_tanh  # noqa: E402
from common import ROOT, fmt_time  # noqa: E402

import nemc  # noqa: E402
from nemc.runtime.runs import interrupts_raise  # noqa: E402

REF = stick_slip_tanh.REF
EXAMPLE = ROOT / "examples" / "stick_slip.yaml"
PARAMS = {"mu_s": 0.4, "v_b": 0.1}  # the reference's oscillator (mu, k, m, g as the example's)
RTOL = 1e-9
TARGET = 50.0  # the bound: nemc at least this much faster at equal (or better) error


@dataclass(frozen=True)
class Config:
    mode: str
    periods: int
    methods: tuple[str, ...]
    v0s: tuple[float, ...]
    rounds: int
    sample_seconds: float


MODES = {
    "full": Config("full", 100, ("nemc.Vern9", "nemc.DOP853"), (1e-6, 1e-7, 1e-8), 5, 0.2),
    "quick": Config("quick", 100, ("nemc.Vern9",), (1e-7,), 3, 0.1),
    "smoke": Config("smoke", 5, ("nemc.Vern9",), (1e-4,), 1, 0.01),
}


def nemc_errors(result: Any, p: Any, t_end: float) -> dict[str, float]:
    """The run's stick-phase error (as the tanh law's) and its switch times' error."""
    speeds = result.outputs["speed"]
    stick = float(np.max(np.abs(speeds - p.v_belt)) / p.v_belt)
    times, _ = result.events["belt.stick_slip"]
    closed = [t for t, _ in REF.stick_slip_switches(p, t_end) if t < t_end - 1e-6]
    times = times[times < t_end - 1e-6]
    switches = float(np.max(np.abs(times - closed))) if len(times) == len(closed) else np.inf
    return {"stick_error": stick, "switch_error": switches, "switches": len(times)}


def run(config: Config) -> dict[str, Any]:
    env = common.environment(config.mode)
    started = time.perf_counter()
    p = REF.StickSlip()
    t_end = p.x_static / p.v_belt + config.periods * REF.stick_slip_cycle(p).period
    samples = np.concatenate([a + (b - a) * stick_slip_tanh.SAMPLES
                              for a, b in REF.stick_slip_stick_intervals(p, t_end)])
    rows: list[dict[str, Any]] = []
    interrupted = False
    try:
        with interrupts_raise():
            model = nemc.compile(EXAMPLE)
            calls = {}
            for method in config.methods:
                options = {"params": PARAMS, "method": method, "rtol": RTOL,
                           "atol": RTOL * 1e-3}
                checked = model.simulate((0.0, t_end), t_eval=np.sort(samples), **options)
                assert checked.success, checked.message
                rows.append({"contender": method, "v0": 0.0, "nfev": int(checked.nfev),
                             **nemc_errors(checked, p, t_end)})
                calls[method] = (lambda o=options: model.simulate((0.0, t_end), t_eval=[t_end],
                                                                    **o), 1)
            loops = {name: common.loop_count(call, config.sample_seconds)
                     for name, (call, _) in calls.items()}
            tanh = {v0: [] for v0 in config.v0s}
            samples: dict[str, list[float]] = {name: [] for name in calls}
            for _ in range(config.rounds):  # each round: every contender once, interleaved
                for name, (call, _) in calls.items():
                    samples[name].append(common.time_loop(call, loops[name]))
                for v0 in config.v0s:
                    tanh[v0].append(stick_slip_tanh.run_tanh(v0, RTOL, periods=config.periods))
            for row in rows:
                row["time"] = common.summary(samples[row["contender"]])
            for v0, runs in tanh.items():
                rows.append({"contender": f"solve_ivp {runs[0]['method']}, tanh law",
                             "v0": v0, "nfev": int(runs[0]["nfev"]),
                             "success": all(r["success"] for r in runs),
                             "stick_error": runs[0]["stick_error"], "switch_error": None,
                             "time": common.summary([r["time_s"] for r in runs]),
                             "per_round": [r["time_s"] / n for r, n in
                                           zip(runs, samples["nemc.Vern9"])]})
                print(f"  tanh v0 {v0:g}: {fmt_time(rows[-1]['time']['median'])}", flush=True)
    except KeyboardInterrupt:  # the rows done are kept
        interrupted = True
    common.finish_environment(env, started)
    return {"environment": env, "config": config.__dict__, "rows": rows, "t_end": t_end,
            "rtol": RTOL, "target": TARGET, "interrupted": interrupted}


def ratio_to(rows: Sequence[dict[str, Any]], row: dict[str, Any]) -> str:
    """Row's median time over nemc.Vern9's, with the range of the per-round ratios (each
    round timed both, one after the other, under the same load)."""
    base = next((r for r in rows if r["contender"] == "nemc.Vern9"), None)
    if base is None:
        return ""
    ratio = row["time"]["median"] / base["time"]["median"]
    rounds = row.get("per_round")
    if not rounds:
        return f"{ratio:.0f}x"
    return f"{ratio:.0f}x ({min(rounds):.0f}x .. {max(rounds):.0f}x)"


def markdown(result: dict[str, Any]) -> str:
    rows = result["rows"]
    lines = ["# Exact Coulomb friction: the stick-slip oscillator against a tanh law", "",
             *common.md_environment(result["environment"]), "",
             f"{result['config']['periods']} periods ({result['t_end']:.3f} s) at rtol "
             f"{result['rtol']:g}. Stick error: the largest |x' - v_belt| / v_belt inside the "
             "closed form's stick phases; switch error: nemc's switch times against the closed "
             "form. Time: median (range); ratio: over nemc.Vern9's median (range: per round).",
             "",
             "| contender | v0 | rhs calls | stick error | switch error | time | ratio |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for row in rows:
        switch = "" if row["switch_error"] is None else f"{row['switch_error']:.1e} s"
        v0 = "exact" if row["v0"] == 0.0 else f"{row['v0']:g}"
        ok = "" if row.get("success", True) else " (failed)"
        lines.append(f"| {row['contender']}{ok} | {v0} | {row['nfev']} | "
                     f"{row['stick_error']:.1e} | {switch} | {common.spread(row['time'])} | "
                     f"{ratio_to(rows, row)} |")
    if result["interrupted"]:
        lines += ["", "Interrupted (Ctrl-C): only the rows above were measured."]
    lines += ["", f"Issue 50's target: nemc at least {result['target']:.0f}x faster than the "
              "tanh law at equal error in the stick phases (nemc's is exactly 0; the tanh "
              "law's shrinks only with v0)."]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = common.mode_parser(__doc__.splitlines()[0], "nemc.Vern9 and one v0, fewer rounds",
                                "5 periods, one round (tests)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    print(f"nemc friction benchmark, {mode} mode", flush=True)
    result = run(MODES[mode])
    folder = common.results_folder(args, "nemc-bench-friction-")
    folder.mkdir(parents=True, exist_ok=True)
    common.write_json(result, folder / "friction-latest.json")
    text = markdown(result)
    (folder / "friction-latest.md").write_text(text)
    print(text)
    print(f"written: {folder / 'friction-latest.json'}, {folder / 'friction-latest.md'}")
    return 130 if result["interrupted"] else 0


if __name__ == "__main__":
    sys.exit(main())
