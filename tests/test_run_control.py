"""Runs that end: the step budget, the pace rule and the stiffness test (the hidden blow-up of
issue 17), max_step and tstops (a pulse narrower than a step), nemc.Taylor refusing a step
over a blow-up, and Ctrl-C (a process sent SIGINT inside a run returns its partial run).

"Ends" is bounded work, never a time: the steps a run took before it stopped (its message
counts them) against the rule that stopped it. The Ctrl-C tests signal a child once it says it
is inside the run (tests/children.py: a handshake, no sleep)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from children import child_process, interrupted
from scipy.integrate import solve_ivp

import nemc
from nemc.runtime import runs
from nemc.runtime.model import ModelError

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
FREE_BODY = EXAMPLES / "free_body_on_spring.yaml"
NATIVE = ["nemc.DOP853", "nemc.Vern9", "nemc.Radau", "nemc.Taylor"]

# A rotor kicked by a torque pulse of width w = 1 ms at t = 1: its final rate is T w sqrt(pi).
PULSE = """\
name: pulse
parameters: {T: 1000, w: 0.001}
bodies:
  rotor: {mass: 1, inertia: 1}
joints:
  A: {type: revolute, parent: ground, child: rotor, coordinate: q}
loads:
  - {torque: "T*exp(-((t - 1)/w)**2)", body: rotor}
simulation:
  t_span: [0, 2]
  t_eval: [2]
"""

# A rod on a pivot with a stiff damper: a mode decaying at c / I_O = 3e5 /s.
STIFF = """\
name: stiff_damper
parameters: {c: 1.0e5, g: 9.81}
gravity: [0, -g]
bodies:
  rod: {mass: 1, inertia: 1/12, com: [0.5, 0]}
joints:
  A: {type: revolute, parent: ground, child: rod, coordinate: q}
loads:
  - joint_spring: {joint: A, k: 10, damping: c}
simulation:
  t_span: [0, 20]
  initial: {q: 1}
"""

# Three links with a joint damper each (c < 0 feeds energy in: the motion runs away).
TRIPLE = """\
name: triple_pendulum
parameters: {m: 1, L: 1, g: 9.81, c: 0.1}
gravity: [0, -g]
bodies:
  l1: {mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {E: [L, 0]}}
  l2: {mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {E: [L, 0]}}
  l3: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  A: {type: revolute, parent: ground, child: l1, coordinate: q1}
  B: {type: revolute, parent: l1, child: l2, at: E, coordinate: q2}
  C: {type: revolute, parent: l2, child: l3, at: E, coordinate: q3}
loads:
  - joint_spring: {joint: A, k: 0, damping: c}
  - joint_spring: {joint: B, k: 0, damping: c}
  - joint_spring: {joint: C, k: 0, damping: c}
simulation:
  t_span: [0, 10]
  initial: {q1: 0.5, q2: 0.3}
"""

# The load exp(exp(10 t)) 1e-300 overflows near t = 0.66: every method must fail there.
BLOW_UP = """\
name: double_exponential
bodies:
  rotor: {mass: 1, inertia: 1}
joints:
  A: {type: revolute, parent: ground, child: rotor, coordinate: q}
loads:
  - {torque: "exp(exp(10*t))*1e-300", body: rotor}
simulation:
  t_span: [0, 1]
"""


def steps_taken(message: str) -> int:
    """The steps a run took before it stopped, as its message says ("... after 1,000 steps")."""
    return int(message.split(" after ")[1].split(" steps")[0].replace(",", ""))


def compiled(tmp_path: Path, name: str, text: str):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return nemc.compile(path)


@pytest.fixture(scope="module")
def every_step(tmp_path_factory: pytest.TempPathFactory):
    """The book's double pendulum with no t_eval: runs return every step."""
    text = (EXAMPLES / "double_pendulum.yaml").read_text().replace(
        "  t_eval: {step: 0.5}\n", "").replace("name: double_pendulum", "name: every_step")
    return compiled(tmp_path_factory.mktemp("steps"), "every_step", text)


@pytest.mark.parametrize("method", ["RK45", "nemc.DOP853", "nemc.Vern9", "DOP853", "Radau",
                                    "nemc.Radau", "LSODA"])
def test_the_hidden_blow_up_ends_at_the_pace_rules_first_look(method: str) -> None:
    """Issue 17: a free body on a spring with k = 1e30, m = 1e-30 over [0, 3] (oscillating at
    1e30 rad/s) ran for ever; it now ends after 1000 steps by the pace rule."""
    model = nemc.compile(FREE_BODY)
    result = model.simulate((0, 3), method=method, params={"k": 1e30, "m": 1e-30})
    assert steps_taken(result.message) == runs.PACE_WINDOW  # 1000 steps, not the budget's 1e6
    assert result.status == -8 and not result.success
    assert result.message.startswith("stopped at t = ")
    assert "The motion is too fast to follow" in result.message and "nemc.Radau" in result.message
    assert result.t.size and np.all(np.isfinite(result.y))


def test_taylor_refuses_the_blow_up_by_its_series() -> None:
    model = nemc.compile(FREE_BODY)
    result = model.simulate((0, 3), method="nemc.Taylor", params={"k": 1e30, "m": 1e-30})
    assert not result.success and "series overflows" in result.message


@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Vern9", "RK45", "DOP853", "RK23"])
def test_stiffness_is_detected_and_named(tmp_path: Path, method: str) -> None:
    """Detected at the stiffness test's first look (every NSTIFF steps for scipy's methods,
    every step natively), not after the step budget's 1,000,000 stability-bound steps."""
    model = compiled(tmp_path, "stiff_damper", STIFF)
    result = model.simulate(method=method)
    assert steps_taken(result.message) < 2 * runs.NSTIFF
    assert result.status == -9 and not result.success
    assert result.message.startswith("stiff from t = ") and "try nemc.Radau" in result.message
    stiff_from = float(result.message.split()[4].rstrip(":"))
    assert 0 <= stiff_from < 0.05  # the fast mode is there from the start
    assert model.simulate(method="nemc.Radau").success  # and the advice holds


def test_a_stiff_run_within_budget_finishes_with_a_note() -> None:
    model = nemc.compile(EXAMPLES / "two_link_robot_arm.yaml")  # the book's 5.4
    result = model.simulate(method="nemc.DOP853")
    assert result.success and "The problem is stiff from t = " in result.message


def test_the_budget_ends_a_run_and_keeps_its_states(tmp_path: Path, every_step) -> None:
    model = every_step
    for method in ("nemc.DOP853", "nemc.Taylor", "RK45", "Radau"):
        result = model.simulate((0, 5), method=method, max_steps=20)
        assert result.status == -7 and not result.success, method
        assert result.t.size == 21 and result.t[-1] < 5  # t0 and 20 steps
        assert "after 20 steps (max_steps)" in result.message
        whole = model.simulate((0, 5), method=method, max_steps=0)
        np.testing.assert_array_equal(result.t, whole.t[:21])  # the same steps until then
    text = (EXAMPLES / "double_pendulum.yaml").read_text().replace(
        "method: RK45", "method: nemc.Vern9\n  max_steps: 10").replace(
        "name: double_pendulum", "name: budgeted")
    assert compiled(tmp_path, "budgeted", text).simulate().status == -7


def test_negative_damping_ends_with_a_message(tmp_path: Path) -> None:
    """Issue 17: the triple pendulum with c = -50 ran over 100 s printing nothing."""
    model = compiled(tmp_path, "triple_pendulum", TRIPLE)
    for method in ("nemc.DOP853", "nemc.Vern9"):
        result = model.simulate(method=method, params={"c": -50})
        assert result.status in (-7, -8) and "after" in result.message
        assert steps_taken(result.message) <= runs.DEFAULT_MAX_STEPS  # within the budget
        assert result.nfev < 20 * runs.DEFAULT_MAX_STEPS
    assert model.simulate(method="nemc.DOP853").success  # damped, it is an ordinary run


def test_settings_are_checked() -> None:
    model = nemc.compile(EXAMPLES / "double_pendulum.yaml")
    for bad, match in (({"max_step": 0}, "max_step must be > 0"),
                       ({"max_step": "1"}, "max_step must be a real number"),
                       ({"max_steps": 2.5}, "max_steps must be a whole number"),
                       ({"max_steps": -1}, "max_steps must be a whole number"),
                       ({"tstops": [np.nan]}, "tstops must be a list of finite times"),
                       ({"tstops": [[1, 2]]}, "tstops must be a list of finite times")):
        with pytest.raises(ModelError, match=match):
            model.simulate(**bad)
    with pytest.raises(ModelError, match="max_events"):
        model.simulate_many(max_events=-1)


# scipy's DOP853 divides 0 by 0 where the error estimate vanishes (the rotor at rest)
@pytest.mark.filterwarnings("ignore:invalid value encountered in scalar divide:RuntimeWarning")
@pytest.mark.parametrize("method", NATIVE + ["RK45", "DOP853", "Radau", "LSODA"])
def test_a_narrow_pulse_is_caught_with_tstops_or_max_step(tmp_path: Path, method: str) -> None:
    model = compiled(tmp_path, "pulse", PULSE)
    kick = 1000 * 0.001 * np.sqrt(np.pi)
    stepped_over = model.simulate(method=method)
    assert abs(stepped_over.y[1, -1]) < 1e-3 * kick  # the default steps miss it entirely
    for setting in ({"tstops": [0.995, 1.005]}, {"max_step": 2e-4}):
        caught = model.simulate(method=method, **setting)
        assert caught.success
        assert caught.y[1, -1] == pytest.approx(kick, rel=2e-5), setting


def test_steps_land_on_tstops_and_max_step_takes_scipys_steps(every_step) -> None:
    model = every_step
    stops = [0.123456789, 1.5, 2.75]
    for method in ("nemc.DOP853", "nemc.Radau", "nemc.Taylor", "nemc.Vern9", "DOP853", "BDF"):
        steps = model.simulate((0, 3), method=method, tstops=stops).t
        assert set(stops) <= set(steps.tolist()), method
    p, y0 = model.parameter_vector(), model.initial_state()
    native = model.simulate((0, 3), method="nemc.DOP853", max_step=0.01, rtol=1e-3,
                            atol=1e-6)
    scipy = solve_ivp(model.compiled.integrator_rhs(p), (0, 3), y0, method="DOP853", max_step=0.01,
                      rtol=1e-3, atol=1e-6)
    assert native.nfev == scipy.nfev and native.t.size == scipy.t.size
    np.testing.assert_allclose(native.t, scipy.t, rtol=1e-12, atol=0)
    assert np.diff(native.t).max() <= 0.01 * (1 + 1e-12)


@pytest.mark.parametrize("method", NATIVE + ["RK45"])
def test_the_double_exponential_fails_near_its_overflow(tmp_path: Path, method: str) -> None:
    """Issue 21: nemc.Taylor took one step from 0 to 1 over exp(exp(10 t)) 1e-300 and called it
    a success; a step now stands only once the expansion at its end is finite."""
    result = compiled(tmp_path, "double_exponential", BLOW_UP).simulate(method=method)
    assert not result.success
    failed_at = float(result.message.split("at t=")[1].split(":")[0])
    assert 0.6 < failed_at < 0.85  # exp(exp(10 t)) overflows at t = ln(709.8) / 10 = 0.656


# A run that would last for ever (to t = 1e6 at rtol 1e-12, no step budget). A native run says
# it is inside once its guard is armed, after its first work (t > 0.1 here, past t = 0.02);
# scipy's runs watch from their start and say it from an event function once past t = 0.02.
LONG_RUN = """\
import sys
import children
import nemc

model = nemc.compile(sys.argv[1])
method, events = sys.argv[2], None
if method.startswith("nemc."):
    children.announce_when_watching()
else:
    def past(t, y):
        if t > 0.02 and not past.said:
            past.said = True
            children.announce(children.WATCHING)
        return 1.0

    past.said, events = False, [past]
result = model.simulate((0, 1e6), method=method, rtol=1e-12, atol=1e-12, max_steps=0,
                        t_eval=[0, 0.01, 0.02, 1e6], events=events)
print(result.status, result.t.size, result.message, flush=True)
"""

# The command line, its first guarded run announced (or, given "scene", once `nemc stress`
# has measured the scene's own run).
CLI = """\
import sys
import children
from nemc.tools import stress_report
from nemc.tools.cli import main

if sys.argv[1] == "scene":
    done = stress_report.Finished.done

    def said_when_measured(finished, line):
        done(finished, line)
        if line.startswith("the scene's run"):
            children.announce("measured the scene's run")

    stress_report.Finished.done = said_when_measured
else:
    children.announce_when_watching()
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Radau", "RK45"])
def test_ctrl_c_returns_the_partial_run(tmp_path: Path, method: str) -> None:
    """SIGINT once the run is inside (a handshake): the run ends, though it would last for
    ever, as interrupted, with the points it had."""
    model = nemc.compile(EXAMPLES / "double_pendulum.yaml")
    if method == "nemc.Radau":
        model.compiled_with("jacobian")  # built here, not in the child
    script = tmp_path / "long_run.py"
    script.write_text(LONG_RUN)
    with child_process([sys.executable, str(script), str(EXAMPLES / "double_pendulum.yaml"),
                        method], stdout=subprocess.PIPE, text=True) as child:
        out, _ = interrupted(child)
        status, count, message = out.split(" ", 2)
        assert (child.returncode, int(status), int(count)) == (0, -11, 3)  # 0, 0.01, 0.02 kept
        assert message.startswith("interrupted (Ctrl-C) at t = ")
        assert 0.02 <= float(message.split()[5]) < 1e6


def test_ctrl_c_stops_the_cli_with_status_130(tmp_path: Path) -> None:
    text = (EXAMPLES / "double_pendulum.yaml").read_text().replace(
        "t_span: [0, 5]", "t_span: [0, 1.0e+6]").replace(
        "t_eval: {step: 0.5}", "t_eval: [0, 0.5, 1.0e+6]\n  max_steps: 0").replace(
        "rtol: 1.0e-6", "rtol: 1.0e-12").replace("method: RK45", "method: nemc.DOP853").replace(
        "name: double_pendulum", "name: long_pendulum")
    path = tmp_path / "long.yaml"
    path.write_text(text)
    nemc.compile(path)  # the child loads it from the cache
    with child_process([sys.executable, "-c", CLI, "run", "simulate", str(path)],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as child:
        out, err = interrupted(child)  # armed past t = 1 (DOP853's first work), past 0.5
        assert child.returncode == 130
        rows = [line.split()[0] for line in out.splitlines()[2:] if not line.startswith("#")]
        assert rows == ["0", "0.5"]  # what it had
        assert "nemc: interrupted (Ctrl-C) at t = " in err


def test_an_interrupted_ensemble_returns_its_runs(tmp_path: Path) -> None:
    """The ensemble watches from its start: every run ends interrupted, short of its end."""
    script = tmp_path / "ensemble.py"
    script.write_text(textwrap.dedent(f"""\
        import numpy as np, children, nemc
        model = nemc.compile({str(EXAMPLES / "double_pendulum.yaml")!r})
        children.announce_when_watching()
        runs = model.simulate_many(np.tile(model.initial_state(), (8, 1)), t_span=(0, 1e6),
                                   t_eval=[0, 1e6], method="nemc.DOP853", rtol=1e-12,
                                   atol=1e-12, max_steps=0, threads=2)
        print(sorted(set(runs.status.tolist())), int(np.isnan(runs.y[:, 0, 1]).sum()),
              flush=True)
        """))
    nemc.compile(EXAMPLES / "double_pendulum.yaml")
    with child_process([sys.executable, str(script)], stdout=subprocess.PIPE, text=True) as child:
        out, _ = interrupted(child)
    assert out.split() == ["[-11]", "8"]


def test_an_interrupted_stress_keeps_what_it_measured(tmp_path: Path) -> None:
    """SIGINT once the scene's own run is measured (a handshake): the partial report has it."""
    nemc.compile(EXAMPLES / "double_pendulum.yaml")
    with child_process([sys.executable, "-c", CLI, "scene", "stress",
                        str(EXAMPLES / "double_pendulum.yaml"), "--out", str(tmp_path)],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as child:
        _, err = interrupted(child, "measured the scene's run")
        assert child.returncode == 130, err
        partial = (tmp_path / "double_pendulum.partial.md").read_text()
        assert "interrupted" in partial and "- the scene's run: RK45" in partial
        assert "nemc: interrupted; what was measured:" in err


class Terminal:
    """A stderr that says it is a terminal, keeping what is written."""

    def __init__(self) -> None:
        self.text = ""

    def isatty(self) -> bool:
        return True

    def write(self, text: str) -> None:
        self.text += text

    def flush(self) -> None:
        pass


def test_progress_shows_only_on_a_terminal() -> None:
    from nemc.runtime.runs import Progress

    terminal = Terminal()
    progress = Progress("runs", 10, delay=0.0, stream=terminal)
    progress.update(4)
    assert "runs 4/10" in terminal.text
    progress.close()
    assert terminal.text.endswith("\r\x1b[K")
    assert Progress("runs", delay=0.0).enabled is sys.stderr.isatty()


def test_threads_take_runs_from_one_counter_and_show_it_as_progress() -> None:
    """run_threads starts the work on every thread at once; the progress shown is the shared
    counter's runs begun, never past the total (each thread's last take overshoots it, as the
    C's nemc_next_run does), and a thread's error is raised."""
    import threading

    from nemc.runtime.ensemble import run_threads
    from nemc.runtime.runs import Progress

    total, counter, lock = 40, [0], threading.Lock()
    threads_seen: set[int] = set()
    all_started = threading.Barrier(3)  # no thread takes a run before the three have begun

    def work() -> None:
        threads_seen.add(threading.get_ident())
        all_started.wait()
        while True:
            with lock:
                counter[0] += 1
                if counter[0] > total:
                    return

    terminal = Terminal()
    progress = Progress("runs", total, delay=0.0, stream=terminal)
    run_threads(work, 3, lambda: counter[0], total, progress, True)
    assert len(threads_seen) == 3 and counter[0] == total + 3
    shown = [int(line.split()[1].split("/")[0]) for line in terminal.text.split("\r\x1b[K")
             if line.startswith("runs ")]
    assert shown and all(0 <= count <= total for count in shown)
    assert shown == sorted(shown)

    def failing() -> None:
        raise ValueError("a run's arrays")

    with pytest.raises(ValueError, match="a run's arrays"):
        run_threads(failing, 2, lambda: 0, total, None, None)
