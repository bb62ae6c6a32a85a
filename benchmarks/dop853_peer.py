"""nemc.DOP853 against numbalsoda's dop853 at the same tolerances (issue 19's driver target).

Run: `python benchmarks/dop853_peer.py [--quick | --smoke] [--sizes 4,8] [--out DIR]`.
Results: benchmarks/results/dop853_peer-latest.{json,md} (smoke: a temporary folder).

numbalsoda (0.3.4; `pip install numbalsoda numba`, apart from the peers extra: PyPI has no wheel
of it for CPython 3.11 and its source build needs a Fortran compiler, while its cp310 wheel's
Fortran libraries load in any CPython through ctypes) runs Hairer's DOP853 in Fortran on a
numba cfunc of benchmarks/peers.py's straight-line program (Kane's M and F with sympy's cse,
LDL^T in named intermediates): the setup of issue 19's measurement. nemc runs
`simulate(method="nemc.DOP853")` on its own C right-hand side. Both take the same rtol, atol =
rtol x 1e-3 and 101 output times (each its own DOP853 dense output), so they take nearly the
same steps (Hairer's step-size factors bounds 0.333-6, scipy's, which nemc.DOP853 follows,
0.2-10): both RHS call counts are reported, and the time per RHS call.

Systems: the book's double pendulum over [0, 20]; in full and quick mode also chains of n
uniform rods (`common.chain_yaml(n)`; full: 4 and 8, quick: 4) over [0, 5]. rtol 1e-6 and
1e-10. Each pair is timed interleaved (calibrated loops, the order rotating each round),
medians and min-max over the rounds. The right-hand side alone is timed the same way, each in
its own compiled loop over 10,000 states (nemc: `rhs_many`; numbalsoda: a numba loop calling
the cfunc's function), so a run's time per RHS call less the RHS alone is the driver's own
work per call. The answers are checked against each other (largest difference over the
output times).
"""

from __future__ import annotations

import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
import peers  # noqa: E402
from common import ROOT, spread  # noqa: E402

PENDULUM = ROOT / "examples" / "double_pendulum.yaml"
RHS_STATES = 10_000


@dataclass(frozen=True)
class Config:
    chains: tuple[int, ...]
    rtols: tuple[float, ...]
    rounds: int
    sample_seconds: float


MODES = {"full": Config((4, 8), (1e-6, 1e-10), 7, 0.2),
         "quick": Config((4,), (1e-6, 1e-10), 3, 0.1),
         "smoke": Config((), (1e-6,), 2, 0.01)}


def systems(config: Config, folder: Path) -> list[tuple[str, Path, tuple[float, float]]]:
    found = [("double pendulum", PENDULUM, (0.0, 20.0))]
    for n in config.chains:
        path = folder / f"chain{n}.yaml"
        path.write_text(common.chain_yaml(n))
        found.append((f"{n}-link chain", path, (0.0, 5.0)))
    return found


def measure_system(name: str, path: Path, span: tuple[float, float],
                   config: Config) -> dict[str, Any]:
    import nemc

    model = nemc.compile(path)
    y0, times = model.initial_state(), np.linspace(*span, 101)
    build_start = time.perf_counter()
    peer = peers.build_numbalsoda(peers.mechanics_model(path), Path(tempfile.mkdtemp()))
    out: dict[str, Any] = {"peer_build_seconds": time.perf_counter() - build_start, "runs": {}}
    states = common.random_states(model.n_state, RHS_STATES)  # (n_state, k) view of rows
    rows = np.ascontiguousarray(states.T)
    out["rhs"] = common.interleaved(
        {"nemc C RHS (rhs_many)": (lambda: model.rhs_many(0.0, states), RHS_STATES),
         "numba cfunc RHS (numba loop)": (lambda: peer.rhs_loop(rows), RHS_STATES)},
        config.rounds, config.sample_seconds)
    for rtol in config.rtols:
        def ours(rtol: float = rtol) -> Any:
            return model.simulate(span, y0, method="nemc.DOP853", t_eval=times, rtol=rtol,
                                  atol=rtol * 1e-3)

        def theirs(rtol: float = rtol) -> tuple[Any, int]:
            return peer.solvers["dop853"](span, y0, times, rtol)

        result, (their_y, their_calls) = ours(), theirs()
        seconds = common.interleaved({"nemc.DOP853": (ours, 1), "numbalsoda dop853": (theirs, 1)},
                                     config.rounds, config.sample_seconds)
        out["runs"][f"{rtol:g}"] = {
            "succeeded": bool(result.success and their_y is not None),
            "rhs_calls": {"nemc.DOP853": int(result.nfev), "numbalsoda dop853": their_calls},
            "difference": float(np.max(np.abs(result.y - their_y))) if their_y is not None
            else None,
            "seconds": seconds,
            "ratio": common.speedup(seconds["numbalsoda dop853"], seconds["nemc.DOP853"]),
        }
    print(f"{name}: measured", flush=True)
    return out


def run(config: Config) -> dict[str, Any]:
    started = time.perf_counter()
    env = common.environment("")
    env["numbalsoda"] = common.version_of("numbalsoda")
    env["numba"] = common.version_of("numba")
    result: dict[str, Any] = {"environment": env, "config": vars(config), "systems": {}}
    if env["numbalsoda"] is None or env["numba"] is None:
        result["note"] = ("numbalsoda or numba is not installed (pip install numbalsoda numba):"
                          " nothing measured")
    else:
        with tempfile.TemporaryDirectory(prefix="nemc-dop853-") as folder:
            for name, path, span in systems(config, Path(folder)):
                result["systems"][name] = measure_system(name, path, span, config)
    common.finish_environment(env, started)
    return result


def markdown(result: dict[str, Any]) -> str:
    lines = ["# nemc.DOP853 against numbalsoda's dop853", "",
             *common.md_environment(result["environment"])]
    if "note" in result:
        return "\n".join([*lines, "", result["note"], ""])
    lines += ["", f"numbalsoda {result['environment']['numbalsoda']}, numba "
              f"{result['environment']['numba']}; {result['config']['rounds']} interleaved "
              "rounds; atol = rtol x 1e-3, 101 output times. Ratio: numbalsoda's time / "
              "nemc's (above 1: nemc faster).", "",
              "| system | rtol | RHS calls, nemc / numbalsoda | nemc.DOP853 | numbalsoda dop853 "
              "| ratio (range) | per RHS call, nemc / numbalsoda | difference |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name, system in result["systems"].items():
        for rtol, r in system["runs"].items():
            ours, theirs = r["seconds"]["nemc.DOP853"], r["seconds"]["numbalsoda dop853"]
            calls = r["rhs_calls"]
            per_call = (f"{ours['median'] / calls['nemc.DOP853'] * 1e9:.0f} / "
                        f"{theirs['median'] / calls['numbalsoda dop853'] * 1e9:.0f} ns")
            q = r["ratio"]
            lines.append(
                f"| {name} | {rtol} | {calls['nemc.DOP853']:,} / {calls['numbalsoda dop853']:,}"
                f" | {spread(ours)} | {spread(theirs)} | **{q['median']:.2f}x** "
                f"({q['min']:.2f}-{q['max']:.2f}) | {per_call} | {r['difference']:.1e} |")
    lines += ["", "The right-hand side alone, per call (each in its own compiled loop over "
              f"{RHS_STATES:,} states):", "", "| system | nemc C RHS | numba cfunc RHS |",
              "| --- | --- | --- |"]
    for name, system in result["systems"].items():
        rhs = system["rhs"]
        lines.append(f"| {name} | {spread(rhs['nemc C RHS (rhs_many)'])} | "
                     f"{spread(rhs['numba cfunc RHS (numba loop)'])} |")
    return "\n".join(lines) + "\n"


def main() -> int:
    return common.run_script(__doc__, ("the pendulum and a 4-link chain, 3 rounds",
                                       "the pendulum at rtol 1e-6, 2 short rounds; a temporary "
                                       "folder"), MODES, "dop853_peer", run, markdown)


if __name__ == "__main__":
    sys.exit(main())
