"""Closed loops and driven joints (format version 2): nemc's compiled models against the
independent Lagrange-multiplier reference (tests/loop_reference.py, checked itself in
tests/test_loop_reference.py) and against conservation laws and a published solution.

- Every loop or drive example (fourbar, fourbar_driven, slider_crank, kapitza, andrews), the
  slider-crank held by a slot or by a prismatic joint, and seeded random four-bars: state names;
  the scene's initial state assembled from `initial` + `guess`; ``rhs`` at consistent states
  (random states projected onto the constraints, with and without parameter overrides) to 1e-10
  relative; every output (constraint and joint reactions, drives, energy, points);
  ``constraint_residual``; ``simulate`` against a tight reference solution.
- The four-bar: both assembly branches picked by `guess`; the constraint residual at every
  returned state at most the run's atol over 1000 s at rtol 1e-9, not growing;
  ``simulate_many`` from random consistent states; nemc.Taylor works or is refused by name;
  energy drift like the open tree's at the same tolerance; a parallelogram through its flat
  positions on its branch. (Every method, scipy's and nemc's, against the reference and keeping the
  constraints, the multistep methods' error falling with rtol, and ensembles against single
  runs: tests/test_scenarios.py.)
- fourbar_driven (0 degrees of freedom): ``simulate`` computes the states over t_eval; its drive
  torque is the reference's multiplier; the drive's power is d/dt of the total energy.
- Kapitza's pendulum: upright and stable at W = 200 rad/s, falling at W = 50.
- Andrews: nemc's solution at t = 0.03 matches the IVP test set's to 1e-8 relative.
- Bad input the validator cannot see: a loop too short to close and initial values that
  over-determine the assembly are refused (exit 2) naming the constraint or the values.
"""

from __future__ import annotations

import functools
import inspect
import json
import math
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from loop_reference import (
    LoopReference,
    closed_chain_yaml,
    random_fourbar,
    slider_crank_variants,
)
from scipy.integrate import solve_ivp

import nemc
from nemc.front.validate import load_mechanism
from nemc.tools.cli import main

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
LOOP_EXAMPLES = ["andrews", "fourbar", "fourbar_driven", "kapitza", "slider_crank"]
ANDREWS = json.loads((ROOT / "tests" / "data" / "andrews_reference.json").read_text())
RHS_RTOL = 1e-10
OUTPUT_RTOL = 1e-9
NATIVE_EXPLICIT = ("nemc.DOP853", "nemc.Vern9")

# per example: span of the reference trajectory the test states come from, and the size of
# the random moves (positions, rates relative to 1 + |rate|) projected back onto the loops
SAMPLING = {"andrews": (0.03, 0.005, 0.05), "fourbar": (2.0, 0.1, 0.3),
            "fourbar_driven": (1.0, 0.1, 0.3), "kapitza": (1.0, 0.3, 0.3),
            "slider_crank": (3.0, 0.1, 0.3)}


# ---------------------------------------------------------------------------------------------
# Cases: the compiled model beside its reference


@functools.cache
def compiled(path: str) -> nemc.runtime.model.Model:
    return nemc.compile(path)


@functools.cache
def reference(path: str, params: tuple = ()) -> LoopReference:
    return LoopReference(load_mechanism(path), dict(params) or None)


def example_path(name: str) -> str:
    return str(EXAMPLES / f"{name}.yaml")


@functools.cache
def trajectory(path: str, t_end: float):
    """A tight reference solution from the scene's initial state (dense)."""
    ref = reference(path)
    sol = solve_ivp(ref.rhs, (0.0, t_end), ref.initial_state(), method="DOP853", rtol=1e-11,
                    atol=1e-12, dense_output=True)
    assert sol.success, sol.message
    return sol


def consistent_states(path: str, seed: int, count: int, params: tuple = ()
                      ) -> Iterator[tuple[float, np.ndarray]]:
    """Random states on the constraints: points of the reference trajectory moved at random,
    then projected back onto Phi = 0 and Phi_q qdot = 0 (at these parameters)."""
    name = Path(path).stem
    span, dq, du = SAMPLING.get(name, (2.0, 0.1, 0.3))
    sol = trajectory(path, span)
    ref = reference(path, params)
    rng = np.random.default_rng(seed)
    for _ in range(count):
        t = float(rng.uniform(0, span))
        y = sol.sol(t).copy()
        y[0::2] += rng.uniform(-dq, dq, len(y) // 2)
        y[1::2] += du * (1 + np.abs(y[1::2])) * rng.uniform(-1, 1, len(y) // 2)
        y = ref.project(t, y)
        position, velocity = ref.residual(t, y)
        assert np.abs(position).max(initial=0) < 1e-12 and np.abs(velocity).max(initial=0) < 1e-9
        yield t, y


def scaled_parameters(path: str, rng: np.random.Generator) -> tuple:
    """The file's numeric parameters, each scaled by 0.97 .. 1.03 (loops still close)."""
    mech = load_mechanism(path)
    plain = [p for p in mech.parameters if not sp.sympify(p.expr).free_symbols]
    return tuple((p.name, float(p.expr) * float(rng.uniform(0.97, 1.03))) for p in plain)


def assert_rel_close(actual, expected, rtol: float, what: str = "") -> None:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    error, scale = float(np.linalg.norm(actual - expected)), float(np.linalg.norm(expected))
    assert error <= rtol * max(scale, 1e-300), \
        f"{what}: relative error {error / max(scale, 1e-300):.3e}\nnemc {actual}\nref  {expected}"


def residual_of(model, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """model.constraint_residual at (t, y): position and velocity residuals as arrays (passing
    t when the function takes it: a driven mechanism's loops depend on time)."""
    function = model.constraint_residual
    takes_t = "t" in inspect.signature(function).parameters
    position, velocity = function(y, t=t) if takes_t else function(y)
    return np.atleast_1d(np.asarray(position, dtype=float)), \
        np.atleast_1d(np.asarray(velocity, dtype=float))


def residual_matches(got: np.ndarray, want: np.ndarray) -> bool:
    """nemc's residual is the reference's: the same vector, or its 2-norm or max-norm."""
    if got.shape == want.shape and np.allclose(got, want, rtol=1e-8, atol=1e-12):
        return True
    if got.size == 1:
        norms = (np.linalg.norm(want), np.abs(want).max(initial=0.0))
        return any(math.isclose(abs(float(got[0])), v, rel_tol=1e-8, abs_tol=1e-12)
                   for v in norms)
    return False


def max_residual(model, t: float, y: np.ndarray) -> tuple[float, float]:
    position, velocity = residual_of(model, t, y)
    return float(np.abs(position).max(initial=0.0)), float(np.abs(velocity).max(initial=0.0))


def assert_outputs_match(model, ref: LoopReference, t: float, y: np.ndarray,
                         params: dict | None = None) -> None:
    got, want = model.outputs(t, y, params), ref.outputs(t, y)
    assert set(got) == set(want), f"names: nemc {sorted(got)}, reference {sorted(want)}"
    forces = [abs(v) for k, v in want.items() if re.search(r"\.(F[xynt]|M|drive)$", k)]
    energy = abs(want.get("energy.kinetic", 0.0)) + abs(want.get("energy.potential", 0.0))
    bad = []
    for name, value in want.items():
        scale = max(forces, default=1.0) if re.search(r"\.(F[xynt]|M|drive)$", name) else \
            energy if name.startswith("energy.") else 1.0
        if not abs(got[name] - value) <= OUTPUT_RTOL * max(1.0, abs(value), scale):
            bad.append(f"{name}: nemc {got[name]!r}, reference {value!r}")
    assert not bad, f"{ref.mech.name} at t={t}, y={np.round(y, 6)}:\n" + "\n".join(bad)


# ---------------------------------------------------------------------------------------------
# Every example


@pytest.mark.parametrize("name", LOOP_EXAMPLES)
def test_state_names_leave_out_driven_coordinates(name: str) -> None:
    model, mech = compiled(example_path(name)), load_mechanism(example_path(name))
    assert tuple(model.state_names) == mech.state_names


@pytest.mark.parametrize("name", LOOP_EXAMPLES)
def test_initial_state_is_assembled_from_initial_and_guess(name: str) -> None:
    path = example_path(name)
    model, ref = compiled(path), reference(path)
    want = ref.initial_state()
    got = model.initial_state()
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-11)
    res = model.simulate(t_span=(0.0, 1e-3 * SAMPLING[name][0]))
    assert res.success, res.message
    np.testing.assert_allclose(res.y[:, 0], want, rtol=1e-10, atol=1e-11)


@pytest.mark.parametrize("name", LOOP_EXAMPLES)
def test_rhs_matches_reference_at_consistent_states(name: str) -> None:
    path = example_path(name)
    model, ref = compiled(path), reference(path)
    for t, y in consistent_states(path, seed=100 + LOOP_EXAMPLES.index(name), count=6):
        assert_rel_close(model.rhs(t, y), ref.rhs(t, y), RHS_RTOL, f"{name} rhs at t={t}")


@pytest.mark.parametrize("name", LOOP_EXAMPLES)
def test_rhs_with_parameter_overrides(name: str) -> None:
    path = example_path(name)
    model = compiled(path)
    rng = np.random.default_rng(300 + LOOP_EXAMPLES.index(name))
    for k in range(2):
        params = scaled_parameters(path, rng)
        ref = reference(path, params)
        for t, y in consistent_states(path, seed=310 + k, count=3, params=params):
            assert_rel_close(model.rhs(t, y, dict(params)), ref.rhs(t, y), RHS_RTOL,
                             f"{name} rhs with {dict(params)}")


@pytest.mark.parametrize("name", LOOP_EXAMPLES)
def test_outputs_match_reference(name: str) -> None:
    path = example_path(name)
    model, ref = compiled(path), reference(path)
    for t, y in consistent_states(path, seed=400 + LOOP_EXAMPLES.index(name), count=5):
        assert_outputs_match(model, ref, t, y)


@pytest.mark.parametrize("name", LOOP_EXAMPLES)
def test_constraint_residual_matches_reference(name: str) -> None:
    path = example_path(name)
    model, ref = compiled(path), reference(path)
    rng = np.random.default_rng(500 + LOOP_EXAMPLES.index(name))
    for t, y in consistent_states(path, seed=510, count=3):
        position, velocity = max_residual(model, t, y)
        assert position < 1e-12 and velocity < 1e-9
        moved = y + rng.uniform(-0.05, 0.05, len(y))  # off the constraints
        got = residual_of(model, t, moved)
        want = ref.residual(t, moved)
        if ref.m_closure:
            assert residual_matches(got[0], want[0]), f"position: nemc {got[0]}, ref {want[0]}"
            assert residual_matches(got[1], want[1]), f"velocity: nemc {got[1]}, ref {want[1]}"


@pytest.mark.parametrize("name", LOOP_EXAMPLES)
def test_simulate_follows_the_reference_and_keeps_the_constraints(name: str) -> None:
    path = example_path(name)
    model = compiled(path)
    span = SAMPLING[name][0]
    times = np.linspace(0.0, span, 31)
    rtol, atol = 1e-10, 1e-12
    res = model.simulate(t_span=(0.0, span), t_eval=times, rtol=rtol, atol=atol)
    assert res.success, res.message
    assert np.all(np.isfinite(res.y))
    want = trajectory(path, span).sol(times)
    scale = np.abs(want).max(axis=1, keepdims=True) + 1
    error = float(np.max(np.abs(res.y - want) / scale))
    assert error < 1e-6, f"{name}: largest scaled difference to the reference {error:.2e}"
    for k, t in enumerate(times):
        position, velocity = max_residual(model, t, res.y[:, k])
        assert position <= atol * 10 and velocity <= 10 * atol * (1 + np.abs(res.y[1::2, k]).max())


# ---------------------------------------------------------------------------------------------
# Seeded random four-bars (with loads)


@functools.cache
def random_case(seed: int, branch: str, folder: str) -> tuple[str, object]:
    fourbar = random_fourbar(np.random.default_rng(seed), f"loop_random{seed}_{branch}",
                             branch=branch)
    path = Path(folder) / f"loop_random{seed}_{branch}.yaml"
    path.write_text(fourbar.text)
    return str(path), fourbar


@pytest.fixture(scope="module")
def random_folder(tmp_path_factory: pytest.TempPathFactory) -> str:
    return str(tmp_path_factory.mktemp("random-loops"))


@pytest.mark.parametrize("seed", range(4))
def test_random_fourbar_rhs_outputs_and_run(seed: int, random_folder: str) -> None:
    path, _ = random_case(seed, "open", random_folder)
    model, ref = compiled(path), reference(path)
    np.testing.assert_allclose(model.initial_state(), ref.initial_state(), rtol=1e-10,
                               atol=1e-11)
    for t, y in consistent_states(path, seed=600 + seed, count=4):
        assert_rel_close(model.rhs(t, y), ref.rhs(t, y), RHS_RTOL, f"random four-bar {seed}")
        assert_outputs_match(model, ref, t, y)
    times = np.linspace(0, 2, 11)
    res = model.simulate(t_span=(0.0, 2.0), t_eval=times, rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    want = trajectory(path, 2.0).sol(times)
    assert np.max(np.abs(res.y - want)) < 1e-6


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("branch", ["open", "crossed"])
def test_guess_picks_the_assembly_branch(seed: int, branch: str, random_folder: str) -> None:
    path, fourbar = random_case(10 + seed, branch, random_folder)
    y0 = compiled(path).initial_state()
    q2, q3 = fourbar.branches[branch]
    assert y0[0] == pytest.approx(fourbar.q1, abs=1e-14)
    difference = np.angle(np.exp(1j * (np.array([y0[2], y0[4]]) - [q2, q3])))
    np.testing.assert_allclose(difference, 0, atol=1e-10)


@pytest.mark.parametrize("branch", ["open", "crossed"])
def test_fourbar_example_both_branches(branch: str, tmp_path: Path) -> None:
    guess = {"open": "{q2: 0.5, q3: 1.9}", "crossed": "{q2: -1, q3: -2.4}"}[branch]
    text = (EXAMPLES / "fourbar.yaml").read_text().replace("{q2: 0.5, q3: 1.9}", guess)
    path = tmp_path / f"fourbar_{branch}.yaml"
    path.write_text(text.replace("name: fourbar", f"name: fourbar_{branch}"))
    q2, q3 = {"open": (0.5481478992387209, 1.9151556505110299),  # circle intersection at
              "crossed": (-1.038105225492449, -2.405112976764758)}[branch]  # q1 = pi/2
    y0 = nemc.compile(path).initial_state()
    np.testing.assert_allclose([y0[2], y0[4]], [q2, q3], atol=1e-10)
    np.testing.assert_allclose(y0, reference(str(path)).initial_state(), atol=1e-11)


@pytest.mark.parametrize("variant", ["prismatic_joint", "slot"])
def test_slider_crank_held_by_a_slot_or_a_prismatic_joint(variant: str,
                                                           random_folder: str) -> None:
    """The other ways of holding the slider: a slot constraint, and a prismatic joint closed by
    a revolute constraint (tests/loop_reference.slider_crank_variants)."""
    text = slider_crank_variants((EXAMPLES / "slider_crank.yaml").read_text())[variant]
    path = Path(random_folder) / f"slider_crank_{variant}.yaml"
    path.write_text(text)
    model, ref = compiled(str(path)), reference(str(path))
    np.testing.assert_allclose(model.initial_state(), ref.initial_state(), rtol=1e-10,
                               atol=1e-11)
    for t, y in consistent_states(str(path), seed=650, count=4):
        assert_rel_close(model.rhs(t, y), ref.rhs(t, y), RHS_RTOL, f"slider crank, {variant}")
        assert_outputs_match(model, ref, t, y)
    times = np.linspace(0, 2, 11)
    res = model.simulate(t_span=(0.0, 2.0), t_eval=times, rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    assert np.max(np.abs(res.y - trajectory(str(path), 2.0).sol(times))) < 1e-6


# ---------------------------------------------------------------------------------------------
# The four-bar over long runs and with every method


@pytest.mark.slow  # 9 s: make test-slow
def test_fourbar_constraints_hold_over_1000_s_without_growth() -> None:
    model = compiled(example_path("fourbar"))
    rtol, atol = 1e-9, 1e-9
    times = np.linspace(0.0, 1000.0, 4001)
    # scipy's DOP853, which the scene named until issue 52 (the examples now name no method).
    # The native methods also stay far below atol, but their position residual grows from 1e-14
    # to 2-4e-12 over the 1000 s (scipy's: to 9e-14): reported in issue 52, not asserted here.
    res = model.simulate(t_span=(0.0, 1000.0), t_eval=times, rtol=rtol, atol=atol,
                         method="DOP853")
    assert res.success, res.message
    assert np.all(np.isfinite(res.y))
    residuals = np.array([max_residual(model, t, res.y[:, k]) for k, t in enumerate(times)])
    assert residuals[:, 0].max() <= atol, f"position residual up to {residuals[:, 0].max():.2e}"
    rates = np.abs(res.y[1::2]).max(axis=0)
    assert np.all(residuals[:, 1] <= atol * (1 + rates)), "velocity residual above atol"
    first, last = residuals[:400].max(axis=0), residuals[-400:].max(axis=0)
    assert np.all(last <= 10 * first + 1e-13), f"residual grows: first 100 s {first}, last {last}"


def test_fourbar_taylor_works_or_is_refused_by_name() -> None:
    model = compiled(example_path("fourbar"))
    try:
        res = model.simulate(t_span=(0.0, 2.0), method="nemc.Taylor", rtol=1e-10, atol=1e-10)
    except Exception as error:  # noqa: BLE001 (any refusal must say which method and why)
        assert "Taylor" in str(error) and re.search(r"constrain|loop", str(error)), str(error)
        return
    if not res.success:
        assert "Taylor" in res.message and re.search(r"constrain|loop", res.message), res.message
        return
    for k, t in enumerate(res.t):
        assert max_residual(model, t, res.y[:, k])[0] <= 1e-10
    want = trajectory(example_path("fourbar"), 2.0).sol(res.t[-1])
    assert np.max(np.abs(res.y[:, -1] - want)) < 1e-6


def test_fourbar_ensembles_from_random_states_follow_the_reference() -> None:
    """Runs from random consistent states (projected by the reference), in one simulate_many,
    keep the constraints and follow the reference's runs from the same states. (Ensembles
    against single runs, bit for bit: test_scenarios.py.)"""
    path = example_path("fourbar")
    model, ref = compiled(path), reference(path)
    states = [y for _, y in consistent_states(path, seed=700, count=6)]
    y0s = np.array([ref.project(0.0, y) for y in states])
    times = np.linspace(0.0, 3.0, 7)
    want = [solve_ivp(ref.rhs, (0.0, 3.0), y0, method="DOP853", rtol=1e-11, atol=1e-12,
                      t_eval=times).y for y0 in y0s]
    for method in NATIVE_EXPLICIT:
        runs = model.simulate_many(y0s, t_span=(0.0, 3.0), t_eval=times, method=method,
                                   rtol=1e-10, atol=1e-12)
        assert np.all(runs.success), runs.status
        for r in range(len(y0s)):
            for k, t in enumerate(times):
                assert max_residual(model, t, runs.y[r][:, k])[0] <= 1e-12
            assert np.max(np.abs(runs.y[r] - want[r])) < 1e-6


def energy_drift(model, t_end: float, rtol: float, atol: float, y0=None) -> float:
    times = np.linspace(0.0, t_end, 501)
    res = model.simulate(t_span=(0.0, t_end), y0=y0, t_eval=times, method="nemc.DOP853",
                         rtol=rtol, atol=atol)
    assert res.success, res.message
    total = res.outputs["energy.total"]
    scale = np.max(np.abs(res.outputs["energy.kinetic"]) + np.abs(res.outputs["energy.potential"]))
    return float(np.max(np.abs(total - total[0])) / scale)


def test_fourbar_energy_drift_is_like_the_open_trees(tmp_path: Path) -> None:
    """The conservative four-bar and the same three bodies without the loop, same tolerance."""
    text = (EXAMPLES / "fourbar.yaml").read_text()
    tree = text.replace("constraints:\n  C: {type: revolute, a: rocker.C, b: coupler.C}\n", "")
    tree = tree.replace("reactions: [A, D, C]", "reactions: [A, D]").replace(
        "name: fourbar", "name: fourbar_open_tree")
    path = tmp_path / "fourbar_open_tree.yaml"
    path.write_text(tree)
    loop = compiled(example_path("fourbar"))
    y0 = loop.initial_state()
    rtol, atol = 1e-9, 1e-11
    loop_drift = energy_drift(loop, 100.0, rtol, atol)
    tree_drift = energy_drift(nemc.compile(path), 100.0, rtol, atol, y0=y0)
    assert loop_drift <= max(10 * tree_drift, 1e-8), (loop_drift, tree_drift)


def test_parallelogram_through_flat_stays_on_its_branch(tmp_path: Path) -> None:
    """A parallelogram linkage turning through its flat positions (Phi_q loses rank there):
    nemc continues on the parallelogram branch (rocker angle = crank angle, coupler level),
    scipy's method and nemc's alike (decision 0036; A02: tests/test_singular_loops.py)."""
    text = (EXAMPLES / "fourbar.yaml").read_text()
    for old, new in (("L2: 0.35", "L2: 0.4"), ("L3: 0.3", "L3: 0.1"),
                     ("{q1: pi/2, dot(q1): 8}", "{q1: pi/2, dot(q1): 12}"),
                     ("{q2: 0.5, q3: 1.9}", "{q2: 0, q3: 1.5}"), ("name: fourbar", "name: flat")):
        text = text.replace(old, new)
    path = tmp_path / "flat.yaml"
    path.write_text(text)
    model = nemc.compile(path)
    times = np.linspace(0.0, 3.0, 3001)
    for method in ("DOP853", "nemc.DOP853"):
        res = model.simulate(t_span=(0.0, 3.0), t_eval=times, rtol=1e-9, atol=1e-11,
                             method=method)
        assert res.success, res.message
        q1, q2, q3 = res.y[0], res.y[2], res.y[4]
        assert np.ptp(q1) > 4 * math.pi, "the crank must turn through its flat positions"
        assert np.max(np.abs(np.angle(np.exp(1j * (q3 - q1))))) < 1e-9
        assert np.max(np.abs(np.angle(np.exp(1j * q2)))) < 1e-9


# ---------------------------------------------------------------------------------------------
# 0 degrees of freedom: the driven four-bar


def test_fourbar_driven_simulate_computes_the_states_over_t_eval() -> None:
    path = example_path("fourbar_driven")
    model, ref = compiled(path), reference(path)
    res = model.simulate()
    assert res.success, res.message
    times = np.arange(101) * 0.01
    np.testing.assert_allclose(res.t, times, rtol=0, atol=1e-12)
    guess = dict(zip(("q2", "q3"), ref.initial_state()[0::2]))
    for k, t in enumerate(res.t):
        want = ref.assemble(t, {}, guess)
        guess = dict(zip(("q2", "q3"), want[0::2]))
        np.testing.assert_allclose(res.y[:, k], want, rtol=1e-9, atol=1e-10)
        drive = ref.drives(t, want)["A"]
        assert res.outputs["A.drive"][k] == pytest.approx(drive, rel=1e-8, abs=1e-9)
        assert max_residual(model, t, res.y[:, k])[0] <= 1e-10


def test_fourbar_driven_drive_power_is_the_rate_of_total_energy() -> None:
    """Over part of a revolution: the drive's work (Simpson on a fine grid) equals the change
    of the total energy; over the whole revolution the energy comes back."""
    model = compiled(example_path("fourbar_driven"))
    w = 2 * math.pi
    times = np.linspace(0.0, 1.0, 2001)
    res = model.simulate(t_span=(0.0, 1.0), t_eval=times)
    assert res.success, res.message
    power = res.outputs["A.drive"] * w
    energy = res.outputs["energy.total"]
    from scipy.integrate import cumulative_simpson

    work = cumulative_simpson(power, x=times, initial=0.0)
    swing = float(np.ptp(energy))
    assert swing > 0.1
    np.testing.assert_allclose(work, energy - energy[0], rtol=0, atol=1e-7 * swing)
    assert energy[-1] == pytest.approx(energy[0], rel=1e-9)


# ---------------------------------------------------------------------------------------------
# Kapitza's pendulum


def test_kapitza_upright_is_stable_at_high_drive_frequency() -> None:
    model = compiled(example_path("kapitza"))
    times = np.linspace(0.0, 3.0, 3001)  # about 95 periods of the drive
    res = model.simulate(t_span=(0.0, 3.0), t_eval=times)
    assert res.success, res.message
    tilt = np.abs(res.y[0] - math.pi / 2)
    assert tilt.max() < 0.35, f"leaves the upright position by {tilt.max():.2f} rad"


def test_kapitza_falls_at_low_drive_frequency() -> None:
    model = compiled(example_path("kapitza"))
    res = model.simulate(t_span=(0.0, 3.0), t_eval=np.linspace(0.0, 3.0, 301),
                         params={"W": 50.0})
    assert res.success, res.message
    assert np.abs(res.y[0] - math.pi / 2).max() > 1.5  # past the horizontal


# ---------------------------------------------------------------------------------------------
# Andrews' squeezing mechanism: the published solution


@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Vern9", "DOP853", "nemc.Radau"])
def test_andrews_matches_the_published_solution(method: str) -> None:
    model = compiled(example_path("andrews"))
    t_end = ANDREWS["t"]
    res = model.simulate(t_span=(0.0, t_end), t_eval=[0.0, t_end], method=method, rtol=1e-12,
                         atol=1e-14)
    assert res.success, res.message
    y = res.y[:, -1]
    angles = np.array(list(ANDREWS["angles"].values()))
    rates = np.array(list(ANDREWS["rates"].values()))
    np.testing.assert_allclose(y[0::2], angles, rtol=1e-8, err_msg=method)
    assert np.linalg.norm(y[1::2] - rates) <= 1e-7 * np.linalg.norm(rates), method
    out = model.outputs(t_end, y)
    reactions = [out[f"{c}.{k}"] for c in ("E3", "E4", "E6") for k in ("Fx", "Fy")]
    np.testing.assert_allclose(reactions, -np.array(ANDREWS["lambda"]), rtol=1e-5)


# ---------------------------------------------------------------------------------------------
# nemc check prints the degrees of freedom; bad input found by assembly


@pytest.mark.parametrize(("name", "dof"), [("fourbar", 1), ("fourbar_driven", 0),
                                           ("slider_crank", 1), ("kapitza", 1), ("andrews", 1)])
def test_check_prints_the_degrees_of_freedom(name: str, dof: int, capsys) -> None:
    assert main(["check", example_path(name)]) == 0
    out = capsys.readouterr().out
    assert re.search(rf"\b{dof} degrees? of freedom|degrees? of freedom\W+{dof}\b", out), out


def test_closed_chain_degrees_of_freedom(tmp_path: Path, capsys) -> None:
    path = tmp_path / "closed5.yaml"
    path.write_text(closed_chain_yaml(5))
    assert main(["check", str(path)]) == 0
    assert re.search(r"\b3 degrees? of freedom|degrees? of freedom\W+3\b", capsys.readouterr().out)


def refused(file: Path, capsys) -> str:
    """`nemc simulate FILE` exits 2 with FILE:LINE: messages and no traceback; its stderr."""
    assert main(["simulate", str(file)]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert lines and all(re.match(rf"{re.escape(str(file))}:\d+: ", text) for text in lines), \
        captured.err
    return captured.err


def test_a_loop_too_short_to_close_is_refused_naming_the_constraint(tmp_path: Path,
                                                                   capsys) -> None:
    file = tmp_path / "short.yaml"
    file.write_text((EXAMPLES / "fourbar.yaml").read_text().replace("L3: 0.3", "L3: 0.05"))
    err = refused(file, capsys)
    assert re.search(r"constraints\.C\b", err), err


def test_initial_values_that_cannot_hold_are_refused_naming_them(tmp_path: Path,
                                                                capsys) -> None:
    file = tmp_path / "over.yaml"
    file.write_text((EXAMPLES / "fourbar.yaml").read_text().replace(
        "initial: {q1: pi/2, dot(q1): 8}", "initial: {q1: pi/2, q2: 0.2, q3: 1.9, dot(q1): 8}"))
    err = refused(file, capsys)
    assert "simulation.initial" in err and re.search(r"\bq[23]\b", err), err
