"""method="auto", the default: its rules, its estimate of the stiffness at the start (against
the analytic Jacobian's eigenvalues), its switch to nemc.Radau when a run turns stiff (against a
tight solution and scipy's Radau), and the defaults of simulate_many and nemc.sweep."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import nemc
from nemc import vocabulary as methods
from nemc.build.builder import lane_count
from nemc.runtime import auto
from nemc.runtime import model as runtime
from nemc.runtime.auto import start_stiffness

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
PENDULUM = EXAMPLES / "double_pendulum.yaml"
TWO_LINK_ARM = EXAMPLES / "two_link_robot_arm.yaml"  # the book's stiff 5.4 (scene: nemc.Radau)


def chain_text(n: int) -> str:
    """An n-link chain of uniform rods whose scene names no method."""
    return "\n".join([
        f"name: chain{n}", "parameters: {m: 1, L: 1, g: 9.81}", "gravity: [0, -g]", "bodies:",
        *[f"  l{i}: {{mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {{tip: [L, 0]}}}}"
          for i in range(1, n + 1)],
        "joints:",
        *[f"  J{i}: {{type: revolute, parent: {'ground' if i == 1 else f'l{i - 1}'}, "
          f"child: l{i}, at: {'[0, 0]' if i == 1 else 'tip'}, coordinate: q{i}, "
          "angle: relative}" for i in range(1, n + 1)],
        "simulation: {t_span: [0, 3], initial: {q1: -0.8, q2: 0.2}}", ""])


CHAIN5 = chain_text(5)


def no_method(path: Path) -> nemc.Model:
    """The example with its scene's method removed: simulate() then runs "auto"."""
    text = "".join(line for line in path.read_text().splitlines(keepends=True)
                   if not line.strip().startswith("method:"))
    return nemc.compile(text=text, name=path.name)


def test_the_rules() -> None:
    assert methods.DEFAULT_METHOD == "auto" and "auto" in methods.METHODS
    choose = methods.auto_method
    assert choose(2, 1e-6, True, 0.0) == "nemc.Taylor"
    assert choose(2, 1e-6, False, 0.0) == "nemc.Vern9"  # no Taylor code in the build
    assert choose(8, 1e-9, True, 0.0) == "nemc.Vern9"
    assert choose(8, 1e-3, True, 0.0) == "nemc.DOP853"
    assert choose(2, 1e-6, True, methods.AUTO_STIFF_STEPS + 1) == "nemc.Radau"
    assert choose(8, 1e-9, True, 0.0, taylor_max=8) == "nemc.Taylor"  # an ensemble in 8 lanes
    assert choose(8, 1e-9, True, 0.0, taylor_max=4) == "nemc.Vern9"
    assert methods.auto_builds_taylor(None, 2) and methods.auto_builds_taylor("auto", 3)
    assert not methods.auto_builds_taylor("RK45", 2) and not methods.auto_builds_taylor(None, 4)
    assert methods.auto_takes_taylor(0.62, 1e-6) and not methods.auto_takes_taylor(0.99, 1e-6)
    assert methods.auto_takes_taylor(0.99, 1e-9) and not methods.auto_takes_taylor(1.1, 1e-12)
    assert methods.auto_keeps_taylor(0.99) and not methods.auto_keeps_taylor(1.1)


def test_a_taylor_program_dear_against_its_rhs_is_left_to_vern9_but_at_tight_tolerances(
) -> None:
    """The cost ratio (Taylor's Cauchy sums per order over the RHS's estimated ns) decides
    between mechanisms of the same size: a 3-link chain's program (44 sums, RHS estimated 44.5
    ns: 0.99) is left to nemc.Vern9 at the default rtol (1.3-1.7x faster there at the error
    1e-6, benchmarks/auto.py), but takes the runs from rtol 1e-8 down, where its order grows
    (1.5x faster at 1e-12): its code is built for auto. A free body on a spring (3
    coordinates too: 11 sums, 20 ns) and a 2-link chain (0.74) take nemc.Taylor at every
    tolerance. A build that has Taylor's code for another reason (taylor=True) follows the
    ratio its model.json records."""
    chain3 = nemc.compile(text=chain_text(3))
    assert chain3.has_part("taylor")
    assert methods.AUTO_TAYLOR_MAX_COST_RATIO < chain3.metadata["taylor_cost_ratio"] <= 1.0
    assert chain3.simulate(rtol=1e-6).method == "nemc.Vern9"
    tight = chain3.simulate((0, 2), rtol=1e-9, atol=1e-12, t_eval=[2.0])
    assert tight.method == "nemc.Taylor" and tight.success
    reference = solve_ivp(chain3.rhs, (0, 2), chain3.initial_state(), method="DOP853",
                          rtol=1e-13, atol=1e-15, t_eval=[2.0])
    assert np.abs(tight.y - reference.y).max() < 1e-8  # the rtol asked, on states of about 2
    assert chain3.simulate(rtol=1e-3).method == "nemc.DOP853"
    for model in (no_method(EXAMPLES / "free_body_on_spring.yaml"),
                  nemc.compile(text=chain_text(2))):
        assert model.metadata["taylor_cost_ratio"] <= methods.AUTO_TAYLOR_MAX_COST_RATIO
        assert model.simulate(rtol=1e-6).method == "nemc.Taylor"
    chain4 = nemc.compile(text=chain_text(4), taylor=True)  # 4 coordinates, 1.10: not auto's
    assert chain4.metadata["taylor_cost_ratio"] > methods.AUTO_TAYLOR_TIGHT_MAX_COST_RATIO
    assert chain4.simulate(rtol=1e-11).method == "nemc.Vern9"


def test_a_scene_naming_no_method_runs_taylor_on_a_small_mechanism() -> None:
    model = no_method(PENDULUM)
    assert model.scene["method"] is None and model.has_part("taylor")  # built for auto
    times = np.linspace(0, 5, 11)
    res = model.simulate((0, 5), t_eval=times, rtol=1e-10, atol=1e-12)
    assert res.success and res.method == "nemc.Taylor"
    tight = solve_ivp(model.rhs, (0, 5), model.initial_state(), method="DOP853", rtol=1e-12,
                      atol=1e-14, t_eval=times)
    assert np.abs(res.y - tight.y).max() < 1e-8


def test_larger_mechanisms_get_vern9_or_dop853_by_the_tolerance() -> None:
    model = nemc.compile(text=CHAIN5)
    assert not model.has_part("taylor")  # five coordinates: no Taylor code built for auto
    assert model.simulate(rtol=1e-8).method == "nemc.Vern9"
    assert model.simulate(rtol=1e-3).method == "nemc.DOP853"


def test_the_start_stiffness_agrees_with_the_analytic_jacobian() -> None:
    """Both ways auto gets the Jacobian at the start, the build's own and forward differences
    of the RHS (a build without it), in the look's C (templates/spectrum.c.tmpl, whose
    eigenvalues tests/test_spectrum.py checks alone), against numpy's eigenvalues of the
    Jacobian."""
    arm, differences = nemc.compile(TWO_LINK_ARM), no_method(TWO_LINK_ARM)
    assert arm.has_part("jacobian") and not differences.has_part("jacobian")
    y0, p, span = arm.initial_state(), arm.parameter_vector(), (0.0, 15.0)
    eigenvalues = np.linalg.eigvals(arm.jacobian(0.0, y0))
    decay = -eigenvalues.real
    expected = decay[decay > np.abs(eigenvalues.imag)].max() * 15.0 / methods.EXPLICIT_STABILITY
    assert start_stiffness(arm, span, y0, p) == pytest.approx(expected, rel=1e-12)
    assert start_stiffness(differences, span, y0, p) == pytest.approx(expected, rel=1e-3)
    assert not differences.has_part("jacobian")  # the look at the start built nothing
    assert expected > methods.AUTO_STIFF_STEPS  # so auto starts this arm with nemc.Radau
    assert arm.simulate(span, method="auto").method == "nemc.Radau"


def test_the_start_look_refuses_a_state_of_the_wrong_size() -> None:
    """The look reads y0 in C: a short or long state is refused before it gets there."""
    arm = nemc.compile(TWO_LINK_ARM)
    for state in ([0.1, 0.0], np.zeros(6), [[0.1, 0.0, 0.2, 0.0]]):
        with pytest.raises(runtime.ModelError, match="state must have shape"):
            arm.auto_method((0.0, 15.0), state, 1e-6)
    assert arm.auto_method((0.0, 15.0), [0.0, 0.0, 1.0, 0.0], 1e-6) == "nemc.Radau"


def test_an_oscillation_or_an_unstable_start_is_not_stiffness() -> None:
    """The double pendulum's modes are undamped oscillations, the compound pendulum starts
    near its top (eigenvalues +-3.4): nothing there for Radau to step over."""
    for path in (PENDULUM, EXAMPLES / "compound_pendulum.yaml"):
        model = nemc.compile(path)
        assert start_stiffness(model, (0.0, 1e6), model.initial_state(),
                               model.parameter_vector()) < 1e-3


@pytest.fixture
def explicit_start(monkeypatch: pytest.MonkeyPatch) -> None:
    """auto starts explicit whatever the start's stiffness: the switch has to do the work."""
    monkeypatch.setattr(auto, "auto_method", lambda *args: "nemc.DOP853")


@pytest.mark.usefixtures("explicit_start")
def test_a_run_that_turns_stiff_goes_on_with_radau() -> None:
    arm = nemc.compile(TWO_LINK_ARM)
    times = np.linspace(0, 15, 151)
    res = arm.simulate((0, 15), method="auto", t_eval=times, rtol=1e-8, atol=1e-10)
    assert res.success and res.method == "nemc.DOP853 then nemc.Radau"
    assert "turned stiff" in res.message and "nemc.Radau went on" in res.message
    assert np.array_equal(res.t, times) and res.y.shape == (arm.n_state, len(times))
    tight = solve_ivp(arm.rhs, (0, 15), arm.initial_state(), method="Radau", rtol=1e-12,
                      atol=1e-14, t_eval=times, jac=arm.jacobian)
    assert np.abs(res.y - tight.y).max() < 1e-6
    alone = arm.simulate((0, 15), method="nemc.DOP853", t_eval=times, rtol=1e-8, atol=1e-10)
    assert res.nfev < alone.nfev / 5  # the switch paid: DOP853 alone is held by stability
    assert res.outputs.keys() == alone.outputs.keys()
    for name in res.outputs:
        assert np.allclose(res.outputs[name], alone.outputs[name], rtol=1e-5, atol=1e-6)


@pytest.mark.usefixtures("explicit_start")
def test_a_switched_run_at_the_solver_steps_has_each_time_once() -> None:
    arm = nemc.compile(TWO_LINK_ARM)
    res = arm.simulate((0, 15), method="auto", t_eval="steps")
    assert res.success and res.method == "nemc.DOP853 then nemc.Radau"
    assert res.t[0] == 0.0 and res.t[-1] == 15.0 and np.all(np.diff(res.t) > 0)
    assert np.allclose(res.y[:, 0], arm.initial_state())


@pytest.mark.usefixtures("explicit_start")
def test_a_switched_run_keeps_the_step_budget() -> None:
    arm = nemc.compile(TWO_LINK_ARM)
    res = arm.simulate((0, 15), method="auto", max_steps=100)  # 32 explicit, 68 Radau
    assert not res.success and res.method == "nemc.DOP853 then nemc.Radau"
    assert "budget" in res.message


def test_ensembles_default_to_the_choice_of_auto() -> None:
    model = no_method(PENDULUM)
    y0s = np.tile(model.initial_state(), (3, 1))
    y0s[:, 0] += [0.0, 0.1, 0.2]
    runs = model.simulate_many(y0s, t_span=(0, 2), t_eval=[0, 1, 2], rtol=1e-9)
    assert runs.method == "nemc.Taylor" and runs.success.all()
    single = model.simulate((0, 2), y0s[2], t_eval=[0, 1, 2], rtol=1e-9)
    assert np.allclose(runs.y[2], single.y, rtol=0, atol=1e-12)
    arm = nemc.compile(TWO_LINK_ARM)  # a scene that names an implicit method keeps it
    assert arm.simulate_many(t_span=(0, 1), t_eval=[1.0]).method == "nemc.Radau"


def test_a_scene_may_name_auto() -> None:
    text = PENDULUM.read_text().replace("method: RK45", "method: auto")
    model = nemc.compile(text=text)
    assert model.scene["method"] == "auto" and model.has_part("taylor")
    assert model.simulate((0, 1)).method == "nemc.Taylor"


def test_a_large_ensemble_builds_taylor_for_auto() -> None:
    """The book's double pendulum names RK45: its build has no Taylor code. 1,000 runs are
    worth building it (methods.AUTO_TAYLOR_BUILD_RUNS), in SIMD lanes; 10 runs are not."""
    model = nemc.compile(PENDULUM)
    assert not model.has_part("taylor")
    rng = np.random.default_rng(7)
    y0s = np.zeros((methods.AUTO_TAYLOR_BUILD_RUNS, 4))
    y0s[:, 0], y0s[:, 2] = rng.uniform(-1, 1, len(y0s)), rng.uniform(-1, 1, len(y0s))
    assert model.simulate_many(y0s[:10], t_span=(0, 0.5), t_eval=[0.5]).method == "nemc.Vern9"
    runs = model.simulate_many(y0s, t_span=(0, 0.5), t_eval=[0.5], rtol=1e-9, atol=1e-12)
    assert runs.method == "nemc.Taylor" and runs.success.all()
    for i in (0, 499, 999):  # against another method at a tight tolerance
        tight = model.simulate((0, 0.5), y0s[i], method="nemc.Vern9", t_eval=[0.5],
                               rtol=1e-12, atol=1e-14)
        assert np.abs(runs.y[i] - tight.y).max() < 1e-8


@pytest.mark.parametrize("links", [4, 5])
def test_ensembles_with_the_lanes_at_hand_take_taylor_by_their_width(
        links: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """With nemc.Taylor's lanes built, an ensemble of AUTO_LANES_MIN_RUNS runs or more takes
    nemc.Taylor up to AUTO_LANES_TAYLOR_MAX_COORDINATES for its lanes per batch (16 with 4
    lanes, 32 with 8; set to 4 here, so that 5 links cross it); without them, or for fewer
    runs, the single run's rule (nothing is built to decide)."""
    assert methods.AUTO_LANES_TAYLOR_MAX_COORDINATES == {4: 16, 8: 32}
    model = nemc.compile(text=chain_text(links))
    span, many = (0.0, 1.0), methods.AUTO_LANES_MIN_RUNS
    assert model.ensemble_method(span, rtol=1e-8, runs=many) == "nemc.Vern9"
    lanes = model.compiled_with("lanes")
    width = lanes.metadata["lane_count"]
    assert width == lane_count()
    monkeypatch.setitem(methods.AUTO_LANES_TAYLOR_MAX_COORDINATES, width, 4)
    wide_enough = links <= 4
    assert model.ensemble_method(span, rtol=1e-8, runs=many) == (
        "nemc.Taylor" if wide_enough else "nemc.Vern9")
    assert model.ensemble_method(span, rtol=1e-8, runs=many - 1) == "nemc.Vern9"
    assert model.simulate((0, 1), rtol=1e-8).method == "nemc.Vern9"  # a single run: unchanged
    rng = np.random.default_rng(links)
    y0s = np.tile(model.initial_state(), (many, 1))
    y0s[:, 0] += rng.uniform(-0.5, 0.5, many)
    runs = model.simulate_many(y0s, t_span=span, t_eval=[0.5, 1.0], rtol=1e-9, atol=1e-12,
                               threads=1, progress=False)
    assert runs.success.all() and runs.method == ("nemc.Taylor" if wide_enough
                                                  else "nemc.Vern9")
    for i in (0, many - 1):  # against another method at a tight tolerance
        tight = model.simulate(span, y0s[i], method="nemc.DOP853", t_eval=[0.5, 1.0],
                               rtol=1e-12, atol=1e-14)
        assert np.abs(runs.y[i] - tight.y).max() < 1e-7

