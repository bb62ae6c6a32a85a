"""Fitting a mechanism to measured data (issue 47; interface.md: nemc.fit, nemc fit): seeded
synthetic data of the book's 5.1 pendulum with a damper at its pin; the estimates recover the
true values with honest error bars (their 2-sigma intervals cover the truth about 95% of the
time over repeated noise draws, the reported errors match the estimates' scatter), several
experiments share parameters, initial values and outputs are fitted, and each bad input or
failing fit is one clear message, from Python and from the command line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from test_sensitivities import DAMPED_PENDULUM

import nemc
from nemc.tools.cli import main

TRUE = {"c": 0.4, "L": 3.0}
SIGMA = 0.01  # rad: the angle sensor's noise
TIMES = np.linspace(0, 8, 81)


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory: pytest.TempPathFactory) -> nemc.runtime.Model:
    path = tmp_path_factory.mktemp("fit") / "damped_pendulum.yaml"
    path.write_text(DAMPED_PENDULUM)
    return nemc.compile(path)


@pytest.fixture(scope="module")
def clean(pendulum) -> np.ndarray:
    return pendulum.simulate((0, 8), t_eval=TIMES, rtol=1e-12, atol=1e-13).y


def noisy(clean: np.ndarray, seed: int, rows: tuple[int, ...] = (0,)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return clean[list(rows)].T + rng.normal(0, SIGMA, (TIMES.size, len(rows)))


def test_the_damping_and_length_come_back_with_honest_error_bars(pendulum, clean) -> None:
    """Over 40 seeded noise draws the 2-sigma intervals hold the true values about 95% of the
    time (binomial: at least 34 of 40 is three of its standard deviations below), and the
    reported standard errors agree with the scatter of the estimates to 30%."""
    estimates, errors = [], []
    for seed in range(40):
        result = nemc.fit(pendulum, TIMES, noisy(clean, seed), fit=["c", "L"],
                          observed=["theta"], start={"c": 0.25, "L": 2.6})
        assert result.success and result.rank == 2
        estimates.append([result.values[name] for name in TRUE])
        errors.append([result.stderr[name] for name in TRUE])
    estimates, errors = np.array(estimates), np.array(errors)
    covered = np.abs(estimates - list(TRUE.values())) <= 2 * errors
    assert np.all(covered.sum(axis=0) >= 34), covered.sum(axis=0)
    scatter = estimates.std(axis=0, ddof=1)
    assert np.all(np.abs(errors.mean(axis=0) / scatter - 1) < 0.3), (errors.mean(0), scatter)


def test_the_result_says_everything_it_holds(pendulum, clean) -> None:
    result = nemc.fit(pendulum, TIMES, {"theta": noisy(clean, 1)[:, 0]}, fit=["c", "L"],
                      observed=["theta"])
    assert result.names == ("c", "L")
    assert result.covariance.shape == (2, 2)
    assert np.allclose(np.diag(result.correlation), 1.0)
    assert abs(result.correlation[0, 1]) < 1
    assert result.residual.shape == (TIMES.size,)
    assert result.dof == TIMES.size - 2
    assert abs(result.rms / SIGMA - 1) < 0.2
    assert result.runs[0].t.size == TIMES.size
    assert "stderr" in repr(result)


def test_known_noise_gives_the_same_errors(pendulum, clean) -> None:
    data = noisy(clean, 2)
    estimated = nemc.fit(pendulum, TIMES, data, fit=["c", "L"], observed=["theta"])
    known = nemc.fit(pendulum, TIMES, data, fit=["c", "L"], observed=["theta"],
                     weights=1 / SIGMA, absolute_sigma=True)
    for name in TRUE:
        assert known.values[name] == pytest.approx(estimated.values[name], rel=1e-6)
        assert known.stderr[name] == pytest.approx(estimated.stderr[name], rel=0.2)


def test_several_experiments_share_the_parameters(pendulum) -> None:
    rng = np.random.default_rng(5)
    experiments = []
    for theta0 in (0.4, 1.2):
        clean = pendulum.simulate((0, 8), [theta0, 0.0], t_eval=TIMES, rtol=1e-12,
                                  atol=1e-13).y[0]
        experiments.append(nemc.Experiment(TIMES, clean + rng.normal(0, SIGMA, TIMES.size),
                                           y0=[theta0, 0.0]))
    result = nemc.fit(pendulum, fit=["c", "L"], observed=["theta"], experiments=experiments)
    assert len(result.runs) == 2 and result.residual.size == 2 * TIMES.size
    for name, value in TRUE.items():
        assert abs(result.values[name] - value) < 3 * result.stderr[name]


def test_an_initial_value_and_an_output_are_fitted(pendulum, clean) -> None:
    result = nemc.fit(pendulum, TIMES, noisy(clean, 3), fit=["theta", "c"], observed=["theta"],
                      start={"theta": 0.6})
    assert abs(result.values["theta"] - 0.7) < 3 * result.stderr["theta"]
    energy = pendulum.simulate((0, 8), t_eval=TIMES, rtol=1e-12, atol=1e-13).outputs
    data = energy["energy.total"] + np.random.default_rng(4).normal(0, 0.01, TIMES.size)
    by_output = nemc.fit(pendulum, TIMES, data, fit=["c"], observed=["energy.total"],
                         start={"c": 0.3})
    assert abs(by_output.values["c"] - 0.4) < 3 * by_output.stderr["c"]


def test_bounds_hold_the_estimate(pendulum, clean) -> None:
    result = nemc.fit(pendulum, TIMES, noisy(clean, 6), fit=["c", "L"], observed=["theta"],
                      bounds={"c": (0.1, 0.35)}, start={"c": 0.2})
    assert 0.1 <= result.values["c"] <= 0.35


@pytest.mark.parametrize("change, message", [
    ({"data": "nan"}, "data holds 1 values that are not finite (NaN or inf), the first at "
     "row 5, observed 'theta'"),
    ({"data": "shape"}, "data must be 81 times x 1 observed ['theta'], got shape (80, 1)"),
    ({"fit": ["c", "mass"]}, "unknown name 'mass'"),
    ({"fit": ["m"]}, "parameter 'm' is derived (m = W/g)"),
    ({"observed": ["phi"]}, "observed 'phi' is neither a state entry"),
    ({"fit": ["c", "W"]}, "cannot identify ['c', 'W'] separately: the sensitivity matrix has "
     "rank 1 of 2"),
    ({"fit": ["c", "theta0"], "y0": [0.7, 0.0]}, "cannot identify ['theta0']: the observed "
     "['theta'] do not depend on them"),
    ({"start": {"c": -60.0}}, "the run of experiment 0 at the start values"),
    ({"max_nfev": 1}, "the fit did not converge"),
    ({"bounds": {"c": (0.5, 1.0)}}, "'c' starts at 0.4, outside its bounds"),
])
def test_each_bad_fit_gets_one_clear_error(pendulum, clean, change, message: str) -> None:
    data = noisy(clean, 7)
    if change.get("data") == "nan":
        data[5, 0] = np.nan
    elif change.get("data") == "shape":
        data = data[1:]
    options = {"fit": ["c", "L"], "observed": ["theta"],
               **{k: v for k, v in change.items() if k != "data"}}
    if "start" not in options:
        start = {"c": 0.4 if "bounds" in change else 0.2, "L": 2.7}
        options["start"] = {k: v for k, v in start.items() if k in options["fit"]}
    with pytest.raises(nemc.FitError) as error:
        nemc.fit(pendulum, TIMES, data, **options)
    assert message in str(error.value)


def write_csv(path: Path, header: str, rows: np.ndarray) -> Path:
    path.write_text(header + "\n" + "\n".join(",".join(f"{v:.9g}" for v in row)
                                              for row in rows) + "\n")
    return path


def test_the_command_line_fits_and_writes_only_a_fit(pendulum, clean, tmp_path: Path,
                                                     capsys) -> None:
    mech = tmp_path / "damped_pendulum.yaml"
    mech.write_text(DAMPED_PENDULUM)
    table = np.column_stack([TIMES, noisy(clean, 8)])
    data = write_csv(tmp_path / "angles.csv", "t,theta", table)
    out = tmp_path / "fit.json"
    assert main(["fit", str(mech), str(data), "--fit", "c", "L", "--start", "c=0.3",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "correlation" in printed and "c" in printed
    written = json.loads(out.read_text())
    assert abs(written["values"]["c"] - 0.4) < 3 * written["stderr"]["c"]
    failing = tmp_path / "never.json"
    cases = [
        (write_csv(tmp_path / "nan.csv", "t,theta", np.where(table == table[3, 1], np.nan,
                                                             table)),
         "line 5: column 'theta': nan is not a finite number"),
        (write_csv(tmp_path / "cols.csv", "t,phi", table),
         "columns ['phi'] are neither state entries"),
        (write_csv(tmp_path / "no_t.csv", "time,theta", table), "no column 't'"),
    ]
    for path, message in cases:
        assert main(["fit", str(mech), str(path), "--fit", "c", "--out", str(failing)]) == 2
        assert message in capsys.readouterr().err
    assert main(["fit", str(mech), str(data), "--fit", "c", "W", "--out", str(failing)]) == 2
    assert "cannot identify ['c', 'W']" in capsys.readouterr().err
    assert main(["fit", str(mech), str(data), "--fit", "mass", "--out", str(failing)]) == 2
    assert "unknown name 'mass'" in capsys.readouterr().err
    assert not failing.exists()


def test_the_tutorials_numbers() -> None:
    """docs/tutorials/fitting.md's data and fit (the numbers it quotes), from its example."""
    model = nemc.compile(Path(__file__).resolve().parent.parent / "examples"
                         / "damped_compound_pendulum.yaml")
    t = np.linspace(0, 10, 101)
    true = model.simulate((0, 10), t_eval=t, rtol=1e-12, atol=1e-12)
    angles = np.round(true.y[0] + np.random.default_rng(2024).normal(0, 0.01, t.size), 6)
    fit = nemc.fit(model, t, angles, fit=["c", "L"], observed=["theta"],
                   start={"c": 0.2, "L": 2.5})
    assert fit.values["c"] == pytest.approx(0.50018105, abs=2e-7)
    assert fit.values["L"] == pytest.approx(2.9995333, abs=2e-6)
    assert fit.stderr["c"] == pytest.approx(0.00123, abs=1e-5)
    assert fit.correlation[0, 1] == pytest.approx(0.857, abs=1e-3)


def test_the_command_lines_estimates_give_an_initial_values_unit(clean, tmp_path: Path,
                                                                   capsys) -> None:
    """With `units:`, a fitted initial value's row carries its unit (theta: rad); a parameter
    has none to give (issue 52: the tables the CLI prints show units)."""
    mech = tmp_path / "damped_pendulum.yaml"
    mech.write_text(DAMPED_PENDULUM + "units: {length: ft, mass: slug, time: s, angle: rad}\n")
    data = write_csv(tmp_path / "angles.csv", "t,theta",
                     np.column_stack([TIMES, noisy(clean, 9)]))
    assert main(["fit", str(mech), str(data), "--fit", "c", "theta"]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert rows[0].split() == ["name", "value", "stderr", "unit"]
    assert rows[1].split()[0] == "c" and len(rows[1].split()) == 3
    assert rows[2].split()[0] == "theta" and rows[2].split()[-1] == "[rad]"
    assert float(rows[2].split()[1]) == pytest.approx(0.7, abs=0.01)  # the scene's theta0


def test_the_fits_figure_draws_the_data_the_model_and_the_residuals(pendulum) -> None:
    """Two weighted experiments: each residual panel's points are the fit's residuals (in
    sigmas), the data panel's points the data, and the model's curve, a run of its own at the
    estimate, passes through data + residual x sigma at the data's times."""
    rng = np.random.default_rng(11)
    experiments = []
    for theta0 in (0.4, 1.2):
        clean = pendulum.simulate((0, 8), [theta0, 0.0], t_eval=TIMES, rtol=1e-12,
                                  atol=1e-13).y[0]
        experiments.append(nemc.Experiment(TIMES, clean + rng.normal(0, SIGMA, TIMES.size),
                                           y0=[theta0, 0.0], weights=1 / SIGMA))
    result = nemc.fit(pendulum, fit=["c", "L"], observed=["theta"], experiments=experiments)
    top, bottom = result.plot().axes
    points = [line for line in bottom.lines if line.get_marker() == "o"]
    assert np.array_equal(np.concatenate([p.get_ydata() for p in points]), result.residual)
    assert bottom.get_ylabel() == "weighted residual (σ)"
    data, curves = top.lines[0::2], top.lines[1::2]
    for k, (experiment, residual) in enumerate(zip(experiments, result.residual.reshape(2, -1))):
        assert np.array_equal(data[k].get_ydata(), experiment.data)
        at = CubicSpline(curves[k].get_xdata(), curves[k].get_ydata())(TIMES)
        assert np.abs(at - (experiment.data + SIGMA * residual)).max() < 1e-8


def test_the_command_line_draws_the_fit_never_over_its_data(pendulum, clean, tmp_path: Path,
                                                             capsys) -> None:
    mech = tmp_path / "damped_pendulum.yaml"
    mech.write_text(DAMPED_PENDULUM)
    data = write_csv(tmp_path / "angles.csv", "t,theta", np.column_stack([TIMES, noisy(clean, 8)]))
    figure = tmp_path / "fit.png"
    assert main(["fit", str(mech), str(data), "--fit", "c", "--plot", str(figure)]) == 0
    assert f"figure written to {figure}" in capsys.readouterr().out
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []
    named_as_figure = tmp_path / "angles.svg"  # a data file a figure's name would destroy
    named_as_figure.write_bytes(data.read_bytes())
    assert main(["fit", str(mech), str(named_as_figure), "--fit", "c",
                 "--plot", str(named_as_figure)]) == 2
    assert "--plot" in capsys.readouterr().err
    assert named_as_figure.read_bytes() == data.read_bytes()
    never = tmp_path / "never.png"
    assert main(["fit", str(mech), str(data), "--fit", "c", "W", "--plot", str(never)]) == 2
    assert "cannot identify" in capsys.readouterr().err and not never.exists()


def test_a_fit_in_shots_draws_each_shots_run_on_its_span(pendulum, clean) -> None:
    """shots=3: three model curves, each over its own shot's data times, which together
    cover the data; the residual panel's points are the fit's residuals (the defects apart)."""
    result = nemc.fit(pendulum, TIMES, noisy(clean, 12), fit=["c", "L"], observed=["theta"],
                      start={"c": 0.3, "L": 2.8}, shots=3)
    top, bottom = result.plot().axes
    curves = top.lines[1:]
    assert len(curves) == 3
    spans = [(c.get_xdata()[0], c.get_xdata()[-1]) for c in curves]
    assert spans[0][0] == TIMES[0] and spans[-1][1] == TIMES[-1]
    assert all(a[1] == b[0] for a, b in zip(spans, spans[1:]))  # a shot ends where the next starts
    points = [line for line in bottom.lines if line.get_marker() == "o"]
    assert np.array_equal(points[0].get_ydata(), result.residual)
