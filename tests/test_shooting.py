"""Multiple shooting in the fit (issue 47: nemc.fit(..., shots=K), `nemc fit --shots K`): the
exact Jacobian of the shots' residuals and defects against central differences, and where one
shot fails: the double pendulum released flat (chaotic), fitted over 6 s from noisy angles and a
poor start, single shooting ends in a local minimum, multiple shooting recovers m2 and L2 within
2 sigma, at the optimum single shooting reaches from the truth (the defects closed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_fit import write_csv

import nemc
from nemc.runtime import fitting
from nemc.runtime.fitting import Experiment, FitError
from nemc.tools.cli import main

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "double_pendulum.yaml"
TRUTH = {"m2": 1.0, "L2": 0.5}
POOR_START = {"m2": 1.5, "L2": 0.65}
SIGMA = 0.01  # rad, on both angles
T = np.linspace(0, 6, 121)


@pytest.fixture(scope="module")
def flat(tmp_path_factory: pytest.TempPathFactory) -> tuple[nemc.runtime.Model, Path]:
    """The double pendulum released with both links flat (q1 = q2 = 0): chaotic."""
    text = EXAMPLE.read_text().replace("initial: {q1: -pi/4, q2: -pi/3}",
                                       "initial: {q1: 0, q2: 0}")
    path = tmp_path_factory.mktemp("shoot") / "double_pendulum_flat.yaml"
    path.write_text(text)
    return nemc.compile(path), path


@pytest.fixture(scope="module")
def angles(flat) -> np.ndarray:
    """The angles q1, q2 at T with seeded noise of SIGMA (n_t x 2)."""
    model, _ = flat
    true = model.simulate((0, T[-1]), t_eval=T, rtol=1e-12, atol=1e-13)
    noise = np.random.default_rng(47).normal(0.0, SIGMA, (T.size, 2))
    return true.y[[0, 2]].T + noise


def fitted(model, data: np.ndarray, shots: int, start: dict) -> fitting.FitResult:
    return nemc.fit(model, T, data, fit=["m2", "L2"], observed=["q1", "q2"],
                    weights=1 / SIGMA, absolute_sigma=True, start=start, shots=shots)


@pytest.mark.parametrize("layout", ["one experiment", "two experiments"])
def test_the_shots_jacobian_is_exact(flat, angles, layout: str) -> None:
    """Every column (the parameters, an initial value of the first shot, the later shots'
    starts, experiment by experiment) against central differences of the residuals, both
    passes' weights."""
    model, _ = flat
    if layout == "one experiment":
        problem = fitting.checked_problem(model, T[:41], angles[:41], ["m2", "L2", "dot(q1)"],
                                          ["q1", "q2"], None, 1 / SIGMA, None, None, None,
                                          "nemc.Vern9", 1e-12, 1e-14)
        cache = fitting.evaluations(problem, 3)
        start = np.array([1.2, 0.55, 0.1])
    else:
        second = Experiment(T[:31], angles[40:71] + 0.1, y0=[0.3, 0.0, -0.2, 1.0],
                            weights=1 / SIGMA)
        problem = fitting.checked_problem(
            model, None, None, ["m2", "L2"], ["q1", "q2"], None, None,
            [Experiment(T[:41], angles[:41], weights=1 / SIGMA), second], None, None,
            "nemc.Vern9", 1e-12, 1e-14)
        cache = fitting.evaluations(problem, 3)
        start = np.array([1.2, 0.55])
    x, _, _ = cache.unknowns(start, np.full(start.size, -np.inf), np.full(start.size, np.inf))
    experiments = len(problem.experiments)
    assert x.size == start.size + experiments * 2 * 4 == len(cache.column_names())
    for tightened in (False, True):
        if tightened:
            assert cache.tighten()
        jacobian = cache.at(x, first=True)[1]
        for k in range(x.size):
            h = 1e-6 * max(1.0, abs(x[k]))
            up, down = x.copy(), x.copy()
            up[k] += h
            down[k] -= h
            reference = (cache.evaluate(up, False)[0] - cache.evaluate(down, False)[0]) / (2 * h)
            error = np.abs(jacobian[:, k] - reference).max() / np.abs(reference).max()
            assert error < 1e-6, cache.column_names()[k]


def test_multiple_shooting_recovers_what_one_shot_cannot(flat, angles) -> None:
    model, _ = flat
    single = fitted(model, angles, 1, POOR_START)  # stuck: a local minimum far off
    assert single.rms > 10
    assert all(abs(single.values[k] - TRUTH[k]) > 100 * single.stderr[k] for k in TRUTH)
    multiple = fitted(model, angles, 12, POOR_START)
    assert 0.8 < multiple.rms < 1.2  # the noise's, as the weights say
    for name, value in TRUTH.items():
        assert abs(multiple.values[name] - value) < 2 * multiple.stderr[name], name
    assert np.abs(multiple.defects).max() < 1e-3 * SIGMA and multiple.defects.size == 11 * 4
    assert len(multiple.runs) == 12
    # docs/tutorials/fitting.md quotes these (its data are these)
    assert multiple.values["m2"] == pytest.approx(1.0001198, abs=2e-7)
    assert multiple.values["L2"] == pytest.approx(0.50005704, abs=2e-8)
    assert single.values["m2"] == pytest.approx(0.68531931, abs=1e-6)
    # the same optimum as one shot started at the truth: the shots joined into one run
    reference = fitted(model, angles, 1, TRUTH)
    for name in TRUTH:
        assert abs(multiple.values[name] - reference.values[name]) < 0.05 * reference.stderr[
            name], name
        assert multiple.stderr[name] == pytest.approx(reference.stderr[name], rel=0.05)


@pytest.mark.parametrize(("shots", "message"), [
    (0, "shots must be an integer >= 1"),
    ("12", "shots must be an integer >= 1"),
    (61, "shots=61 for 121 times: each shot needs two measurements at least"),
])
def test_bad_shots_get_one_clear_error(flat, angles, shots, message: str) -> None:
    model, _ = flat
    with pytest.raises(FitError, match=message):
        fitted(model, angles, shots, POOR_START)


def test_the_command_line_takes_shots(flat, angles, tmp_path: Path, capsys) -> None:
    _, path = flat
    data = write_csv(tmp_path / "angles.csv", "t,q1,q2", np.column_stack([T, angles]))
    start = [f"--start={name}={value}" for name, value in POOR_START.items()]
    assert main(["fit", str(path), str(data), "--fit", "m2", "L2", *start, "--sigma",
                 str(SIGMA), "--shots", "12"]) == 0
    printed = capsys.readouterr().out
    assert "shots joined: largest continuity defect" in printed
    value = float(next(line for line in printed.splitlines()
                       if line.split()[:1] == ["m2"]).split()[1])
    assert value == pytest.approx(1.0, abs=1e-3)
