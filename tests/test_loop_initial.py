"""A closed loop's initial values set by every entry point (issue 51): `simulate(y0={...})`,
`nemc simulate --initial`, `simulate_many(y0s={...})`, `nemc.sweep` and `nemc sweep --grid`
each assemble each run from the values given, kept exactly, the others solved. Checked on
examples/fourbar.yaml against the four-bar's loop equations written here in closed form (not
the model's C), and each ensemble or sweep run against one `simulate` of the same values. A
value the constraints cannot meet is refused by its run (a sweep's run fails, not the sweep)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.runtime.model import ModelError
from nemc.tools.cli import main
from nemc.tools.sweeps import INPUTS_REFUSED

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "fourbar.yaml"
RUN = dict(t_span=(0.0, 0.5), t_eval=[0.0, 0.25, 0.5], method="nemc.DOP853", rtol=1e-9,
           atol=1e-11)
CRANK = np.linspace(0.0, 2 * np.pi, 9)[:-1]  # the Grashof crank turns fully: every angle closes
SCENE_RATE = 8.0  # the scene's dot(q1), kept by --initial and sweeps (the scene's given values)
# L0 = 0.7: B (at L1 from A) must lie within L2 + L3 = 0.65 of D, so crank angles near 0 close
# and those near pi/2 (the scene's) do not
LONG_GROUND = 0.7


@pytest.fixture(scope="module")
def model():
    return nemc.compile(EXAMPLE)


def loop_residual(model, y: np.ndarray, params: dict | None = None) -> float:
    """The largest |gap| of the four-bar's loop at C and of its rate, from the geometry (A at
    the origin, D at (L0, 0); q2 the coupler's absolute angle, q3 the rocker's)."""
    p = {**model.parameters, **(params or {})}
    q1, dq1, q2, dq2, q3, dq3 = (y[model.state_names.index(n)] for n in
                                 ("q1", "dot(q1)", "q2", "dot(q2)", "q3", "dot(q3)"))
    L0, L1, L2, L3 = p["L0"], p["L1"], p["L2"], p["L3"]
    gaps = [L1 * np.cos(q1) + L2 * np.cos(q2) - L0 - L3 * np.cos(q3),
            L1 * np.sin(q1) + L2 * np.sin(q2) - L3 * np.sin(q3),
            -L1 * np.sin(q1) * dq1 - L2 * np.sin(q2) * dq2 + L3 * np.sin(q3) * dq3,
            L1 * np.cos(q1) * dq1 + L2 * np.cos(q2) * dq2 - L3 * np.cos(q3) * dq3]
    return float(np.max(np.abs(gaps)))


def assert_same_run(states: np.ndarray, reference: np.ndarray) -> None:
    """Two runs of the same start, method and settings: equal to rounding."""
    np.testing.assert_allclose(states, reference, rtol=0, atol=1e-12)


def test_a_swept_crank_angle_is_kept_and_the_rest_assembled(model):
    runs = nemc.sweep(model, {"q1": CRANK}, **RUN)
    assert np.all(runs.status == 0), runs.failures(5)
    y0 = np.asarray(runs.dataset["y0"].values)
    assert np.array_equal(y0[:, model.state_names.index("q1")], CRANK)  # exactly
    assert np.all(y0[:, model.state_names.index("dot(q1)")] == SCENE_RATE)
    assert max(loop_residual(model, state) for state in y0) < 1e-12
    for i, angle in enumerate(CRANK):  # as one run given the scene's values and the sweep's
        one = model.simulate(y0={"q1": angle, "dot(q1)": SCENE_RATE}, **RUN)
        assert_same_run(np.asarray(runs.y[i]), one.y)
        assert_same_run(y0[i], one.y[:, 0])


def test_simulate_many_assembles_each_run_from_a_dict_as_simulate(model):
    ensemble = model.simulate_many({"q1": CRANK}, threads=1, **RUN)
    assert np.all(ensemble.success)
    starts = ensemble.y[:, :, 0]
    assert np.array_equal(starts[:, model.state_names.index("q1")], CRANK)
    assert max(loop_residual(model, state) for state in starts) < 1e-12
    for i, angle in enumerate(CRANK):
        assert_same_run(ensemble.y[i], model.simulate(y0={"q1": angle}, **RUN).y)


def test_simulate_many_refuses_a_run_the_loop_cannot_meet_by_its_number(model):
    rate = model.simulate_many({"q1": [0.3, 1.0], "dot(q1)": 2.0}, threads=1, **RUN)
    assert np.all(rate.y[:, model.state_names.index("dot(q1)"), 0] == 2.0)
    closing = model.simulate(y0={"q1": 0.0}, **RUN).y[model.state_names.index("q2"), 0]
    with pytest.raises(ModelError, match=r"run 1 of 2: the mechanism cannot be assembled with "
                       r"q1=0, q2=3 given: constraint 'C'"):
        model.simulate_many({"q1": 0.0, "q2": [closing, 3.0]}, threads=1, **RUN)
    off = model.initial_state()
    off[model.state_names.index("q1")] += 0.1  # a full state off the loop: nothing is solved
    with pytest.raises(ModelError, match="run 1 of 2: the mechanism cannot be assembled"):
        model.simulate_many([model.initial_state(), off], threads=1, **RUN)
    with pytest.raises(ModelError, match="run 1 of 2: the mechanism cannot be assembled with "
                       "q1=1.57079633, dot.q1.=8 given"):  # the scene's own values, at L0 0.7
        model.simulate_many(params={"L0": [0.4, LONG_GROUND]}, threads=1, **RUN)
    with pytest.raises(ModelError, match="y0s: unknown state name 'q9'"):
        model.simulate_many({"q9": [0.0, 1.0]}, **RUN)


def test_a_sweep_fails_only_the_runs_the_loop_cannot_meet(model):
    angles = np.array([0.0, 2.0, 0.0, 1.0])
    grounds = np.array([LONG_GROUND, LONG_GROUND, 0.4, 0.4])
    runs = nemc.sweep(model, {"q1": angles}, params={"L0": grounds}, **RUN)
    assert runs.status.tolist() == [0, INPUTS_REFUSED, 0, 0]
    (run, status, message), = runs.failures(5)
    assert (run, status) == (1, INPUTS_REFUSED)
    assert message.startswith("initial values refused: the mechanism cannot be assembled with "
                              "q1=2, dot(q1)=8 given: constraint 'C'")
    y0 = np.asarray(runs.dataset["y0"].values)
    assert np.all(np.isnan(y0[1])) and np.all(np.isnan(np.asarray(runs.y[1])))
    for i in (0, 2, 3):
        params = {"L0": grounds[i]}
        assert loop_residual(model, y0[i], params) < 1e-12
        one = model.simulate(y0={"q1": angles[i], "dot(q1)": SCENE_RATE}, params=params, **RUN)
        assert_same_run(np.asarray(runs.y[i]), one.y)


def test_a_loop_the_scene_cannot_close_starts_from_the_values_given(model):
    """At L0 = 0.7 the scene's crank angle cannot close the loop, q1 = 0 can: the scene's
    values are then only the guess, and the values given decide."""
    params = {"L0": LONG_GROUND}
    with pytest.raises(ModelError, match="cannot be assembled"):
        model.initial_state(params)
    one = model.simulate(y0={"q1": 0.0}, params=params, **RUN)
    assert one.y[0, 0] == 0.0 and loop_residual(model, one.y[:, 0], params) < 1e-12


def test_cli_initial_keeps_the_value_and_refuses_one_the_loop_cannot_meet(
        model, tmp_path: Path, capsys):
    table = tmp_path / "run.csv"
    assert main(["simulate", str(EXAMPLE), "--set", f"L0={LONG_GROUND}", "--initial", "q1=0",
                 "--t-end", "0.5", "--method", "nemc.DOP853", "--csv", str(table)]) == 0
    header = table.read_text().splitlines()[0].split(",")
    first = np.loadtxt(table, delimiter=",", skiprows=1, max_rows=1)
    start = np.array([first[header.index(name) if name in header else
                           header.index(f"{name} [rad]")] for name in model.state_names])
    assert start[0] == 0.0 and start[1] == SCENE_RATE
    assert loop_residual(model, start, {"L0": LONG_GROUND}) < 1e-12
    capsys.readouterr()
    assert main(["simulate", str(EXAMPLE), "--set", f"L0={LONG_GROUND}", "--initial", "q1=2",
                 "--t-end", "0.5"]) == 2
    assert "cannot be assembled with q1=2, dot(q1)=8 given" in capsys.readouterr().err


def test_cli_sweep_over_the_crank_angle(model, tmp_path: Path, capsys):
    pytest.importorskip("xarray")
    store = tmp_path / "crank.nc"
    assert main(["sweep", str(EXAMPLE), "--grid", "q1=0:6:4", "--t-end", "0.5", "--times", "3",
                 "--method", "nemc.DOP853", "--rtol", "1e-9", "--atol", "1e-11",
                 "--out", str(store)]) == 0, capsys.readouterr().err
    import xarray as xr

    data = xr.open_dataset(store, engine="h5netcdf").load()
    y0 = data["y0"].values
    assert np.array_equal(y0[:, 0], np.linspace(0, 6, 4))
    assert max(loop_residual(model, state) for state in y0) < 1e-12
    one = model.simulate(y0={"q1": 4.0, "dot(q1)": SCENE_RATE}, **RUN)
    assert_same_run(data["y"].values[2], one.y)


def test_a_sweep_of_full_states_fails_only_the_one_off_the_loop(model):
    """A full state is given whole: nothing is solved, so one off the constraints fails."""
    on = model.simulate(y0={"q1": 1.0}, **RUN).y[:, 0]
    off = on.copy()
    off[model.state_names.index("q3")] += 1e-3
    runs = nemc.sweep(model, np.array([on, off, on]), **RUN)
    assert runs.status.tolist() == [0, INPUTS_REFUSED, 0]
    assert "initial values refused: the mechanism cannot be assembled" in runs.failures(5)[0][2]
    assert np.array_equal(np.asarray(runs.dataset["y0"].values)[0], on)  # kept, not re-solved
    assert_same_run(np.asarray(runs.y[0]), model.simulate(y0=on, **RUN).y)


def test_cli_linearize_at_a_crank_angle_keeps_it(model, tmp_path: Path, capsys):
    """`--at` set the value over the scene's state, which linearize then projected onto the
    constraints, moving it (q1=1 became 1.037): now the value is kept, the others solved."""
    import json

    out = tmp_path / "lin.json"
    assert main(["linearize", str(EXAMPLE), "--at", "q1=1", "--out", str(out)]) == 0
    assert "linearization at t=0: q1=1, dot(q1)=8," in capsys.readouterr().out
    point = np.array(json.loads(out.read_text())["y"])
    assert point[0] == 1.0 and point[1] == SCENE_RATE and loop_residual(model, point) < 1e-12
    one = model.simulate(y0={"q1": 1.0, "dot(q1)": SCENE_RATE}, **RUN)
    assert_same_run(point, one.y[:, 0])
    assert main(["linearize", str(EXAMPLE), "--at", "q2=3"]) == 2
    assert "cannot be assembled with q1=1.57079633, dot(q1)=8, q2=3 given" in \
        capsys.readouterr().err


def test_simulate_many_of_a_tree_takes_a_dict_as_simulate():
    """A tree's dict: the values given, the others 0, as simulate's y0={...}."""
    tree = nemc.compile(EXAMPLE.parent / "double_pendulum.yaml")
    angles = np.array([0.1, -0.4])
    ensemble = tree.simulate_many({"q1": angles, "dot(q2)": 0.5}, threads=1, **RUN)
    for i, angle in enumerate(angles):
        one = tree.simulate(y0={"q1": angle, "dot(q2)": 0.5}, **RUN)
        assert one.y[2, 0] == 0.0  # q2: not given, 0
        assert_same_run(ensemble.y[i], one.y)
