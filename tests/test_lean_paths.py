"""The fast paths of issue 19's lean calls give what the general paths give: model.rhs with the
default parameters, simulate's plain-float spans, tolerances and t_eval, the initial state's
finiteness, the shared default run settings, the interrupt flag as a context manager. (Their
speed is measured by benchmarks/overhead.py and benchmarks/startup.py, never asserted here.)"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.runtime import runs
from nemc.runtime.checks import all_finite, checked_span, checked_times
from nemc.runtime.model import Model, ModelError

ROOT = Path(__file__).resolve().parent.parent
COMPOUND = ROOT / "examples" / "compound_pendulum.yaml"  # state [theta, dot(theta)]


@pytest.fixture(scope="module")
def model() -> Model:
    return nemc.compile(COMPOUND)


def test_rhs_with_defaults_is_rhs_with_no_overrides(model: Model) -> None:
    y = np.array([0.4, -0.3])
    expected = model.rhs(0.5, y, params={})
    for t, state in [(0.5, y), (np.float64(0.5), y), (1, list(y)), (0.5, y.astype(">f8")),
                     (0.5, np.array([0.4, 9.0, -0.3])[::2]), (0.5, np.asfortranarray(y))]:
        np.testing.assert_array_equal(model.rhs(t, state), model.rhs(0.5, y, params={}))
    assert model.rhs(0.5, y) is not model.rhs(0.5, y)  # a new array each call
    np.testing.assert_array_equal(model.rhs(0.5, y), expected)


@pytest.mark.parametrize("t", [math.nan, math.inf, "0.5", [0.5, 0.6]])
def test_rhs_with_defaults_refuses_bad_times(model: Model, t: object) -> None:
    with pytest.raises(ModelError):
        model.rhs(t, np.array([0.4, -0.3]))


@pytest.mark.parametrize("y", [np.zeros(3), np.zeros(2, dtype=complex), [0.1], "ab"])
def test_rhs_with_defaults_refuses_bad_states(model: Model, y: object) -> None:
    with pytest.raises(ModelError):
        model.rhs(0.0, y)


def test_defaults_after_overrides_are_the_defaults(model: Model) -> None:
    y = np.array([0.4, -0.3])
    before = model.rhs(0.0, y)
    changed = model.rhs(0.0, y, params={"g": 9.81})
    assert not np.array_equal(before, changed)
    np.testing.assert_array_equal(model.rhs(0.0, y), before)
    np.testing.assert_array_equal(model.parameter_vector(None), model.parameter_vector({}))


@pytest.mark.parametrize("span", [(0.0, math.nan), [math.inf, 1.0], (0.0, 1.0, 2.0),
                                  (1e308, -1e308)])
def test_plain_float_spans_are_checked(span: object) -> None:
    with pytest.raises(ModelError):
        checked_span(span)


def test_spans_of_any_real_kind_agree() -> None:
    assert checked_span((0.0, 2.5)) == checked_span([0, 2.5]) == checked_span(np.array([0, 2.5]))


@pytest.mark.parametrize("times", [[math.nan], [math.inf], [0.5, math.nan], [-math.inf, 0.5],
                                   [2.0], [0.5, 0.4]])
def test_t_eval_checked_of_any_size(times: list[float]) -> None:
    with pytest.raises(ModelError):
        checked_times(np.array(times), (0.0, 1.0))


def test_all_finite() -> None:
    assert all_finite(np.array([1e308, 1e308]))  # the sum overflows; every entry is finite
    assert all_finite(np.ones(100))
    for bad in ([math.nan, 1.0], [math.inf, -math.inf], [1.0] * 99 + [math.nan]):
        assert not all_finite(np.array(bad))


@pytest.mark.parametrize("y0", [[math.nan, 0.0], [0.0, math.inf]])
def test_simulate_refuses_a_non_finite_initial_state(model: Model, y0: list[float]) -> None:
    with pytest.raises(ModelError, match="finite"):
        model.simulate((0.0, 0.1), y0)


@pytest.mark.parametrize("rtol", [math.nan, math.inf, 0.0, 1.0, True])
def test_float_tolerances_are_checked(model: Model, rtol: object) -> None:
    with pytest.raises(ModelError):
        model.simulate((0.0, 0.1), rtol=rtol)


def test_results_do_not_share_their_params(model: Model) -> None:
    first, second = model.simulate((0.0, 0.1)), model.simulate((0.0, 0.1))
    first.params[model.parameter_names[0]] = -1.0
    assert second.params == model.parameters
    assert model.simulate((0.0, 0.1)).params == model.parameters


def test_default_run_settings_are_shared_and_read_only() -> None:
    settings = runs.run_settings({}, (0.0, 1.0))
    assert settings is runs.DEFAULT_SETTINGS
    assert (settings.max_step, settings.max_steps, settings.tstops.size) == (
        math.inf, runs.DEFAULT_MAX_STEPS, 0)
    with pytest.raises(ValueError):
        settings.tstops[...] = 1.0  # an empty, read-only array
    assert runs.run_settings({"max_steps": 0}, (0.0, 1.0)).max_steps == 0
    assert runs.run_settings({"tstops": [0.5]}, (0.0, 1.0)).tstops.tolist() == [0.5]
    assert runs.run_settings({}, (0.0, 1.0), max_step=0.1).max_step == 0.1


def test_interrupt_flag_restores_the_handlers_also_after_an_error() -> None:
    import signal

    handler = signal.getsignal(signal.SIGINT)
    with pytest.raises(RuntimeError), runs.interrupt_flag() as flag:
        assert flag.dtype == np.intc and flag[0] == 0
        raise RuntimeError("inside")
    assert signal.getsignal(signal.SIGINT) is handler
    assert signal.set_wakeup_fd(-1) == -1  # none left set
    assert not runs.WATCH.guards


def test_a_cached_compile_imports_no_build_or_report_machinery(model: Model) -> None:
    """A cache hit needs numpy and the extension, not the compiler's tools (issue 19)."""
    code = ("import sys, nemc; nemc.compile(sys.argv[1]); print(' '.join(sorted(m for m in ("
            "'cffi', 'subprocess', 'tempfile', 'shutil', 'concurrent.futures', 'difflib', "
            "'html', 'scipy', 'sympy', 'yaml', 'matplotlib', 'importlib.resources') "
            "if m in sys.modules)))")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}  # this checkout's nemc, the session's cache
    done = subprocess.run([sys.executable, "-c", code, str(COMPOUND)], capture_output=True,
                          text=True, check=True, env=env)
    assert done.stdout.strip() == ""


def test_a_cached_models_sensitivities_import_no_sympy(model: Model) -> None:
    """The part "sensitivities" and the drivers for its system's size, once built, are found
    in the cache without the symbolic stages (finding the drivers used to import sympy
    through the emitter: 0.4 s of a process's first fit)."""
    model.simulate((0, 1), sensitivities=["y0"])  # both built into the session's cache
    code = ("import sys, nemc; model = nemc.compile(sys.argv[1]); "
            "res = model.simulate((0, 1), sensitivities=['y0']); "
            "print(res.success, 'sympy' in sys.modules)")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", code, str(COMPOUND)], capture_output=True,
                          text=True, check=True, env=env)
    assert done.stdout.split() == ["True", "False"]


def test_only_a_run_that_lasts_swaps_the_sigint_handler(model: Model, monkeypatch) -> None:
    """The Ctrl-C guard is armed from C (nemc_run.arm_interrupt) once a run has done
    NEMC_ARM_WORK: a short run never touches the handlers, a long one arms once, and the
    handlers are back as they were afterwards (issue 19: 1.5 us less a short run)."""
    import signal

    armed: list[bool] = []
    arm = runs.arm_interrupts

    def counted(flag: object) -> int:
        go_on = arm(flag)
        armed.append(signal.getsignal(signal.SIGINT) is runs.swallow_sigint)
        return go_on

    monkeypatch.setattr(runs, "arm_interrupts", counted)
    model = nemc.compile(COMPOUND)  # its callback made now: the counted one
    handler = signal.getsignal(signal.SIGINT)
    for method in ("nemc.DOP853", "nemc.Vern9", "nemc.Radau", "nemc.Taylor"):
        armed.clear()
        short = model.simulate((0.0, 1e-3), method=method, t_eval=[1e-3])
        assert short.success and armed == []
        long = model.simulate((0.0, 200.0), method=method, rtol=1e-10, t_eval=[200.0])
        assert long.success and armed == [True], method
        assert signal.getsignal(signal.SIGINT) is handler
        assert signal.set_wakeup_fd(-1) == -1
        assert not runs.WATCH.guards and not runs.ARMED


def test_a_ctrl_c_before_the_guard_is_armed_ends_the_run(model: Model) -> None:
    """A SIGINT that came before arming raises KeyboardInterrupt in the arming callback, which
    cannot pass it through C: its onerror tells the run to end as an interrupted one."""
    def interrupted(flag: object) -> int:
        raise KeyboardInterrupt

    callback = model.compiled.ffi.callback("int(int *)", interrupted, error=0,
                                   onerror=runs.interrupted_while_arming)
    flag = model.compiled.ffi.new("int *")
    assert callback(flag) == 1
    assert runs.arm_interrupts(flag) == 0 and len(runs.ARMED) == 1  # armed: watched
    runs.after_run(flag)
    assert not runs.ARMED and not runs.WATCH.guards


def test_without_callbacks_a_run_is_watched_from_its_start(monkeypatch) -> None:
    """Where cffi cannot make the arming callback (no write+execute memory), single runs get
    the guard from their start, as before, with the same result and the handlers restored."""
    import signal

    model = nemc.compile(COMPOUND)
    lazy = model.simulate((0.0, 50.0), method="nemc.DOP853", t_eval=[50.0])
    model.compiled.arm_interrupts = None
    watched: list[bool] = []
    enter = runs.interrupt_flag.__enter__

    def entered(guard: runs.interrupt_flag) -> object:
        flag = enter(guard)
        watched.append(signal.getsignal(signal.SIGINT) is runs.swallow_sigint)
        return flag

    monkeypatch.setattr(runs.interrupt_flag, "__enter__", entered)
    eager = model.simulate((0.0, 50.0), method="nemc.DOP853", t_eval=[50.0])
    assert watched == [True]
    np.testing.assert_array_equal(eager.y, lazy.y)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert not runs.WATCH.guards
