"""Peers, when installed (`pip install '.[peers]'`, numbalsoda apart): PyDy (Cython backend),
JiTCODE, heyoka, numbalsoda's dop853.

Each peer gets the same mechanism from its YAML file: `mechanics_model` builds it with
sympy.physics.mechanics (KanesMethod; revolute and prismatic joints, gravity, joint springs), the
way a PyDy user writes it. PyDy compiles Kane's M and F with its Cython generator (numpy solve per
call). JiTCODE, heyoka and numbalsoda need an explicit RHS: M qdd = F is solved by an LDL^T
elimination written as named intermediates (JiTCODE helpers; heyoka shares the subexpressions in its
expression graph; numbalsoda gets a numba cfunc of the program, one assignment a line), so the
code grows as n^3 / 6 rather than as the symbolic inverse.

Every peer runs in a worker process of its own (`python benchmarks/peers.py SPEC.json OUT.json`)
under a time budget: a peer that fails (e.g. JiTCODE's RecursionError at 32 links) or runs out of
time is recorded, never waited on. The worker first checks the peer's RHS against nemc's on random
states, then times the peer interleaved with nemc's compiled RHS in the same process (ratios are
within one process), then runs the peer's integrators over a tolerance sweep against the suite's
reference solution. Octave (the book's ode45 programs) only when `octave-cli` is on the PATH.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402

PEER_NAMES = {"pydy": "PyDy (Cython)", "jitcode": "JiTCODE", "heyoka": "heyoka",
              "numbalsoda": "numbalsoda"}
AGREEMENT_TOLERANCE = 1e-9  # relative: a peer whose RHS differs more is not timed


# -- the mechanism in sympy.physics.mechanics -------------------------------------------------


@dataclass
class MechanicsModel:
    """Kane's equations M(q) u' = F(q, u) of a mechanism, as a PyDy user would build them."""

    mass_matrix: Any
    forcing: Any
    mass_matrix_full: Any  # of the whole state [q, u] (what PyDy's generator takes)
    forcing_full: Any
    q: list[Any]  # dynamicsymbols, in nemc's coordinate order
    u: list[Any]
    constants: list[Any]  # the mechanism's parameters (symbols)
    constant_values: list[float]
    derive_seconds: float
    state_names: list[str] = field(default_factory=list)


def mechanics_model(path: Path) -> MechanicsModel:
    """KanesMethod of a tree of revolute/prismatic joints with gravity and joint springs."""
    import sympy as sp
    from sympy.physics import mechanics as me

    from nemc.front.mechanism import GROUND, symbol
    from nemc.front.validate import load_mechanism
    from nemc.kinds.loads import JointSpring

    sys.path.insert(0, str(common.ROOT / "tests"))
    from reference import resolve_parameters  # the numeric parameter values

    start = time.perf_counter()
    mech = load_mechanism(path)
    unsupported = [type(load).__name__ for load in mech.loads if not isinstance(load, JointSpring)]
    if unsupported or any(j.type not in ("revolute", "prismatic") for j in mech.joints):
        raise NotImplementedError(f"the peer adapter has no {unsupported or 'joint type'}")
    values = resolve_parameters(mech)
    fold = {symbol(c.name): sp.Float(values[c.name]) for c in mech.constants}
    q = me.dynamicsymbols(" ".join(mech.coordinates) + " _", real=True)[:-1]
    u = me.dynamicsymbols(" ".join(f"u_{c}" for c in mech.coordinates) + " _", real=True)[:-1]
    coord = {name: (qi, ui) for name, qi, ui in zip(mech.coordinates, q, u)}
    N, origin = me.ReferenceFrame("N"), me.Point("O")
    origin.set_vel(N, 0)
    frames, origins, rel = {GROUND: N}, {GROUND: origin}, {}
    bodies, loads = [], []

    def vec(frame, xy):
        return sp.sympify(xy[0]).xreplace(fold) * frame.x + sp.sympify(xy[1]).xreplace(fold) * \
            frame.y

    for joint in mech.joints:  # parents come first in a validated mechanism
        P, Po = frames[joint.parent], origins[joint.parent]
        qi, _ = coord[joint.coordinates[0]]
        B = me.ReferenceFrame(f"F_{joint.child}")
        offset = sp.sympify(joint.offset).xreplace(fold)
        at = Po.locatenew(f"A_{joint.name}", vec(P, joint.at))
        at.v2pt_theory(Po, N, P)  # velocities joint by joint, as a PyDy user writes them
        if joint.type == "revolute":
            base = P if joint.angle == "relative" else N
            B.orient_axis(base, base.z, qi + offset)
            Bo = at
            rel[joint.name] = qi if joint.angle == "relative" else qi - angle_of(P, N, frames)
        else:
            B.orient_axis(P, P.z, offset)
            axis = vec(P, joint.axis).normalize()
            Bo = at.locatenew(f"O_{joint.child}", qi * axis)
            Bo.set_vel(P, qi.diff(me.dynamicsymbols._t) * axis)
            Bo.v1pt_theory(at, N, P)
            rel[joint.name] = qi
        frames[joint.child], origins[joint.child] = B, Bo
        body = mech.body(joint.child)
        com = Bo.locatenew(f"C_{joint.child}", vec(B, body.com))
        com.v2pt_theory(Bo, N, B)
        mass, inertia = (sp.sympify(v).xreplace(fold) for v in (body.mass, body.inertia))
        bodies.append(me.RigidBody(joint.child, com, B, mass, (me.inertia(B, 0, 0, inertia), com)))
        loads.append((com, mass * vec(N, mech.gravity)))
    for load in mech.loads:
        joint = mech.joint(load.joint)
        k, rest, c = (sp.sympify(v).xreplace(fold) for v in (load.k, load.rest, load.damping))
        x = rel[joint.name]
        generalized = -k * (x - rest) - c * x.diff(me.dynamicsymbols._t)
        B, P = frames[joint.child], frames[joint.parent]
        if joint.type == "revolute":
            loads += [(B, generalized * N.z), (P, -generalized * N.z)]
        else:
            direction = vec(P, joint.axis).normalize()
            on_parent = origins[joint.parent].locatenew(f"R_{joint.name}",
                                                        origins[joint.child].pos_from(
                                                            origins[joint.parent]))
            on_parent.v2pt_theory(origins[joint.parent], N, P)
            loads += [(origins[joint.child], generalized * direction),
                      (on_parent, -generalized * direction)]
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    kane.kanes_equations(bodies, loads)
    params = [symbol(p.name) for p in mech.parameters]
    return MechanicsModel(kane.mass_matrix, kane.forcing, kane.mass_matrix_full,
                          kane.forcing_full, list(q), list(u), params,
                          [values[p.name] for p in mech.parameters],
                          time.perf_counter() - start, list(mech.state_names))


def angle_of(frame, ground, frames) -> Any:
    """The absolute angle of a planar frame (for joint springs on absolute revolute joints)."""
    import sympy as sp

    return sp.atan2(frame.x.dot(ground.y), frame.x.dot(ground.x)) if frame is not ground else 0


# -- explicit RHS by an LDL^T elimination in named intermediates ------------------------------


def ldl_solve(mass: Sequence[Sequence[Any]], forcing: Sequence[Any],
              name: Callable[[Any], Any]) -> list[Any]:
    """x with M x = f for symmetric positive definite M; `name(expr)` returns a name for expr
    (a helper symbol, or expr itself where the algebra shares subexpressions)."""
    n = len(forcing)
    low = [[None] * n for _ in range(n)]
    diag: list[Any] = []
    for j in range(n):
        diag.append(name(mass[j][j] - sum((low[j][k] ** 2 * diag[k] for k in range(j)), 0)))
        for i in range(j + 1, n):
            low[i][j] = name((mass[i][j] - sum((low[i][k] * low[j][k] * diag[k]
                                                for k in range(j)), 0)) / diag[j])
    z: list[Any] = []
    for i in range(n):
        z.append(name(forcing[i] - sum((low[i][k] * z[k] for k in range(i)), 0)))
    x: list[Any] = [None] * n
    for i in reversed(range(n)):
        x[i] = name(z[i] / diag[i] - sum((low[k][i] * x[k] for k in range(i + 1, n)), 0))
    return x


def plain_symbols(model: MechanicsModel):
    """M and F with q(t), u(t) replaced by plain symbols and parameters folded to numbers."""
    import sympy as sp

    qs = sp.symbols(f"q0:{len(model.q)}", real=True)
    us = sp.symbols(f"u0:{len(model.u)}", real=True)
    subs = {**dict(zip(model.q, qs)), **dict(zip(model.u, us))}
    subs.update({c: sp.Float(v) for c, v in zip(model.constants, model.constant_values)})
    return model.mass_matrix.xreplace(subs), model.forcing.xreplace(subs), qs, us


# -- the peers ---------------------------------------------------------------------------------


@dataclass
class Peer:
    """A built peer: its RHS in nemc's state order and its integrators."""

    rhs: Callable[[float, np.ndarray], np.ndarray]
    solvers: dict[str, Callable[[tuple, np.ndarray, np.ndarray, float], tuple[np.ndarray, int]]]
    build_seconds: dict[str, float]
    # the RHS at t = 0 over rows of states (k, n_state) in the peer's own compiled loop: its
    # cost per call without Python (numbalsoda only)
    rhs_loop: Callable[[np.ndarray], Any] | None = None


def orders(model: MechanicsModel) -> tuple[np.ndarray, np.ndarray]:
    """Index arrays: nemc state -> peer's [q..., u...] order and back."""
    n = len(model.q)
    to_peer = np.array([2 * k for k in range(n)] + [2 * k + 1 for k in range(n)])
    return to_peer, np.argsort(to_peer)


def scipy_solver(rhs: Callable, method: str):
    from scipy.integrate import solve_ivp

    def solve(span, y0, t_eval, rtol):
        sol = solve_ivp(rhs, span, y0, method=method, rtol=rtol, atol=rtol * 1e-3, t_eval=t_eval)
        return (sol.y if sol.success else None), int(sol.nfev)

    return solve


def build_pydy(model: MechanicsModel, folder: Path) -> Peer:
    from pydy.codegen.ode_function_generators import generate_ode_function

    start = time.perf_counter()
    f = generate_ode_function(model.forcing_full, model.q, model.u, model.constants,
                              mass_matrix=model.mass_matrix_full, generator="cython",
                              constants_arg_type="array", tmp_dir=str(folder))
    seconds = time.perf_counter() - start
    to_peer, back = orders(model)
    p = np.asarray(model.constant_values)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        return f(y[to_peer], t, p)[back]

    solvers = {m: scipy_solver(rhs, m) for m in ("DOP853", "LSODA")}
    return Peer(rhs, solvers, {"cython build": seconds})


def build_jitcode(model: MechanicsModel, folder: Path) -> Peer:
    import symengine
    from jitcode import jitcode, y

    start = time.perf_counter()
    mass, forcing, qs, us = plain_symbols(model)
    n = len(qs)
    subs = {**{symengine.sympify(s): y(2 * k) for k, s in enumerate(qs)},
            **{symengine.sympify(s): y(2 * k + 1) for k, s in enumerate(us)}}
    helpers: list[tuple[Any, Any]] = []

    def name(expr):
        symbol = symengine.Symbol(f"h{len(helpers)}")
        helpers.append((symbol, expr))
        return symbol

    m = [[name(symengine.sympify(mass[i, j]).subs(subs)) if j <= i else None for j in range(n)]
         for i in range(n)]
    sym = [[m[max(i, j)][min(i, j)] for j in range(n)] for i in range(n)]
    f = [name(symengine.sympify(forcing[i]).subs(subs)) for i in range(n)]
    qdd = ldl_solve(sym, f, name)
    f_sym = [e for k in range(n) for e in (y(2 * k + 1), qdd[k])]
    ode = jitcode(f_sym, helpers=helpers, n=2 * n, verbose=False)
    ode.generate_f_C(simplify=False, do_cse=False, chunk_size=100)
    ode.compile_C(modulename=f"nemcbench{os.getpid()}")
    seconds = time.perf_counter() - start
    rhs = ode.f

    def solve(span, y0, t_eval, rtol):
        ode.set_integrator("dop853", rtol=rtol, atol=rtol * 1e-3, nsteps=10**9)
        ode.set_initial_value(y0, span[0])
        out = np.column_stack([ode.integrate(t) if t > span[0] else y0 for t in t_eval])
        return out, -1

    return Peer(lambda t, yy: rhs(t, yy), {"dop853 (scipy ode)": solve},
                {"derive helpers + C compile": seconds})


def build_heyoka(model: MechanicsModel, folder: Path) -> Peer:
    import heyoka as hy

    start = time.perf_counter()
    mass, forcing, qs, us = plain_symbols(model)
    n = len(qs)
    hq = hy.make_vars(*[f"q{k}" for k in range(n)])
    hu = hy.make_vars(*[f"u{k}" for k in range(n)])
    hq, hu = (list(v) if isinstance(v, list | tuple) else [v] for v in (hq, hu))
    smap = {**dict(zip(qs, hq)), **dict(zip(us, hu))}
    m = [[hy.from_sympy(mass[max(i, j), min(i, j)], s_dict=smap) for j in range(n)]
         for i in range(n)]
    f = [hy.from_sympy(forcing[i], s_dict=smap) for i in range(n)]
    qdd = ldl_solve(m, f, lambda e: e)
    system = [eq for k in range(n) for eq in ((hq[k], hu[k]), (hu[k], qdd[k]))]
    variables = [v for k in range(n) for v in (hq[k], hu[k])]
    compact = n > 4  # the default mode takes minutes past 8 links (FIELD-NOTES)
    cf = hy.cfunc(qdd, vars=variables, compact_mode=compact)
    seconds = {"expressions + cfunc": time.perf_counter() - start}

    def rhs(t: float, yy: np.ndarray) -> np.ndarray:
        dy = np.empty(2 * n)
        dy[0::2] = yy[1::2]
        dy[1::2] = cf(yy)
        return dy

    integrators: dict[float, Any] = {}

    def solve(span, y0, t_eval, rtol):
        if rtol not in integrators:  # JIT compiled once per tolerance (the worker's warm-up)
            build = time.perf_counter()
            integrators[rtol] = hy.taylor_adaptive(system, list(y0), tol=rtol,
                                                   compact_mode=compact)
            seconds[f"taylor_adaptive tol {rtol:g}"] = time.perf_counter() - build
        ta = integrators[rtol]
        ta.state[:] = y0
        ta.time = span[0]
        out = ta.propagate_grid(np.asarray(t_eval))
        return np.asarray(out[-1]).T, -1

    return Peer(rhs, {"taylor (tol = rtol)": solve}, seconds)


def straight_line_rhs(model: MechanicsModel) -> str:
    """The Python source of `rhs(t, u, du, p)` (numbalsoda's signature, nemc's state order):
    Kane's M and F with their common subexpressions shared (sympy's cse), M qdd = F solved by
    ldl_solve in named intermediates, one assignment a line, as a numba user writes it for
    numbalsoda; p[0] counts the calls."""
    import sympy as sp
    from sympy.printing.pycode import PythonCodePrinter

    mass, forcing, qs, us = plain_symbols(model)
    n = len(qs)
    lower = [(i, j) for i in range(n) for j in range(i + 1)]
    shared, reduced = sp.cse([mass[i, j] for i, j in lower] + [forcing[i] for i in range(n)],
                             symbols=sp.numbered_symbols("c"))
    helpers = list(shared)

    def name(expr: Any) -> Any:
        symbol = sp.Symbol(f"h{len(helpers)}")
        helpers.append((symbol, expr))
        return symbol

    m_low = dict(zip(lower, (name(e) for e in reduced[:len(lower)])))
    m = [[m_low[max(i, j), min(i, j)] for j in range(n)] for i in range(n)]
    qdd = ldl_solve(m, [name(e) for e in reduced[len(lower):]], name)
    printer = PythonCodePrinter({"standard": "python3"})
    lines = ["def rhs(t, u, du, p):"]
    lines += [f"    {q} = u[{2 * k}]\n    {v} = u[{2 * k + 1}]" for k, (q, v) in
              enumerate(zip(qs, us))]
    lines += [f"    {symbol} = {printer.doprint(expr)}" for symbol, expr in helpers]
    lines += [f"    du[{2 * k}] = {us[k]}\n    du[{2 * k + 1}] = {printer.doprint(qdd[k])}"
              for k in range(n)]
    return "\n".join([*lines, "    p[0] += 1.0"])


def build_numbalsoda(model: MechanicsModel, folder: Path) -> Peer:
    """numbalsoda's dop853 (Hairer's DOP853 in Fortran) on a numba cfunc of
    straight_line_rhs: the setup of issue 19's comparison."""
    import math

    import numba
    from numbalsoda import dop853, lsoda_sig

    start = time.perf_counter()
    namespace: dict[str, Any] = {"math": math}
    exec(straight_line_rhs(model), namespace)  # noqa: S102 (benchmark code made from sympy)
    jitted = numba.njit(namespace["rhs"])
    address = numba.cfunc(lsoda_sig)(jitted).address
    n_state = 2 * len(model.q)
    counter = np.zeros(1)
    jitted(0.0, np.zeros(n_state), np.zeros(n_state), counter)  # compiled here, not timed
    seconds = time.perf_counter() - start

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        dy = np.empty(n_state)
        jitted(t, np.ascontiguousarray(y, dtype=float), dy, counter)
        return dy

    @numba.njit
    def rhs_loop(rows: np.ndarray) -> float:
        dy, calls, total = np.empty(n_state), np.zeros(1), 0.0
        for k in range(rows.shape[0]):
            jitted(0.0, rows[k], dy, calls)
            total += dy[-1]  # used, so the calls are not optimized away
        return total

    rhs_loop(np.zeros((1, n_state)))  # compiled here, not timed

    def solve(span, y0, t_eval, rtol):
        calls = np.zeros(1)
        ys, success = dop853(address, np.array(y0, dtype=float), np.asarray(t_eval, float),
                             data=calls, rtol=rtol, atol=rtol * 1e-3, mxstep=10**8)
        return (ys.T if success else None), int(calls[0])

    return Peer(rhs, {"dop853": solve}, {"sympy cse + numba cfunc": seconds}, rhs_loop)


BUILDERS = {"pydy": build_pydy, "jitcode": build_jitcode, "heyoka": build_heyoka,
            "numbalsoda": build_numbalsoda}


# -- the worker (one peer, one system, in its own process) ------------------------------------


def worker(spec: dict[str, Any]) -> dict[str, Any]:
    import nemc

    path = Path(spec["path"])
    out: dict[str, Any] = {"peer": spec["peer"], "system": path.stem}
    model = nemc.compile(path)
    mech = mechanics_model(path)
    out["sympy.physics.mechanics derive seconds"] = mech.derive_seconds
    with tempfile.TemporaryDirectory(prefix="nemc-bench-peer-") as folder:
        peer = BUILDERS[spec["peer"]](mech, Path(folder))
        out["build_seconds"] = peer.build_seconds
        closure = model.compiled.integrator_rhs(model.parameter_vector())
        states = np.random.default_rng(2).uniform(-1.5, 1.5, size=(16, model.n_state))
        ours = np.array([closure(0.0, s) for s in states])
        theirs = np.array([peer.rhs(0.0, s) for s in states])
        out["agreement"] = float(np.max(np.abs(theirs - ours)) / max(1.0, np.max(np.abs(ours))))
        if not out["agreement"] <= AGREEMENT_TOLERANCE:
            out["failure"] = f"RHS disagrees with nemc's (relative {out['agreement']:.1e})"
            return out
        y = np.ascontiguousarray(states[0])
        calls = {"nemc closure": (lambda: closure(0.0, y), 1),
                 PEER_NAMES[spec["peer"]]: (lambda: peer.rhs(0.0, y), 1)}
        out["rhs_seconds"] = common.interleaved(calls, spec["rounds"], spec["sample_seconds"])
        if spec.get("reference_file"):
            out["work_precision"] = peer_work_precision(peer, model, spec)
    return out


def peer_work_precision(peer: Peer, model, spec: dict[str, Any]) -> list[dict[str, Any]]:
    ref = json.loads(Path(spec["reference_file"]).read_text())
    t_eval, ref_y = np.asarray(ref["t"]), np.asarray(ref["y"])
    span, y0 = (t_eval[0], t_eval[-1]), model.initial_state()
    rows = []
    for method, solve in peer.solvers.items():
        for rtol in sorted(spec["rtols"], reverse=True):
            ys, nfev = solve(span, y0, t_eval, rtol)  # warm-up: JIT builds, first-call costs
            times = []
            for _ in range(spec["repeats"] if ys is not None else 0):
                start = time.perf_counter()
                ys, nfev = solve(span, y0, t_eval, rtol)
                times.append(time.perf_counter() - start)
                if ys is None or times[-1] > spec["cell_cap"]:
                    break
            row = {"contender": f"{PEER_NAMES[spec['peer']]} {method}", "method": method,
                   "rtol": rtol, "seconds": common.summary(times) if times else None,
                   "nfev": nfev,
                   "error": None, "trajectory_error": None}
            if ys is not None and np.shape(ys) == ref_y.shape:
                row["error"] = float(np.max(np.abs(ys[:, -1] - ref_y[:, -1])))
                row["trajectory_error"] = float(np.max(np.abs(ys - ref_y)))
            rows.append(row)
            if not times or times[0] > spec["cell_cap"]:
                break
            if row["error"] is not None and row["error"] <= spec.get("stop_below", -1.0):
                break  # the tightest error wanted is reached: tighter tolerances are not needed
    return rows


# -- in the benchmark process -----------------------------------------------------------------


def installed() -> dict[str, str | None]:
    return {name: (common.version_of(name) if importlib.util.find_spec(name) else None)
            for name in PEER_NAMES}


def availability() -> dict[str, Any]:
    """What is installed, and why nothing was measured."""
    notes = {}
    for name, version in installed().items():
        notes[name] = (f"installed ({version}); not run in this mode" if version else
                       "skipped: not installed (pip install '.[peers]')")
    notes["octave"] = octave_note()
    return {"notes": notes}


def octave_note() -> str:
    if shutil.which("octave-cli") is None:
        return "skipped: octave-cli is not on the PATH (the book's ode45 programs need it)"
    return "octave-cli found, but the book's ode45 programs are not part of this repository: " \
           "not run"


def run_worker(spec: dict[str, Any], timeout: float) -> dict[str, Any]:
    """One worker process under `timeout` seconds; a failure or timeout is the result."""
    with tempfile.TemporaryDirectory(prefix="nemc-bench-peerspec-") as folder:
        spec_file, out_file = Path(folder) / "spec.json", Path(folder) / "out.json"
        spec_file.write_text(json.dumps(spec))
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            p for p in (str(common.ROOT), os.environ.get("PYTHONPATH", "")) if p))
        start = time.perf_counter()
        # A session of its own: on timeout the whole group goes, the peer's compiler too (a
        # JiTCODE gcc left running took a core and 7 GB through the next benchmark).
        worker = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), str(spec_file),
                                   str(out_file)], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True, env=env,
                                  start_new_session=True)
        try:
            _, stderr = worker.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(worker.pid, signal.SIGKILL)
            worker.communicate()
            return {"peer": spec["peer"], "failure": f"did not finish in {timeout:.0f} s "
                    "(time budget)", "wall_seconds": timeout}
        result = json.loads(out_file.read_text()) if out_file.is_file() else {
            "peer": spec["peer"], "failure": f"worker exit {worker.returncode}: "
            f"{(stderr.strip().splitlines() or ['?'])[-1]}"}
        result["wall_seconds"] = time.perf_counter() - start
        return result


def run_peers(path: Path, result: dict[str, Any], timeout: float) -> dict[str, Any]:
    """Each installed peer on the double pendulum: RHS cost and work-precision."""
    wp = result["work_precision"].get(path.stem, {})
    ref_file = wp.get("reference", {}).get("file")
    rtols = result["config"]["wp_rtols"]  # the same grid as nemc's and lambdify's
    out: dict[str, Any] = {"notes": {"octave": octave_note()}, "runs": {},
                           "work_precision": []}
    for name, version in installed().items():
        if version is None:
            out["notes"][name] = "skipped: not installed (pip install '.[peers]')"
            continue
        print(f"peer {name} on {path.stem}", flush=True)
        spec = {"peer": name, "path": str(path), "reference_file": ref_file,
                "rtols": sorted(set(rtols), reverse=True), "rounds": 5, "sample_seconds": 0.05,
                "repeats": 3, "cell_cap": 5.0}
        run = run_worker(spec, timeout)
        out["runs"][name] = run
        out["work_precision"] += run.get("work_precision", [])
        out["notes"][name] = f"{version}: " + (run.get("failure") or "measured")
    return out


def markdown(peers: dict[str, Any]) -> list[str]:
    lines = ["## 4. Peers", ""] + [f"- {k}: {v}" for k, v in peers["notes"].items()] + [""]
    runs = peers.get("runs", {})
    if any("rhs_seconds" in r for r in runs.values()):
        lines += ["RHS cost per call from Python, each peer timed interleaved with nemc's "
                  "closure in the peer's own process (ratio: peer / nemc, within that process):",
                  "", "| peer | build | peer RHS | nemc closure | peer / nemc | agreement |",
                  "| --- | --- | --- | --- | --- | --- |"]
        for name, r in runs.items():
            if "rhs_seconds" not in r:
                continue
            peer_t = r["rhs_seconds"][PEER_NAMES[name]]
            ours = r["rhs_seconds"]["nemc closure"]
            build = ", ".join(f"{k} {v:.2f} s" for k, v in r["build_seconds"].items()
                              if not k.startswith("taylor_adaptive"))
            lines.append(f"| {PEER_NAMES[name]} | {build} | {common.spread(peer_t)} | "
                         f"{common.spread(ours)} | {peer_t['median'] / ours['median']:.1f} | "
                         f"{r['agreement']:.1e} |")
        lines += [""]
    return lines


if __name__ == "__main__":
    spec_path, out_path = Path(sys.argv[1]), Path(sys.argv[2])
    try:
        output = worker(json.loads(spec_path.read_text()))
    except Exception as error:  # noqa: BLE001 (any failure of a peer is a recorded result)
        output = {"failure": f"{type(error).__name__}: {str(error)[:300]}",
                  "traceback": traceback.format_exc()[-2000:]}
    output.setdefault("peer", json.loads(spec_path.read_text())["peer"])
    out_path.write_text(json.dumps(output, default=float))
