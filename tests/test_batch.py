"""nemc.Taylor's ensembles in SIMD lanes (templates/batch.c.tmpl, the part "lanes"): the same
results to the last bit as the runs one after the other (simulate_many(lanes=False)), with
per-run parameters, runs of different lengths, ensembles of 1 to 19 runs, at several orders,
either lane count, failures in one lane, tstops, max_step and step budgets, Ctrl-C; the
generated C warning-free. (Lanes against simulate() run by run on every scenario, alone and on
two threads, with events and impacts, backwards and over empty intervals: test_scenarios.py.)"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from children import child_process, interrupted

import nemc
from nemc.build.builder import Source, fma_available, lane_count
from nemc.pipeline import compile_source, read_source
from nemc.runtime.model import EnsembleResult, ModelError

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
LANE_COUNTS = (4, 8)  # nemc.emit.taylor_c.LANE_TARGETS: AVX2 and AVX-512
MODELS = Path(__file__).resolve().parent / "models"
FUNCTIONS = (MODELS / "functions.yaml").read_text()  # every Taylor recurrence, t, a real power
OVERFLOW = (MODELS / "overflow_slider.yaml").read_text()

# The overflowing slider of test_taylor with the growth rate a parameter: c = 1000 fails near
# t = 0.71, c = 1 runs to the end.
OVERFLOW_RATE = OVERFLOW.replace("parameters: {m: 1}", "parameters: {m: 1, c: 1000}").replace(
    "exp(1000*t)", "exp(c*t)").replace("name: overflow", "name: overflow_rate")


def compiled(tmp_path_factory: pytest.TempPathFactory, name: str, text: str) -> nemc.Model:
    path = tmp_path_factory.mktemp("batch") / f"{name}.yaml"
    path.write_text(text)
    return nemc.compile(path)


@pytest.fixture(scope="module")
def pendulum() -> nemc.Model:
    return nemc.compile(EXAMPLES / "double_pendulum.yaml")


@pytest.fixture(scope="module")
def overflow(tmp_path_factory: pytest.TempPathFactory) -> nemc.Model:
    return compiled(tmp_path_factory, "overflow_rate", OVERFLOW_RATE)


def both(model: nemc.Model, y0s, **options) -> tuple[EnsembleResult, EnsembleResult]:
    """The ensemble in lanes and one run after the other."""
    options = {"method": "nemc.Taylor", "threads": 1, "progress": False, **options}
    return (model.simulate_many(y0s, lanes=True, **options),
            model.simulate_many(y0s, lanes=False, **options))


def assert_same(lanes: EnsembleResult, one_by_one: EnsembleResult) -> None:
    """Bit for bit: states (NaN where a run stopped), statuses, counts, events."""
    np.testing.assert_array_equal(lanes.y, one_by_one.y)
    for field in ("status", "nfev", "njev", "nlu", "event_t", "event_which", "event_count"):
        np.testing.assert_array_equal(getattr(lanes, field), getattr(one_by_one, field),
                                      err_msg=field)


def random_states(model: nemc.Model, k: int, seed: int, spread: float = 1.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return model.initial_state() + rng.uniform(-spread, spread, (k, model.n_state))


def test_the_lanes_part_is_built_on_first_use_only(pendulum: nemc.Model) -> None:
    assert not pendulum.has_part("lanes")
    lanes = pendulum.compiled_with("lanes")
    assert lanes.has_part("lanes") and lanes.has_part("taylor")
    assert lanes.compiled_with("lanes") is lanes


def test_lanes_compile_warning_free(tmp_path: Path) -> None:
    pendulum = read_source(EXAMPLES / "double_pendulum.yaml")
    functions = Source("functions.yaml", FUNCTIONS.encode())  # every recurrence, t, a real power
    for source, count in ((pendulum, 4), (pendulum, 8), (functions, lane_count())):
        compiled = compile_source(source, None, taylor=True, lanes=count)
        c_file = compiled.package / f"{compiled.model.name}.c"
        assert "taylor_coefficients_lanes" in c_file.read_text()
        done = subprocess.run(
            ["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-c", str(c_file),
             "-o", str(tmp_path / "lanes.o")], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        assert "warning" not in done.stderr and "note" not in done.stderr, done.stderr


def test_fused_multiply_adds_follow_the_cpu(tmp_path: Path) -> None:
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nflags\t\t: fpu sse2 avx avx2 fma\n")
    assert fma_available(cpuinfo, "x86_64")
    cpuinfo.write_text("processor\t: 0\nflags\t\t: fpu sse2 sse4_2 fma4\n")
    assert not fma_available(cpuinfo, "x86_64")  # a flag that only begins with fma
    assert not fma_available(tmp_path / "absent", "x86_64")
    assert fma_available(tmp_path / "absent", "aarch64")  # in the baseline there
    assert not fma_available(cpuinfo, "riscv64")


def test_builds_with_and_without_fma_agree_and_keep_their_lanes_bit_equal(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A build for FMA fuses Taylor's multiply-adds, one without it does not: the same steps,
    states equal to rounding, and in each build the lanes equal the runs one by one."""
    source = read_source(EXAMPLES / "double_pendulum.yaml")
    fused = compile_source(source, None, taylor=True, lanes=lane_count())
    monkeypatch.setattr("nemc.build.builder.fma_available", lambda *_: False)
    monkeypatch.setattr("nemc.pipeline.fma_available", lambda *_: False)
    plain = compile_source(source, None, taylor=True, lanes=lane_count())
    assert plain.package != fused.package  # the build key tells them apart
    fused_c, plain_c = ((build.package / f"{build.model.name}.c").read_text()
                        for build in (fused, plain))
    assert f"#define NEMC_FMA {int(fma_available())}" in fused_c
    assert "#define NEMC_FMA 0" in plain_c
    assert fused.model.metadata["fma"] is fma_available() and plain.model.metadata["fma"] is False
    y0s = random_states(fused.model, 12, seed=5)
    results = [both(build.model, y0s, t_span=(0.0, 3.0), t_eval=np.linspace(0, 3, 7),
                    rtol=1e-10, atol=1e-12) for build in (fused, plain)]
    for lanes, one_by_one in results:
        assert_same(lanes, one_by_one)
    (fused_run, _), (plain_run, _) = results
    np.testing.assert_array_equal(fused_run.nfev, plain_run.nfev)
    np.testing.assert_allclose(fused_run.y, plain_run.y, rtol=0, atol=1e-9)


def test_a_cpu_without_fma_refuses_a_build_for_it(monkeypatch: pytest.MonkeyPatch) -> None:
    """A package built for FMA, loaded where the CPU lacks it (taylor_ready() is 0): nemc.Taylor
    says so and what to do, and "auto" chooses another method."""
    model = nemc.compile(EXAMPLES / "double_pendulum.yaml").compiled_with("taylor")
    monkeypatch.setattr(type(model.compiled), "taylor_ready", lambda self: False)
    with pytest.raises(ModelError, match="FMA.*compile the mechanism again"):
        model.simulate((0.0, 1.0), method="nemc.Taylor")
    assert model.simulate((0.0, 1.0), method="auto").method == "nemc.Vern9"
    monkeypatch.undo()
    assert model.compiled.taylor_ready() and model.simulate((0.0, 1.0), method="auto").method == \
        "nemc.Taylor"


def test_the_lane_count_follows_the_cpu(tmp_path: Path) -> None:
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nflags\t\t: fpu sse2 avx avx2 fma\n")
    assert lane_count(cpuinfo) == 4
    cpuinfo.write_text("processor\t: 0\nflags\t\t: fpu sse2 avx2 avx512f avx512dq\n")
    assert lane_count(cpuinfo) == 8
    cpuinfo.write_text("processor\t: 0\nflags\t\t: fpu sse2 avx2 avx512fp16x\n")
    assert lane_count(cpuinfo) == 4  # a flag that only begins with avx512f
    assert lane_count(tmp_path / "absent") == 4
    assert nemc.compile(EXAMPLES / "double_pendulum.yaml").compiled_with(
        "lanes").metadata["lane_count"] == lane_count()


@pytest.mark.parametrize("count", LANE_COUNTS)
def test_either_lane_count_equals_the_scalar_runs(count: int) -> None:
    """4 and 8 lanes per batch, whichever this CPU has: a count whose vector unit the CPU
    lacks runs one run after the other (integrate_lanes' fallback), with the same results."""
    source = read_source(EXAMPLES / "double_pendulum.yaml")
    model = compile_source(source, None, taylor=True, lanes=count).model
    assert model.metadata["lane_count"] == count
    y0s = random_states(model, 19, seed=count)
    lanes, one_by_one = both(model, y0s, params={"L2": np.linspace(0.6, 1.4, 19)},
                             t_span=(0, 3), t_eval=np.linspace(0, 3, 13), rtol=1e-9, atol=1e-11)
    assert_same(lanes, one_by_one)
    assert lanes.success.all() and len(set(lanes.nfev.tolist())) > 1


@pytest.mark.parametrize("k", [1, 3, 4, 11])
def test_pendulum_runs_equal_the_scalar_runs_bit_for_bit(pendulum: nemc.Model, k: int) -> None:
    y0s = random_states(pendulum, k, seed=k)
    lengths = np.linspace(0.5, 1.5, k)  # per-run parameters: runs of different step counts
    lanes, one_by_one = both(pendulum, y0s, params={"L1": lengths}, t_span=(0, 3),
                             t_eval=np.linspace(0, 3, 31), rtol=1e-10, atol=1e-12)
    assert_same(lanes, one_by_one)
    assert lanes.success.all()
    if k > 1:
        assert len(set(lanes.nfev.tolist())) > 1  # the lanes took different numbers of steps


def test_lanes_equal_the_scalar_runs_at_several_orders(pendulum: nemc.Model) -> None:
    """The book's scene (rtol 1e-6, atol 1e-9) and tighter runs: orders 11, 14 and 16, every
    one through the loop over the orders, in lanes as in the one-run code."""
    y0s = random_states(pendulum, 9, seed=8)
    for rtol, atol in ((1e-6, 1e-9), (1e-9, 1e-12), (1e-8, 1e-10)):
        lanes, one_by_one = both(pendulum, y0s, t_span=(0, 3), t_eval=np.linspace(0, 3, 7),
                                 rtol=rtol, atol=atol)
        assert_same(lanes, one_by_one)
        assert lanes.success.all()


def test_a_lane_fails_alone(overflow: nemc.Model) -> None:
    """Runs 1 and 4 overflow near t = 0.71; the runs beside them in the lanes go on."""
    rates = np.array([1.0, 1000.0, 1.0, 2.0, 1000.0, 1.0])
    y0s = np.tile(overflow.initial_state(), (6, 1))
    lanes, one_by_one = both(overflow, y0s, params={"c": rates}, t_span=(0, 2),
                             t_eval=np.linspace(0, 2, 21), rtol=1e-8, atol=1e-8)
    assert_same(lanes, one_by_one)
    failed = rates == 1000.0
    assert (lanes.success == ~failed).all()
    assert np.isnan(lanes.y[failed][:, :, -1]).all() and np.isfinite(lanes.y[~failed]).all()


def test_run_settings_in_lanes(pendulum: nemc.Model) -> None:
    y0s = random_states(pendulum, 5, seed=5)
    times = np.linspace(0, 4, 9)
    for settings in ({"tstops": [0.3, 1.7]}, {"max_step": 0.05}, {"max_steps": 40}):
        lanes, one_by_one = both(pendulum, y0s, t_span=(0, 4), t_eval=times, rtol=1e-9,
                                 atol=1e-9, **settings)
        assert_same(lanes, one_by_one)
    assert (lanes.status == -7).all()  # the step budget ended every run, in lanes too


def test_ctrl_c_stops_the_lanes_with_their_runs(tmp_path: Path) -> None:
    """Every run in lanes stops between steps with the status interrupted and its states so far."""
    # built here from a model fresh as the child's (the fixture's variants, made by the tests
    # before, would add their parts to the build's key), loaded from the cache by the child
    nemc.compile(EXAMPLES / "double_pendulum.yaml").compiled_with("lanes")
    script = tmp_path / "lanes.py"
    script.write_text(textwrap.dedent(f"""\
        import numpy as np, children, nemc
        model = nemc.compile({str(EXAMPLES / "double_pendulum.yaml")!r})
        children.announce_when_watching()  # the ensemble watches from its start
        runs = model.simulate_many(np.tile(model.initial_state(), (9, 1)), t_span=(0, 1e6),
                                   t_eval=[0, 1e6], method="nemc.Taylor", rtol=1e-12,
                                   atol=1e-12, max_steps=0, threads=1)
        print(sorted(set(runs.status.tolist())), int(np.isnan(runs.y[:, 0, 1]).sum()),
              flush=True)
        """))
    root = str(Path(__file__).resolve().parent.parent)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    with child_process([sys.executable, str(script)], stdout=subprocess.PIPE, text=True,
                       env=env) as child:
        out, _ = interrupted(child)
    assert out.split() == ["[-11]", "9"]


def test_a_lane_whose_last_coefficients_vanish_equals_its_run() -> None:
    """A pendulum released at rest from the horizontal (a series in t^4: at order 20 its last
    two coefficients vanish, and its step comes from the two before, taylor_step_size) in lanes
    beside moving ones: every lane the scalar run's bits."""
    model = nemc.compile(EXAMPLES / "pendulum_to_vertical.yaml", taylor=True)
    y0s = np.zeros((9, 2))
    y0s[1:, 1] = np.linspace(0.1, 1.0, 8)
    lanes, one_by_one = both(model, y0s, t_span=(0, 0.5), t_eval=np.linspace(0, 0.5, 6),
                             rtol=1e-10, atol=1e-12)
    assert_same(lanes, one_by_one)
    assert lanes.success.all() and lanes.nfev[0] > 2


def test_the_ensemble_that_builds_its_lanes_says_so_once() -> None:
    """The first simulate_many that compiles the lanes warns (nemc.BuildNotice, at the caller's
    line) what it built and how long that took, which is within the call's own time; the next
    call, and a new model of the same text (its build loaded from the cache), say nothing."""
    import time
    import warnings

    text = (EXAMPLES / "compound_pendulum.yaml").read_text() + "# the build notice's own key\n"
    model = nemc.compile(text=text, name="notice.yaml")
    assert not model.has_part("lanes")
    y0s = np.array([[0.1 * k, 0.0] for k in range(1, 9)])
    options = dict(t_span=(0.0, 1.0), t_eval=[1.0], method="nemc.Taylor", lanes=True)
    start = time.perf_counter()
    with pytest.warns(nemc.BuildNotice) as record:
        first = model.simulate_many(y0s, **options)
    elapsed = time.perf_counter() - start
    assert [Path(w.filename) for w in record] == [Path(__file__)]
    message = str(record[0].message)
    found = re.fullmatch(r"simulate_many built compound_pendulum's code for nemc\.Taylor in "
                         r"SIMD lanes in ([\d.]+) s, once: later calls and sessions load it "
                         r"from nemc's cache", message)
    assert found and 0 < float(found[1]) <= elapsed + 0.05, (message, elapsed)  # to 0.1 s
    with warnings.catch_warnings():
        warnings.simplefilter("error", nemc.BuildNotice)
        again = model.simulate_many(y0s, **options)
        cached = nemc.compile(text=text, name="notice.yaml").simulate_many(y0s, **options)
    np.testing.assert_array_equal(first.y, again.y)
    np.testing.assert_array_equal(first.y, cached.y)
