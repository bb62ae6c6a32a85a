"""The accuracy table of docs/fmu.md ("Accuracy and speed"), made with tests/test_fmu.py's own
functions over every example an FMU export takes (those with Coulomb friction or contacts
are refused): FMPy's validation of the four FMUs (FMI 2, 3; model exchange, co-simulation),
model exchange with FMPy's CVode at rtol 1e-10 (and 1e-12 where 1e-10 misses 1e-6) against
nemc.Radau at rtol 1e-12, and co-simulation against nemc's own runs step by step.

Run: `python benchmarks/fmu_accuracy.py [EXAMPLE ...]` (several minutes over all examples).
Prints the Markdown table; writes nothing.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

import test_fmu as fmu_tests  # noqa: E402  (the tests' own functions)
from fmpy.validation import validate_fmu  # noqa: E402

import nemc  # noqa: E402

KINDS = [(2, "me"), (2, "cs"), (3, "me"), (3, "cs")]


def row(example: str, folder: Path) -> str:
    """One example's row: validation problems, ME errors, CS agreement and method."""
    model = nemc.compile(fmu_tests.EXAMPLES / f"{example}.yaml")
    # a gear pair's equation "as at the start" is met by any start: never a kinematic analysis
    moving = model.metadata.get("constraint_starts") or not fmu_tests.kinematic(model)
    paths = {(fmi, kind): str(model.export_fmu(folder / f"{example}_{fmi}{kind}.fmu", fmi=fmi,
                                               kind=kind)) for fmi, kind in KINDS}
    problems = ", ".join(str(len(validate_fmu(paths[k]))) for k in KINDS)
    _, _, step = fmu_tests.scene_times(model)
    times, states = fmu_tests.fmpy_states(paths[2, "me"], model, 1e-10, step)
    error = fmu_tests.radau_error(model, times, states)
    residual = ""
    if model.has_loops and moving:
        residual = f" (residual {model.constraint_residual(states, times).max():.0e})"
    tight = ""
    if error > 1e-6:
        times, states = fmu_tests.fmpy_states(paths[2, "me"], model, 1e-12, step / 10)
        tight = f"{fmu_tests.radau_error(model, times, states):.1e}"
    same, method = [], ""
    for fmi in (2, 3):
        times, states, method = fmu_tests.cosimulation(paths[fmi, "cs"], model, fmi, 40)
        steps = fmu_tests.nemc_steps(model, times, method)
        same.append("yes" if np.allclose(states, steps, rtol=1e-12, atol=1e-12) else "no")
    if not moving:
        method = "kinematic (no degree of freedom)"
    return (f"| {example} | {problems} | {error:.1e}{residual} | {tight} | "
            f"{', '.join(same)}; {method} |")


def main(examples: list[str]) -> None:
    print("| example | FMPy's validation problems (FMI 2 ME, CS; FMI 3 ME, CS) | ME: largest "
          "difference from nemc.Radau, CVode rtol 1e-10 | the same, rtol 1e-12 (where 1e-10 "
          "misses 1e-6) | CS: as nemc's own runs (FMI 2, 3); the FMU's method |")
    print("| --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory(prefix="nemc-fmu-table-") as folder:
        for example in examples or fmu_tests.ALL:
            print(row(example, Path(folder)), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
