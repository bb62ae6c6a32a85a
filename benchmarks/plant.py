"""The model as a plant (issue 46): A and B, the Jacobian, params= and nemc.feedback timed.

What they cost against sympy's Linearizer and Pinocchio, measured in one run, interleaved and
repeated.

1. **A and B of a pendulum on a cart** (a cart on a prismatic rail, a chain of uniform rods,
   a force input F on the cart; 4 links in full mode: A 10x10, B 10x1): the build's C function
   `<prefix>linearization` in a C loop over 64 states (preallocated buffers, called through a
   pointer as overhead.py's loop calls the RHS), the same C called from Python through cffi with
   preallocated buffers, and `model.linearize(y, u)`. Against sympy.physics.mechanics: the same
   cart and chain by KanesMethod, `kane.linearize(A_and_B=True)` at a general point (floats for
   the parameters), its u-dot terms (sympy 20486: Linearizer leaves them in A) given as
   arguments, then `lambdify(cse=True)` of A and B, built in a fresh process under a time budget
   (set-up reported apart, stage by stage); per point: A and B with the accelerations they need
   from `lambdify(cse=True)` of Kane's M and f and numpy.linalg.solve, and A and B alone. The
   matrices are compared with nemc's at random states first (an independent check).
2. **d ydot/d(y, u) of chains** of 8, 16, 32, 64 uniform rods (revolute joints, relative angles,
   gravity; a torque input at every joint so that both sides compute d/dq, d/dv and d/dtau):
   nemc's C Jacobian (d/dy, the part "jacobian") and linearization (d/d(y, u)) in a C loop, and
   `model.jacobian` from Python; against Pinocchio's `computeABADerivatives` on the same chain as
   revolute-z joints built in code (pip `pin`, an optional peer): from Python, and in a C++ loop
   compiled here against the installed Pinocchio (its headers need Eigen's, pip `cmeel-eigen`;
   skipped, with the reason, when they or g++ are missing). Pinocchio's ABA accelerations and
   derivatives are checked against nemc's first. With the profile: each build's C size, the
   accelerations' program and its tangent (steps, nemc's cost estimate), and the Jacobian's time
   against 2n tangent runs and 2n right-hand sides.
3. **params=**: model.rhs, model.jacobian and model.linearize of a 6-link chain with 25
   parameters, without params and with the same dict of 1, 5 and 25 entries passed again, and
   with a new dict of 25 equal values each call. `--against PATH` runs this section also with
   the nemc of another checkout (before a change), in a fresh process in the same run.
4. **nemc.feedback**: a cart-pole and the 4-link cart held upright by LQR (designed from
   model.linearize) through nemc.feedback, against the same run with a constant input, per
   accepted step (the runs' step counts differ), nemc.DOP853, nemc.Vern9 and nemc.Taylor.

The timed contenders of a section are interleaved in one process on one CPU (common.one_cpu),
`rounds` rounds of calibrated loops; median and min-max; the load average is recorded with
every section. Builds (nemc's parts, sympy's set-up, the C++ harness) are timed apart.

Run: `python benchmarks/plant.py [--quick | --smoke] [--sizes 8,16] [--against PATH] [--out
DIR]`: full (about 10-15 minutes: sympy's set-up most of it), `--quick` (the cart with 2 links,
the 8-link chain, short loops: about a minute, CI's smoke test) and `--smoke` (the same).
Results: `results/plant-latest.{json,md}` (`quick/` for --quick).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402
from common import (  # noqa: E402
    environment,
    finish_environment,
    fmt_time,
    interleaved,
    load_average,
    md_environment,
    mode_of,
    mode_parser,
    one_cpu,
    power_fit,
    results_folder,
    spread,
    summary,
    timed,
    version_of,
    write_results,
)

TARGETS = {"A, B in C": 2e-6, "A, B from Python": 10e-6, "vs sympy": 10.0,
           "feedback per step": 1.2}
CART = {"M": 1.0, "m": 0.5, "L": 0.5, "g": 9.81}  # the cart and its rods
ROD = {"m": 1.0, "L": 1.0, "g": 9.81}  # the chains' rods
STATES = 64  # the C loops cycle through this many random states
AGREE = 1e-9  # a peer further from nemc than this (relative) is recorded as failed


@dataclass(frozen=True)
class Config:
    cart_links: int = 4
    chains: tuple[int, ...] = (8, 16, 32, 64)
    rounds: int = 5
    sample_seconds: float = 0.2
    sympy_timeout: float = 900.0
    run_span: float = 20.0  # the feedback section's runs
    methods: tuple[str, ...] = ("nemc.DOP853", "nemc.Vern9", "nemc.Taylor")
    params_sizes: tuple[int, ...] = (1, 5, 25)


MODES = {
    "full": Config(),
    "quick": Config(cart_links=2, chains=(8,), rounds=2, sample_seconds=0.03,
                    sympy_timeout=120.0, run_span=3.0),
    "smoke": Config(cart_links=2, chains=(4,), rounds=1, sample_seconds=0.02,
                    sympy_timeout=120.0, run_span=2.0, methods=("nemc.DOP853",)),
}


# ---- the models --------------------------------------------------------------------------------


def cart_yaml(links: int) -> str:
    """A cart on a rail (prismatic x) with LINKS uniform rods hinged in a chain (relative
    angles), gravity, and the input F pushing the cart."""
    lines = [f"name: cart{links}",
             f"description: a cart with a {links}-link pendulum of rods, a force F on the cart"
             " (nemc benchmark)",
             "parameters: {" + ", ".join(f"{k}: {v}" for k, v in CART.items()) + "}",
             "inputs:", "  F: 0", "gravity: [0, -g]", "bodies:",
             "  cart: {mass: M, inertia: 0.01}"]
    for i in range(1, links + 1):
        lines.append(f"  link{i}: {{mass: m, inertia: m*L**2/12, com: [L/2, 0], "
                     "points: {tip: [L, 0]}}")
    lines += ["joints:", "  rail: {type: prismatic, parent: ground, child: cart, coordinate: x}"]
    for i in range(1, links + 1):
        parent, at = ("cart", "[0, 0]") if i == 1 else (f"link{i - 1}", "tip")
        lines.append(f"  J{i}: {{type: revolute, parent: {parent}, child: link{i}, at: {at}, "
                     f"coordinate: q{i}, angle: relative}}")
    lines += ["loads:", "  - {force: [F, 0], body: cart}", "simulation:", "  t_span: [0, 5]",
              "  initial: {q1: 1.7}"]
    return "\n".join(lines) + "\n"


def torque_chain_yaml(n: int) -> str:
    """common.chain_yaml(n)'s chain (uniform rods m = 1, L = 1, relative angles) with a torque
    input tau<i> at every joint (on the link, its reaction on the parent)."""
    lines = [f"name: torque_chain{n}",
             f"description: {n}-link chain of uniform rods, a torque input at every joint"
             " (nemc benchmark)",
             "parameters: {" + ", ".join(f"{k}: {v}" for k, v in ROD.items()) + "}",
             "inputs:"] + [f"  tau{i}: 0" for i in range(1, n + 1)]
    lines += ["gravity: [0, -g]", "bodies:"]
    for i in range(1, n + 1):
        lines.append(f"  link{i}: {{mass: m, inertia: m*L**2/12, com: [L/2, 0], "
                     "points: {tip: [L, 0]}}")
    lines.append("joints:")
    for i in range(1, n + 1):
        parent, at = ("ground", "[0, 0]") if i == 1 else (f"link{i - 1}", "tip")
        lines.append(f"  J{i}: {{type: revolute, parent: {parent}, child: link{i}, at: {at}, "
                     f"coordinate: q{i}, angle: relative}}")
    lines.append("loads:")
    for i in range(1, n + 1):
        reaction = "" if i == 1 else f", reaction: link{i - 1}"
        lines.append(f"  - {{torque: tau{i}, body: link{i}{reaction}}}")
    lines += ["simulation:", "  t_span: [0, 5]", "  initial: {q1: -pi/4}"]
    return "\n".join(lines) + "\n"


def params_yaml(links: int = 6) -> str:
    """A chain of LINKS rods with a mass, length, joint stiffness and damping each, and g: 25
    parameters at 6 links."""
    lines = ["name: params25", f"description: a {links}-link chain with {4 * links + 1} "
             "parameters (nemc benchmark)", "parameters:", "  g: 9.81"]
    for i in range(1, links + 1):
        lines += [f"  m{i}: {1 + 0.1 * i:g}", f"  L{i}: {0.5 + 0.05 * i:g}",
                  f"  k{i}: {2.0 + i:g}", f"  c{i}: {0.05 * i:g}"]
    lines += ["gravity: [0, -g]", "bodies:"]
    for i in range(1, links + 1):
        lines.append(f"  link{i}: {{mass: m{i}, inertia: m{i}*L{i}**2/12, com: [L{i}/2, 0], "
                     f"points: {{tip: [L{i}, 0]}}}}")
    lines.append("joints:")
    for i in range(1, links + 1):
        parent, at = ("ground", "[0, 0]") if i == 1 else (f"link{i - 1}", "tip")
        lines.append(f"  J{i}: {{type: revolute, parent: {parent}, child: link{i}, at: {at}, "
                     f"coordinate: q{i}, angle: relative}}")
    lines.append("loads:")
    for i in range(1, links + 1):
        lines.append(f"  - joint_spring: {{joint: J{i}, k: k{i}, damping: c{i}}}")
    lines += ["simulation:", "  t_span: [0, 5]", "  initial: {q1: 0.5, q2: 0.1}"]
    return "\n".join(lines) + "\n"


def compiled(text: str, folder: Path, parts: Sequence[str] = ()) -> tuple[Any, dict]:
    """The model of TEXT and its build with PARTS (each built on first need, timed)."""
    import nemc

    path = folder / f"{text.split(chr(10), 1)[0].split()[1]}.yaml"
    path.write_text(text)
    seconds, model = timed(lambda: nemc.compile(path))
    builds = {"nemc.compile": seconds}
    build = model
    for part in parts:
        seconds, build = timed(lambda part=part: model.compiled_with(part))
        builds[f"part {part!r}"] = seconds
    return (model, build), builds


def package_folder(model: Any) -> Path | None:
    """The folder of a loaded build (its cffi module's)."""
    for module in list(sys.modules.values()):
        if getattr(module, "lib", None) is model.compiled.lib and getattr(module, "__file__",
                                                                           None):
            return Path(module.__file__).parent
    return None


def c_size(model: Any) -> int | None:
    folder = package_folder(model)
    return None if folder is None else sum(p.stat().st_size for p in folder.glob("*.c"))


def jacobian_machine_code(model: Any) -> int | None:
    """Bytes of machine code in the build's Jacobian functions (its own and its parts': the
    primal and the tangent run once per column), from `nm` of the build's extension; None
    without nm."""
    folder = package_folder(model)
    library = next(iter(folder.glob("_native*.so")), None) if folder else None
    tool = shutil.which("nm")
    if library is None or tool is None:
        return None
    listed = subprocess.run([tool, "--size-sort", "-S", "-t", "d", str(library)],
                            capture_output=True, text=True).stdout.splitlines()
    total = 0
    for line in listed:
        fields = line.split()
        if (len(fields) == 4 and fields[2] in "tT" and "jacobian" in fields[3]
                and "_cffi_" not in fields[3] and "constraint_jacobian" not in fields[3]):
            total += int(fields[1])
    return total


def random_rows(n_state: int, count: int, seed: int, bound: float = 1.5) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-bound, bound, size=(count, n_state))


# ---- C loops -----------------------------------------------------------------------------------

LOOP_C = r"""
typedef int (*state_fn)(double t, const double *y, const double *p, double *out);
typedef int (*lin_fn)(double t, const double *y, const double *p, double *ab, double *cd);

/* CALLS calls of a build's rhs or jacobian (same signature) over COUNT states (rows of n),
   cycling, writing one preallocated output, through a pointer as the drivers call it. */
int loop_state(const void *function, int n, int count, const double *states, const double *p,
               double *out, long calls)
{
    state_fn f = (state_fn)function;
    const double *state = states, *end = states + (long)count * n;
    int status = 0;
    for (long c = 0; c < calls; ++c) {
        status |= f(0.0, state, p, out);
        state = state + n == end ? states : state + n;
    }
    return status;
}

/* The same for <prefix>linearization, without the outputs (cd NULL). */
int loop_linearization(const void *function, int n, int count, const double *states,
                       const double *p, double *ab, long calls)
{
    lin_fn f = (lin_fn)function;
    const double *state = states, *end = states + (long)count * n;
    int status = 0;
    for (long c = 0; c < calls; ++c) {
        status |= f(0.0, state, p, ab, (double *)0);
        state = state + n == end ? states : state + n;
    }
    return status;
}
"""
LOOP_CDEF = """
int loop_state(const void *, int, int, const double *, const double *, double *, long);
int loop_linearization(const void *, int, int, const double *, const double *, double *, long);
"""


class CLoops:
    """LOOP_C compiled once with the drivers' flags and loaded (cffi ABI mode)."""

    def __init__(self, folder: Path):
        import cffi

        from nemc.build.builder import DRIVERS_CFLAGS, compiler

        source, library = folder / "plant_loops.c", folder / "plant_loops.so"
        source.write_text(LOOP_C)
        subprocess.run([*compiler(), *DRIVERS_CFLAGS, "-shared", str(source), "-o",
                        str(library)], check=True)
        self.ffi = cffi.FFI()
        self.ffi.cdef(LOOP_CDEF)
        self.lib = self.ffi.dlopen(str(library))
        self.kept: list[Any] = []  # buffers the loops read, alive as long as this

    def caller(self, model: Any, name: str, rows: np.ndarray, p: np.ndarray, out: np.ndarray,
               calls: int) -> Callable[[], None]:
        """A call of the C loop over `name` ("rhs", "jacobian", "linearization") of MODEL's
        build at ROWS (count, n_state), CALLS calls."""
        c = model.compiled
        address = int(c.ffi.cast("uintptr_t", c.ffi.addressof(c.lib, c.prefix + name)))
        function = self.ffi.cast("const void *", address)
        rows, p = np.ascontiguousarray(rows), np.ascontiguousarray(p)
        buffers = (self.ffi.from_buffer("double[]", rows), self.ffi.from_buffer("double[]", p),
                   self.ffi.from_buffer("double[]", out))
        self.kept.append((rows, p, out, buffers))
        loop = self.lib.loop_linearization if name == "linearization" else self.lib.loop_state
        n, count = rows.shape[1], rows.shape[0]

        def call() -> None:
            if loop(function, n, count, *buffers, calls):
                raise RuntimeError(f"{name}: the C returned a failure status")
        return call


def calls_for(call_once: Callable[[int], Callable[[], None]], seconds: float = 2e-3) -> int:
    """Calls per invocation so that one takes about SECONDS (timeit's loops then repeat it)."""
    probe = call_once(16)
    start = time.perf_counter()
    probe()
    each = max((time.perf_counter() - start) / 16, 1e-9)
    return max(16, int(seconds / each))


# ---- 1. A and B of the cart ---------------------------------------------------------------------


def kane_cart(links: int, params: dict[str, float]):
    """sympy.physics.mechanics: the cart (a particle on x) with LINKS rods hinged in a chain,
    relative angles, gravity -y, F on the cart. (kane, q, u, F)."""
    import sympy as sp
    from sympy.physics import mechanics as me

    q = me.dynamicsymbols(f"x q1:{links + 1}")
    u = me.dynamicsymbols(f"vx w1:{links + 1}")
    force = me.dynamicsymbols("F")
    t = me.dynamicsymbols._t
    mass_cart, m, length, g = (sp.Float(params[k]) for k in ("M", "m", "L", "g"))
    ground = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(ground, 0)
    cart = origin.locatenew("C", q[0] * ground.x)
    cart.set_vel(ground, u[0] * ground.x)
    bodies = [me.Particle("cart", cart, mass_cart)]
    loads = [(cart, force * ground.x - mass_cart * g * ground.y)]
    frame, joint = ground, cart
    kinematics = [q[0].diff(t) - u[0]]
    for i in range(1, links + 1):
        link = frame.orientnew(f"B{i}", "Axis", (q[i], ground.z))
        link.set_ang_vel(frame, u[i] * ground.z)
        com = joint.locatenew(f"G{i}", length / 2 * link.x)
        com.v2pt_theory(joint, ground, link)
        inertia = (me.inertia(link, 0, 0, m * length**2 / 12), com)
        bodies.append(me.RigidBody(f"link{i}", com, link, m, inertia))
        loads.append((com, -m * g * ground.y))
        tip = joint.locatenew(f"T{i}", length * link.x)
        tip.v2pt_theory(joint, ground, link)
        frame, joint = link, tip
        kinematics.append(q[i].diff(t) - u[i])
    kane = me.KanesMethod(ground, q_ind=q, u_ind=u, kd_eqs=kinematics)
    kane.kanes_equations(bodies, loads)
    return kane, q, u, force


def sympy_child(links: int, folder: Path) -> None:
    """In a fresh process: Kane's equations, Linearizer's A and B, lambdify(cse=True); each
    stage's time written to FOLDER/stages.json as soon as it is done, the sources after."""
    import inspect

    import sympy as sp
    from sympy.physics import mechanics as me

    stages: dict[str, float] = {}

    def done(stage: str, start: float) -> float:
        stages[stage] = time.perf_counter() - start
        (folder / "stages.json.tmp").write_text(json.dumps(stages))
        os.replace(folder / "stages.json.tmp", folder / "stages.json")
        return time.perf_counter()

    start = time.perf_counter()
    kane, q, u, force = kane_cart(links, CART)
    start = done("KanesMethod (derivation)", start)
    a, b, inputs = kane.linearize(A_and_B=True, simplify=False)
    assert list(inputs) == [force], inputs
    start = done("kane.linearize(A_and_B=True) (Linearizer)", start)
    t = me.dynamicsymbols._t
    qs, us = sp.symbols(f"q0:{len(q)}"), sp.symbols(f"u0:{len(u)}")
    rates, f_symbol = sp.symbols(f"udot0:{len(u)}"), sp.Symbol("F_in")
    symbols = {**{ui.diff(t): r for ui, r in zip(u, rates)}, **dict(zip(q, qs)),
               **dict(zip(u, us)), force: f_symbol}
    a, b = a.xreplace(symbols), b.xreplace(symbols)
    left = (a.free_symbols | b.free_symbols) - {*qs, *us, *rates, f_symbol}
    assert not left and not a.atoms(sp.Derivative), left
    start = done("symbols for q, u, u-dot, F (xreplace)", start)
    ab = sp.lambdify([*qs, *us, f_symbol, *rates], [a, b], cse=True)
    start = done("lambdify(cse=True) of A and B", start)
    mass, forcing = (kane.mass_matrix.xreplace(symbols), kane.forcing.xreplace(symbols))
    accelerations = sp.lambdify([*qs, *us, f_symbol], [mass, forcing], cse=True)
    done("lambdify(cse=True) of Kane's M and f (the u-dot A needs)", start)
    (folder / "sources.json").write_text(json.dumps({
        "ab": inspect.getsource(ab), "accelerations": inspect.getsource(accelerations),
        "n_coord": len(q)}))


def lambdified(source: str) -> Callable:
    """exec a lambdify-generated source in the namespace lambdify gives numpy code."""
    import sympy

    namespace = dict(sympy.lambdify([], 0, modules="numpy").__globals__)
    exec(compile(source, "<lambdify>", "exec"), namespace)  # noqa: S102 (sympy's, made here)
    return namespace[source.split("def ", 1)[1].split("(", 1)[0]]


def sympy_build(links: int, timeout: float) -> dict[str, Any]:
    """sympy_child under TIMEOUT seconds: its stages' times and, when it finished, its
    functions."""
    with tempfile.TemporaryDirectory(prefix="nemc-bench-plant-sympy-") as folder:
        command = [sys.executable, str(Path(__file__).resolve()), "--sympy-child", str(links),
                   folder]
        why = None
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
            if done.returncode != 0:
                lines = done.stderr.strip().splitlines()
                why = f"failed: {lines[-1] if lines else 'exit ' + str(done.returncode)}"
        except subprocess.TimeoutExpired:
            why = f"not finished within the {timeout:.0f} s budget"
        stages_file, sources_file = Path(folder) / "stages.json", Path(folder) / "sources.json"
        stages = json.loads(stages_file.read_text()) if stages_file.is_file() else {}
        sources = json.loads(sources_file.read_text()) if sources_file.is_file() else None
    found: dict[str, Any] = {"stages": stages, "setup_seconds": sum(stages.values()),
                             "why_not": why if sources is None else None}
    if sources is not None:
        found["ab"] = lambdified(sources["ab"])
        found["accelerations"] = lambdified(sources["accelerations"])
        found["n_coord"] = sources["n_coord"]
    return found


def sympy_point(built: dict[str, Any], n_coord: int) -> tuple[Callable, Callable]:
    """sympy's A and B at a state in nemc's order (x, dx, q1, dq1, ...) and F: with the
    accelerations from Kane's M and f, and with them given (A and B alone)."""
    ab, accelerations = built["ab"], built["accelerations"]
    order = np.ravel(np.column_stack([np.arange(n_coord), n_coord + np.arange(n_coord)]))

    def alone(q: Sequence[float], u: Sequence[float], force: float, rates: Sequence[float]):
        return ab(*q, *u, force, *rates)

    def at(y: np.ndarray, force: float) -> tuple[np.ndarray, np.ndarray]:
        q, u = y[0::2].tolist(), y[1::2].tolist()
        mass, forcing = accelerations(*q, *u, force)
        rates = np.linalg.solve(mass, np.ravel(forcing))
        return alone(q, u, force, rates.tolist())

    def in_nemc_order(a: Any, b: Any) -> tuple[np.ndarray, np.ndarray]:
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float).reshape(-1, 1)
        return a[np.ix_(order, order)], b[order]

    return at, in_nemc_order


NEMC_C = "nemc: A, B in C (a C loop over 64 states)"
NEMC_PYTHON = "nemc: model.linearize(y, u) from Python"
SYMPY_POINT = "sympy: A, B with the u-dot they need"
SYMPY_ALONE = "sympy: A, B alone (u-dot given)"


def relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def cart_section(config: Config, folder: Path, loops: CLoops) -> dict[str, Any]:
    from nemc.runtime.plant import with_inputs

    links = config.cart_links
    (model, build), builds = compiled(cart_yaml(links), folder, ("linearization",))
    n = model.n_state
    force = 0.3
    rows = random_rows(n, STATES, seed=46)
    y = rows[0].copy()
    p = with_inputs(model, model.parameter_vector(), [force])
    ab = np.empty((n, n + 1))
    section: dict[str, Any] = {"links": links, "shape_A": [n, n], "shape_B": [n, 1],
                               "force": force, "nemc_builds": builds,
                               "c_bytes": c_size(build), "notes": []}
    lin_c = build.compiled.functions["linearization"]
    buffer = build.compiled.buffer
    y_buffer, p_buffer, ab_buffer = buffer(y), buffer(p), buffer(ab)
    null = build.compiled.ffi.NULL
    calls = calls_for(lambda k: loops.caller(build, "linearization", rows, p, ab, k))
    contenders: dict[str, tuple[Callable[[], Any], int]] = {
        NEMC_C: (loops.caller(build, "linearization", rows, p, ab, calls), calls),
        "nemc: the C through cffi, preallocated buffers": (
            lambda: lin_c(0.0, y_buffer, p_buffer, ab_buffer, null), 1),
        NEMC_PYTHON: (lambda: model.linearize(y, [force]), 1),
        "nemc: model.linearize(y) from Python (u: the build's law, 0)": (
            lambda: model.linearize(y), 1),
    }
    sympy_built = sympy_build(links, config.sympy_timeout)
    section["sympy"] = {"stages": sympy_built["stages"],
                        "setup_seconds": sympy_built["setup_seconds"],
                        "why_not": sympy_built["why_not"]}
    if sympy_built["why_not"] is None:
        at, in_nemc_order = sympy_point(sympy_built, sympy_built["n_coord"])
        worst = 0.0
        for state in rows[:8]:
            lin = model.linearize(state, [force])
            a, b = in_nemc_order(*at(state, force))
            section["sympy"].setdefault("agreement_A", []).append(relative_difference(a, lin.A))
            section["sympy"].setdefault("agreement_B", []).append(relative_difference(b, lin.B))
            worst = max(worst, relative_difference(a, lin.A), relative_difference(b, lin.B))
        section["sympy"]["agreement"] = worst
        if worst > AGREE:
            section["notes"].append(f"sympy's A, B differ from nemc's by {worst:.2g} "
                                    "(relative): not timed")
        else:
            q, u = y[0::2].tolist(), y[1::2].tolist()
            mass, forcing = sympy_built["accelerations"](*q, *u, force)
            rates = np.linalg.solve(mass, np.ravel(forcing)).tolist()
            ab_alone = sympy_built["ab"]
            contenders[SYMPY_POINT] = (lambda: at(y, force), 1)
            contenders[SYMPY_ALONE] = (lambda: ab_alone(*q, *u, force, *rates), 1)
    else:
        section["notes"].append(f"sympy: {sympy_built['why_not']} (stages done: "
                                f"{sympy_built['stages']})")
    section["load_before"] = load_average()
    section["times"] = interleaved(contenders, config.rounds, config.sample_seconds)
    section["load_after"] = load_average()
    return section


# ---- 2. chains against Pinocchio ----------------------------------------------------------------

PIN_CPP = r"""
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/aba-derivatives.hpp>

using namespace pinocchio;
struct Chain { Model model; Data data; Eigen::VectorXd q, v, tau; };

extern "C" {
/* n revolute-z joints, each link a uniform rod (mass m, length L, along its x axis), the next
   joint at its tip; gravity -g along y. */
void *chain_new(int n, double m, double L, double g)
{
    Chain *chain = new Chain;
    JointIndex parent = 0;
    for (int i = 0; i < n; ++i) {
        SE3 placement = SE3::Identity();
        placement.translation() << (i ? L : 0.0), 0.0, 0.0;
        parent = chain->model.addJoint(parent, JointModelRZ(), placement,
                                       "J" + std::to_string(i + 1));
        Eigen::Matrix3d rotational = Eigen::Vector3d(0.0, m * L * L / 12,
                                                     m * L * L / 12).asDiagonal();
        chain->model.appendBodyToJoint(parent, Inertia(m, Eigen::Vector3d(L / 2, 0, 0),
                                                       rotational), SE3::Identity());
    }
    chain->model.gravity.linear() << 0.0, -g, 0.0;
    chain->data = Data(chain->model);
    chain->q = chain->v = chain->tau = Eigen::VectorXd::Zero(n);
    return chain;
}

/* computeABADerivatives at one state: ddq, d ddq/dq, d ddq/dv, d ddq/dtau (row-major). */
void chain_derivatives(void *handle, const double *q, const double *v, const double *tau,
                       double *ddq, double *dq, double *dv, double *dtau)
{
    Chain &c = *static_cast<Chain *>(handle);
    int n = c.model.nv;
    typedef Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Rows;
    c.q = Eigen::Map<const Eigen::VectorXd>(q, n);
    c.v = Eigen::Map<const Eigen::VectorXd>(v, n);
    c.tau = Eigen::Map<const Eigen::VectorXd>(tau, n);
    computeABADerivatives(c.model, c.data, c.q, c.v, c.tau);
    Eigen::Map<Eigen::VectorXd>(ddq, n) = c.data.ddq;
    Eigen::Map<Rows>(dq, n, n) = c.data.ddq_dq;
    Eigen::Map<Rows>(dv, n, n) = c.data.ddq_dv;
    Eigen::MatrixXd minv = c.data.Minv;
    minv.triangularView<Eigen::StrictlyLower>() = minv.transpose();
    Eigen::Map<Rows>(dtau, n, n) = minv;
}

/* CALLS calls over COUNT states (q and v rows of n), cycling, tau held. */
int chain_loop(void *handle, int count, const double *qs, const double *vs, long calls)
{
    Chain &c = *static_cast<Chain *>(handle);
    int n = c.model.nv, k = 0;
    for (long call = 0; call < calls; ++call) {
        c.q = Eigen::Map<const Eigen::VectorXd>(qs + (long)k * n, n);
        c.v = Eigen::Map<const Eigen::VectorXd>(vs + (long)k * n, n);
        computeABADerivatives(c.model, c.data, c.q, c.v, c.tau);
        k = k + 1 == count ? 0 : k + 1;
    }
    return 0;
}
}
"""
PIN_CDEF = """
void *chain_new(int, double, double, double);
void chain_derivatives(void *, const double *, const double *, const double *, double *,
                       double *, double *, double *);
int chain_loop(void *, int, const double *, const double *, long);
"""
# what Pinocchio's CMake config gives its users (lib/cmake/pinocchio): boost's MPL limits for
# its joint variant, and its explicit template instantiations (the library's own code runs)
PIN_DEFINES = ["-DBOOST_MPL_LIMIT_LIST_SIZE=30", "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
               "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "-DBOOST_FUSION_INVOKE_MAX_ARITY=12",
               "-DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION"]


def pinocchio_harness(folder: Path) -> tuple[Any, Any, dict[str, Any]]:
    """PIN_CPP compiled against the installed Pinocchio (pip `pin`: its cmeel prefix) and
    loaded: (ffi, lib, record), or (None, None, record with the reason)."""
    import cffi

    record: dict[str, Any] = {}
    try:
        import pinocchio
    except ImportError:
        return None, None, {"why_not": "pinocchio not installed (pip install pin)"}
    prefix = next((Path(p) / "cmeel.prefix" for p in sys.path
                   if (Path(p) / "cmeel.prefix" / "include" / "pinocchio").is_dir()), None)
    compiler = shutil.which(os.environ.get("CXX", "g++"))
    if prefix is None or compiler is None:
        return None, None, {"why_not": "no Pinocchio headers (cmeel.prefix) or no C++ compiler"}
    if not (prefix / "include" / "eigen3" / "Eigen").is_dir():
        return None, None, {"why_not": "no Eigen headers next to Pinocchio's (pip install "
                                       "cmeel-eigen)"}
    libraries = [p for p in (prefix / "lib").glob("libpinocchio_default.so*")]
    if not libraries:
        return None, None, {"why_not": f"no libpinocchio_default in {prefix / 'lib'}"}
    source, library = folder / "pin_chain.cpp", folder / "pin_chain.so"
    source.write_text(PIN_CPP)
    flags = ["-O2", "-DNDEBUG", "-std=c++17", "-fPIC", "-shared", *PIN_DEFINES]
    command = [compiler, *flags, f"-I{prefix / 'include'}", f"-I{prefix / 'include' / 'eigen3'}",
               str(source), "-o", str(library), f"-L{prefix / 'lib'}", "-lpinocchio_default",
               f"-Wl,-rpath,{prefix / 'lib'}"]
    seconds, done = timed(lambda: subprocess.run(command, capture_output=True, text=True,
                                                 timeout=600))
    if done.returncode != 0:
        last = done.stderr.strip().splitlines()[-1:] or ["no message"]
        return None, None, {"why_not": f"the C++ harness did not compile: {last[0]}"}
    record.update(compile_seconds=seconds, flags=" ".join(flags),
                  pinocchio=getattr(pinocchio, "__version__", None))
    ffi = cffi.FFI()
    ffi.cdef(PIN_CDEF)
    return ffi, ffi.dlopen(str(library)), record


def pinocchio_chain(pin: Any, n: int) -> Any:
    """The chain as a Pinocchio model in Python: revolute-z joints, the same rods."""
    m, length, g = ROD["m"], ROD["L"], ROD["g"]
    model = pin.Model()
    parent = 0
    for i in range(n):
        placement = pin.SE3(np.eye(3), np.array([length if i else 0.0, 0.0, 0.0]))
        parent = model.addJoint(parent, pin.JointModelRZ(), placement, f"J{i + 1}")
        rotational = np.diag([0.0, m * length**2 / 12, m * length**2 / 12])
        model.appendBodyToJoint(parent, pin.Inertia(m, np.array([length / 2, 0.0, 0.0]),
                                                     rotational), pin.SE3.Identity())
    model.gravity.linear = np.array([0.0, -g, 0.0])
    return model


def symmetric(upper: np.ndarray) -> np.ndarray:
    """A symmetric matrix from its upper triangle (Pinocchio's Minv fills only that)."""
    return np.triu(upper) + np.triu(upper, 1).T


def program_profile(text: str) -> dict[str, Any]:
    """The accelerations' program and its tangent (the Jacobian's and linearization's, run once
    per column): steps and nemc's cost estimate (nemc.derive.c_cost), from the derivation."""
    from nemc.derive.c_cost import estimated_ns
    from nemc.derive.equations import derive, with_jacobian, with_linearization
    from nemc.emit.optimize import optimize_equations
    from nemc.front.validate import validate_text

    start = time.perf_counter()
    equations = with_linearization(with_jacobian(derive(validate_text(text.encode(),
                                                                      "chain.yaml"))))
    programs = optimize_equations(equations).programs
    found = {name: {"steps": program.size, "estimated_ns": estimated_ns(program)}
             for name, program in programs.items()}
    found["seconds"] = time.perf_counter() - start
    return found


def chain_section(config: Config, folder: Path, loops: CLoops,
                  harness: tuple[Any, Any, dict]) -> dict[str, Any]:
    ffi, lib, record = harness
    try:
        import pinocchio as pin
    except ImportError:
        pin = None
    rows_out: dict[int, dict[str, Any]] = {}
    for n in config.chains:
        text = torque_chain_yaml(n)
        (model, build), builds = compiled(text, folder, ("jacobian", "linearization"))
        n_state = model.n_state
        states = random_rows(n_state, STATES, seed=n)
        p = model.parameter_vector()
        row: dict[str, Any] = {"builds": builds, "c_bytes": c_size(build),
                               "jacobian_machine_code": jacobian_machine_code(build),
                               "program": program_profile(text), "checks": {}, "notes": []}
        jac, ab, dy = (np.empty((n_state, n_state)), np.empty((n_state, n_state + n)),
                       np.empty(n_state))
        calls = calls_for(lambda k, b=build, s=states, p=p, j=jac: loops.caller(
            b, "jacobian", s, p, j, k))
        lin_calls = max(16, calls * 2 // 3)
        rhs_calls = calls * 2 * n
        contenders: dict[str, tuple[Callable[[], Any], int]] = {
            "nemc: RHS in C": (loops.caller(build, "rhs", states, p, dy, rhs_calls),
                               rhs_calls),
            "nemc: Jacobian d/dy in C": (loops.caller(build, "jacobian", states, p, jac,
                                                      calls), calls),
            "nemc: linearization d/d(y, u) in C": (loops.caller(
                build, "linearization", states, p, ab, lin_calls), lin_calls),
        }
        y = states[0].copy()
        contenders["nemc: model.jacobian(t, y) from Python"] = (
            lambda m=model, y=y: m.jacobian(0.0, y), 1)
        lin = model.linearize(y)
        qs, vs = np.ascontiguousarray(states[:, 0::2]), np.ascontiguousarray(states[:, 1::2])
        tau = np.zeros(n)
        if pin is not None:
            pin_model = pinocchio_chain(pin, n)
            data = pin_model.createData()
            q, v = qs[0].copy(), vs[0].copy()
            ddq = pin.aba(pin_model, data, q, v, tau)
            row["checks"]["pinocchio (Python) aba vs nemc rhs"] = relative_difference(
                ddq, model.rhs(0.0, y)[1::2])
            dq, dv, dtau = (np.array(m) for m in pin.computeABADerivatives(
                pin_model, data, q, v, tau))
            row["checks"]["pinocchio (Python) derivatives vs nemc linearize"] = max(
                relative_difference(dq, lin.A[1::2, 0::2]),
                relative_difference(dv, lin.A[1::2, 1::2]),
                relative_difference(symmetric(dtau), lin.B[1::2]))
            if max(row["checks"].values()) <= AGREE:
                contenders["Pinocchio: computeABADerivatives from Python"] = (
                    lambda m=pin_model, d=data, q=q, v=v, t=tau: pin.computeABADerivatives(
                        m, d, q, v, t), 1)
        if lib is not None:
            handle = lib.chain_new(n, ROD["m"], ROD["L"], ROD["g"])
            outs = [np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((n, n))]
            buffers = [ffi.from_buffer("double[]", a) for a in (qs[0], vs[0], tau, *outs)]
            lib.chain_derivatives(handle, *buffers)
            row["checks"]["pinocchio (C++) derivatives vs nemc linearize"] = max(
                relative_difference(outs[0], model.rhs(0.0, y)[1::2]),
                relative_difference(outs[1], lin.A[1::2, 0::2]),
                relative_difference(outs[2], lin.A[1::2, 1::2]),
                relative_difference(outs[3], lin.B[1::2]))
            if row["checks"]["pinocchio (C++) derivatives vs nemc linearize"] <= AGREE:
                q_buffer, v_buffer = ffi.from_buffer("double[]", qs), ffi.from_buffer(
                    "double[]", vs)
                loops.kept.append((qs, vs, q_buffer, v_buffer))
                pin_calls = max(16, calls // 2)
                contenders["Pinocchio: computeABADerivatives in C++"] = (
                    lambda h=handle, qb=q_buffer, vb=v_buffer, k=pin_calls: lib.chain_loop(
                        h, STATES, qb, vb, k), pin_calls)
        bad = {k: v for k, v in row["checks"].items() if v > AGREE}
        if bad:
            row["notes"].append(f"Pinocchio disagrees with nemc: {bad}; not timed")
        row["load_before"] = load_average()
        row["times"] = interleaved(contenders, config.rounds, config.sample_seconds)
        row["load_after"] = load_average()
        times = row["times"]
        tangent_ns = row["program"]["jacobian"]["estimated_ns"]
        row["profile"] = {
            "jacobian / (2n RHS)": times["nemc: Jacobian d/dy in C"]["median"]
            / (2 * n * times["nemc: RHS in C"]["median"]),
            "jacobian / (2n x tangent estimate)": times["nemc: Jacobian d/dy in C"]["median"]
            / (2 * n * tangent_ns * 1e-9),
            "linearization / jacobian (3n vs 2n columns)":
            times["nemc: linearization d/d(y, u) in C"]["median"]
            / times["nemc: Jacobian d/dy in C"]["median"],
        }
        rows_out[n] = row
        print(f"  chain {n}: " + ", ".join(f"{k} {fmt_time(v['median'])}"
                                         for k, v in times.items()), flush=True)
    ns = sorted(rows_out)
    fits = {}
    for name in ("nemc: Jacobian d/dy in C", "nemc: linearization d/d(y, u) in C",
                 "nemc: RHS in C", "Pinocchio: computeABADerivatives in C++",
                 "Pinocchio: computeABADerivatives from Python"):
        values = [rows_out[n]["times"].get(name, {}).get("median") for n in ns]
        fits[name] = power_fit(ns, values)
    fits["tangent program steps"] = power_fit(ns, [rows_out[n]["program"]["jacobian"]["steps"]
                                                   for n in ns])
    fits["C bytes"] = power_fit(ns, [rows_out[n]["c_bytes"] for n in ns])
    fits["the Jacobian's machine code"] = power_fit(
        ns, [rows_out[n]["jacobian_machine_code"] for n in ns])
    return {"rows": rows_out, "fits": fits, "harness": record}


# ---- 3. params= ---------------------------------------------------------------------------------


def params_section(config: Config, folder: Path) -> dict[str, Any]:
    """model.rhs, jacobian, linearize without params and with the same dict passed again."""
    (model, _), builds = compiled(params_yaml(), folder, ("jacobian", "linearization"))
    y = model.initial_state()
    y[1::2] = 0.3
    every = model.parameters
    calls: dict[str, tuple[Callable[[], Any], int]] = {}
    for what, call in (("model.rhs", lambda params: model.rhs(0.0, y, params=params)),
                       ("model.jacobian", lambda params: model.jacobian(0.0, y, params=params)),
                       ("model.linearize", lambda params: model.linearize(y, params=params))):
        calls[f"{what}, no params"] = (lambda call=call: call(None), 1)
        for k in config.params_sizes:
            kept = dict(list(every.items())[:k])
            calls[f"{what}, the same dict of {k}"] = (lambda call=call, d=kept: call(d), 1)
        calls[f"{what}, a new dict of {len(every)} each call"] = (
            lambda call=call: call({name: value * 1.0 for name, value in every.items()}), 1)
    section: dict[str, Any] = {"parameters": len(every), "builds": builds,
                               "load_before": load_average()}
    section["times"] = interleaved(calls, config.rounds, config.sample_seconds)
    section["load_after"] = load_average()
    return section


def params_against(path: Path, mode: str) -> dict[str, Any]:
    """params_section with the nemc of the checkout PATH, in a fresh process (this script's
    --params-only, PATH first on its import path)."""
    with tempfile.TemporaryDirectory(prefix="nemc-bench-plant-against-") as out:
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [str(path), os.environ.get("PYTHONPATH", "")])}
        command = [sys.executable, str(Path(__file__).resolve()), "--params-only", out,
                   *([f"--{mode}"] if mode != "full" else [])]
        done = subprocess.run(command, capture_output=True, text=True, env=env, cwd=path,
                              timeout=1800)
        if done.returncode != 0:
            return {"why_not": done.stderr.strip().splitlines()[-1:]}
        found = json.loads((Path(out) / "params.json").read_text())
    found["nemc"] = str(path)
    return found


# ---- 4. nemc.feedback ----------------------------------------------------------------------------

CLOSED, OPEN = "nemc.feedback (LQR about upright)", "constant input F = 0"
# the feedback's machinery on the open loop's very steps: u = 0 - 0 (y - y_up)
ZERO_GAIN = "nemc.feedback with K = 0 (the open loop's trajectory)"
RTOL, ATOL = 1e-10, 1e-12  # tight: many steps, so that simulate's fixed cost is a small part


def ratio_of(closed: Sequence[float], open_: Sequence[float]) -> dict[str, float]:
    per_round = [c / o for c, o in zip(closed, open_)]
    return {"median": float(np.median(closed) / np.median(open_)), "min": min(per_round),
            "max": max(per_round)}


def feedback_section(config: Config, folder: Path) -> dict[str, Any]:
    from scipy.linalg import solve_continuous_are

    import nemc

    section: dict[str, Any] = {}
    for links in sorted({1, config.cart_links}):
        model, builds = compiled(cart_yaml(links), folder, ("linearization",))
        model = model[0]
        upright = np.zeros(model.n_state)
        upright[2] = np.pi / 2
        lin = model.linearize(upright, [0.0])
        q = np.diag([1.0, 1.0] + [10.0, 1.0] * links)
        r = np.array([[0.1]])
        gain = np.linalg.solve(r, lin.B.T @ solve_continuous_are(lin.A, lin.B, q, r))
        start = upright.copy()
        start[2] += 0.3 if links == 1 else 0.05
        span = (0.0, config.run_span)
        ways = {CLOSED: {"F": lin.feedback(gain)}, OPEN: {"F": 0.0},
                ZERO_GAIN: {"F": nemc.feedback(np.zeros_like(gain), upright, 0.0)}}
        record: dict[str, Any] = {"builds": builds, "start": start.tolist(),
                                  "gain": gain.tolist(), "span": span, "rtol": RTOL,
                                  "atol": ATOL, "methods": {}}
        for method in config.methods:
            steps, contenders = {}, {}
            for way, inputs in ways.items():
                every = model.simulate(span, start, method=method, rtol=RTOL, atol=ATOL,
                                       inputs=inputs)  # every accepted step returned
                assert every.success, every.message
                steps[way] = {"accepted": len(every.t) - 1, "nfev": every.nfev,
                              "final": every.y[:, -1].tolist()}
                contenders[way] = (lambda m=model, s=start, method=method, inputs=inputs,
                                   span=span: m.simulate(span, s, method=method,
                                                         t_eval=[span[1]], rtol=RTOL,
                                                         atol=ATOL, inputs=inputs), 1)
                # simulate's fixed cost with these inputs: an empty interval
                contenders[f"{way}, over [0, 0]"] = (
                    lambda m=model, s=start, method=method, inputs=inputs: m.simulate(
                        (0.0, 0.0), s, method=method, t_eval=[0.0], inputs=inputs), 1)
            held = abs(steps[CLOSED]["final"][2] - np.pi / 2)  # the LQR holds it up
            load = load_average()
            times = interleaved(contenders, config.rounds, config.sample_seconds)
            per_step, net = {}, {}
            for way in ways:
                count = steps[way]["accepted"]
                per_step[way] = [v / count for v in times[way]["values"]]
                net[way] = [(v - f) / count for v, f in zip(times[way]["values"],
                                                            times[f"{way}, over [0, 0]"]["values"])]
            record["methods"][method] = {
                "steps": steps, "times": times,
                "per_step": {way: summary(v) for way, v in per_step.items()},
                "per_step_net": {way: summary(v) for way, v in net.items()},
                "ratio": ratio_of(per_step[CLOSED], per_step[OPEN]),
                "ratio_net": ratio_of(net[CLOSED], net[OPEN]),
                "ratio_zero_gain": ratio_of(per_step[ZERO_GAIN], per_step[OPEN]),
                "zero_gain_same_steps": steps[ZERO_GAIN]["accepted"] == steps[OPEN][
                    "accepted"] and steps[ZERO_GAIN]["nfev"] == steps[OPEN]["nfev"],
                "held_upright_within": held, "load_before": load, "load_after": load_average()}
        section[f"cart with {links} link{'s' if links > 1 else ''}"] = record
    return section


# ---- the run and its Markdown -------------------------------------------------------------------


def run(config: Config, against: Path | None, mode: str) -> dict[str, Any]:
    started = time.perf_counter()
    env = environment(mode)
    env["versions"]["pinocchio"] = version_of("pinocchio")
    result: dict[str, Any] = {"environment": env, "config": dataclasses.asdict(config),
                              "targets": TARGETS}
    with tempfile.TemporaryDirectory(prefix="nemc-bench-plant-") as scratch, one_cpu(env):
        folder = Path(scratch)
        loops = CLoops(folder)
        print("1. A and B of the cart", flush=True)
        result["cart"] = cart_section(config, folder, loops)
        print("2. chains against Pinocchio", flush=True)
        harness = pinocchio_harness(folder)
        result["chains"] = chain_section(config, folder, loops, harness)
        print("3. params=", flush=True)
        result["params"] = params_section(config, folder)
        if against is not None:
            result["params_against"] = params_against(against, mode)
        print("4. nemc.feedback", flush=True)
        result["feedback"] = feedback_section(config, folder)
    finish_environment(env, started)
    return result


def ratio_text(slow: dict[str, Any], fast: dict[str, Any]) -> str:
    """slow / fast: the ratio of medians (min-max of the per-round ratios)."""
    per_round = [a / b for a, b in zip(slow["values"], fast["values"])]
    return (f"{slow['median'] / fast['median']:.2f} ({min(per_round):.2f}–"
            f"{max(per_round):.2f})")


def load_text(section: dict[str, Any]) -> str:
    return f"load {section.get('load_before')} → {section.get('load_after')}"


def markdown(result: dict[str, Any]) -> str:
    lines = ["# The model as a plant: A, B, the Jacobian, params= and nemc.feedback (issue 46)",
             "", *md_environment(result["environment"]),
             f"- Pinocchio {result['environment']['versions'].get('pinocchio')}", ""]
    lines += cart_markdown(result["cart"])
    lines += chains_markdown(result["chains"])
    lines += params_markdown(result["params"], result.get("params_against"))
    lines += feedback_markdown(result["feedback"])
    return "\n".join(lines) + "\n"


def cart_markdown(cart: dict[str, Any]) -> list[str]:
    times = cart["times"]
    n = cart["shape_A"][0]
    lines = [f"## 1. A ({n}x{n}) and B ({n}x1) of a cart with a {cart['links']}-link pendulum",
             "", f"One CPU, {load_text(cart)}; nemc's builds (apart): "
             + ", ".join(f"{k} {v:.1f} s" for k, v in cart["nemc_builds"].items())
             + f"; the build's C {cart['c_bytes']} bytes.", "",
             "| contender | per point, median (min–max) | target |", "| --- | --- | --- |"]
    for name, found in times.items():
        target = ""
        if name == NEMC_C:
            target = f"≤ {fmt_time(TARGETS['A, B in C'])}: " + (
                "met" if found["median"] <= TARGETS["A, B in C"] else "**not met**")
        elif name == NEMC_PYTHON:
            target = f"≤ {fmt_time(TARGETS['A, B from Python'])}: " + (
                "met" if found["median"] <= TARGETS["A, B from Python"] else "**not met**")
        lines.append(f"| {name} | {spread(found)} | {target} |")
    sympy = cart["sympy"]
    lines += ["", "sympy's set-up (a fresh process, apart): " + (", ".join(
        f"{k} {v:.1f} s" for k, v in sympy["stages"].items()) or "nothing finished")
        + f"; total {sympy['setup_seconds']:.1f} s."]
    if "agreement" in sympy:
        lines.append(f"sympy's A and B against nemc's at 8 random states: largest difference "
                     f"{sympy['agreement']:.1e} (relative to the largest entry).")
    if SYMPY_POINT in times:
        lines += ["", f"*{SYMPY_POINT}*: Linearizer's A and B (lambdify(cse)) with the "
                  "accelerations their u-dot terms need at a general state, from lambdify(cse) "
                  "of Kane's M and f and numpy.linalg.solve: what a point costs a user. "
                  f"*{SYMPY_ALONE}*: the A, B function alone.", "",
                  "| ratio (sympy / nemc, per point) | median (min–max over rounds) | "
                  "target |", "| --- | --- | --- |"]
        for slow in (SYMPY_POINT, SYMPY_ALONE):
            for fast in (NEMC_PYTHON, NEMC_C):
                ratio = times[slow]["median"] / times[fast]["median"]
                met = "met" if ratio >= TARGETS["vs sympy"] else "**not met**"
                lines.append(f"| {slow} / {fast} | {ratio_text(times[slow], times[fast])} | "
                             f"≥ 10x: {met} |")
    lines += [f"- {note}" for note in cart["notes"]]
    return lines + [""]


def chains_markdown(chains: dict[str, Any]) -> list[str]:
    rows = chains["rows"]
    names: list[str] = []
    for row in rows.values():
        names += [k for k in row["times"] if k not in names]
    lines = ["## 2. d ydot/d(y, u) of n-link chains against Pinocchio's computeABADerivatives",
             "", "Uniform rods, revolute joints (Pinocchio: revolute-z), a torque input at every "
             "joint; C loops over 64 random states, Python calls at one; one CPU, interleaved.",
             "Pinocchio's C++ harness: " + (
                 f"compiled in {chains['harness']['compile_seconds']:.1f} s "
                 f"({chains['harness']['flags']}), against the pip wheel's libpinocchio_default"
                 if "compile_seconds" in chains["harness"] else
                 chains["harness"].get("why_not", "absent")), "",
             "| n | " + " | ".join(names) + " | load |", "| --- " * (len(names) + 2) + "|"]
    for n, row in rows.items():
        cells = [spread(row["times"][k]) if k in row["times"] else "—" for k in names]
        lines.append(f"| {n} | " + " | ".join(cells) + f" | {load_text(row)} |")
    lines += ["", "| n | nemc Jacobian / Pinocchio C++ | nemc linearization / Pinocchio C++ | "
              "model.jacobian / Pinocchio Python | target (≤ 1) |", "| --- | --- | --- | --- | "
              "--- |"]
    for n, row in rows.items():
        times = row["times"]
        cells = []
        for ours, theirs in (("nemc: Jacobian d/dy in C", "Pinocchio: computeABADerivatives "
                              "in C++"), ("nemc: linearization d/d(y, u) in C",
                                          "Pinocchio: computeABADerivatives in C++"),
                             ("nemc: model.jacobian(t, y) from Python",
                              "Pinocchio: computeABADerivatives from Python")):
            cells.append(ratio_text(times[ours], times[theirs]) if theirs in times else "—")
        pin = times.get("Pinocchio: computeABADerivatives in C++")
        met = ("—" if pin is None else "met" if times["nemc: linearization d/d(y, u) in C"][
            "median"] <= pin["median"] else "**not met**")
        lines.append(f"| {n} | " + " | ".join(cells) + f" | {met} |")
    lines += ["", "Profile: the build's C, the accelerations' program and its tangent (run once "
              "per column: 2n for the Jacobian, 3n with the inputs), nemc's cost estimate "
              "(nemc/derive/c_cost.py), and the Jacobian's time against them.", "",
              "| n | C bytes | the Jacobian's machine code | program steps | tangent steps | "
              "tangent estimate | Jacobian / (2n RHS) | Jacobian / (2n tangent estimates) | "
              "linearization / Jacobian | checks (relative) |", "| --- " * 10 + "|"]
    for n, row in rows.items():
        program, profile = row["program"], row["profile"]
        checks = "; ".join(f"{k}: {v:.1e}" for k, v in row["checks"].items()) or "—"
        lines.append(
            f"| {n} | {row['c_bytes']} | {row['jacobian_machine_code']} bytes | "
            f"{program['dynamics']['steps']} | "
            f"{program['jacobian']['steps']} | {program['jacobian']['estimated_ns']:.0f} ns | "
            f"{profile['jacobian / (2n RHS)']:.2f} | "
            f"{profile['jacobian / (2n x tangent estimate)']:.2f} | "
            f"{profile['linearization / jacobian (3n vs 2n columns)']:.2f} | {checks} |")
    lines += ["", "Power-law fits, time (or size) ~ c n^p over the sizes measured:", ""]
    for name, fit in chains["fits"].items():
        if fit:
            lines.append(f"- {name}: p = {fit['exponent']:.2f} (n = {fit['n']}, rms log "
                         f"residual {fit['rms_log_residual']:.2f})")
    for n, row in rows.items():
        lines += [f"- n = {n}: {note}" for note in row["notes"]]
    return lines + [""]


def params_markdown(params: dict[str, Any], against: dict[str, Any] | None) -> list[str]:
    runs = [("this checkout", params)]
    if against is not None and "times" in against:
        runs.append((f"nemc at {against['nemc']}", against))
    lines = [f"## 3. params= ({params['parameters']} parameters, a 6-link chain)", ""]
    for label, found in runs:
        times = found["times"]
        lines += [f"{label}: one CPU, {load_text(found)}.", "",
                  "| call | per call, median (min–max) | / no params |", "| --- | --- | --- |"]
        for name, found_time in times.items():
            base = times[name.split(",", 1)[0] + ", no params"]
            lines.append(f"| {name} | {spread(found_time)} | {ratio_text(found_time, base)} |")
        lines.append("")
    if against is not None and "times" not in against:
        lines.append(f"- --against: {against.get('why_not')}")
    return lines


def feedback_markdown(feedback: dict[str, Any]) -> list[str]:
    first = next(iter(feedback.values()))
    lines = ["## 4. A closed loop through nemc.feedback against the open loop, per step", "",
             f"Runs over {first['span']} at rtol {first['rtol']:g}, atol {first['atol']:g} "
             "from the upright pose tipped (0.3 rad for the cart-pole, 0.05 for the others): "
             "the closed loop (LQR from model.linearize, u = -K (y - y_up) in C) against a "
             "constant F = 0 (the pendulum falls), each run's time over its accepted steps. "
             "*Net*: less simulate()'s fixed cost with the same inputs (a run over [0, 0]). "
             "One CPU, interleaved.", "",
             "*K = 0*: nemc.feedback with a zero gain, the open loop's trajectory and steps "
             "(its steps and RHS calls: the open loop's, checked), so its ratio is the law's "
             "cost in C alone.", "",
             "| system | method | closed loop per step | open loop per step | ratio (target ≤ "
             "1.2) | net ratio | K = 0 / open loop | steps closed / open / K = 0 | nfev closed "
             "/ open | load |", "| --- " * 10 + "|"]
    for system, record in feedback.items():
        for method, found in record["methods"].items():
            closed, open_ = found["per_step"][CLOSED], found["per_step"][OPEN]
            steps, ratio, net = found["steps"], found["ratio"], found["ratio_net"]
            zero = found["ratio_zero_gain"]
            met = "met" if ratio["median"] <= TARGETS["feedback per step"] else "**not met**"
            lines.append(
                f"| {system} | {method} | {spread(closed)} | {spread(open_)} | "
                f"{ratio['median']:.2f} ({ratio['min']:.2f}–{ratio['max']:.2f}): {met} | "
                f"{net['median']:.2f} ({net['min']:.2f}–{net['max']:.2f}) | "
                f"{zero['median']:.2f} ({zero['min']:.2f}–{zero['max']:.2f}) | "
                f"{steps[CLOSED]['accepted']} / {steps[OPEN]['accepted']} / "
                f"{steps[ZERO_GAIN]['accepted']} | "
                f"{steps[CLOSED]['nfev']} / {steps[OPEN]['nfev']} | {found['load_before']} → "
                f"{found['load_after']} |")
    lines += [f"- {system}, {method}: with K = 0 the run took other steps than the open loop "
              "(its ratio is not the law's cost alone)" for system, record in feedback.items()
              for method, found in record["methods"].items()
              if not found["zero_gain_same_steps"]]
    return lines + [""]


def main() -> int:
    if len(sys.argv) > 1 and sys.argv[1] == "--sympy-child":
        sympy_child(int(sys.argv[2]), Path(sys.argv[3]))
        return 0
    if len(sys.argv) > 1 and sys.argv[1] == "--params-only":
        mode = "quick" if "--quick" in sys.argv else "smoke" if "--smoke" in sys.argv else "full"
        env: dict[str, Any] = {}
        with tempfile.TemporaryDirectory(prefix="nemc-bench-plant-") as scratch, one_cpu(env):
            found = params_section(MODES[mode], Path(scratch))
        Path(sys.argv[2], "params.json").write_text(json.dumps(found, default=float))
        return 0
    parser = mode_parser(__doc__.splitlines()[0], "the cart with 2 links, the 8-link chain, "
                         "short loops (CI's smoke test)", "the same, smaller")
    parser.add_argument("--against", type=Path, help="another nemc checkout: the params= "
                        "section again with its nemc, in a fresh process")
    args: argparse.Namespace = parser.parse_args()
    mode = mode_of(args)
    config = MODES[mode]
    if args.sizes:
        config = dataclasses.replace(config, chains=args.sizes)
    print(f"{__doc__.splitlines()[0]} ({mode} mode)", flush=True)
    result = run(config, args.against, mode)
    write_results(result, results_folder(args, "nemc-bench-plant-"), "plant", markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
