"""nemc's default method ("auto") against every native method at equal final error (issue 19).

Run: `python benchmarks/auto.py [--quick | --smoke] [--out DIR]`; part of `make bench`.
Results: benchmarks/results/auto-latest.{json,md} (quick: benchmarks/results/quick/; smoke: a
temporary folder).

Systems: the book's double pendulum over [0, 20], chains of 3, 4 and 8 uniform rods over [0, 5]
(`common.chain_yaml`) and examples/free_body_on_spring.yaml over [0, 10] (3 coordinates, as the
3-link chain: where "auto"'s bound for nemc.Taylor falls), each from a scene that names no
method, so `simulate()` runs "auto"; and
the book's stiff 5.4 arm over [0, 15] and with its gains x100 over [0, 2] (benchmarks/stiff.py's
case), whose scene names nemc.Radau, run with method="auto" named.
Contenders: "auto" and nemc.DOP853, nemc.Vern9, nemc.Taylor, nemc.Radau. For each target final
error (1e-6, 1e-9, 1e-12; error = max |y(t_end) - reference|) each contender runs at the loosest
rtol of benchmarks/native.py's quarter-decade ladder (atol = rtol x 1e-3) whose error is at most
the target, found for that contender itself; the contenders of a cell are then timed interleaved
(median (min-max) over rounds). Every contender's first call (which builds a Taylor or Jacobian
part the model lacks) is made before any timing and reported apart. Ratio: the fastest native
method's time / auto's time (1 or more: auto is as fast as the best; the issue asks >= 0.8).
Reference: benchmarks/native.py's (nemc.Vern9 at rtol 10^-13.5, checked against itself at 1e-13
and against scipy's DOP853 with nemc's C RHS).
"""

from __future__ import annotations

import re
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
from common import ROOT, fmt_time, spread  # noqa: E402
from native import loosest_rtol, nemc_solver, reference  # noqa: E402

import nemc  # noqa: E402

AUTO = "auto"
METHODS = ("nemc.DOP853", "nemc.Vern9", "nemc.Taylor", "nemc.Radau")
TARGETS = (1e-6, 1e-9, 1e-12)
GAINS_X100 = {"b01": 45000.0, "g01": 30000.0, "b12": 20000.0, "g12": 30000.0}
MODES = {  # rounds, seconds per timed sample, a search run longer than this ends the search
    "smoke": (1, 0.01, 0.5),
    "quick": (3, 0.05, 2.0),
    "full": (5, 0.1, 5.0),
}


def without_method(text: str) -> str:
    """The YAML with its scene's `method:` line removed: simulate() then runs "auto"."""
    return re.sub(r"(?m)^\s+method:.*\n", "", text)


def systems(mode: str) -> list[tuple[str, Any, tuple[float, float], dict[str, float]]]:
    """(label, model, span, parameters) of each case."""
    pendulum = (ROOT / "examples" / "double_pendulum.yaml").read_text()
    cases = [("double pendulum [0, 20]", nemc.compile(text=without_method(pendulum)),
              (0.0, 20.0), {})]
    for n in (4,) if mode == "smoke" else (3, 4, 8):
        cases.append((f"{n}-link chain [0, 5]",
                      nemc.compile(text=without_method(common.chain_yaml(n))), (0.0, 5.0), {}))
    if mode != "smoke":  # 3 coordinates too, a free body: where the rule's bound falls
        body = (ROOT / "examples" / "free_body_on_spring.yaml").read_text()
        cases.append(("free body on a spring [0, 10]", nemc.compile(text=without_method(body)),
                      (0.0, 10.0), {}))
    arm = nemc.compile(ROOT / "examples" / "two_link_robot_arm.yaml")
    cases.append(("5.4 stiff arm [0, 15]", arm, (0.0, 15.0), {}))
    if mode != "smoke":
        cases.append(("5.4 gains x100 [0, 2]", arm, (0.0, 2.0), GAINS_X100))
    return cases


def solver(model, method: str, span, times, params: dict[str, float]):
    """native.nemc_solver at these parameters; auto is simulate(method=None) when the scene
    names no method (the default a user gets), else method="auto"."""
    if not params:
        named = None if method == AUTO and model.scene["method"] is None else method
        return nemc_solver(model, named, span, times)
    y0 = model.initial_state(params)

    def solve(rtol: float):
        res = model.simulate(span, y0, method=method, rtol=rtol, atol=rtol * 1e-3,
                             t_eval=times, params=params)
        return (res.y if res.success else None), res.nfev

    return solve


def first_calls(model, span, params: dict[str, float]) -> dict[str, float]:
    """Seconds of each contender's first call at rtol 1e-3 (building a missing part)."""
    seconds = {}
    for method in (AUTO, *METHODS):
        seconds[method], _ = common.timed(lambda m=method: solver(model, m, span, list(span),
                                                                  params)(1e-3))
    return seconds


def chosen_method(model, span, params, rtol: float) -> str:
    res = model.simulate(span, model.initial_state(params), method=AUTO, rtol=rtol,
                         atol=rtol * 1e-3, params=params, t_eval=list(span))
    return res.method


def run_system(label: str, model, span, params, mode: str) -> dict[str, Any]:
    rounds, sample, give_up = MODES[mode]
    times = list(span)
    print(f"{label}:", flush=True)
    builds = first_calls(model, span, params)
    ref = reference_at(model, span, times, params)
    solvers = {name: solver(model, name, span, times, params) for name in (AUTO, *METHODS)}
    rows = []
    for target in TARGETS if mode != "smoke" else TARGETS[:1]:
        found = {name: loosest_rtol(s, ref["y"], target, 0, give_up)
                 for name, s in solvers.items()}
        timings = common.interleaved({name: (lambda s=solvers[name], r=f.rtol: s(r), 1)
                                      for name, f in found.items() if f.reached},
                                     rounds, sample)
        best = min((timings[m]["median"] for m in METHODS if m in timings), default=None)
        auto = timings.get(AUTO, {}).get("median")
        ratio = best / auto if best and auto else None
        rows.append({"target": target, "ratio": ratio,
                     "auto_chose": chosen_method(model, span, params, found[AUTO].rtol),
                     "contenders": {name: {"rtol": f.rtol, "error": f.error, "nfev": f.nfev,
                                           "reached": f.reached, **timings.get(name, {})}
                                    for name, f in found.items()}})
        print(f"  target {target:g}: auto ({rows[-1]['auto_chose']}) "
              f"{fmt_time(auto) if auto else 'not reached'}; best other "
              f"{fmt_time(best) if best else '-'}; ratio {ratio or 0:.2f}", flush=True)
    return {"system": label, "t_span": list(span), "params": params, "first_call_s": builds,
            "reference": {k: v for k, v in ref.items() if k != "y"}, "rows": rows}


def reference_at(model, span, times, params):
    if not params:
        return reference(model, span, times)
    tight = solver(model, "nemc.Vern9", span, times, params)(10.0 ** -13.5)[0]
    check = solver(model, "nemc.Radau", span, times, params)(1e-10)[0]
    difference = float(abs(tight - check).max())
    print(f"  reference: nemc.Vern9 at rtol 10^-13.5; nemc.Radau at 1e-10 differs by "
          f"{difference:.1e}", flush=True)
    return {"method": "nemc.Vern9", "rtol": 10.0 ** -13.5, "y": tight,
            "cross_check": "nemc.Radau at rtol 1e-10", "cross_check_difference": difference}


def markdown(result: dict[str, Any]) -> str:
    lines = ["# The default method (auto) against each native method at equal error", "",
             *common.md_environment(result["environment"]), "",
             "Each contender at the loosest rtol whose final error is at most the target; time: "
             "median (min-max) of interleaved rounds. Ratio: the fastest native method's time /"
             " auto's (1 or more: auto as fast as the best). First calls (which build a part "
             "the model lacks) are listed apart, untimed in the table.", ""]
    for system in result["systems"]:
        lines += [f"## {system['system']}", "", "First call (s): " + ", ".join(
            f"{m} {s:.2f}" for m, s in system["first_call_s"].items()), "",
            "| target | auto chose | ratio | " + " | ".join((AUTO, *METHODS)) + " |",
            "| --- | --- | --- |" + " --- |" * (1 + len(METHODS))]
        for row in system["rows"]:
            cells = []
            for name in (AUTO, *METHODS):
                c = row["contenders"][name]
                cells.append(f"{spread(c)}, rtol {c['rtol']:.2g}"
                             if "median" in c else f"not reached ({c['error']:.1e})")
            ratio = f"**{row['ratio']:.2f}**" if row["ratio"] else "-"
            lines.append(f"| {row['target']:g} | {row['auto_chose']} | {ratio} | "
                         + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = common.mode_parser(__doc__.splitlines()[0], "3 rounds (a few minutes)",
                                "one target, smallest systems (a check that it runs)")
    args = parser.parse_args(argv)
    mode = common.mode_of(args)
    environment = common.environment(mode)
    started = time.perf_counter()
    result = {"environment": environment,
              "systems": [run_system(*case, mode) for case in systems(mode)]}
    common.finish_environment(environment, started)
    common.write_results(result, common.results_folder(args, "nemc-auto-"), "auto",
                         markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
