"""Which program computes the right-hand side: every form of each system's accelerations timed
as C, against the one nemc chose by estimate (nemc/c_cost.py, derive.fastest_dynamics).

Run: `python benchmarks/rhs_forms.py [--quick | --smoke] [--out DIR]`.
Results: benchmarks/results/rhs_forms-latest.{json,md} (quick: results/quick; smoke: a
temporary folder).

Each system is derived once; its forms are the articulated-body program and, up to
mass_form.MAX_COORDINATES coordinates, the mass-matrix form as derived, linearized, and
linearized with the sines and cosines of sums from those of their parts (nemc/angle_sums.py).
Each form is built as a model of its own (the system's `dynamics` replaced) and its
`rhs_many` timed over 10,000 random states (angles and rates uniform in [-1.5, 1.5]),
interleaved rounds with the order rotating; the forms' results are checked against the
articulated-body program's. The table gives each form's median time per call, nemc's estimate
(a ranking only: its offset is left out), the form nemc chose and its time over the fastest's.
Build times are not part of the timings.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
from common import ROOT  # noqa: E402

STATES = 10_000
BOOK_AND_EXAMPLES = ("compound_pendulum", "double_pendulum", "robot_arm", "two_link_robot_arm",
                     "prismatic_cart_pendulum", "weld_t_pendulum", "free_body_on_spring",
                     "damped_spring_pendulum", "joint_spring_telescope")


@dataclass(frozen=True)
class Config:
    examples: tuple[str, ...]
    chains: tuple[int, ...]
    rounds: int
    sample_seconds: float


MODES = {"full": Config(BOOK_AND_EXAMPLES, (2, 3, 4), 7, 0.1),
         "quick": Config(BOOK_AND_EXAMPLES[:4], (3,), 3, 0.05),
         "smoke": Config(("double_pendulum",), (), 2, 0.01)}


def systems(config: Config, folder: Path) -> list[tuple[str, Path]]:
    found = [(name.replace("_", " "), ROOT / "examples" / f"{name}.yaml")
             for name in config.examples]
    for n in config.chains:
        path = folder / f"chain{n}.yaml"
        path.write_text(common.chain_yaml(n))
        found.append((f"{n}-link chain", path))
    return found


def built(eqs: Any, program: Any, tag: str) -> Any:
    """A model whose right-hand side runs PROGRAM."""
    from nemc.build.builder import build
    from nemc.emit.emitted import emit
    from nemc.emit.optimize import optimize_equations
    from nemc.runtime.load import load_package

    variant = dataclasses.replace(eqs, dynamics=program)
    code = emit(variant, optimize_equations(variant))
    return load_package(build(code, f"rhs-forms-{tag}-{time.time_ns()}"))


def measure_system(path: Path, config: Config) -> dict[str, Any]:
    from nemc.derive.c_cost import estimated_ns
    from nemc.derive.equations import ARTICULATED, derive
    from nemc.front.validate import validate_text

    eqs = derive(validate_text(path.read_bytes(), str(path)))
    forms = dict(eqs.forms)
    models = {form: built(eqs, program, str(k)) for k, (form, program) in
              enumerate(forms.items())}
    states = common.random_states(2 * eqs.n, STATES)
    reference = models[ARTICULATED].rhs_many(0.0, states)
    seconds = common.interleaved(
        {form: (lambda model=model: model.rhs_many(0.0, states), STATES)
         for form, model in models.items()}, config.rounds, config.sample_seconds)
    fastest = min(seconds, key=lambda form: seconds[form]["median"])
    return {
        "coordinates": eqs.n,
        "chosen": eqs.dynamics_form,
        "fastest": fastest,
        "chosen_over_fastest": seconds[eqs.dynamics_form]["median"]
        / seconds[fastest]["median"],
        "forms": {form: {"seconds": seconds[form], "estimate_ns": estimated_ns(program),
                         "difference": float(np.max(np.abs(
                             models[form].rhs_many(0.0, states) - reference)))}
                  for form, program in forms.items()},
    }


def run(config: Config) -> dict[str, Any]:
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nemc-rhs-forms-") as folder:
        os.environ["NEMC_CACHE"] = str(Path(folder) / "cache")  # the forms' builds go here
        env = common.environment("")
        result: dict[str, Any] = {"environment": env, "config": vars(config), "systems": {}}
        for name, path in systems(config, Path(folder)):
            result["systems"][name] = measure_system(path, config)
            print(f"{name}: measured", flush=True)
    common.finish_environment(env, started)
    return result


def markdown(result: dict[str, Any]) -> str:
    lines = ["# Which program computes the right-hand side", "",
             *common.md_environment(result["environment"]), "",
             f"rhs_many over {STATES:,} random states, {result['config']['rounds']} interleaved "
             "rounds: median time per call (min-max), nemc's estimate (c_cost.estimated_ns, a "
             "ranking without its offset) in brackets. **Bold**: the form nemc chose.", "",
             "| system | n | articulated body | mass matrix | mass matrix, linearized | "
             "linearized, addition formulas | chosen / fastest |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    columns = ("articulated body", "mass matrix", "mass matrix, linearized",
               "mass matrix, linearized, addition formulas")
    for name, system in result["systems"].items():
        cells = []
        for column in columns:
            found = [(form, r) for form, r in system["forms"].items()
                     if form.startswith(column) and form.count(",") == column.count(",")]
            if not found:
                cells.append("–")
                continue
            form, r = found[0]
            text = f"{common.spread(r['seconds'])} [{r['estimate_ns']:.0f}]"
            cells.append(f"**{text}**" if form == system["chosen"] else text)
        lines.append(f"| {name} | {system['coordinates']} | {' | '.join(cells)} | "
                     f"{system['chosen_over_fastest']:.2f}x |")
    worst = max((s["chosen_over_fastest"] for s in result["systems"].values()), default=1.0)
    largest = max((r["difference"] for s in result["systems"].values()
                   for r in s["forms"].values()), default=0.0)
    lines += ["", f"The chosen form is at most {worst:.2f}x the fastest form's median. Largest "
              f"difference between a form's results and the articulated-body program's: "
              f"{largest:.1e}.", ""]
    return "\n".join(lines)


def main() -> int:
    return common.run_script(__doc__, ("the book's four systems and a 3-link chain, 3 rounds",
                                       "the double pendulum, 2 short rounds"),
                             MODES, "rhs_forms", run, markdown)


if __name__ == "__main__":
    sys.exit(main())
