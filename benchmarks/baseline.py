"""The sympy lambdify baselines, built in a fresh process under a time budget.

`python benchmarks/baseline.py MECHANISM.yaml FOLDER` derives M(q) and f(t, q, dq) (nemc's own
`nemc.derive.equations.derive` when it still exposes them, else the independent Lagrangian
derivation of tests/reference.py), folds the parameters to their defaults and writes, one file
per variant as soon as it is done, the Python source that `sympy.lambdify` generated:

- `cse.json`:      lambdify(args, [M, f], cse=...)   (mass-matrix form; numpy.linalg.solve)
- `plain.json`:    lambdify(args, [M, f])            (the same without CSE)
- `explicit.json`: lambdify(args, M.LUsolve(f), cse=...)  (explicit symbolic RHS, the book's way)

`build_baselines` runs that process with a timeout and turns the files it managed to write into
RHS callables in this process: a variant past the budget is recorded as infeasible, never waited on.
CSE is `sympy.cse(order="none")`: the same elimination as `cse=True` without the canonical
ordering, which costs tens of seconds at 8 links (FIELD-NOTES).
"""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
VARIANTS = ("cse", "plain", "explicit")
LABELS = {"cse": "lambdify(cse)", "plain": "lambdify (no cse)",
          "explicit": "lambdify explicit (cse)"}


# -- in the child process ---------------------------------------------------------------------


def equations(path: Path):
    """(args, M, f, source) with parameters folded: nemc's derivation, else the reference."""
    import sympy

    from nemc.front.mechanism import TIME, rate_symbol, symbol
    from nemc.front.validate import load_mechanism

    mech = load_mechanism(path)
    try:
        from nemc.derive.equations import derive

        eqs = derive(mech)
        fold = {s: sympy.Float(v) for s, v in zip(eqs.parameters, eqs.parameter_defaults)}
        mass, forcing = eqs.mass_matrix.xreplace(fold), eqs.forcing.xreplace(fold)
        source = "nemc.derive.equations (the M and f nemc emits)"
    except AttributeError:  # a derivation without an explicit M and f
        sys.path.insert(0, str(ROOT / "tests"))
        import reference

        mass, forcing = reference.equations(reference.lagrangian(mech))
        values = reference.resolve_parameters(mech)
        fold = {symbol(k): sympy.Float(v) for k, v in values.items()}
        mass, forcing = mass.xreplace(fold), forcing.xreplace(fold)
        source = "tests/reference.py (independent Lagrangian derivation)"
    coords = [symbol(c) for c in mech.coordinates]
    args = [TIME, *coords, *(rate_symbol(c) for c in mech.coordinates)]
    return args, mass, forcing, source, mech.state_names, list(mech.coordinates)


def lambdify_source(args, exprs, cse: bool) -> str:
    import sympy

    options = {"cse": partial(sympy.cse, order="none")} if cse else {}
    return inspect.getsource(sympy.lambdify(args, exprs, modules="numpy", **options))


def child(path: Path, folder: Path, variants: Sequence[str]) -> None:
    start = time.perf_counter()
    args, mass, forcing, source, states, coords = equations(path)
    derive_seconds = time.perf_counter() - start
    common = {"equations": source, "derive_seconds": derive_seconds, "state_names": states,
              "coordinates": coords}
    for variant in variants:
        start = time.perf_counter()
        if variant == "explicit":
            text = lambdify_source(args, list(mass.LUsolve(forcing)), cse=True)
        else:
            text = lambdify_source(args, [mass, forcing], cse=variant == "cse")
        record = {**common, "variant": variant, "source": text,
                  "seconds": time.perf_counter() - start}
        (folder / f"{variant}.json.tmp").write_text(json.dumps(record))
        os.replace(folder / f"{variant}.json.tmp", folder / f"{variant}.json")


# -- in the benchmark process -----------------------------------------------------------------


@dataclass
class Baselines:
    """RHS callables (t, y) -> dy of the variants that were built in time, and notes on the rest."""

    rhs: dict[str, Callable[[float, np.ndarray], np.ndarray]] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)
    equations: str = ""


def compiled_function(source: str) -> Callable:
    """exec a lambdify-generated source in the namespace lambdify gives numpy code."""
    import sympy

    namespace = dict(sympy.lambdify([], 0, modules="numpy").__globals__)
    exec(compile(source, "<lambdify baseline>", "exec"), namespace)  # noqa: S102 (our own code)
    name = source.split("def ", 1)[1].split("(", 1)[0]
    return namespace[name]


def rhs_from(record: dict[str, Any]) -> Callable[[float, np.ndarray], np.ndarray]:
    function = compiled_function(record["source"])
    states = record["state_names"]
    q_index = np.array([states.index(c) for c in record["coordinates"]])
    u_index = np.array([states.index(f"dot({c})") for c in record["coordinates"]])
    n_state = len(states)

    if record["variant"] == "explicit":
        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            dy = np.empty(n_state)
            dy[q_index] = y[u_index]
            dy[u_index] = np.ravel(function(t, *y[q_index], *y[u_index]))
            return dy
    else:
        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            mass, forcing = function(t, *y[q_index], *y[u_index])
            dy = np.empty(n_state)
            dy[q_index] = y[u_index]
            dy[u_index] = np.linalg.solve(mass, np.ravel(forcing))
            return dy

    return rhs


def build_baselines(path: Path, variants: Sequence[str], timeout: float) -> Baselines:
    """Run the child under `timeout` seconds and load whatever variants it finished."""
    out = Baselines()
    with tempfile.TemporaryDirectory(prefix="nemc-bench-lambdify-") as folder:
        command = [sys.executable, str(Path(__file__).resolve()), str(path), folder, *variants]
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p))
        why = ""
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                                  env=env)
            if done.returncode != 0:
                lines = done.stderr.strip().splitlines()
                why = f"failed: {lines[-1] if lines else 'exit ' + str(done.returncode)}"
        except subprocess.TimeoutExpired:
            why = f"not built within the {timeout:.0f} s budget (derive + lambdify)"
        for variant in variants:
            file = Path(folder) / f"{variant}.json"
            if not file.is_file():
                out.notes[LABELS[variant]] = why or "not built"
                continue
            record = json.loads(file.read_text())
            out.rhs[LABELS[variant]] = rhs_from(record)
            out.seconds["derive (baseline)"] = record["derive_seconds"]
            out.seconds[LABELS[variant]] = record["seconds"]
            out.equations = record["equations"]
    return out


if __name__ == "__main__":
    child(Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3:] or VARIANTS)
