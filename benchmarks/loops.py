"""Closed loops (issue 16): nemc against the obvious Python route, and the cost of a loop in C.

Run: `python benchmarks/loops.py [--quick | --smoke] [--out DIR]`; part of `make bench`.
Results: benchmarks/results/loops-latest.{json,md} (smoke: a temporary folder).

1. Equal error: the four-bar of examples/fourbar.yaml (its scene's method removed, so nemc runs
   its default) over [0, 10], targets of final error (full: 1e-6 and 1e-9; quick: 1e-9),
   error = max |y(10) - reference|. Each contender at the loosest rtol of native.py's ladder
   (atol = rtol x 1e-3) reaching the target, timed interleaved as native.py does. Contenders:
   - the baseline, "solve_ivp-class DOP853 + lambdify(cse) index-1 RHS + projection": M, f,
     Phi_q and gamma of tests/loop_reference.py (the independent Lagrange-multiplier
     derivation), parameters folded, lambdified with CSE; the RHS solves
     [[M, Phi_q^T], [Phi_q, 0]] [qdd; -lambda] = [f; gamma] with numpy; scipy's DOP853 class
     stepped by hand, after every step q projected onto Phi = 0 by Gauss-Newton and qdot onto
     Phi_q qdot = 0 (tests/loop_reference.projected_run);
   - nemc's default method, nemc.DOP853, nemc.Vern9, solve_ivp DOP853 + nemc's C RHS.
   Reference: the reference's index-1 equations by DOP853's 8th-order formula at a fixed step in
   extended precision (tests/loop_reference.extended_precision_run), its error bounded by the
   same run at twice the step; scipy's DOP853 at rtol 1e-13 cannot serve (it is only good to
   about 1e-9 here, its difference to the reference is recorded).
2. RHS in C, a closed chain against the open tree of the same bodies: the four-bar against its
   three links without the constraint, and a 6-bar loop (five links pinned to the ground at both
   ends) against the five-link chain; `Model.rhs_many` over 1000 states on the loop (projected
   onto it), per state. Target: closed within 2x of open. The baseline's index-1 RHS per call
   beside them.
3. Through singular positions: the IFToMM benchmark A02 (examples/double_fourbar.yaml, the
   double four-bar lying flat twice a turn) over [0, 10] at rtol 1e-10 (atol 1e-12), each of
   nemc's methods that run closed loops: time (median of interleaved rounds), nfev, the crank
   angle's error at t = 10 against the 1-DOF minimal-coordinate ODE (its cranks stay parallel:
   tests/loop_reference.double_fourbar_crank), the total energy's drift. Target: under 50 ms.
4. RHS in C, a gear train and a rolling wheel beside a revolute loop of the same size (3
   coordinates, 2 constraint equations, 1 degree of freedom; issue 49): the four-bar, three
   gears in a train (two couplings) and a disc rolling on an incline (a free joint and a
   rolling constraint); per state over 1000 states on each one's constraints, interleaved: the
   C RHS loop under one start (as a run calls it) and `Model.rhs_many` (each state its own
   start). Target: the gear train and the wheel no dearer than the four-bar.
nemc parts that fail (closed loops not compiled yet) are rows "nemc: not supported yet" with the
reason; the baseline parts run regardless.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import common  # noqa: E402 (the benchmarks folder is not a package)
from common import ROOT, fmt_time, spread  # noqa: E402
from native import ATOL_FACTOR, LADDER, Found, loosest_rtol, time_contenders  # noqa: E402

FOURBAR = ROOT / "examples" / "fourbar.yaml"
DOUBLE_FOURBAR = ROOT / "examples" / "double_fourbar.yaml"
SINGULAR_TOLERANCES = (1e-10, 1e-12)  # rtol, atol of section 3
SINGULAR_METHODS = ("nemc.DOP853", "nemc.Vern9", "nemc.Radau")
SPAN = (0.0, 10.0)
SCIPY_TIGHT = (1e-13, 1e-14)  # rtol, atol of the recorded scipy comparison
BASELINE = "DOP853 + lambdify(cse) index-1 RHS + projection"
SCIPY_C = "solve_ivp DOP853 + nemc C RHS"
UNSUPPORTED = "nemc: not supported yet"
RHS_STATES = 1000

Solver = Callable[[float], tuple[np.ndarray | None, int]]  # rtol -> (y at SPAN, nfev)


@dataclass(frozen=True)
class Config:
    mode: str
    targets: tuple[float, ...]
    rounds: int
    sample_seconds: float
    cell_cap: float  # a contender whose run takes longer is timed once (native.time_contenders)
    chains: tuple[int, ...]  # closed chains of n links for section 2 (4 bodies: a 5-bar, ...)
    reference_steps: int  # fixed steps of the extended-precision reference over SPAN


MODES = {
    "smoke": Config("smoke", (1e-6,), 1, 0.01, 1.0, (), 5000),
    "quick": Config("quick", (1e-9,), 3, 0.05, 5.0, (5,), 20000),
    "full": Config("full", (1e-6, 1e-9), 5, 0.1, 10.0, (5,), 20000),
}


# -- the baseline -----------------------------------------------------------------------------


def baseline_functions(path: Path) -> tuple[Callable, Callable, dict[str, float]]:
    """(rhs(t, y), project(t, y), build seconds) of the lambdify index-1 baseline."""
    import sympy as sp
    from loop_reference import LoopReference

    from nemc.front.mechanism import TIME
    from nemc.front.validate import load_mechanism

    start = time.perf_counter()
    ref = LoopReference(load_mechanism(path))
    if len(ref.driven):
        raise ValueError("the baseline takes mechanisms without driven joints")
    derived = time.perf_counter() - start
    start = time.perf_counter()
    fold = {s: sp.Float(v) for s, v in zip(ref.p_symbols, ref.p)}
    q, n = sp.Matrix(ref.q), ref.n
    closure = ref.closure.xreplace(fold)
    cse = partial(sp.cse, order="none")
    kkt = sp.lambdify((TIME, *ref.q, *ref.u), [ref.ref.M.xreplace(fold), ref.ref.f.xreplace(fold),
                                               ref.Phi_q.xreplace(fold),
                                               ref.gamma.xreplace(fold)],
                      modules="numpy", cse=cse)
    constraints = sp.lambdify(ref.q, [closure, closure.jacobian(q)], modules="numpy", cse=cse)
    lambdified = time.perf_counter() - start
    m = closure.rows
    A = np.zeros((n + m, n + m))

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        M, f, Phi_q, gamma = kkt(t, *y[0::2], *y[1::2])
        A[:n, :n], A[:n, n:], A[n:, :n] = M, np.transpose(Phi_q), Phi_q
        x = np.linalg.solve(A, np.concatenate([np.ravel(f), np.ravel(gamma)]))
        dy = np.empty(2 * n)
        dy[0::2], dy[1::2] = y[1::2], x[:n]
        return dy

    def project(t: float, y: np.ndarray) -> np.ndarray:
        y = np.array(y, dtype=float)
        for _ in range(4):
            Phi, Phi_q = (np.asarray(v, dtype=float) for v in constraints(*y[0::2]))
            if np.max(np.abs(Phi)) <= 1e-15:
                break
            y[0::2] -= np.linalg.lstsq(Phi_q, np.ravel(Phi), rcond=None)[0]
        _, Phi_q = (np.asarray(v, dtype=float) for v in constraints(*y[0::2]))
        y[1::2] -= np.linalg.lstsq(Phi_q, Phi_q @ y[1::2], rcond=None)[0]
        return y

    return rhs, project, {"derive (reference)": derived, "lambdify(cse)": lambdified}


def baseline_solver(rhs: Callable, project: Callable, y0: np.ndarray) -> Solver:
    from loop_reference import projected_run

    def solve(rtol: float) -> tuple[np.ndarray | None, int]:
        try:
            run = projected_run(rhs, project, SPAN, y0, rtol, rtol * ATOL_FACTOR, t_eval=SPAN)
        except RuntimeError:
            return None, 0
        return run.y, run.nfev

    return solve


def reference_solution(path: Path, y0: np.ndarray, steps: int) -> dict[str, Any]:
    """The extended-precision solution at SPAN, its step-halving error bound, and the
    difference of scipy's tightest DOP853 to it."""
    from loop_reference import LoopReference, extended_precision_run
    from scipy.integrate import solve_ivp

    from nemc.front.validate import load_mechanism

    ref = LoopReference(load_mechanism(path))
    start = time.perf_counter()
    fine = extended_precision_run(ref, SPAN, y0, steps)
    coarse = extended_precision_run(ref, SPAN, y0, steps // 2)
    seconds = time.perf_counter() - start
    y = np.column_stack([y0, fine.astype(float)])
    rtol, atol = SCIPY_TIGHT
    scipy_y = solve_ivp(ref.rhs, SPAN, y0, method="DOP853", rtol=rtol, atol=atol).y[:, -1]
    record = {"method": f"DOP853's 8th-order formula, {steps} fixed steps, np.longdouble "
                        f"(eps {np.finfo(np.longdouble).eps:.1e}), tests/loop_reference.py "
                        "index-1 equations",
              "steps": steps, "seconds": seconds, "y": y,
              "error_bound": float(np.max(np.abs(fine - coarse))),
              "error_bound_is": f"max difference to the same at {steps // 2} steps",
              "scipy_difference": float(np.max(np.abs(scipy_y - y[:, -1]))),
              "scipy_is": f"solve_ivp DOP853 at rtol {rtol:g}, atol {atol:g}",
              "final_position_residual": float(np.abs(ref.residual(SPAN[1], y[:, -1])[0]).max())}
    print(f"  reference ({fmt_time(seconds)}): error bound {record['error_bound']:.1e}; "
          f"{record['scipy_is']} differs by {record['scipy_difference']:.1e}", flush=True)
    return record


# -- nemc -------------------------------------------------------------------------------------


def first_line(error: BaseException) -> str:
    """The error's type, first line, and where it was raised."""
    import traceback

    text = str(error).strip().splitlines()
    where = traceback.extract_tb(error.__traceback__)[-1] if error.__traceback__ else None
    at = f" (at {Path(where.filename).name}:{where.lineno})" if where else ""
    return f"{type(error).__name__}: {text[0] if text else ''}"[:200] + at


AGREEMENT = 1e-9  # nemc's RHS must agree with the reference this well to be timed at all


def disagreement(model, path: Path) -> float:
    """Largest relative difference of nemc's RHS to the reference's at states on the loop (a
    build that ignores its constraints disagrees by O(1))."""
    from loop_reference import LoopReference

    from nemc.front.validate import load_mechanism

    ref = LoopReference(load_mechanism(path))
    states = loop_states(path, 5)
    return max(float(np.linalg.norm(model.rhs(0.0, y) - ref.rhs(0.0, y))
                     / np.linalg.norm(ref.rhs(0.0, y))) for y in states.T)


def checked_model(path: Path):
    """nemc's build of a closed chain, refused unless its RHS is the reference's."""
    import nemc

    model = nemc.compile(path)
    off = disagreement(model, path)
    if not off <= AGREEMENT:
        raise RuntimeError(f"its RHS differs from the reference's by {off:.1e} (relative): "
                           "the loop is not enforced")
    return model


def nemc_solver(model, method: str | None, y0: np.ndarray) -> Solver:
    def solve(rtol: float) -> tuple[np.ndarray | None, int]:
        res = model.simulate(SPAN, y0, method=method, rtol=rtol, atol=rtol * ATOL_FACTOR,
                             t_eval=SPAN)
        return (res.y if res.success else None), res.nfev

    return solve


def without_scene_method(path: Path, folder: Path) -> Path:
    text = "".join(line for line in path.read_text().splitlines(keepends=True)
                   if not line.strip().startswith("method:"))
    out = folder / "fourbar_bench.yaml"
    out.write_text(text.replace("name: fourbar", "name: fourbar_bench"))
    return out


def nemc_contenders(path: Path, y0: np.ndarray) -> tuple[dict[str, Solver], list[str]]:
    """nemc's contenders that run on a closed loop, and a note for each that cannot (nemc.Taylor
    has no recurrence for the projection) or for all (the model does not compile)."""
    try:
        from nemc import vocabulary as methods

        model = checked_model(path)
    except Exception as error:  # noqa: BLE001 (recorded, never hidden)
        return {}, [f"{UNSUPPORTED}: {first_line(error)}"]
    default = f"nemc default ({methods.DEFAULT_METHOD})"
    solvers = {default: nemc_solver(model, None, y0),
               **{m: nemc_solver(model, m, y0) for m in common.native_methods(True)},
               SCIPY_C: nemc_solver(model, "DOP853", y0)}
    running, notes = {}, []
    for name, solve in solvers.items():
        try:
            y, _ = solve(1e-6)  # runs at all? (also warms the build's parts up)
            if y is None:
                raise RuntimeError(f"{name} did not reach the end at rtol 1e-6")
            running[name] = solve
        except Exception as error:  # noqa: BLE001 (recorded, never hidden)
            notes.append(f"{name}: not timed: {first_line(error)}")
    return running, notes


# -- 1. equal error ---------------------------------------------------------------------------


def equal_error(config: Config, folder: Path, result: dict[str, Any]) -> None:
    from loop_reference import LoopReference

    from nemc.front.validate import load_mechanism

    path = without_scene_method(FOURBAR, folder)
    y0 = LoopReference(load_mechanism(path)).initial_state()
    print(f"four-bar over {list(SPAN)}:", flush=True)
    ref = reference_solution(path, y0, config.reference_steps)
    result["references"]["fourbar"] = {k: v for k, v in ref.items() if k != "y"} | \
        {"y": ref["y"].tolist()}
    rhs, project, seconds = baseline_functions(path)
    result["setup"]["baseline build seconds"] = seconds
    reference_rhs = LoopReference(load_mechanism(path)).rhs
    result["setup"]["baseline agreement"] = max(
        float(np.linalg.norm(rhs(0.0, y) - reference_rhs(0.0, y))
              / np.linalg.norm(reference_rhs(0.0, y))) for y in loop_states(path, 5).T)
    solvers = {BASELINE: baseline_solver(rhs, project, y0)}
    nemc_solvers, notes = nemc_contenders(path, y0)
    solvers.update(nemc_solvers)
    result["notes"] += notes
    previous: dict[str, Found] = {}
    for target in sorted(config.targets, reverse=True):
        found = {}
        for name, solve in solvers.items():
            start = LADDER.index(previous[name].rtol) if name in previous else 0
            found[name] = loosest_rtol(solve, ref["y"], target, start, config.cell_cap * 5)
        previous = found
        timings = time_contenders(solvers, found, config)
        base = timings[BASELINE]["median"]
        for name, f in found.items():
            result["rows"].append({
                "section": "equal error", "system": "fourbar", "t_span": list(SPAN),
                "target_error": target, "contender": name, "rtol": f.rtol,
                "atol": f.rtol * ATOL_FACTOR, "error": f.error, "reached": f.reached,
                "nfev": f.nfev, **timings[name], "speedup_vs_baseline": base / timings[name][
                    "median"]})
        if notes and not nemc_solvers:
            result["rows"].append({"section": "equal error", "system": "fourbar",
                                   "target_error": target, "contender": UNSUPPORTED,
                                   "reason": notes[0]})
        print(f"  target {target:g}: " + ", ".join(
            f"{n} {fmt_time(timings[n]['median'])} (rtol {f.rtol:.2g})"
            for n, f in found.items()), flush=True)


# -- 2. RHS cost: closed vs open --------------------------------------------------------------


def open_tree_text(path: Path) -> str:
    """The four-bar without its constraint (and without the constraint's reaction)."""
    text = path.read_text().replace("constraints:\n  C: {type: revolute, a: rocker.C, b: "
                                    "coupler.C}\n", "")
    return text.replace("reactions: [A, D, C]", "reactions: [A, D]").replace(
        "name: fourbar", "name: fourbar_open")


def pairs(config: Config, folder: Path) -> list[tuple[str, Path, Path]]:
    from loop_reference import closed_chain_yaml

    open_fourbar = folder / "fourbar_open.yaml"
    open_fourbar.write_text(open_tree_text(FOURBAR))
    out = [("four-bar (3 links)", FOURBAR, open_fourbar)]
    for n in config.chains:
        closed, chain = folder / f"closed{n}.yaml", folder / f"open{n}.yaml"
        closed.write_text(closed_chain_yaml(n, closed=True))
        chain.write_text(closed_chain_yaml(n, closed=False))
        out.append((f"{n + 1}-bar loop ({n} links)", closed, chain))
    return out


def loop_states(path: Path, count: int) -> np.ndarray:
    """(n_state, count) states on the loop: random moves of the scene's state, projected."""
    from loop_reference import LoopReference

    from nemc.front.validate import load_mechanism

    ref = LoopReference(load_mechanism(path))
    y0 = ref.initial_state()
    rng = np.random.default_rng(5)
    rows = [ref.project(0.0, y0 + np.repeat([[0.1, 1.0]], ref.n, axis=0).ravel()
                        * rng.uniform(-1, 1, len(y0))) for _ in range(count)]
    return np.ascontiguousarray(rows).T


def rhs_rows(config: Config, folder: Path, result: dict[str, Any]) -> None:
    import nemc

    for label, closed, tree in pairs(config, folder):
        print(f"RHS cost, {label}:", flush=True)
        states = loop_states(closed, RHS_STATES)
        calls: dict[str, tuple[Callable[[], Any], int]] = {}
        for kind, path in (("closed (nemc C)", closed), ("open tree (nemc C)", tree)):
            try:
                model = checked_model(path) if path == closed else nemc.compile(path)
                model.rhs_many(0.0, states)
                calls[kind] = (partial(model.rhs_many, 0.0, states), RHS_STATES)
            except Exception as error:  # noqa: BLE001 (recorded)
                result["rows"].append({"section": "rhs", "system": label, "contender": kind,
                                       "reason": f"{UNSUPPORTED}: {first_line(error)}"})
                result["notes"].append(f"{label}, {kind}: {UNSUPPORTED}: {first_line(error)}")
        rhs, _, _ = baseline_functions(closed)
        y = states[:, 0].copy()
        calls["closed (baseline lambdify index-1)"] = (partial(rhs, 0.0, y), 1)
        timings = common.interleaved(calls, config.rounds, config.sample_seconds)
        open_time = timings.get("open tree (nemc C)", {}).get("median")
        for kind, timing in timings.items():
            result["rows"].append({"section": "rhs", "system": label, "contender": kind,
                                   "states": RHS_STATES, **timing,
                                   "vs_open_tree": timing["median"] / open_time
                                   if open_time else None})
        print("  " + ", ".join(f"{k} {fmt_time(v['median'])}" for k, v in timings.items()),
              flush=True)


# -- 3. through singular positions -----------------------------------------------------------


def singular_rows(config: Config, result: dict[str, Any]) -> None:
    """A02 over SPAN by each native method: time, nfev, the crank's error, the energy drift."""
    from loop_reference import double_fourbar_crank

    import nemc

    print("Through singular positions: A02", flush=True)
    reference = double_fourbar_crank(SPAN[1])[0]
    model = nemc.compile(DOUBLE_FOURBAR)
    rtol, atol = SINGULAR_TOLERANCES
    calls: dict[str, tuple[Callable[[], Any], int]] = {}
    runs: dict[str, Any] = {}
    for method in SINGULAR_METHODS:
        call = partial(model.simulate, SPAN, method=method, rtol=rtol, atol=atol,
                       t_eval=np.linspace(*SPAN, 401))
        runs[method] = call()
        calls[method] = (call, 1)
    timings = common.interleaved(calls, config.rounds, config.sample_seconds)
    for method, timing in timings.items():
        res = runs[method]
        energy = res.outputs["energy.total"]
        result["rows"].append({
            "section": "singular", "system": "A02 double four-bar", "contender": method,
            "rtol": rtol, "atol": atol, "success": bool(res.success), "nfev": int(res.nfev),
            "crank_error": float(abs(res.y[0, -1] - reference)),
            "energy_drift": float(np.ptp(energy) / np.abs(energy).max()), **timing})
        print(f"  {method}: {fmt_time(timing['median'])}, nfev {res.nfev}, crank error "
              f"{abs(res.y[0, -1] - reference):.1e}", flush=True)


# -- 4. RHS cost: couplings and rolling beside a revolute loop -------------------------------

GEAR_TRAIN = """\
name: gear_train3
parameters: {r1: 0.1, r2: 0.25, r3: 0.15, tau: 1.0}
bodies:
  g1: {mass: 1, inertia: 0.02}
  g2: {mass: 2, inertia: 0.3}
  g3: {mass: 1.5, inertia: 0.1}
joints:
  A: {type: revolute, parent: ground, child: g1, coordinate: q1}
  B: {type: revolute, parent: ground, child: g2, at: [0.35, 0], coordinate: q2}
  C: {type: revolute, parent: ground, child: g3, at: [0.75, 0], coordinate: q3}
constraints:
  m12: {type: coupling, a: A, b: B, ratio: -r2/r1}
  m23: {type: coupling, a: B, b: C, ratio: -r3/r2}
loads:
  - {torque: tau - 0.1*dot(q1), body: g1}
simulation:
  t_span: [0, 1]
"""

ROLLING_WHEEL = """\
name: rolling_wheel
parameters: {m: 2.0, R: 0.3, I: 0.09, g: 9.81, alpha: 0.5}
gravity: [0, -g]
bodies:
  disc: {mass: m, inertia: I}
joints:
  flight: {type: free, parent: ground, child: disc, coordinates: [x, y, th]}
constraints:
  roll: {type: rolling, disc: disc, radius: R, on: {body: ground, at: [0, 0]},
         axis: [cos(alpha), -sin(alpha)]}
simulation:
  t_span: [0, 1]
  initial: {x: 0.3*sin(alpha), y: 0.3*cos(alpha)}
"""

SAME_SIZE = "revolute loop (four-bar)"


def projected_rows(model, count: int, seed: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """(the parameter vector started at the initial state, (count, n_state) C-contiguous rows):
    random moves of the initial state brought onto the constraints by the model's own
    projection, every one under that one start (a gear pair's offset, a wheel's), as the states
    of one run are."""
    rng = np.random.default_rng(seed)
    y0 = model.initial_state()
    p = model.loops.started(0.0, y0, model.parameter_vector())
    moved = y0[:, None] + rng.normal(0.0, 0.1, (model.n_state, count))
    return p, np.ascontiguousarray(model.loops.projected(np.zeros(count), moved, p).T)


def rhs_calls(label: str, model, count: int) -> dict[str, tuple[Callable[[], Any], int]]:
    """The C RHS over `count` states as a run calls it (one start), and `Model.rhs_many`, which
    takes each state as its own start (one C call per state where equations hold as at the
    start)."""
    p, rows = projected_rows(model, count)
    ts, out = np.zeros(count), np.empty_like(rows)
    model.compiled.call_many("rhs_many", ts, rows, p, out)
    np.testing.assert_allclose(out, model.rhs_many(0.0, rows.T).T, rtol=1e-12, atol=1e-12)
    return {f"{label}: C RHS, one start": (
                partial(model.compiled.call_many, "rhs_many", ts, rows, p, out), count),
            f"{label}: Model.rhs_many": (partial(model.rhs_many, 0.0, rows.T), count)}


def kinds_rows(config: Config, folder: Path, result: dict[str, Any]) -> None:
    """Section 4: the four-bar, a gear train and a rolling wheel, interleaved."""
    import nemc

    paths = {SAME_SIZE: FOURBAR}
    for label, name, text in (("gear train (3 gears, 2 couplings)", "gear_train3", GEAR_TRAIN),
                              ("rolling wheel (free disc, rolling)", "rolling_wheel",
                               ROLLING_WHEEL)):
        paths[label] = folder / f"{name}.yaml"
        paths[label].write_text(text)
    print("RHS cost, a gear train and a rolling wheel beside the four-bar:", flush=True)
    calls: dict[str, tuple[Callable[[], Any], int]] = {}
    for label, path in paths.items():
        try:
            calls.update(rhs_calls(label, nemc.compile(path), RHS_STATES))
        except Exception as error:  # noqa: BLE001 (recorded)
            result["rows"].append({"section": "kinds", "system": label, "contender": "nemc C",
                                   "reason": f"{UNSUPPORTED}: {first_line(error)}"})
    timings = common.interleaved(calls, config.rounds, config.sample_seconds)
    for name, timing in timings.items():
        system, contender = name.split(": ", 1)
        loop = timings.get(f"{SAME_SIZE}: {contender}", {}).get("median")
        result["rows"].append({"section": "kinds", "system": system, "contender": contender,
                               "states": RHS_STATES, **timing,
                               "vs_revolute_loop": timing["median"] / loop if loop else None})
    print("  " + ", ".join(f"{k} {fmt_time(v['median'])}" for k, v in timings.items()),
          flush=True)


# -- the run ----------------------------------------------------------------------------------


def run(config: Config) -> dict[str, Any]:
    result: dict[str, Any] = {"environment": common.environment(config.mode),
                              "config": asdict(config), "ladder": list(LADDER), "setup": {},
                              "references": {}, "rows": [], "notes": []}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nemc-bench-loops-") as folder:
        equal_error(config, Path(folder), result)
        rhs_rows(config, Path(folder), result)
        singular_rows(config, result)
        kinds_rows(config, Path(folder), result)
    common.finish_environment(result["environment"], start)
    return result


# -- output -----------------------------------------------------------------------------------


def ratio(value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return "–"
    return f"**{value:.0f}x**" if value >= 10 else f"**{value:.2g}x**"


def md_equal_error(result: dict[str, Any]) -> list[str]:
    ref = result["references"]["fourbar"]
    build = ", ".join(f"{k} {fmt_time(v)}" for k, v in result["setup"].get(
        "baseline build seconds", {}).items())
    lines = ["## 1. The four-bar over [0, 10] at equal final error", "",
             f"Reference: {ref['method']}; error at most {ref['error_bound']:.1e} "
             f"({ref['error_bound_is']}); {ref['scipy_is']} differs from it by "
             f"{ref['scipy_difference']:.1e}. Each "
             "contender at the loosest rtol of the ladder (quarter decades, atol = rtol x 1e-3) "
             "whose final error is at most the target (*not reached*: its best error). Time: "
             "median (min–max) of interleaved rounds. Speed-up: the baseline's time / this "
             f"time (target: nemc at least 100x). Baseline build (untimed): {build}; its RHS "
             f"agrees with the reference's to {result['setup']['baseline agreement']:.1e} "
             "(relative, at 5 states on the loop). nemc is timed only where its RHS agrees "
             f"to {AGREEMENT:g}.", "",
             "| target | contender | rtol | final error | nfev | time | speed-up |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in (r for r in result["rows"] if r["section"] == "equal error"):
        if "reason" in r:
            lines.append(f"| {r['target_error']:.0e} | {UNSUPPORTED} | – | – | – | – | – |")
            continue
        error = f"{r['error']:.1e}" + ("" if r["reached"] else " *not reached*")
        lines.append(f"| {r['target_error']:.0e} | {r['contender']} | {r['rtol']:.2g} | "
                     f"{error} | {r['nfev']} | {spread(r)} | {ratio(r['speedup_vs_baseline'])} |")
    return lines + [""]


def md_rhs(result: dict[str, Any]) -> list[str]:
    lines = ["## 2. RHS cost: a closed chain against the open tree of the same bodies", "",
             f"nemc: `Model.rhs_many` over {RHS_STATES} states on the loop, per state; the "
             "baseline: one call of its index-1 RHS. Ratio: this time / the open tree's "
             "(target: the closed chain's within 2x).", "",
             "| system | contender | time per state | vs open tree |", "| --- | --- | --- | --- |"]
    for r in (r for r in result["rows"] if r["section"] == "rhs"):
        if "reason" in r:
            lines.append(f"| {r['system']} | {r['contender']}: {UNSUPPORTED} | – | – |")
            continue
        lines.append(f"| {r['system']} | {r['contender']} | {spread(r)} | "
                     f"{ratio(r['vs_open_tree'])} |")
    return lines + [""]


def md_singular(result: dict[str, Any]) -> list[str]:
    rows = [r for r in result["rows"] if r["section"] == "singular"]
    if not rows:
        return []
    lines = ["## 3. Through singular positions: IFToMM A02 over [0, 10]", "",
             f"The double four-bar (examples/double_fourbar.yaml) at rtol {rows[0]['rtol']:g}, "
             f"atol {rows[0]['atol']:g}, 401 states returned. Crank error: |q1(10) - the "
             "minimal-coordinate ODE's|; energy drift: the total energy's range over its "
             "largest value. Target: under 50 ms.", "",
             "| contender | reached t = 10 | nfev | crank error | energy drift | time |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['contender']} | {'yes' if r['success'] else '**no**'} | {r['nfev']} "
                     f"| {r['crank_error']:.1e} | {r['energy_drift']:.1e} | {spread(r)} |")
    return lines + [""]


def md_kinds(result: dict[str, Any]) -> list[str]:
    lines = ["## 4. RHS cost: a gear train and a rolling wheel beside a revolute loop", "",
             "Each 3 coordinates, 2 constraint equations, 1 degree of freedom. Per state, over "
             f"{RHS_STATES} states on the constraints, all six interleaved: the C RHS loop as a "
             "run calls it (one start: a gear pair's or a wheel's offset set once), and "
             "`Model.rhs_many`, which takes each state as its own start (a C call per state "
             "where an equation holds as at the start). Ratio: this time / the four-bar's by "
             "the same route (target: at most 1x).", "",
             "| system | route | time per state | vs revolute loop |",
             "| --- | --- | --- | --- |"]
    for r in (r for r in result["rows"] if r["section"] == "kinds"):
        if "reason" in r:
            lines.append(f"| {r['system']}: {r['reason']} | – | – | – |")
            continue
        lines.append(f"| {r['system']} | {r['contender']} | {spread(r)} | "
                     f"{ratio(r['vs_revolute_loop'])} |")
    return lines + [""]


def markdown(result: dict[str, Any]) -> str:
    lines = ["# Closed loops: nemc against lambdify + projection, and the cost of a loop", ""]
    lines += common.md_environment(result["environment"]) + [""]
    lines += md_equal_error(result) + md_rhs(result) + md_singular(result) + md_kinds(result)
    if result["notes"]:
        lines += ["## Notes", ""] + [f"- {n}" for n in dict.fromkeys(result["notes"])] + [""]
    return "\n".join(lines)


def parse_args(argv: Sequence[str]):
    parser = common.mode_parser(
        __doc__.splitlines()[0],
        "target 1e-9 only, 3 rounds, the four-bar and a 6-bar loop",
        "target 1e-6, 1 round, no 6-bar (seconds); a temporary folder",
    )
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    print(f"nemc closed-loop benchmark, {mode} mode", flush=True)
    result = run(MODES[mode])
    folder = common.results_folder(args, "nemc-bench-loops-")
    common.write_results(result, folder, "loops", markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
