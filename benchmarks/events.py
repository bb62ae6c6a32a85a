"""What locating events costs (issue 17): a run with events against the same run without.

Run: `python benchmarks/events.py [--quick | --smoke] [--out DIR]`; part of `make bench`.
Results: benchmarks/results/events-latest.{json,md} (smoke: a temporary folder).

System: the book's double pendulum (5.2) over [0, 20], twice compiled: as the book gives it, and
with one recorded event per swing (`swing: {when: q1 + pi/2}`, both directions: the first link
passing the vertical, about 20 times). The two models have the same right-hand side; every
method takes the same steps in both (checked: same step count), so the difference is what the
events cost: their function at every step's end, and at each crossing the dense output (DOP853:
3 more stages when the step has no t_eval point anyway), Brent's iterations on it, the state
there (nemc.Vern9: quintic Hermite, then polished by short Vern9 steps).
Contenders: each native method and scipy's DOP853 (events through solve_ivp), at rtol 1e-6,
1e-9, 1e-12 (atol = rtol x 1e-3), t_eval the default (every step) and 201 points. Both runs of a
cell are timed interleaved (common.interleaved: calibrated loops, rounds rotating the order);
overhead = median(with) / median(without) - 1, with the range over rounds of the per-round
ratios; the load average is recorded at the start and the end.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
from common import ROOT, fmt_time  # noqa: E402

import nemc  # noqa: E402
from nemc.runtime.runs import interrupts_raise  # noqa: E402

BOOK = ROOT / "examples" / "double_pendulum.yaml"
SPAN = (0.0, 20.0)
EVENT = "  events:\n    swing: {when: q1 + pi/2}\n"
TOLERANCES = (1e-6, 1e-9, 1e-12)
LIMIT = 0.10  # the bound on the overhead


@dataclass(frozen=True)
class Config:
    mode: str
    methods: tuple[str, ...]
    tolerances: tuple[float, ...]
    rounds: int
    sample_seconds: float


MODES = {
    "full": Config("full", ("nemc.DOP853", "nemc.Vern9", "nemc.Radau", "nemc.Taylor", "DOP853"),
                   TOLERANCES, 15, 0.2),
    "quick": Config("quick", ("nemc.DOP853", "nemc.Vern9", "nemc.Radau", "nemc.Taylor"),
                    TOLERANCES, 7, 0.1),
    "smoke": Config("smoke", ("nemc.DOP853",), (1e-6,), 3, 0.02),
}


def models(folder: Path) -> tuple[Any, Any]:
    """The book's double pendulum without and with the swing event (no t_eval in either)."""
    text = BOOK.read_text().replace("  t_eval: {step: 0.5}\n", "")
    plain, swinging = folder / "plain.yaml", folder / "swinging.yaml"
    plain.write_text(text.replace("name: double_pendulum", "name: bench_plain"))
    swinging.write_text(text.replace("name: double_pendulum", "name: bench_swinging").replace(
        "\nsimulation:\n", "\nsimulation:\n" + EVENT))  # the scene may not end the file
    return nemc.compile(plain, jacobian=True, taylor=True), nemc.compile(
        swinging, jacobian=True, taylor=True)


def cell(plain: Any, swinging: Any, method: str, rtol: float, t_eval: np.ndarray | None,
         config: Config) -> dict[str, Any]:
    """One method, tolerance and output grid: both runs timed interleaved."""
    options = {"method": method, "rtol": rtol, "atol": rtol * 1e-3, "t_eval": t_eval}
    without, with_ = plain.simulate(SPAN, **options), swinging.simulate(SPAN, **options)
    swings = len(with_.events["swing"][0])
    assert without.success and with_.success and swings >= 10, (method, rtol)
    steps = [model.simulate(SPAN, **{**options, "t_eval": None}).t for model in (plain, swinging)]
    same_steps = bool(np.array_equal(*steps))  # the events change no step
    times = common.interleaved({
        "without": (lambda: plain.simulate(SPAN, **options), 1),
        "with": (lambda: swinging.simulate(SPAN, **options), 1),
    }, config.rounds, config.sample_seconds)
    ratios = [b / a for a, b in zip(times["without"]["values"], times["with"]["values"])]
    return {"method": method, "rtol": rtol, "t_eval": "steps" if t_eval is None else t_eval.size,
            "events": swings, "nfev": [without.nfev, with_.nfev], "same_steps": same_steps,
            "without": times["without"], "with": times["with"],
            "overhead": times["with"]["median"] / times["without"]["median"] - 1,
            "overhead_range": [min(ratios) - 1, max(ratios) - 1]}


def run(config: Config) -> dict[str, Any]:
    env = common.environment(config.mode)
    started = time.perf_counter()
    cells: list[dict[str, Any]] = []
    interrupted = False
    try:
        with tempfile.TemporaryDirectory(prefix="nemc-bench-events-") as folder, \
                interrupts_raise():
            plain, swinging = models(Path(folder))
            grid = np.linspace(*SPAN, 201)
            for method in config.methods:
                for rtol in config.tolerances:
                    for t_eval in (None, grid):
                        cells.append(cell(plain, swinging, method, rtol, t_eval, config))
                        print(f"  {method} rtol {rtol:g}: {cells[-1]['overhead']:+.1%}",
                              flush=True)
    except KeyboardInterrupt:  # the cells done are kept
        interrupted = True
    common.finish_environment(env, started)
    return {"environment": env, "config": config.__dict__, "cells": cells, "limit": LIMIT,
            "interrupted": interrupted}


def markdown(result: dict[str, Any]) -> str:
    lines = ["# Event location: cost on the double pendulum (one event per swing)", "",
             *common.md_environment(result["environment"]), "",
             "Overhead = median time with the event / without - 1 (range: the per-round "
             f"ratios). Issue 17's bound: {LIMIT:.0%}.", "",
             "| method | rtol | t_eval | events | rhs calls without / with | without | with "
             "| overhead (range) | same steps |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for c in result["cells"]:
        low, high = c["overhead_range"]
        lines.append(
            f"| {c['method']} | {c['rtol']:g} | {c['t_eval']} | {c['events']} | "
            f"{c['nfev'][0]} / {c['nfev'][1]} | {fmt_time(c['without']['median'])} | "
            f"{fmt_time(c['with']['median'])} | {c['overhead']:+.1%} ({low:+.1%} .. "
            f"{high:+.1%}) | {'yes' if c['same_steps'] else 'NO'} |")
    if result["interrupted"]:
        lines += ["", "Interrupted (Ctrl-C): only the cells above were measured."]
    if not result["cells"]:
        return "\n".join(lines) + "\n"
    worst = max(result["cells"], key=lambda c: c["overhead"])
    lines += ["", f"Largest median overhead: {worst['overhead']:+.1%} ({worst['method']}, rtol "
              f"{worst['rtol']:g}, t_eval {worst['t_eval']})."]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = common.mode_parser(__doc__.splitlines()[0], "fewer rounds, native methods only",
                                "one cell (tests)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    print(f"nemc events benchmark, {mode} mode", flush=True)
    result = run(MODES[mode])
    folder = common.results_folder(args, "nemc-bench-events-")
    folder.mkdir(parents=True, exist_ok=True)
    common.write_json(result, folder / "events-latest.json")
    text = markdown(result)
    (folder / "events-latest.md").write_text(text)
    print(text)
    print(f"written: {folder / 'events-latest.json'}, {folder / 'events-latest.md'}")
    return 130 if result["interrupted"] else 0


if __name__ == "__main__":
    sys.exit(main())
