"""Hostile input and misuse, round 3, the rest of issue 51: a case per class, with inputs of its
own (files made here), each in its own section: a run whose equations fail mid-run keeps what
it computed; stress on a ball at rest and a 0-DOF analysis; scene values refused by `check`;
degrees of freedom at a singular start; --initial on a closed loop; --dask workers dying; a
free run passing singular configurations says so; motion laws with abs, sign, min, max on a
moving mechanism. The table of every class, its fix and its test: test_hostile_round3.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
TINY = ROOT / "tests" / "models" / "tiny.yaml"  # one rod on a pin: m 2, L 0.5


# ---- 1. a run whose equations fail mid-run keeps the states before ------------------------

FAILS_AT = 0.6  # T: the torque sqrt(T - t) is nan after it
FAILING = """loads: [{torque: 'sqrt(T - t)', body: rod}]
outputs: {expressions: {rate: dot(q)}}
simulation:
  t_span: [0, 1]
  initial: {q: 0.1, dot(q): -0.5}
  events:
    passes: {when: q - 0.2, direction: rising}
"""


def rod_angle(t: np.ndarray, q0: float = 0.1, v0: float = -0.5, big_t: float = FAILS_AT
              ) -> np.ndarray:
    """The rod's angle under torque sqrt(T - t), no gravity, in closed form (I = m L^2 / 3)."""
    inertia = 2 * 0.5**2 / 3
    return q0 + v0 * t + 2 / (3 * inertia) * (
        big_t**1.5 * t - 0.4 * (big_t**2.5 - (big_t - t)**2.5))


@pytest.fixture(scope="module")
def failing(tmp_path_factory: pytest.TempPathFactory):
    import nemc

    file = tmp_path_factory.mktemp("failing") / "failing.yaml"
    file.write_text(TINY.read_text().replace("gravity: [0, -9.81]", "").replace(
        "parameters: {m: 2, L: 0.5}", f"parameters: {{m: 2, L: 0.5, T: {FAILS_AT}}}")
        + FAILING)
    return nemc.compile(file)


def failing_methods() -> list[str]:
    from nemc.runtime.model import METHODS

    return list(dict.fromkeys([*METHODS, "auto"]))


@pytest.mark.parametrize("method", failing_methods())
@pytest.mark.parametrize("at_times", [True, False])
def test_a_run_that_fails_mid_run_keeps_its_states_events_and_outputs(
        method: str, at_times: bool, failing) -> None:
    """The torque sqrt(T - t) turns nan after T: the run ends with status -2 (the docs'
    "equations failed"), its states before the failure kept (the closed form), the event it
    found before (q rising through 0.2) kept, and the outputs along them computed."""
    times = np.linspace(0, 1, 41) if at_times else None
    run = failing.simulate(method=method, t_eval=times, rtol=1e-10, atol=1e-12)
    assert run.status == -2 and not run.success, run.message
    assert run.message.startswith("integration failed: at t=") and "not finite" in run.message
    assert run.t.size >= 2 and run.t[0] == 0 and run.t[-1] <= FAILS_AT, run.t
    if at_times:
        np.testing.assert_array_equal(run.t, times[:run.t.size])
    q = run.y[0]
    np.testing.assert_allclose(q, rod_angle(run.t), atol=1e-7)
    np.testing.assert_allclose(run.outputs["rate"], run.y[1], rtol=0, atol=0)
    crossing = run.events["passes"][0]  # q = 0.2 rising (at t ~ 0.28): the closed form's root
    assert crossing.size == 1 and abs(rod_angle(crossing)[0] - 0.2) < 1e-7, crossing


FALLING = """simulation:
  t_span: [0, 3]
  initial: {q: 0}
  events:
"""
EVENT_OR_LAW = {  # the failing part -> the cause its message names
    "odd: {when: sqrt(q + 1) - 2, direction: rising}": "an event's function",
    "half: {when: q + 0.5, direction: falling, action: {dot(q): log(q - 10)}}": "an impact law",
}


@pytest.fixture(scope="module")
def falling(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The rod let go horizontal (it falls through q = -0.5 at about 0.29 s and q = -1 at
    about 0.43 s): with each failing event, and without (the reference, tight)."""
    import nemc

    folder = tmp_path_factory.mktemp("falling")
    models = {}
    for k, event in enumerate(["", *EVENT_OR_LAW]):
        file = folder / f"falling{k}.yaml"
        file.write_text(TINY.read_text() + FALLING.replace("  events:\n", "") if not event
                        else TINY.read_text() + FALLING + f"    {event}\n")
        models[event] = nemc.compile(file)
    return models


@pytest.mark.parametrize("method", failing_methods())
@pytest.mark.parametrize("event", sorted(EVENT_OR_LAW))
def test_an_event_function_or_law_failing_mid_run_keeps_the_states_before(
        method: str, event: str, falling: dict) -> None:
    """An event's function nan below q = -1, an impact law nan at q = -0.5: status -2, the
    message naming it, the states before kept (a tight run without the event; scipy's methods
    evaluate events after a step: theirs keep the step whose end the function failed at)."""
    run = falling[event].simulate(method=method, rtol=1e-9, atol=1e-11)
    assert run.status == -2 and EVENT_OR_LAW[event] in run.message, run.message
    assert run.t.size >= 2 and run.t[0] == 0 and run.t[-1] < 0.5, run.t
    assert np.all(run.y[0, :-1] > -1), run.y[0]  # scipy's keeps the step it failed after
    failed_at = float(run.message.split("at t=")[1].split(":")[0])
    assert run.t[-1] <= failed_at + 1e-8 and failed_at < 0.5, (run.t[-1], failed_at)
    reference = falling[""].simulate((0, run.t[-1]), t_eval=run.t, method="DOP853",
                                     rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(run.y, reference.y, atol=1e-6)


@pytest.mark.parametrize("method", failing_methods())
def test_a_run_that_fails_at_its_start_returns_the_state_it_failed_at(method: str,
                                                                      tmp_path: Path) -> None:
    """The torque sqrt(-1 - t) is nan from t = 0: status -2 and the one state it failed at."""
    import nemc

    file = tmp_path / "at_start.yaml"
    file.write_text(TINY.read_text() + "loads: [{torque: 'sqrt(-1 - t)', body: rod}]\n"
                    "simulation: {t_span: [0, 1], initial: {q: 0.25}}\n")
    run = nemc.compile(file).simulate(method=method)
    assert run.status == -2 and run.message.startswith("integration failed: at t=0:"), run.message
    assert run.t.tolist() == [0.0] and run.y[:, 0].tolist() == [0.25, 0.0]


# ---- 3. nemc stress on a ball that comes to rest and on a 0-DOF analysis --------------------

RESTING_BALL = """name: resting_ball
parameters: {m: 0.1, r: 0.02, e: 0.6, g: 9.81}
gravity: [0, -g]
bodies: {ball: {mass: m, inertia: 2*m*r**2/5}}
joints: {flight: {type: free, parent: ground, child: ball, coordinates: [x, y, th]}}
simulation:
  t_span: [0, 1]
  initial: {y: 0.5}
  rtol: 1.0e-10
  atol: 1.0e-12
  events:
    bounce: {when: y - r, direction: falling, action: {dot(y): -e*dot(y)}}
"""


def test_stress_measures_a_ball_that_comes_to_rest_before_its_horizon(tmp_path: Path,
                                                                     capsys) -> None:
    """The long reference (5 s) chatters where the bounces accumulate, at t0 (1 + e)/(1 - e)
    (t0 = sqrt(2 h / g) the first fall): the report is written over the part before, and says
    where and why the long run ended (it exited 2)."""
    from nemc.tools.cli import main

    file = tmp_path / "resting_ball.yaml"
    file.write_text(RESTING_BALL)
    assert main(["stress", str(file), "--out", str(tmp_path), "--horizon", "5"]) == 0
    capsys.readouterr()
    text = (tmp_path / "resting_ball.md").read_text()
    ended = text.split("The long run ends early: event 'bounce' chatters at t = ")[1]
    at_rest = np.sqrt(2 * 0.48 / 9.81) * 1.6 / 0.4
    assert abs(float(ended.split(":")[0]) - at_rest) < 1e-4, ended[:80]


def test_stress_reports_a_mechanism_without_a_degree_of_freedom(tmp_path: Path, capsys) -> None:
    """A slider-crank whose crank is driven (0 DOF): the report is written (it exited 2 on a
    start it could not move), saying no initial value can be moved."""
    from nemc.tools.cli import main

    text = (ROOT / "examples" / "slider_crank.yaml").read_text()
    text = text.replace("coordinate: q1}", "coordinate: q1, motion: 20*t}").replace(
        "  - torque: T0*(1 - dot(q1)/w0)\n    body: crank\n", "").replace(
        "  initial: {q1: pi/4, dot(q1): 0}\n", "")
    file = tmp_path / "driven_slider_crank.yaml"
    file.write_text(text)
    assert main(["stress", str(file), "--out", str(tmp_path), "--horizon", "3"]) == 0
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    report = (tmp_path / "slider_crank.md").read_text()  # named after the model
    assert "No degree of freedom is left by the drives" in report


# ---- 7. --dask local:N whose workers die at start -------------------------------------------

@pytest.mark.parametrize("preload", ["nemc_no_such_module_51", "nemc.no_such_part"])
def test_workers_that_die_at_start_are_one_line(preload: str, tmp_path: Path) -> None:
    """Workers whose start fails (here a preload that cannot be imported; in the field an
    import, memory): exit 1, one line naming the cause (it was "Nanny failed to start" and a
    traceback per worker), no store written."""
    import os
    import shutil
    import subprocess
    import sys

    pytest.importorskip("distributed")
    shutil.copy(TINY, tmp_path / "m.yaml")
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__PRELOAD": f'["{preload}"]'}
    done = subprocess.run(
        [sys.executable, "-c", "import sys; from nemc.tools.cli import main; "
         "sys.exit(main(sys.argv[1:]))", "sweep", "m.yaml", "--grid", "m=1:2:2", "--t-end", "0.1",
         "--dask", "local:1", "--out", "s.zarr"], cwd=tmp_path, env=env, capture_output=True,
        text=True, timeout=300)
    assert done.returncode == 1 and done.stdout == "", done.stderr
    assert done.stderr.splitlines() == [
        "nemc: --dask local:1: the worker processes could not start (ModuleNotFoundError: "
        f"No module named '{preload}')"], done.stderr
    assert not (tmp_path / "s.zarr").exists()


# ---- 4. scene values that every run refuses, refused by `check` at their line ----------------

@pytest.mark.parametrize("example, key, value", [
    ("tiny", "dot(q)", "1e200"), ("tiny", "q", "-3.5e151"),
    ("slider_crank", "dot(q1)", "1e308"), ("slider_crank", "q1", "2e160"),
])
def test_check_refuses_initial_values_no_run_can_take(example: str, key: str, value: str,
                                                      tmp_path: Path, capsys) -> None:
    """A rate or coordinate whose square overflows (every centripetal term, a loop's
    distances): `check` names its line (a run failed with "accelerations not finite", or a
    loop's "given rates cannot satisfy", blamed on --set/options)."""
    from nemc.tools.cli import main

    source = TINY if example == "tiny" else ROOT / "examples" / f"{example}.yaml"
    file = tmp_path / "big.yaml"
    text = source.read_text()
    if example == "tiny":
        text += f"simulation: {{t_span: [0, 1], initial: {{{key}: {value}}}}}\n"
    else:
        text = text.replace("initial: {q1: pi/4, dot(q1): 0}", f"initial: {{{key}: {value}}}")
    file.write_text(text)
    line = next(k for k, row in enumerate(text.splitlines(), 1) if f"{key}: {value}" in row)
    assert main(["check", str(file)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{file}:{line}: simulation.initial.{key}: ") and "too large" in err


def test_a_warning_of_a_command_is_one_line(tmp_path: Path, capsys) -> None:
    """rtol 1e-300 (check accepts it: below 100 eps it is raised to it, with a warning, as
    scipy does): the run succeeds, and the warning is one line naming the tolerance (it was
    Python's two, the second nemc's own `sys.exit(main())`)."""
    from nemc.tools.cli import main

    file = tmp_path / "fine.yaml"
    file.write_text(TINY.read_text() + "simulation: {t_span: [0, 0.1], rtol: 1.0e-300}\n")
    assert main(["check", str(file)]) == 0
    assert main(["simulate", str(file), "--outputs", "none"]) == 0
    err = capsys.readouterr().err
    assert err.splitlines() == ["nemc: warning: At least one element of `rtol` is too small. "
                                "Setting `rtol = np.maximum(rtol, 2.220446049250313e-14)`."], err


@pytest.mark.parametrize("rate", [1e8, 1e12, 1e40])
def test_large_consistent_rates_of_a_loop_are_assembled(rate: float, tmp_path: Path) -> None:
    """The rates' residual is relative to their terms' size: dot(q1) = 1e8 was refused ("the
    given rates cannot satisfy constraint") for a rounding of 1e-8. The rates solved satisfy
    Phi_q q' = 0 to rounding (the slider-crank's loop has no time term)."""
    import nemc

    model = nemc.compile(ROOT / "examples" / "slider_crank.yaml")
    run = model.simulate((0, 0), {"q1": 0.7, "dot(q1)": rate})  # the assembled start
    assert run.success, run.message
    y0 = run.y[:, 0]
    position, velocity = model.constraint_residual(y0)
    assert position < 1e-10 and velocity <= 1e-12 * rate, (position, velocity)
    assert y0[model.state_names.index("dot(q1)")] == rate


@pytest.mark.parametrize("example, old, new, blamed, message", [
    # the connecting rod of length 0: the crank pin is the slider's, driven across the guide
    # at r w = 0.1 x 10 pi (found by the value fuzz, tests/test_fuzz.py)
    ("slider_crank_driven", "  l: 0.35", "  l: 0", "guide:",
     "constraints.guide: no rates satisfy this constraint at the start (its rate stays 3.14 "
     "from 0): the mechanism cannot move as its drives prescribe there"),
    # every rate given, the coupler's and the rocker's at rest while the crank turns
    ("fourbar", "initial: {q1: pi/2, dot(q1): 8}",
     "initial: {q1: pi/2, dot(q1): 8, dot(q2): 0, dot(q3): 0}", "initial:",
     "simulation.initial: constraint 'C' (constraints.C, line 43) cannot hold with these "
     "initial rates: its rate stays 0.8 from 0"),  # the crank pin's speed L1 q1' = 0.1 x 8
])
def test_check_refuses_a_start_no_rates_can_take(example: str, old: str, new: str, blamed: str,
                                                 message: str, tmp_path: Path, capsys) -> None:
    """Rates at the start that no solution of Phi_q q' = -Phi_t has (a mechanism locked
    against its drive, or given rates that over-determine the loop): `check` (and so every
    compile) names the constraint's or the initial values' line; a run was refused with "the
    given rates cannot satisfy", no rate given, blamed on --set/options. The run that sets
    such values (params=) says what the drives cannot do."""
    import nemc
    from nemc.runtime.model import ModelError
    from nemc.tools.cli import main

    text = (ROOT / "examples" / f"{example}.yaml").read_text()
    assert old in text
    file = tmp_path / f"{example}.yaml"
    file.write_text(text.replace(old, new))
    line = next(k for k, row in enumerate(file.read_text().splitlines(), 1) if blamed in row)
    assert main(["check", str(file)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{file}:{line}: {message}"), err
    if example == "slider_crank_driven":
        model = nemc.compile(ROOT / "examples" / f"{example}.yaml")
        with pytest.raises(ModelError, match=r"no rates satisfy constraint 'guide' \(residual "
                                             r"3.14\)"):
            model.simulate(params={"l": 0.0})


# ---- 5. degrees of freedom counted at a singular start --------------------------------------

def parallelogram(tmp_path: Path, start: str) -> Path:
    """A parallelogram four-bar (ground and coupler 0.4, crank and rocker 0.1) with its crank
    driven from angle START: flat, a singular configuration, at 0."""
    text = (ROOT / "examples" / "fourbar_driven.yaml").read_text()
    for old, new in (("  L2: 0.35", "  L2: 0.4"), ("  L3: 0.3", "  L3: 0.1"),
                     ("motion: pi/2 + w*t", f"motion: {start} + w*t"),
                     ("guess: {q2: 0.5, q3: 1.9}", f"guess: {{q2: 0.01, q3: {start} + 0.02}}")):
        assert old in text
        text = text.replace(old, new)
    file = tmp_path / f"parallelogram_{start}.yaml"
    file.write_text(text)
    return file


def test_a_start_at_a_singular_configuration_is_refused_by_name(tmp_path: Path,
                                                                capsys) -> None:
    """Flat at the start, Phi_q loses rank: 1 degree of freedom counted there instead of 0
    (`check` said 1; the run failed on "given rates cannot satisfy"). Both name the singular
    start and the constraint."""
    import nemc
    from nemc.runtime.model import ModelError
    from nemc.tools.cli import main

    file = parallelogram(tmp_path, "0")
    assert main(["check", str(file)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{file}:") and "the initial state is at a singular configuration: "\
        "constraint 'C'" in err and "(1 there, 0 elsewhere)" in err, err
    model = nemc.compile(parallelogram(tmp_path, "0.3"))  # compiles away from the flat
    flat = -0.3 / (2 * np.pi)  # q1 = 0.3 + w t is 0 there
    with pytest.raises(ModelError, match="the initial state is at a singular "
                                         "configuration: constraint 'C'"):
        model.simulate((flat, 0.1), y0={"q2": 0.0, "q3": 0.0})
    # away from it: a kinematic analysis (0 DOF) on the parallelogram branch, q2 = 0, q3 = q1
    run = model.simulate((0, 0.04), t_eval=np.linspace(0, 0.04, 5))
    assert run.success and run.method == "kinematic", run.message
    names = model.state_names
    np.testing.assert_allclose(run.y[names.index("q2")], 0, atol=1e-9)
    np.testing.assert_allclose(run.y[names.index("q3")], 0.3 + 2 * np.pi * run.t, atol=1e-9)


# ---- 6. --initial on a closed loop: the given values kept, the others solved ----------------

@pytest.mark.parametrize("initial, kept", [
    (["q1=1.2"], {"q1": 1.2, "dot(q1)": 0.0}),  # the scene's dot(q1) kept too
    (["q1=-0.4", "dot(q1)=5"], {"q1": -0.4, "dot(q1)": 5.0}),
    (["dot(q1)=-3"], {"q1": np.pi / 4, "dot(q1)": -3.0}),
])
def test_initial_values_of_a_closed_loop_are_kept_and_the_rest_solved(
        initial: list[str], kept: dict, tmp_path: Path, capsys) -> None:
    """`--initial` handed the whole state over (the scene's assembly with one value changed),
    which the loop refused ("cannot be assembled with q1, dot(q1), q2, ... given"): now the
    scene's given values and --initial's are kept and the others solved, the start on the
    constraints (their residual, computed apart)."""
    import csv

    import nemc
    from nemc.tools.cli import main

    example = ROOT / "examples" / "slider_crank.yaml"
    options = [part for value in initial for part in ("--initial", value)]
    out = tmp_path / "run.csv"
    assert main(["simulate", str(example), *options, "--t-end", "0.01", "--csv", str(out)]) == 0
    capsys.readouterr()
    with out.open() as handle:
        first = next(csv.DictReader(handle))
    model = nemc.compile(example)
    row = {name.split(" ")[0]: float(value) for name, value in first.items()}
    for name, value in kept.items():
        assert row[name] == pytest.approx(value, abs=1e-12), (name, row)
    y0 = np.array([row[name] for name in model.state_names])
    position, velocity = model.constraint_residual(y0)
    assert position < 1e-9 and velocity < 1e-9, (position, velocity)


# ---- 8. a free run that passes a singular configuration says so -----------------------------

FREE_PARALLELOGRAM = """\
name: free_parallelogram
parameters: {L0: 0.7, L1: 0.25, m1: 0.4, m2: 1.1, m3: 0.8}
bodies:
  crank: {mass: m1, inertia: m1*L1**2/12, com: [L1/2, 0], points: {B: [L1, 0]}}
  coupler: {mass: m2, inertia: m2*L0**2/12, com: [L0/2, 0], points: {C: [L0, 0]}}
  rocker: {mass: m3, inertia: m3*L1**2/12, com: [L1/2, 0], points: {C: [L1, 0]}}
joints:
  A: {type: revolute, parent: ground, child: crank, at: [0, 0], coordinate: q1}
  B: {type: revolute, parent: crank, child: coupler, at: B, coordinate: q2, angle: absolute}
  D: {type: revolute, parent: ground, child: rocker, at: [L0, 0], coordinate: q3}
constraints:
  closure: {type: revolute, a: rocker.C, b: coupler.C}
simulation:
  t_span: [0, 4]
  initial: {q1: 0.3, dot(q1): 3}
  guess: {q2: 0.01, q3: 0.3}
  rtol: 1.0e-10
  atol: 1.0e-12
"""


@pytest.fixture(scope="module")
def free_parallelogram(tmp_path_factory: pytest.TempPathFactory):
    import nemc

    file = tmp_path_factory.mktemp("free") / "free_parallelogram.yaml"
    file.write_text(FREE_PARALLELOGRAM)
    return nemc.compile(file)


def passed_times(message: str) -> list[float]:
    """The times a run's message says it passed singular configurations near."""
    import re

    found = re.search(r"It passed (\d+) singular configurations? of constraints? .*?\(near "
                      r"t = ([^)]*)\)", message)
    assert found, message
    times = [float(x) for x in found.group(2).split(" and ")[0].split(", ")]
    assert int(found.group(1)) >= len(times)
    return times


@pytest.mark.parametrize("method", ["auto", "nemc.DOP853", "nemc.Radau", "RK45", "DOP853"])
@pytest.mark.parametrize("times", ["steps", "coarse", "fine"])
def test_a_free_run_through_a_singular_configuration_says_so(method: str, times: str,
                                                             free_parallelogram) -> None:
    """A parallelogram four-bar without gravity turns at a constant rate (its kinetic energy
    (I1 + I3 + m2 L1^2) q1'^2 / 2 is all it has), so it lies flat at q1 = k pi, t = (k pi -
    0.3) / 3: three times in [0, 4]. The run passes them on its branch (q3 = q1) and its
    message names the constraint and those times (to 1e-5), whatever times it returns: the
    solver's steps (1.5 rad apart), 21 of them, or 401."""
    t_eval = {"steps": "steps", "coarse": np.linspace(0, 4, 21),
              "fine": np.linspace(0, 4, 401)}[times]
    run = free_parallelogram.simulate(method=method, t_eval=t_eval)
    assert run.success, run.message
    names = free_parallelogram.state_names
    np.testing.assert_allclose(run.y[names.index("q3")], run.y[names.index("q1")], atol=1e-6)
    assert "It passed 3 singular configurations of constraint 'closure'" in run.message, \
        run.message
    flat = (np.arange(1, 4) * np.pi - 0.3) / 3
    np.testing.assert_allclose(passed_times(run.message), flat, atol=1e-5)


def test_a_run_away_from_singular_configurations_says_nothing_of_them() -> None:
    """A Grashof four-bar (examples/fourbar.yaml) and a slider-crank never lose rank: no
    passage in their messages; the free parallelogram stopped before its first flat
    position (t < 0.947) neither."""
    import nemc

    for example in ("fourbar", "slider_crank"):
        run = nemc.compile(ROOT / "examples" / f"{example}.yaml").simulate()
        assert run.success and "singular" not in run.message, (example, run.message)


def test_a_free_run_stopped_before_the_flat_position_says_nothing(free_parallelogram) -> None:
    run = free_parallelogram.simulate((0, 0.9))
    assert run.success and "singular" not in run.message, run.message


def test_the_double_four_bar_names_its_ten_flat_positions() -> None:
    """IFToMM A02 (examples/double_fourbar.yaml) lies flat where its cranks are level, sin(q1)
    = 0: the times from its own states sampled every 1 ms (the zero crossings, interpolated),
    10 in [0, 10]; its message gives them to 1e-4."""
    import nemc

    model = nemc.compile(ROOT / "examples" / "double_fourbar.yaml")
    run = model.simulate()
    assert run.success and "It passed 10 singular configurations" in run.message, run.message
    fine = model.simulate(t_eval=np.linspace(0, 10, 10_001))
    crank = np.sin(fine.y[model.state_names.index("q1")])
    at = np.flatnonzero(np.sign(crank[1:]) != np.sign(crank[:-1]))
    flat = fine.t[at] - crank[at] * (fine.t[at + 1] - fine.t[at]) / (crank[at + 1] - crank[at])
    assert len(flat) == 10
    np.testing.assert_allclose(passed_times(run.message), flat[:8], atol=1e-4)


# ---- 9. motion laws with abs, sign, min, max driving a mechanism that moves ----------------

CART = """name: cart_law
parameters: {m: 1.3, L: 0.9, M: 2}
gravity: [0, -9.81]
bodies:
  cart: {mass: M, inertia: 0.1}
  rod: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  S: {type: prismatic, parent: ground, child: cart, axis: [1, 0], coordinate: x, motion: 'LAW'}
  O: {type: revolute, parent: cart, child: rod, coordinate: th}
simulation:
  t_span: [0, 2]
  initial: {th: -1, dot(th): 0.5}
"""
CART_LAW = ("0.2*abs(t - 0.5)**3 + 0.3*sign(t - 1.2)*(t - 1.2)**2 + 0.1*max(t - 1, 0)**2"
            " + 0.05*min(t - 0.8, 0)**2")  # x' continuous, x'' jumping at 0.8, 1, 1.2


def test_abs_sign_min_max_in_a_drive_of_a_moving_mechanism(tmp_path: Path) -> None:
    """A rod hinged on a cart driven along x by a law with abs, sign, max and min (the issue's
    crash in the compile, here with a degree of freedom left): the rod's angle at t = 2 is the
    pendulum's on an accelerated support, (m L^2/3) th'' = m L/2 (sin th x'' - g cos th),
    with x'' written by hand and integrated by scipy between the kinks, to 1e-9."""
    from scipy.integrate import solve_ivp

    import nemc

    file = tmp_path / "cart.yaml"
    file.write_text(CART.replace("LAW", CART_LAW))
    run = nemc.compile(file).simulate(method="nemc.Vern9", rtol=1e-12, atol=1e-12,
                                      tstops=[0.8, 1.0, 1.2])
    assert run.success, run.message
    length, g = 0.9, 9.81  # m cancels

    def x2(t: float) -> float:
        return 1.2 * abs(t - 0.5) + 0.6 * np.sign(t - 1.2) + 0.2 * (t > 1) + 0.1 * (t < 0.8)

    def pendulum(t: float, y: np.ndarray) -> list[float]:
        return [y[1], (np.sin(y[0]) * x2(t) - g * np.cos(y[0])) * 1.5 / length]

    state = np.array([-1.0, 0.5])
    for a, b in ((0, 0.8), (0.8, 1), (1, 1.2), (1.2, 2)):
        state = solve_ivp(pendulum, (a, b), state, method="DOP853", rtol=1e-13,
                          atol=1e-13).y[:, -1]
    np.testing.assert_allclose(run.y[:, -1], state, atol=1e-9)


# ---- 10. a driven parallelogram's analysis at any requested times ---------------------------

DRIVEN = {  # two driven parallelograms, q1 = 0.4 + 3 t: flat at t = 0.914, 1.961 (and near 3)
    "heavy": FREE_PARALLELOGRAM.replace("{L0: 0.7, L1: 0.25, m1: 0.4, m2: 1.1, m3: 0.8}",
                                        "{L0: 0.5, L1: 0.15, m1: 0.3, m2: 0.9, m3: 0.6}")
    .replace("bodies:", "gravity: [0, -9.81]\nbodies:"),
    "light": FREE_PARALLELOGRAM,
}


@pytest.mark.parametrize("mechanism, count", [
    ("heavy", 31), ("heavy", 151), ("heavy", 301), ("heavy", 601), ("heavy", 1201),
    ("light", 151), ("light", 301), ("light", 601), ("light", 1201),
])
def test_a_driven_parallelogram_keeps_its_branch_at_any_requested_times(
        mechanism: str, count: int, tmp_path: Path) -> None:
    """With COUNT requested times over [0, 3] the coupler stays level and the rocker parallel
    to the crank (q2 = 0, q3 = q1 = 0.4 + 3 t, q3' = 3), to 1e-12. With 151, 301, 601 or 1201
    times the analysis stopped on "a dead point" (or a rates failure) at the first flat: a
    passage's node fell 1e-10 s from a requested time, and the cubic through those two states
    predicted the next one by their distance's inverse cubed (kinematic.BranchFollower.nearest
    now takes its second state apart from the first). The light one's 601 times (0.005 s) then
    left the branch just past the flat: a passage's edge search split a step of 0.115 rad, and
    the half step's assembly from the state before landed on the crossed branch 1.3e-3 rad
    from the prediction, within 5% of its motion (kinematic.BranchFollower.near now also asks
    5% of Phi_q's conditioning there, 7.8e-4)."""
    import nemc

    file = tmp_path / "driven_parallelogram.yaml"
    file.write_text(DRIVEN[mechanism]
                    .replace("coordinate: q1}", "coordinate: q1, motion: 0.4 + 3*t}")
                    .replace("  initial: {q1: 0.3, dot(q1): 3}\n", ""))
    model = nemc.compile(file)
    times = np.linspace(0, 3, count)
    run = model.simulate(t_eval=times)
    assert run.success and "It passed" in run.message, run.message
    names = model.state_names
    np.testing.assert_allclose(run.y[names.index("q2")], 0, atol=1e-12)
    np.testing.assert_allclose(run.y[names.index("q3")], 0.4 + 3 * times, atol=1e-12)
    np.testing.assert_allclose(run.y[names.index("dot(q3)")], 3, atol=1e-10)
