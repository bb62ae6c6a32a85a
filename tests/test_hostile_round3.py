"""Hostile input and misuse, round 3 (issue 51): a case per class the third adversarial pass
found, each with its own inputs (tests/hostile/round3/ and files made here), general rather than
tuned to one file. The classes, in the order of the issue's note: outputs written over the
files nemc read; a sweep store's missing chunks; events exactly at the interval's end; crashes
of the derivation; bad option values; the cache's stray extensions; messages.

Every class of the issue, its fix and its tests (r3 = this module, r3b = test_hostile_round3b;
the issue's bullets split into their classes, 24 for its 22: the bad option values and the
API's sizes are one guard, a run's NaN event and its doubled "integration failed" one message):

 1. `--csv X.yaml` overwrites the mechanism
    fix: tools/files.py `output_refusal`, `same_file` (every output option)
    test: r3 `test_no_output_option_writes_over_the_mechanism`,
          `test_fit_never_writes_over_its_data`
 2. driven parallelogram jumps branch after flat
    fix: runtime/kinematic.py `BranchFollower` (`nearest`: two states apart); free runs'
         message runtime/passages.py
    test: test_kinematic_branch.py (all); r3b
          `test_a_driven_parallelogram_keeps_its_branch_at_any_requested_times`,
          `test_a_free_run_through_a_singular_configuration_says_so`,
          `test_the_double_four_bar_names_its_ten_flat_positions`
 3. sweep store's lost status / `y` chunk reads as success
    fix: tools/sweep_store.py status fill value NOT_RUN, a done chunk's files
    test: r3 `test_a_lost_chunk_of_a_sweep_store_is_run_again`
 4. event zero exactly at t_end missed by native methods
    fix: templates/run_control.c.tmpl (the interval's end located)
    test: r3 `test_every_method_sees_an_event_exactly_at_t_end`
 5. every coordinate driven: sympy TypeError
    fix: derive/equations.py, runtime/simulation.py `kinematic_run`
    test: r3 `test_a_tree_with_every_coordinate_driven_is_an_inverse_dynamic_analysis`
 6. abs/sign/min/max motion laws crash the compile
    fix: derive/kinematics.py (derivatives where they exist)
    test: r3 same test, its 7 laws; r3b `test_abs_sign_min_max_in_a_drive_of_a_moving_mechanism`
 7. event / impact law naming a driven coordinate
    fix: derive/loops.py, front/scene.py (a law setting one refused)
    test: r3 `test_events_and_impact_laws_may_name_driven_coordinates`,
          `test_an_impact_law_setting_a_driven_coordinate_is_refused_at_its_line`
 8. LSODA blow-up: ZeroDivisionError
    fix: runtime/runs.py (message of a zero step)
    test: r3 `test_a_blow_up_is_a_failed_run_under_every_method`
 9. bad option values: tracebacks, hangs
    fix: tools/cli.py argument types, runtime/checks.py `within_budget`, `step_times`,
         build/builder.py (CC)
    test: r3 `test_bad_option_values_are_one_line_refusals`,
          `test_an_unsplittable_cc_is_a_one_line_build_error`
10. sweep store with corrupted metadata: traceback
    fix: tools/sweep_store.py `damaged_store`
    test: r3 `test_a_damaged_sweep_store_is_a_one_line_refusal`
11. cache loads a stray `_native.*.so`
    fix: runtime/load.py `extension_file` (the manifest's file)
    test: r3 `test_a_stray_extension_beside_a_cached_build_is_never_loaded`
12. `--dask local:N` workers die: Nanny traceback
    fix: tools/sweeps.py, tools/cli.py (one line, exit 1)
    test: r3b `test_workers_that_die_at_start_are_one_line`
13. `simulate_many` of 10^9 runs, 10^8-point t_eval: MemoryError
    fix: runtime/checks.py `within_budget`
    test: r3 `test_api_calls_too_large_are_refused_before_allocating`
14. a run failing mid-run returns only the failing point
    fix: runtime/outcome.py `failed_after`, runtime/runs.py `ScipyControl.fail`
    test: r3b `test_a_run_that_fails_mid_run_keeps_its_states_events_and_outputs`,
          `test_an_event_function_or_law_failing_mid_run_keeps_the_states_before`,
          `test_a_run_that_fails_at_its_start_returns_the_state_it_failed_at`
15. a loop's initial values not settable by `--initial` or a sweep
    fix: tools/start.py `start_values`, runtime/built.py `guess_state`, tools/sweeps.py
    test: r3b `test_initial_values_of_a_closed_loop_are_kept_and_the_rest_solved`;
          test_loop_initial.py (all)
16. degrees of freedom counted at a singular start
    fix: derive/assembly.py and runtime/loops.py `singular_start`
    test: r3b `test_a_start_at_a_singular_configuration_is_refused_by_name`
17. auto hands a stiffening problem to nemc.Taylor
    fix: templates/taylor.c.tmpl (Hairer's stiffness test), runtime/simulation.py
         `integrate_auto`
    test: test_taylor_stiffness.py `test_auto_hands_the_stiff_rest_to_radau`,
          `test_taylor_alone_stops_stiff_well_before_its_budget`
18. NaN event function reported as "accelerations not finite"
    fix: templates/events.c.tmpl, run_control.c.tmpl (NEMC_EVENT_NOT_FINITE,
         NEMC_LAW_NOT_FINITE), runtime/failures.py
    test: r3 `test_a_nan_event_function_or_impact_law_is_named_once`
19. "integration failed: integration failed:"
    fix: tools/cli.py `failure_line`
    test: r3 same test (said once)
20. `--csv ''` silently ignored
    fix: tools/files.py `output_refusal`
    test: r3 `test_an_empty_output_name_is_refused`
21. Ctrl-C before the sweep's store exists says runs were kept
    fix: tools/cli.py `interrupted_sweep`
    test: r3 `test_ctrl_c_before_the_sweep_store_exists_says_nothing_was_kept`
22. two sweeps creating one store: the loser names its scratch
    fix: tools/sweep_store.py `publish`
    test: r3 `test_the_sweep_that_loses_the_race_to_create_a_store_names_it`
23. `nemc stress` exits 2 on bouncing_ball, fourbar_driven
    fix: tools/stress.py (a long run ended by its events; 0 DOF)
    test: r3b `test_stress_measures_a_ball_that_comes_to_rest_before_its_horizon`,
          `test_stress_reports_a_mechanism_without_a_degree_of_freedom`
24. scene values `check` accepts refused only by the run
    fix: front/scene.py (rtol, initial values over 1e150), templates/loops.c.tmpl (rates
         relative), derive/assembly.py `rates_problem`; an accepted rtol below 100 eps
         warns in one line (tools/cli.py `one_line_warning`)
    test: r3 `test_an_rtol_no_run_takes_is_refused_by_check_at_its_line`; r3b
          `test_check_refuses_initial_values_no_run_can_take`,
          `test_large_consistent_rates_of_a_loop_are_assembled`,
          `test_check_refuses_a_start_no_rates_can_take`,
          `test_a_warning_of_a_command_is_one_line`

What `check` accepts is compiled and run by the fuzzer (test_fuzz.py, slow):
`test_what_check_accepts_compiles_and_runs` (mutated examples) and
`test_values_check_accepts_run_on_the_examples_own_builds` (values, on each example's build).
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from nemc.runtime.model import ModelError
from nemc.tools.cli import main

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "tests" / "hostile" / "round3"
TINY = ROOT / "tests" / "models" / "tiny.yaml"  # one rod on a pin


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def folder_state(folder: Path) -> dict[str, str]:
    """Every file under FOLDER by name and content (links by target)."""
    return {str(p.relative_to(folder)): os.readlink(p) if p.is_symlink() else digest(p)
            for p in sorted(folder.rglob("*")) if p.is_file() or p.is_symlink()}


# ---- 1. no output over a file nemc read --------------------------------------------------

def spellings(folder: Path, name: str) -> dict[str, str]:
    """Ways to name FOLDER/NAME again: relative, dotted, absolute, through a symbolic link, a
    hard link and a linked folder."""
    (folder / f"soft-{name}").symlink_to(name)
    os.link(folder / name, folder / f"hard-{name}")
    (folder / "via").symlink_to(folder)
    return {"relative": name, "dotted": f"./sub/../{name}", "absolute": str(folder / name),
            "symbolic link": f"soft-{name}", "hard link": f"hard-{name}",
            "linked folder": f"via/{name}"}


OVER_THE_MECHANISM = [  # (command, the mechanism's file name, the output option)
    (["simulate", "--t-end", "0.1"], "m.yaml", "--csv"),
    (["simulate", "--t-end", "0.1"], "m.yaml", "--mat"),
    (["simulate", "--t-end", "0.1"], "m.svg", "--plot"),  # a mechanism named as a figure
    (["animate", "--t-end", "0.1"], "m.gif", "--out"),
    (["stress", "--horizon", "1"], "m.yaml", "--out"),
    (["linearize"], "m.json", "--out"),
    (["export"], "m.fmu", "--fmu"),
    (["compile"], "m.yaml", "-o"),
    (["sweep", "--runs", "2"], "m.npz", "--out"),
]


@pytest.mark.parametrize("command, name, option", OVER_THE_MECHANISM)
def test_no_output_option_writes_over_the_mechanism(command: list[str], name: str, option: str,
                                                    tmp_path: Path, capsys,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """Any command, any output option, any spelling of the file it reads: exit status 2, one
    line naming the option, and not a byte written anywhere."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    shutil.copy(TINY, tmp_path / name)
    for how, spelled in spellings(tmp_path, name).items():
        before = folder_state(tmp_path)
        status = main([command[0], name, *command[1:], option, spelled])
        captured = capsys.readouterr()
        assert status == 2, (how, captured)
        assert captured.out == "" and len(captured.err.splitlines()) == 1, (how, captured)
        assert "is the file nemc reads" in captured.err and spelled in captured.err
        assert folder_state(tmp_path) == before, how


def test_fit_never_writes_over_its_data(tmp_path: Path, capsys,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    shutil.copy(TINY, tmp_path / "m.yaml")
    (tmp_path / "data.json").write_text("t,q\n0,0\n0.1,0.01\n")  # a CSV, named as the output
    before = folder_state(tmp_path)
    assert main(["fit", "m.yaml", "data.json", "--fit", "m", "--out", "./data.json"]) == 2
    assert "(data data.json)" in capsys.readouterr().err
    assert folder_state(tmp_path) == before


def test_an_output_that_is_another_file_is_written(tmp_path: Path, capsys,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """The guard compares files, not names: a file of the same name elsewhere is written."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "other").mkdir()
    shutil.copy(TINY, tmp_path / "m.yaml")
    shutil.copy(TINY, tmp_path / "other" / "m.yaml")
    assert main(["simulate", "m.yaml", "--t-end", "0.1", "--csv", "other/m.yaml"]) == 0
    capsys.readouterr()
    assert (tmp_path / "other" / "m.yaml").read_text().startswith("t")
    assert digest(tmp_path / "m.yaml") == digest(TINY)


# ---- 2. a sweep store's lost chunk is "not run" --------------------------------------------

SWEEP = ["sweep", "m.yaml", "--grid", "m=1:3:5", "--random", "L=0.3:0.6", "--runs", "2",
         "--seed", "7", "--chunk", "3", "--t-end", "0.4", "--times", "4", "--out", "s.zarr"]


@pytest.mark.parametrize("variable", ["status", "y", "y0", "nfev", "message"])
def test_a_lost_chunk_of_a_sweep_store_is_run_again(variable: str, tmp_path: Path, capsys,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """10 runs in chunks of 3 (the last one short); one chunk file of VARIABLE deleted (a
    seeded pick): that chunk reads as not run (never as a success with NaN states) and only
    its runs are run again, to the same numbers."""
    xr = pytest.importorskip("xarray")
    rng = __import__("random").Random(f"lost-{variable}")
    monkeypatch.chdir(tmp_path)
    shutil.copy(TINY, tmp_path / "m.yaml")
    assert main(SWEEP) == 0
    capsys.readouterr()
    whole = xr.open_zarr("s.zarr", consolidated=False).load()
    assert whole.sizes["run"] == 10 and (whole.status.values == 0).all()
    chunk = rng.randrange(4)
    lost = sorted((tmp_path / "s.zarr" / variable / "c").glob(f"{chunk}*"))
    assert len(lost) == 1, lost
    shutil.rmtree(lost[0]) if lost[0].is_dir() else lost[0].unlink()
    if variable == "status":  # any reader: zarr's fill value
        status = xr.open_zarr("s.zarr", consolidated=False).status.values
        assert list(status != 0) == [run // 3 == chunk for run in range(10)]
    assert main(SWEEP) == 0  # the same command again: it continues
    runs_again = min(3, 10 - 3 * chunk)
    assert f"10 runs ({10 - runs_again} done before)" in capsys.readouterr().out
    again = xr.open_zarr("s.zarr", consolidated=False).load()
    assert again.identical(whole)


# ---- 3. an event exactly zero at t_end: every method sees it -------------------------------

def every_method() -> list[str]:
    from nemc.runtime.model import METHODS

    return list(dict.fromkeys([*METHODS, "auto"]))


@pytest.fixture(scope="module")
def at_the_end() -> tuple:
    import nemc

    return (nemc.compile(CASES / "events_at_the_end.yaml"),
            nemc.compile(CASES / "event_stops_at_the_end.yaml"))


@pytest.mark.parametrize("method", every_method())
def test_every_method_sees_an_event_exactly_at_t_end(method: str, at_the_end: tuple) -> None:
    """Functions exactly zero at t_end (T, seeded draws): each crossing in its direction is
    found at T by every method, as scipy's methods find it (scipy counts a value reaching 0
    as a crossing); a direction it does not cross in is not; a stopping one stops, status 1."""
    import random

    records, stops = at_the_end
    rng = random.Random(51)
    for end in (1.25, *(round(rng.uniform(0.01, 4), rng.randrange(1, 6)) for _ in range(4))):
        run = records.simulate((0, end), method=method, params={"T": end})
        assert run.success and run.status == 0, (end, run.message)
        found = {name: times.tolist() for name, (times, _) in run.events.items()}
        assert found == {"up": [end], "down": [end], "either": [end], "never": []}, (end, found)
        stop = stops.simulate((0, end), method=method, params={"T": end})
        assert stop.status == 1 and stop.t[-1] == end, (end, stop.message)
        assert stop.events["halt"][0].tolist() == [end]


# ---- 4. crashes of the derivation ------------------------------------------------------------

LAWS = {  # motion law -> (f(t), f''(t) where it exists), the kinks at t = 1, pi (and 0.5, 1.5)
    "w*t": (lambda t: 1.5 * t, lambda t: 0 * t),
    "abs(sin(t))": (lambda t: abs(np.sin(t)), lambda t: -abs(np.sin(t))),
    "sign(t - 1)*t**2": (lambda t: np.sign(t - 1) * t**2, lambda t: 2 * np.sign(t - 1)),
    "max(t**2, t)": (lambda t: np.maximum(t**2, t), lambda t: np.where(t > 1, 2.0, 0.0)),
    "min(t, 1)*t": (lambda t: np.minimum(t, 1) * t, lambda t: np.where(t < 1, 2.0, 0.0)),
    "abs(t - 1)**3": (lambda t: abs(t - 1)**3, lambda t: 6 * abs(t - 1)),
    "max(0, min(1, t - 0.5))": (lambda t: np.clip(t - 0.5, 0, 1), lambda t: 0 * t),
}


@pytest.mark.parametrize("law", sorted(LAWS))
def test_a_tree_with_every_coordinate_driven_is_an_inverse_dynamic_analysis(
        law: str, tmp_path: Path) -> None:
    """No state: `simulate` computes the drives at each time (method "kinematic"), and they
    are the closed forms: the rod's (m L^2/3) f'' + m g L/2 cos f, the slider's M (s'' + g).
    Motion laws with abs, sign, min and max compile (their derivatives where they exist)."""
    import nemc

    text = (CASES / "every_coordinate_driven.yaml").read_text()
    file = tmp_path / "driven.yaml"
    file.write_text(text.replace("motion: w*t", f"motion: '{law}'"))
    model = nemc.compile(file)
    times = np.linspace(0.05, 3.95, 53)
    times = times[np.min(abs(times[:, None] - [0.5, 1, 1.5, np.pi]), axis=1) > 1e-3]
    run = model.simulate((0, 4), t_eval=times)
    assert run.success and run.method == "kinematic" and run.y.shape == (0, len(times))
    f, f2 = LAWS[law]
    m, big_m, length, a, w, g = 2, 3, 0.8, 0.2, 5, 9.81
    rod = m * length**2 / 3 * f2(times) + m * g * length / 2 * np.cos(f(times))
    slider = big_m * (-a * w**2 * np.sin(w * times) + g)
    np.testing.assert_allclose(run.outputs["O.drive"], rod, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(run.outputs["S.drive"], slider, rtol=1e-12, atol=1e-12)
    with pytest.raises(ModelError, match="no degree of freedom left by its drives"):
        model.simulate_many(np.zeros((2, 0)))


@pytest.mark.parametrize("method", ["RK45", "nemc.DOP853", "nemc.Vern9", "nemc.Radau"])
def test_events_and_impact_laws_may_name_driven_coordinates(method: str) -> None:
    """s = A sin(W t) driven: `s - A/2` rises at asin(1/2)/W, `dot(s) - 1` falls at
    acos(1/(A W))/W; the impact law reads dot(s) and s."""
    import nemc

    model = nemc.compile(CASES / "events_on_a_driven_coordinate.yaml")
    run = model.simulate(method=method, rtol=1e-10, atol=1e-12)
    assert run.success, run.message
    np.testing.assert_allclose(run.events["rises"][0], [np.arcsin(0.5) / 20], rtol=1e-9)
    np.testing.assert_allclose(run.events["fast"][0], [np.arccos(0.5) / 20], rtol=1e-9)
    assert len(run.events["kick"][0]) >= 1
    np.testing.assert_allclose(run.events["kick"][1][:, 0], 0.2999, atol=1e-9)


def test_an_impact_law_setting_a_driven_coordinate_is_refused_at_its_line(capsys) -> None:
    file = CASES / "impact_sets_a_driven_coordinate.yaml"
    assert main(["check", str(file)]) == 2
    assert capsys.readouterr().err == (
        f"{file}:13: simulation.events.stop_it.action.dot(s): s is driven (joints.S.motion): "
        "its value is prescribed; an impact law cannot set it\n")


@pytest.mark.parametrize("torque", ["q**3", "2*q**5 + dot(q)**2", "exp(q)*dot(q)"])
def test_a_blow_up_is_a_failed_run_under_every_method(torque: str, tmp_path: Path) -> None:
    """A finite-time blow-up ends every method's run with a message (LSODA's steps shrink to
    length 0: its message divided by them)."""
    import nemc
    from nemc.runtime.model import METHODS

    file = tmp_path / "blow.yaml"
    file.write_text(TINY.read_text().replace("gravity: [0, -9.81]", "") +
                    f"loads: [{{torque: '{torque}', body: rod}}]\n"
                    "simulation: {t_span: [0, 10], initial: {q: 1, dot(q): 1}}\n")
    model = nemc.compile(file)
    for method in METHODS:
        run = model.simulate(method=method)
        assert not run.success and run.status < 0 and run.t[-1] < 10, method
        assert run.message and "Traceback" not in run.message, method


# ---- 5. bad option values: one line, before anything is allocated ----------------------------

def cli(args: list[str], capsys) -> tuple[int, str, str]:
    """main(ARGS): its exit status (argparse's too), stdout and stderr."""
    try:
        status = main(args)
    except SystemExit as stop:
        status = stop.code
    captured = capsys.readouterr()
    return status, captured.out, captured.err


BAD_OPTIONS = [  # (arguments after the command's mechanism m.yaml, part of the message)
    (["simulate", "--t-eval", "1e-9"], "--t-eval: t_eval {step: 1e-09} over t_span [0.0, 10.0] "
                                       "gives more than 1000000 times"),
    (["simulate", "--t-eval", "1e-300", "--t-end", "1e300"], "gives more than 1000000 times"),
    (["sweep", "--grid", "m=1:2:2", "--seed", "-1"], "--seed: expected a whole number >= 0"),
    (["sweep", "--grid", "m=1:2:2", "--seed", "1e3"], "--seed: expected a whole number"),
    (["sweep", "--grid", "m=1:2:2", "--times", "1000000000"], "--times: at most 1000000"),
    (["sweep", "--grid", "m=1:2:1000000000"], "1000000000 runs would hold"),
    (["sweep", "--grid", "m=1:2:100000", "--grid", "L=1:2:100000"], "10000000000 runs would"),
    (["sweep", "--random", "m=1:2", "--runs", "999999999999"], "runs would hold"),
    (["sweep", "--grid", "m=1:2:2", "--dask", "local:abc"], "local:N: expected N"),
    (["sweep", "--grid", "m=1:2:2", "--dask", "local:0"], "local:N: expected N"),
    (["sweep", "--grid", "m=1:2:2", "--dask", "local:-3"], "local:N: expected N"),
    (["sweep", "--grid", "m=1:2:2", "--dask", "local:99999"], "local:N: expected N"),
    (["animate", "--fps", "1e-9"], "--fps: expected frames per second from 0.01 to 1000"),
    (["animate", "--fps", "1e9"], "--fps: expected frames per second from 0.01 to 1000"),
    (["stress", "--horizon", "1e-300"], "--horizon: the long horizon must be at least"),
    (["stress", "--horizon", "9.99"], "--horizon: the long horizon must be at least"),
]


@pytest.mark.parametrize("args, message", BAD_OPTIONS)
def test_bad_option_values_are_one_line_refusals(args: list[str], message: str, tmp_path: Path,
                                                 capsys, monkeypatch: pytest.MonkeyPatch) -> None:
    """Exit status 2, one line naming the option (argparse adds its usage), no traceback, no
    file written; the work bounded (a refusal, not a MemoryError or a hang)."""
    from budgets import work_of

    monkeypatch.chdir(tmp_path)
    shutil.copy(TINY, tmp_path / "m.yaml")
    before = folder_state(tmp_path)
    work = work_of(lambda: cli([args[0], "m.yaml", *args[1:]], capsys))
    assert work.error is None, work.error
    status, out, err = work.result
    assert status == 2 and out == "" and message in err, err
    assert "Traceback" not in err and len([e for e in err.splitlines() if "usage" not in e
                                           and not e.startswith(" ")]) == 1, err
    assert work.peak_bytes < 200e6
    assert folder_state(tmp_path) == before


def test_an_unsplittable_cc_is_a_one_line_build_error(tmp_path: Path, capsys,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CC", 'gcc "')
    monkeypatch.setenv("NEMC_CACHE", str(tmp_path / "cache"))  # a build, not a cached one
    status, out, err = cli(["compile", str(TINY), "-o", str(tmp_path / "out")], capsys)
    assert status == 1 and err == "nemc: CC='gcc \"': not a command line (No closing quotation)\n"


@pytest.mark.parametrize("call", ["broadcast y0s", "per-run parameter", "long t_eval",
                                  "ensemble times"])
def test_api_calls_too_large_are_refused_before_allocating(call: str) -> None:
    """10^9 runs, 10^8 output times, 10^9 results of an ensemble: a ModelError naming the
    size and the budget, holding no more than a few megabytes."""
    from budgets import work_of

    import nemc

    model = nemc.compile(TINY)
    y0 = model.initial_state()
    calls = {
        "broadcast y0s": lambda: model.simulate_many(np.broadcast_to(y0, (10**9, 2))),
        "per-run parameter": lambda: model.simulate_many(
            params={"m": np.broadcast_to(2.0, (10**9,))}),
        "long t_eval": lambda: model.simulate((0, 1), t_eval=np.broadcast_to(0.5, (10**8,))),
        "ensemble times": lambda: model.simulate_many(np.zeros((1000, 2)), t_span=(0, 1),
                                                      t_eval=np.linspace(0, 1, 10**6)),
    }
    work = work_of(calls[call])
    assert isinstance(work.error, ModelError), work.error
    assert "over nemc's budget of 1.34e+08 (1 GiB)" in str(work.error)
    assert work.peak_bytes < 20e6


# ---- 6. the cache loads exactly the extension its manifest verified --------------------------

def other_model(tmp_path: Path, name: str, mass: str) -> Path:
    """TINY renamed NAME with the rod's mass MASS: another model, another build."""
    file = tmp_path / f"{name}.yaml"
    file.write_text(TINY.read_text().replace("name: tiny", f"name: {name}")
                    .replace("m: 2", f"m: {mass}"))
    return file


def load_in_a_child(source: str, cache: Path) -> subprocess.CompletedProcess:
    """A fresh process (an extension is imported once a process) running SOURCE."""
    return subprocess.run([sys.executable, "-c", source], capture_output=True, text=True,
                          timeout=300, env={**os.environ, "NEMC_CACHE": str(cache),
                                            "PYTHONPATH": str(ROOT)})


def test_a_stray_extension_beside_a_cached_build_is_never_loaded(tmp_path: Path) -> None:
    """Another model's extension copied into a cache entry under every name an interpreter
    imports (this one's own suffix first, which a glob may also find first): the entry still
    verifies, and loading it gives its own model, whose accelerations are its own."""
    cache = tmp_path / "cache"
    mine, theirs = other_model(tmp_path, "mine", "2"), other_model(tmp_path, "theirs", "7")
    code = ("import sys, nemc; m = nemc.compile(sys.argv[1]); print(m.name, "
            "m.rhs(0.0, [0.5, 0.0])[1])")
    for file in (mine, theirs):
        done = load_in_a_child(code.replace("sys.argv[1]", repr(str(file))), cache)
        assert done.returncode == 0, done.stderr
    expected = load_in_a_child(code.replace("sys.argv[1]", repr(str(mine))), cache).stdout
    entries = {json.loads((p / "model.json").read_text())["name"]: p
               for p in cache.iterdir() if (p / "model.json").is_file()}
    stray = next(entries["theirs"].glob("_native.*.so"))
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        target = entries["mine"] / f"_native{suffix}"
        if not target.exists():
            shutil.copy(stray, target)
    done = load_in_a_child(code.replace("sys.argv[1]", repr(str(mine))), cache)
    assert done.returncode == 0 and done.stdout == expected, done.stderr
    assert expected.startswith("mine ")


# ---- 7. messages ----------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["RK45", "LSODA", "nemc.DOP853", "nemc.Vern9", "nemc.Radau",
                                    "nemc.Taylor"])
def test_a_nan_event_function_or_impact_law_is_named_once(method: str, capsys) -> None:
    """An event's function turning nan, and (B < 0: the function stays finite) an impact
    law's nan value: the message names each, says "integration failed" once, and never
    blames the accelerations."""
    file = CASES / "event_function_not_finite.yaml"
    for b, cause in (("0.3", "an event's function (simulation.events, `when`) is not finite"),
                     ("-0.5", "an impact law (simulation.events, `action`) gives a new value "
                              "that is not finite")):
        status, out, err = cli(["simulate", str(file), "--method", method, "--set", f"B={b}"],
                               capsys)
        assert status == 1 and err.startswith("integration failed: at t=") and cause in err, err
        assert err.count("integration failed") == 1 and "accelerations" not in err, err
        assert len(err.splitlines()) == 1


@pytest.mark.parametrize("command, option", [
    (["simulate", "--t-end", "0.1"], "--csv"), (["simulate", "--t-end", "0.1"], "--mat"),
    (["animate", "--t-end", "0.1"], "--out"), (["stress"], "--out"), (["compile"], "-o"),
    (["linearize"], "--out"), (["export"], "--fmu"), (["sweep", "--grid", "m=1:2:2"], "--out"),
])
def test_an_empty_output_name_is_refused(command: list[str], option: str, tmp_path: Path,
                                         capsys, monkeypatch: pytest.MonkeyPatch) -> None:
    """`--csv ''` was silently ignored (and `animate --out ''` wrote the default file)."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(TINY, tmp_path / "m.yaml")
    before = folder_state(tmp_path)
    for empty in ("", " "):
        status, out, err = cli([command[0], "m.yaml", *command[1:], option, empty], capsys)
        assert status == 2 and out == "" and "expected a file name, got" in err, err
        assert len(err.splitlines()) == 1
    assert folder_state(tmp_path) == before


def damage(store: Path, how: str, rng) -> None:
    """Damage one metadata file of STORE (picked by RNG) in the way HOW says."""
    files = sorted(store.rglob("zarr.json"))
    target = files[rng.randrange(len(files))] if how != "chunk_runs" else store / "zarr.json"
    if how == "truncated":
        target.write_bytes(target.read_bytes()[:rng.randrange(1, 40)])
    elif how == "garbage":
        target.write_bytes(bytes(rng.randrange(256) for _ in range(30)))
    elif how == "chunk_runs":
        meta = json.loads(target.read_text())
        meta["attributes"]["chunk_runs"] = "three"
        target.write_text(json.dumps(meta))
    else:  # a variable's folder gone
        shutil.rmtree(store / rng.choice(["y", "y0", "nfev", "message", "status"]))


@pytest.mark.parametrize("how", ["truncated", "garbage", "chunk_runs", "variable deleted"])
def test_a_damaged_sweep_store_is_a_one_line_refusal(how: str, tmp_path: Path, capsys,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """A sweep store whose metadata was edited, cut or deleted: the same command says the
    store is damaged (exit status 2, one line) and leaves it as it is."""
    pytest.importorskip("xarray")
    import random

    monkeypatch.chdir(tmp_path)
    shutil.copy(TINY, tmp_path / "m.yaml")
    assert main(SWEEP) == 0
    capsys.readouterr()
    damage(tmp_path / "s.zarr", how, random.Random(how))
    before = folder_state(tmp_path)
    status, out, err = cli(SWEEP, capsys)
    assert status == 2 and out == "", err  # the group's own metadata cut: not a sweep's
    assert "s.zarr: the sweep store is damaged" in err or "is not a nemc sweep" in err, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert folder_state(tmp_path) == before


@pytest.mark.parametrize("value", ["2", "1", "1e308"])
def test_an_rtol_no_run_takes_is_refused_by_check_at_its_line(value: str, tmp_path: Path,
                                                              capsys) -> None:
    """`rtol: 2` passed check and every run refused it, blamed on --set/options."""
    file = tmp_path / "rtol.yaml"
    file.write_text((CASES / "rtol_not_relative.yaml").read_text().replace("rtol: 2",
                                                                          f"rtol: {value}"))
    status, out, err = cli(["check", str(file)], capsys)
    assert status == 2 and err.startswith(f"{file}:7: simulation.rtol: must be a number > 0 "
                                          "and < 1 (a relative error)"), err


def test_ctrl_c_before_the_sweep_store_exists_says_nothing_was_kept(
        tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C while the runs are planned: no store, and the message said runs were kept."""
    from nemc.tools import sweep_plan

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.chdir(tmp_path)
    shutil.copy(TINY, tmp_path / "m.yaml")
    monkeypatch.setattr(sweep_plan, "plan_runs", interrupted)
    status, out, err = cli(SWEEP, capsys)
    assert status == 130 and "interrupted before the sweep began: nothing kept" in err, err
    assert not (tmp_path / "s.zarr").exists() and "kept in" not in err


def test_the_sweep_that_loses_the_race_to_create_a_store_names_it(
        tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch) -> None:
    """Another sweep publishes the store between this one's scratch folder and its rename:
    the message names the store (it named this process's scratch folder), the other's store
    is untouched, no scratch folder is left."""
    from nemc.tools import sweep_store

    monkeypatch.chdir(tmp_path)
    shutil.copy(TINY, tmp_path / "m.yaml")
    rename = os.rename

    def the_other_sweep_first(source, target):
        if Path(target).name == "s.zarr" and not Path(target).exists():
            Path(target).mkdir()
            (Path(target) / "zarr.json").write_text("{}")
        rename(source, target)

    monkeypatch.setattr(sweep_store.os, "rename", the_other_sweep_first)
    status, out, err = cli(SWEEP, capsys)
    assert status == 2 and "s.zarr: another sweep created it at the same time" in err, err
    assert ".tmp-" not in err and len(err.splitlines()) == 1
    assert folder_state(tmp_path / "s.zarr") == {"zarr.json": digest_of_text("{}")}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.yaml", "s.zarr"]


def digest_of_text(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()
