"""Stiff scenes: time against error for Radau, BDF and LSODA with nemc's analytic Jacobian,
with finite-difference Jacobians of nemc's compiled RHS, and with sympy lambdify (cse).

Cases: the book's 5.4 two-link robot arm over [0, 15], the same with gains x100, and a double
pendulum with a stiff joint spring (k = 1e6). Contenders are interleaved and repeated; the table
gives medians (min-max) and the error of the final state against a tight reference
(Radau, rtol 1e-12, analytic Jacobian). Run: python benchmarks/stiff.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import sympy
from scipy.integrate import solve_ivp

import nemc
from nemc.derive.equations import derive
from nemc.front.validate import load_mechanism
from nemc.runtime.scipy_run import integrator_jacobian

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
METHODS = ("Radau", "BDF", "LSODA")


def stiff_spring_yaml() -> Path:
    text = (ROOT / "examples" / "double_pendulum.yaml").read_text().replace(
        "outputs:", "loads:\n  - joint_spring: {joint: B, k: 1.0e6, damping: 10}\noutputs:"
    ).replace("name: double_pendulum", "name: stiff_spring_pendulum")
    path = Path(tempfile.mkdtemp()) / "stiff_spring_pendulum.yaml"
    path.write_text(text)
    return path


def lambdify_rhs(path: Path, params: dict[str, float]):
    """solve_ivp RHS from sympy lambdify(cse=True) of the same M and f, numpy solve."""
    eqs = derive(load_mechanism(path))
    values = dict(zip(eqs.parameters, eqs.parameter_defaults))
    values.update({sympy.Symbol(k, real=True): v for k, v in params.items()})
    mass, forcing = eqs.mass_matrix.xreplace(values), eqs.forcing.xreplace(values)
    args = [nemc.front.mechanism.TIME, *eqs.coordinates, *eqs.speeds]
    f_mass = sympy.lambdify(args, mass, cse=True)
    f_forcing = sympy.lambdify(args, forcing, cse=True)
    n = eqs.n

    def rhs(t, y):
        q, u = y[0::2], y[1::2]
        qdd = np.linalg.solve(f_mass(t, *q, *u), np.ravel(f_forcing(t, *q, *u)))
        out = np.empty(2 * n)
        out[0::2], out[1::2] = u, qdd
        return out

    return rhs


def contenders(model, path: Path, params: dict[str, float], method: str, span, rtol: float):
    p = model.parameter_vector(params)
    y0 = model.initial_state(params)
    c_rhs = model.compiled.integrator_rhs(p)
    py_rhs = lambdify_rhs(path, params)
    atol = rtol * 1e-2

    def run(fun, jac=None):
        extra = {"jac": jac} if jac is not None else {}
        return solve_ivp(fun, span, y0, method=method, rtol=rtol, atol=atol, **extra)

    return {
        "nemc analytic J": lambda: run(c_rhs, integrator_jacobian(model, p)),
        "nemc FD J": lambda: run(c_rhs),
        "lambdify(cse) FD J": lambda: run(py_rhs),
    }


def measure(case: str, path: Path, params, span, tolerances, repeats: int) -> list[dict]:
    model = nemc.compile(path, jacobian=True)
    p = model.parameter_vector(params)
    reference = solve_ivp(model.compiled.integrator_rhs(p), span, model.initial_state(params),
                          method="Radau", rtol=1e-12, atol=1e-14,
                          jac=integrator_jacobian(model, p)).y[:, -1]
    rows = []
    for method in METHODS:
        for rtol in tolerances:
            runs = contenders(model, path, params, method, span, rtol)
            times: dict[str, list[float]] = {name: [] for name in runs}
            last = {}
            for _ in range(repeats):  # interleaved
                for name, go in runs.items():
                    start = time.perf_counter()
                    last[name] = go()
                    times[name].append(time.perf_counter() - start)
            for name, sol in last.items():
                rows.append({
                    "case": case, "method": method, "rtol": rtol, "contender": name,
                    "median_s": statistics.median(times[name]), "min_s": min(times[name]),
                    "max_s": max(times[name]), "nfev": int(sol.nfev), "njev": int(sol.njev),
                    "error": float(np.max(np.abs(sol.y[:, -1] - reference))),
                })
    return rows


def markdown(rows: list[dict]) -> str:
    lines = ["| case | method | rtol | contender | median s (min-max) | nfev | njev | error |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['method']} | {r['rtol']:g} | {r['contender']} | "
            f"{r['median_s']:.4f} ({r['min_s']:.4f}-{r['max_s']:.4f}) | {r['nfev']} | "
            f"{r['njev']} | {r['error']:.1e} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    args = argparse.ArgumentParser(description=__doc__)
    args.add_argument("--quick", action="store_true")
    quick = args.parse_args(argv).quick
    arm = ROOT / "examples" / "two_link_robot_arm.yaml"
    gains = {"b01": 45000.0, "g01": 30000.0, "b12": 20000.0, "g12": 30000.0}
    cases = [("5.4 [0, 15]", arm, {}, (0.0, 15.0)),
             ("5.4 gains x100 [0, 2]", arm, gains, (0.0, 2.0)),
             ("stiff joint spring [0, 1]", stiff_spring_yaml(), {}, (0.0, 1.0))]
    tolerances = (1e-4, 1e-8) if quick else (1e-4, 1e-6, 1e-8)
    rows = []
    for case, path, params, span in cases[:2] if quick else cases:
        rows += measure(case, path, params, span, tolerances, repeats=1 if quick else 3)
    info = {"python": sys.version.split()[0], "machine": platform.platform(),
            "numpy": np.__version__, "sympy": sympy.__version__, "nemc": nemc.__version__}
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "stiff-latest.json").write_text(json.dumps({"info": info, "rows": rows}, indent=1))
    text = markdown(rows)
    (RESULTS / "stiff-latest.md").write_text(f"# Stiff scenes\n\n{info}\n\n{text}\n")
    print(text)


if __name__ == "__main__":
    main()
