"""nemc.sweep (nemc/sweeps.py) and `nemc sweep`: the results equal the same runs done serially
(bit for bit), whatever the chunking, on this machine's threads or on a real Dask LocalCluster
of worker processes, when a worker is killed mid-sweep, and when an interrupted sweep is
resumed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from children import child_process, interrupted

import nemc
from nemc.runtime.model import ModelError
from nemc.tools.sweep_plan import output_times, parse_axis, plan_runs
from nemc.tools.sweeps import SweepInterrupted, SweepStoreError, sweep

pytest.importorskip("distributed")
pytest.importorskip("xarray")
pytest.importorskip("zarr")

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "double_pendulum.yaml"
SETTINGS = dict(t_span=(0.0, 2.0), t_eval=[0.5, 1.0, 2.0], method="nemc.DOP853", rtol=1e-8,
                atol=1e-10)
NEMC = [sys.executable, "-m", "nemc.tools.cli"]


@pytest.fixture(scope="module")
def model():
    return nemc.compile(EXAMPLE)


@pytest.fixture(scope="module")
def runs():
    """120 runs: a grid of initial angles, and a mass that differs per run."""
    q1, q2 = np.meshgrid(np.linspace(-2.5, 2.5, 12), np.linspace(-2.0, 2.0, 10), indexing="ij")
    y0s = np.zeros((q1.size, 4))
    y0s[:, 0], y0s[:, 2] = q1.ravel(), q2.ravel()
    return y0s, {"m2": np.linspace(0.5, 1.5, q1.size), "L1": 1.1}


def serial(model, y0s, params, **settings):
    """The same runs in one simulate_many call on one thread: the reference."""
    return model.simulate_many(y0s, params=params, threads=1, **{**SETTINGS, **settings})


def assert_same_runs(result, reference):
    assert np.array_equal(np.asarray(result.y), reference.y, equal_nan=True)
    assert np.array_equal(result.status, reference.status)
    assert np.array_equal(result.nfev, reference.nfev)
    assert np.array_equal(result.t, reference.t)


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as dask_client:
        yield dask_client


@pytest.mark.parametrize("chunk_runs", [7, 50, 120])
def test_local_sweep_equals_serial_whatever_the_chunking(model, runs, chunk_runs):
    y0s, params = runs
    result = sweep(model, y0s, params=params, chunk_runs=chunk_runs, threads=2,
                   progress=False, **SETTINGS)
    assert_same_runs(result, serial(model, y0s, params))
    assert result.ran == len(y0s) and result.failed == 0
    assert np.array_equal(result.dataset["m2"].values, params["m2"])
    assert np.array_equal(result.dataset["y0"].values, y0s)


def test_defaults_are_simulate_many_defaults(model, runs):
    """No settings given: the scene's t_span, t_eval, tolerances and ensemble method, as
    simulate_many resolves them (the sweep resolves them once, for every worker)."""
    y0s, params = runs
    result = nemc.sweep(model, y0s[:10], params={"m2": params["m2"][:10]}, progress=False)
    reference = model.simulate_many(y0s[:10], params={"m2": params["m2"][:10]}, threads=1)
    assert_same_runs(result, reference)
    assert result.dataset.attrs["method"] == reference.method


def test_dask_sweep_to_zarr_equals_serial(model, runs, client, tmp_path):
    y0s, params = runs
    result = sweep(model, y0s, params=params, client=client, chunk_runs=9,
                   out=tmp_path / "runs.zarr", progress=False, **SETTINGS)
    reference = serial(model, y0s, params)
    assert_same_runs(result, reference)
    data = result.dataset
    assert dict(data.sizes) == {"run": 120, "state": 4, "time": 3, "output": 11}
    assert list(data["state"].values) == list(model.state_names)
    assert set(data["message"].values) == {""}
    assert data.attrs["method"] == "nemc.DOP853" and data.attrs["shared_inputs"] == '{"L1": 1.1}'


def test_initial_state_columns_take_the_scene_for_the_rest(model, client):
    """y0s as columns: the other states are the scene's initial state (here dot(q) = 0)."""
    q1 = np.linspace(-1, 1, 30)
    result = sweep(model, {"q1": q1, "q2": 0.5}, client=client, chunk_runs=8, progress=False,
                   **SETTINGS)
    y0s = model.initial_state()[None, :].repeat(30, axis=0)
    y0s[:, 0], y0s[:, 2] = q1, 0.5
    assert_same_runs(result, serial(model, y0s, None))


def test_a_worker_killed_mid_sweep_costs_only_a_rerun(model, client):
    """SIGKILL one worker process after the first chunk is stored: Dask re-runs its chunks
    (the nanny starts a new worker) and the results still equal the serial runs."""
    q1, q2 = np.meshgrid(np.linspace(-3, 3, 30), np.linspace(-3, 3, 30), indexing="ij")
    y0s = np.zeros((q1.size, 4))
    y0s[:, 0], y0s[:, 2] = q1.ravel(), q2.ravel()
    before = client.run(os.getpid)
    killed = []

    def kill_one(report):
        if not killed:
            killed.append(next(iter(before.values())))
            os.kill(killed[0], signal.SIGKILL)

    settings = {**SETTINGS, "t_span": (0.0, 4.0), "t_eval": [4.0]}
    result = sweep(model, y0s, client=client, chunk_runs=20, on_chunk=kill_one,
                   progress=False, **settings)
    assert killed and result.chunk_errors == [] and result.not_run == 0
    assert_same_runs(result, serial(model, y0s, None, **settings))
    client.wait_for_workers(2, timeout=60)
    assert killed[0] not in client.run(os.getpid).values()


@pytest.mark.parametrize("suffix", [".zarr", ".nc", ".npz"])
def test_an_interrupted_sweep_keeps_its_chunks_and_resumes(model, runs, tmp_path, suffix):
    y0s, params = runs
    out = tmp_path / f"runs{suffix}"
    stored = []

    def interrupt(report):
        stored.append(report)
        if len(stored) == 3:
            raise KeyboardInterrupt

    with pytest.raises(SweepInterrupted) as stop:
        sweep(model, y0s, params=params, out=out, chunk_runs=10, threads=1,
              on_chunk=interrupt, progress=False, **SETTINGS)
    assert stop.value.done == 30 and stop.value.runs == 120
    resumed = sweep(model, y0s, params=params, out=out, chunk_runs=10, resume=True,
                    progress=False, **SETTINGS)
    assert (resumed.resumed, resumed.ran) == (30, 90)
    assert_same_runs(resumed, serial(model, y0s, params))
    assert not Path(str(out) + ".partial.zarr").exists()
    whole = sweep(model, y0s, params=params, chunk_runs=10, progress=False, **SETTINGS)
    assert np.array_equal(resumed.dataset["outputs"].values, whole.dataset["outputs"].values)
    if suffix == ".zarr":  # the resumed store, file by file, is the store of one whole sweep
        sweep(model, y0s, params=params, out=tmp_path / "whole.zarr", chunk_runs=10,
              progress=False, **SETTINGS)
        assert store_files(out) == store_files(tmp_path / "whole.zarr")
    again = sweep(model, y0s, params=params, out=out, progress=False, **SETTINGS)
    assert (again.resumed, again.ran) == (120, 0)


def test_a_zarr_store_opens_without_a_warning_finished_or_not(model, runs, tmp_path):
    """The store's metadata is consolidated when it is created: xarray's open_zarr reads it
    without its warning (turned into an error here), before and after a resume."""
    import warnings

    import xarray as xr

    y0s, params = runs
    out = tmp_path / "runs.zarr"

    def stop_after_one(report):
        raise KeyboardInterrupt

    with pytest.raises(SweepInterrupted):
        sweep(model, y0s, params=params, out=out, chunk_runs=40, threads=1,
              on_chunk=stop_after_one, progress=False, **SETTINGS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        partial = xr.open_zarr(out)
        assert np.sum(partial["status"].values == -9) == 80
        sweep(model, y0s, params=params, out=out, chunk_runs=40, progress=False, **SETTINGS)
        whole = xr.open_zarr(out)
        assert np.array_equal(whole["y"].values, serial(model, y0s, params).y)
        assert np.all(whole["status"].values == 0)


def test_an_analyst_opens_selects_combines_and_unstacks_without_warnings(model, tmp_path):
    """A grid q1 x m2 (no random draws): the store opens, two selections of y merge (the
    initial states are a variable, not a coordinate that would conflict), two halves concat
    back to the whole, and nemc.open_sweep's grid equals xarray's own set_index + unstack."""
    import warnings

    import xarray as xr

    grids = [parse_axis("q1=-1:1:3", True), parse_axis("m2=0.5:1.5:4", True)]
    y0, params, attrs = plan_runs(model, grids, [], None, 0, {})
    out = tmp_path / "grid.zarr"
    sweep(model, y0, params=params, out=out, chunk_runs=5, attrs=attrs, progress=False,
          **SETTINGS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        flat = xr.open_zarr(out)
        assert "y0" in flat.data_vars and "y0" not in flat.coords
        end = flat["y"].isel(time=-1)
        both = xr.merge([end.sel(state="q1", drop=True).rename("q1_end"),
                         end.sel(state="q2", drop=True).rename("q2_end")])
        assert np.array_equal(both["q2_end"].values, end.values[:, 2])
        halves = xr.concat([flat.isel(run=slice(0, 5)), flat.isel(run=slice(5, None))], "run")
        assert halves.identical(flat)
        by_xarray = flat.set_index(run=["q1", "m2"]).unstack("run")
        grid = nemc.open_sweep(out)
        assert dict(grid["y"].sizes) == {"q1": 3, "m2": 4, "state": 4, "time": 3}
        assert np.array_equal(grid["q1"].values, [-1.0, 0.0, 1.0])
        assert np.array_equal(grid["m2"].values, np.linspace(0.5, 1.5, 4))
        for name in ("y", "y0", "status", "nfev"):
            assert np.array_equal(grid[name].values, by_xarray[name].transpose(
                *grid[name].dims).values), name
        point = grid.sel(q1=1.0, m2=1.5)
        assert np.array_equal(point["y"].values, flat["y"].values[int(point["run"])])


def test_open_sweep_puts_random_draws_along_draw_and_refuses_a_non_grid(model, tmp_path):
    grids = [parse_axis("q1=-1:1:2", True), parse_axis("m2=0.5:1.5:3", True)]
    y0, params, attrs = plan_runs(model, grids, [parse_axis("q2=0:0.5", False)], 2, 3, {})
    result = sweep(model, y0, params=params, attrs=attrs, progress=False, **SETTINGS)
    grid = nemc.open_sweep(result)
    assert dict(grid["y"].sizes) == {"q1": 2, "m2": 3, "draw": 2, "state": 4, "time": 3}
    assert grid["q2"].dims == ("q1", "m2", "draw")
    flat = result.dataset
    for run in range(12):  # run = (i * 3 + j) * 2 + d: the first axis slowest
        i, j, d = np.unravel_index(run, (2, 3, 2))
        assert np.array_equal(grid["y"].values[i, j, d], flat["y"].values[run])
        assert grid["q2"].values[i, j, d] == flat["q2"].values[run]
    by_name = nemc.open_sweep(result.dataset, grid=["q1"])  # the rest: 6 runs a point
    assert dict(by_name["y"].sizes) == {"q1": 2, "draw": 6, "state": 4, "time": 3}
    random_only = sweep(model, {"q1": np.linspace(-1, 1, 4) ** 3}, progress=False,
                        **SETTINGS)
    assert dict(nemc.open_sweep(random_only)["y"].sizes) == {"run": 4, "state": 4, "time": 3}
    for wrong in (["m2", "q1"], ["m2"]):  # m2 repeats within q1's points
        with pytest.raises(SweepStoreError, match="not the grid"):
            nemc.open_sweep(result, grid=wrong)
    with pytest.raises(SweepStoreError, match="not an input that varies"):
        nemc.open_sweep(result, grid=["g"])


@pytest.mark.parametrize("vary_mass", [False, True])  # one C call a chunk / a run
def test_the_scenes_outputs_are_stored_beside_the_states(model, tmp_path, vary_mass):
    """outputs (run, output, time) equal Model.outputs at each run's stored states (a call
    per state); the total energy is conserved to the tolerance (an independent check); NaN
    for a refused run; outputs=False stores the states only."""
    q1 = np.linspace(-2.0, 2.0, 9)
    masses = np.linspace(-0.6, 1.5, 9) if vary_mass else 1.2  # the first 3 refused
    settings = {**SETTINGS, "t_eval": [0.0, 1.0, 2.0], "rtol": 1e-11, "atol": 1e-12}
    result = sweep(model, {"q1": q1}, params={"m2": masses}, out=tmp_path / "o.zarr",
                   chunk_runs=4, progress=False, **settings)
    data = result.dataset
    assert list(data["output"].values) == list(model.output_names)
    assert data["outputs"].dims == ("run", "output", "time")
    for run in range(9):
        mass = float(np.atleast_1d(masses)[run % np.size(masses)])
        if mass < 0:
            assert result.status[run] == -3
            assert np.all(np.isnan(data["outputs"].values[run]))
            continue
        expected = model.outputs(data["time"].values, data["y"].values[run], {"m2": mass})
        stored = data["outputs"].values[run]
        for k, name in enumerate(model.output_names):
            assert np.allclose(stored[k], expected[name], rtol=1e-14, atol=1e-12), name
        energy = data["outputs"].sel(output="energy.total").values[run]
        assert np.max(np.abs(energy - energy[0])) < 1e-8 * max(1.0, abs(energy[0]))
    states_only = sweep(model, {"q1": q1}, params={"m2": masses}, outputs=False,
                        progress=False, **settings)
    assert "outputs" not in states_only.dataset and "output" not in states_only.dataset.coords
    assert np.array_equal(np.asarray(states_only.y), np.asarray(result.y), equal_nan=True)


def test_outputs_take_each_runs_inputs_and_start():
    """A model's inputs (per run, a table) and a gear pair (a coupling, its reaction an
    output): the stored outputs are those simulate gives each run. (The gear pair's outputs
    do not depend on where its relation was taken, so the start's offsets go untested.)"""
    examples = EXAMPLE.parent
    cart = nemc.compile(examples / "cart_pole.yaml")
    gears = nemc.compile(examples / "gear_train.yaml")
    times = [0.0, 0.25, 0.75, 1.0]
    settings = dict(t_span=(0.0, 1.0), t_eval=times, method="nemc.DOP853", rtol=1e-10,
                    atol=1e-12)
    table = (np.array([0.0, 0.5, 1.0]), np.array([0.0, 2.0, -1.0]))
    y0s = np.array([gears.initial_state()] * 3)
    y0s[:, 0] += [0.0, 0.2, 0.4]
    cases = [(cart, None, {"F": np.linspace(-1.0, 1.0, 3)}),
             (cart, {"x": np.linspace(0.0, 0.1, 3)}, {"F": table}), (gears, y0s, None)]
    for model, y0, inputs in cases:
        data = sweep(model, y0, inputs=inputs, progress=False, **settings).dataset
        for run in range(3):
            given = None if inputs is None else {
                "F": float(inputs["F"][run]) if isinstance(inputs["F"], np.ndarray)
                else inputs["F"]}
            alone = model.simulate(y0=data["y0"].values[run], inputs=given, **settings)
            expected = np.array([alone.outputs[name] for name in model.output_names])
            assert np.allclose(data["outputs"].values[run], expected, rtol=1e-13,
                               atol=1e-13)


def test_one_progress_display_the_sweeps(model, runs, monkeypatch, capsys):
    """The sweep's bar is the only display: no chunk's simulate_many shows its own counter
    (which wrote over the bar on the same line of a terminal)."""
    asked = []
    many = model.simulate_many

    def spy(*args, **options):
        asked.append(options.get("progress"))
        return many(*args, **options)

    monkeypatch.setattr(model, "simulate_many", spy)
    sweep(model, runs[0][:30], chunk_runs=10, threads=1, progress=True, **SETTINGS)
    assert len(asked) == 4 and set(asked) == {False}  # the check run, then 3 chunks
    assert "sweep: 100%" in capsys.readouterr().err  # the sweep's bar, at its end


def store_files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def test_an_output_of_another_sweep_or_not_nemcs_is_refused(model, runs, tmp_path):
    y0s, params = runs
    out = tmp_path / "runs.zarr"
    sweep(model, y0s[:10], out=out, progress=False, **SETTINGS)
    with pytest.raises(SweepStoreError, match="different sweep"):
        sweep(model, y0s[:11], out=out, progress=False, **SETTINGS)
    foreign = tmp_path / "mine.nc"
    foreign.write_bytes(b"not a sweep")
    with pytest.raises(SweepStoreError, match="not a nemc sweep"):
        sweep(model, y0s[:10], out=foreign, progress=False, **SETTINGS)
    assert foreign.read_bytes() == b"not a sweep"
    with pytest.raises(SweepStoreError, match="nothing|no sweep"):
        sweep(model, y0s[:10], out=tmp_path / "new.zarr", resume=True, progress=False,
              **SETTINGS)


def test_refused_parameters_fail_their_runs_only(model, runs):
    y0s, _ = runs
    masses = np.linspace(-1.0, 1.5, 20)  # the first 8 are negative
    result = sweep(model, y0s[:20], params={"m2": masses}, chunk_runs=6, progress=False,
                   **SETTINGS)
    refused = masses < 0
    assert np.all(result.status[refused] == -3) and np.all(result.status[~refused] == 0)
    assert result.failures(1)[0][2].startswith("inputs refused: bodies.link2.mass must be >= 0")
    reference = serial(model, y0s[:20][~refused], {"m2": masses[~refused]})
    assert np.array_equal(np.asarray(result.y)[~refused], reference.y)
    assert np.all(np.isnan(np.asarray(result.y)[refused]))


def test_settings_and_names_are_checked_before_anything_runs(model, runs, tmp_path):
    y0s, _ = runs
    with pytest.raises(ModelError, match="t_eval"):
        sweep(model, y0s, t_span=(0, 1), t_eval=[2.0], out=tmp_path / "x.zarr", progress=False)
    with pytest.raises(ModelError, match="unknown state"):
        sweep(model, {"q3": [1.0, 2.0]}, progress=False)
    with pytest.raises(ModelError, match="disagree"):
        sweep(model, y0s, params={"m2": [1.0, 2.0]}, progress=False)
    assert not (tmp_path / "x.zarr").exists()


def test_the_plan_of_grids_and_random_draws(model):
    grids = [parse_axis("q1=-1:1:3", True), parse_axis("m2=1:2:2", True)]
    y0, params, attrs = plan_runs(model, grids, [parse_axis("q2=0:0.5", False)], 4, 7, {"g": 9})
    assert np.array_equal(y0["q1"], np.repeat([-1.0, -1.0, 0.0, 0.0, 1.0, 1.0], 4))
    assert np.array_equal(params["m2"], np.tile(np.repeat([1.0, 2.0], 4), 3))
    assert params["g"] == 9 and len(y0["q2"]) == 24 and np.all((0 <= y0["q2"]) & (y0["q2"] < 0.5))
    again = plan_runs(model, grids, [parse_axis("q2=0:0.5", False)], 4, 7, {"g": 9})
    assert np.array_equal(again[0]["q2"], y0["q2"])  # seeded
    with pytest.raises(ModelError, match="neither a parameter"):
        plan_runs(model, [parse_axis("q9=0:1:2", True)], [], None, 0, {})
    with pytest.raises(ValueError, match="NAME=START:STOP:N"):
        parse_axis("q1=0:1", True)
    assert np.array_equal(output_times((0.0, 10.0), 2), [0.0, 10.0])
    assert np.array_equal(output_times((1.0, 3.0), 5), [1.0, 1.5, 2.0, 2.5, 3.0])
    assert np.array_equal(output_times((0.0, 10.0), 1), [10.0])  # the end only


def test_core_nemc_imports_none_of_the_sweep_extra():
    code = ("import sys, nemc, nemc.tools.sweeps, nemc.tools.cli; "
            "heavy = {'xarray', 'dask', 'distributed',"
            " 'zarr', 'tqdm', 'h5netcdf'} & set(sys.modules); assert not heavy, heavy")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_workers_report_the_key_they_built_under_and_a_mismatch_warns(model, runs):
    """A worker builds the shipped recipe itself; the key it built under comes back with
    each chunk, and one that differs from this machine's warns (other nemc or compiler)."""
    import dataclasses
    import warnings

    from nemc.tools.sweeps import Inputs, Settings, Tracker, model_ref, run_chunk

    ref = model_ref(model)
    settings = Settings.resolve(model, SETTINGS["t_span"], SETTINGS["t_eval"], "nemc.DOP853",
                                1e-8, 1e-10)
    chunk = Inputs.of(model, runs[0][:3], None).chunk(0, 3)
    out = run_chunk(dataclasses.replace(ref, key="another-machine"), settings, chunk)
    assert out.build_key == ref.key
    assert np.array_equal(out.y, serial(model, runs[0][:3], None).y)
    tracker = Tracker(None, 3, 0, False, None, dataclasses.replace(ref, key="another-machine"))
    with pytest.warns(UserWarning, match="another key"):
        tracker.check_build(out.build_key)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tracker.check_build(out.build_key)  # once per key


def test_a_missing_extra_says_how_to_install_it():
    from nemc.tools.sweep_store import require

    with pytest.raises(ImportError, match=r"pip install 'nemc\[sweep\]'"):
        require("nemc_no_such_module")


def cli(*args, **kwargs):
    return subprocess.run([*NEMC, "sweep", str(EXAMPLE), *args], capture_output=True,
                          text=True, **kwargs)


def test_cli_end_to_end_on_threads_and_on_a_local_cluster(model, tmp_path):
    grid = ["--grid", "q1=-2:2:5", "--grid", "q2=-1:1:4", "--random", "m2=0.5:1.5",
            "--runs", "3", "--t-end", "2", "--times", "5", "--rtol", "1e-8", "--atol", "1e-10"]
    done = cli(*grid, "--out", str(tmp_path / "a.nc"))
    assert done.returncode == 0, done.stderr
    assert "60 runs (0 done before)" in done.stdout and "0 failed" in done.stdout
    import xarray as xr

    data = xr.open_dataset(tmp_path / "a.nc", engine="h5netcdf").load()
    assert dict(data.sizes) == {"run": 60, "state": 4, "time": 5, "output": 11}
    q1 = np.repeat(np.linspace(-2, 2, 5), 4 * 3)
    assert np.array_equal(data["q1"].values, q1)
    assert np.array_equal(data["time"].values, [0.0, 0.5, 1.0, 1.5, 2.0])  # t = 0 included
    assert np.array_equal(data["y"].isel(time=0).values, data["y0"].values)
    assert data.attrs["method"] == model.ensemble_method((0.0, 2.0), rtol=1e-8) == "nemc.Vern9"
    reference = model.simulate_many(
        data["y0"].values, params={"m2": data["m2"].values}, t_span=(0.0, 2.0),
        t_eval=data["time"].values, method="nemc.Vern9", rtol=1e-8, atol=1e-10, threads=1)
    assert np.array_equal(data["y"].values, reference.y)
    assert np.all(data["status"].values == 0)
    assert np.all(np.isfinite(data["outputs"].values))
    on_cluster = cli(*grid, "--out", str(tmp_path / "b.zarr"), "--dask", "local:2",
                     "--chunk", "7", "--no-outputs")
    assert on_cluster.returncode == 0, on_cluster.stderr
    other = xr.open_zarr(tmp_path / "b.zarr")
    assert "outputs" not in other
    assert np.array_equal(other["y"].values, data["y"].values)


def test_cli_refuses_bad_input_with_status_2(tmp_path):
    unknown = cli("--grid", "q9=0:1:3", "--out", str(tmp_path / "x.zarr"))
    assert unknown.returncode == 2 and "'q9' is neither a parameter" in unknown.stderr
    malformed = cli("--grid", "q1=0:1", "--out", str(tmp_path / "x.zarr"))
    assert malformed.returncode == 2 and "NAME=START:STOP:N" in malformed.stderr
    foreign = tmp_path / "mine.npz"
    foreign.write_bytes(b"keep me")
    refused = cli("--grid", "q1=0:1:3", "--out", str(foreign))
    assert refused.returncode == 2 and "not a nemc sweep" in refused.stderr
    assert foreign.read_bytes() == b"keep me" and not (tmp_path / "x.zarr").exists()


# `nemc sweep` whose sweep says when 200 runs are stored, then waits for the Ctrl-C there.
SWEEP_CHILD = """\
import signal
import sys
import children
from nemc.tools import sweeps
from nemc.tools.cli import main

sweep = sweeps.sweep


def said_at_200(report):
    if report.done >= 200:
        children.announce("200 runs stored")
        signal.pause()  # until SIGINT: KeyboardInterrupt here, with the sweep's pool at work


sweeps.sweep = lambda *args, **options: sweep(*args, on_chunk=said_at_200, **options)
sys.exit(main(sys.argv[1:]))
"""


def test_cli_ctrl_c_keeps_finished_chunks_exits_130_and_the_same_command_resumes(tmp_path):
    """SIGINT once 200 runs are stored (a handshake): exactly those are kept."""
    out = tmp_path / "long.zarr"
    args = ["--grid", "q1=-3:3:100", "--grid", "q2=-3:3:100", "--t-end", "4", "--times", "1",
            "--chunk", "100", "--threads", "1", "--out", str(out)]
    with child_process([sys.executable, "-c", SWEEP_CHILD, "sweep", str(EXAMPLE), *args],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as process:
        stdout, stderr = interrupted(process, "200 runs stored")
        kept = finished_runs(out)
        assert process.returncode == 130, stderr
        assert "interrupted" in stderr and "run the same command again" in stderr
        assert kept == 200
        again = cli(*args)
        assert again.returncode == 0, again.stderr
        assert f"10000 runs ({kept} done before)" in again.stdout


def test_cli_ctrl_c_on_a_local_cluster_says_one_line(tmp_path):
    """Ctrl-C in a terminal goes to the whole process group, the local workers too: they
    ignore it (no tracebacks of theirs), and the sweep stops with its one line."""
    from children import HANG

    args = ["--grid", "q1=-3:3:100", "--grid", "q2=-3:3:100", "--t-end", "4", "--times", "1",
            "--chunk", "100", "--dask", "local:1", "--no-outputs", "--out",
            str(tmp_path / "long.zarr")]
    with child_process([sys.executable, "-W", "ignore", "-c", SWEEP_CHILD, "sweep",
                        str(EXAMPLE), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True, start_new_session=True) as process:
        process.says("200 runs stored")
        os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole group
        _, stderr = process.communicate(timeout=HANG)
    assert process.returncode == 130, stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted: "), stderr


def finished_runs(store: Path) -> int:
    """Runs whose status is written (not NOT_RUN), read the way resume reads them."""
    import zarr

    try:
        return int(np.sum(zarr.open_group(str(store), mode="r")["status"][:] != -9))
    except Exception:  # noqa: BLE001 - not created yet
        return 0
