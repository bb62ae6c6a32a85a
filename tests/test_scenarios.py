"""The properties stated once, on every scenario of the table they apply to (tests/scenarios.py:
models x independent references x options):

(a) every method, nemc's and scipy's, follows the independent reference (Lagrange's equations,
    or the loop reference's multipliers, solved tight) at the scenario's times, within about
    1e3 of its rtol (1e4 for the multistep methods, whose error must also fall with rtol); on a
    closed loop every returned state satisfies the constraints to the run's atol; and "auto",
    the default, at other parameters: the reference at those;
(b) an ensemble (simulate_many: one run after the other, on two threads, and nemc.Taylor's SIMD
    lanes, alone and on two threads) is its single runs (simulate) bit for bit: states,
    statuses, counts and event times, with initial states and a parameter per run;
(c) every native method runs backwards to where it started, and over an empty interval returns
    its start exactly, alone and in an ensemble.
"""

from __future__ import annotations

import numpy as np
import pytest
import scenarios as table
from scenarios import METHODS, MULTISTEP, NATIVE, Scenario

ENSEMBLE_RUNS = 11  # neither a multiple of 4 nor of 8 lanes: the last batch is part-empty

# ---- (a) every method against the independent reference --------------------------------------


@pytest.mark.parametrize(("scenario", "method"),
                         table.cases(lambda s: not s.events, lambda s: s.methods), ids=str)
def test_every_method_follows_the_reference(scenario: Scenario, method: str) -> None:
    tolerance = METHODS[method]
    model = table.model_for(scenario.name, method)
    truth = table.truth(scenario.name)
    result = model.simulate(scenario.span, method=method, t_eval=scenario.times,
                            rtol=tolerance.rtol, atol=tolerance.rtol / 100)
    assert result.success and result.method == method, result.message
    np.testing.assert_array_equal(result.t, scenario.times)
    # the start: the scene's initial state (a closed loop's assembled by each, to 1e-11)
    np.testing.assert_allclose(result.y[:, 0], truth[:, 0], rtol=0,
                               atol=1e-11 if model.has_loops else 1e-14)
    error = scaled_error(result.y, truth)
    assert error <= tolerance.error, f"{error:.2e} from the reference (rtol {tolerance.rtol:g})"
    if model.has_loops:
        atol = tolerance.rtol / 100
        position, velocity = model.constraint_residual(result.y, result.t)
        rates = np.abs(result.y[1::2]).max(axis=0)
        assert np.all(position <= atol), position.max()
        assert np.all(velocity <= atol * (1 + rates)), velocity.max()
    if method in MULTISTEP:  # a tighter run is closer: the error is the method's, not a floor
        tighter = model.simulate(scenario.span, method=method, t_eval=scenario.times,
                                 rtol=tolerance.rtol / 100, atol=tolerance.rtol / 1e4)
        assert scaled_error(tighter.y, truth) < error / 10


@pytest.mark.parametrize("scenario", table.where(lambda s: not s.events), ids=str)
def test_auto_follows_the_reference_at_other_parameters(scenario: Scenario) -> None:
    """The default method, its choice and switches included, with the scenario's parameter
    (if any) at 1.2 times its value: the reference at that value."""
    model = table.model(scenario.name)
    params = {} if scenario.parameter is None else \
        {scenario.parameter: 1.2 * model.parameters[scenario.parameter]}
    truth = table.truth(scenario.name, tuple(params.items()))
    result = model.simulate(scenario.span, method="auto", t_eval=scenario.times, rtol=1e-10,
                            atol=1e-12, params=params)
    assert result.success, result.message
    np.testing.assert_array_equal(result.t, scenario.times)
    assert scaled_error(result.y, truth) <= 1e-7


def scaled_error(y: np.ndarray, truth: np.ndarray) -> float:
    return float(np.max(np.abs(y - truth) / (1 + np.abs(truth))))


# ---- (b) an ensemble is its single runs ---------------------------------------------------------

MODES = {"one by one": {"threads": 1, "lanes": False},
         "two threads": {"threads": 2, "lanes": False},
         "lanes": {"threads": 1, "lanes": True},
         "lanes on two threads": {"threads": 2, "lanes": True}}


def ensemble_modes(scenario: Scenario) -> list[tuple[str, str]]:
    return [(method, mode) for method in NATIVE if method in scenario.methods for mode in MODES
            if method == "nemc.Taylor" or not mode.startswith("lanes")]


@pytest.mark.parametrize(("scenario", "method_mode"),
                         table.cases(lambda s: True, ensemble_modes),
                         ids=lambda case: str(case) if isinstance(case, Scenario) else
                         " ".join(case))
def test_an_ensemble_is_its_single_runs(scenario: Scenario, method_mode: tuple[str, str]) -> None:
    method, mode = method_mode
    model = table.model_for(scenario.name, method)
    seed = list(table.SCENARIOS).index(scenario.name)
    y0s = table.starts(scenario.name, ENSEMBLE_RUNS, seed)
    params = table.varied(scenario.name, ENSEMBLE_RUNS)
    options = {"method": method, "rtol": 1e-9, "atol": 1e-11, "t_eval": scenario.times}
    events = {"max_events": 8} if scenario.events else {}
    ensemble = model.simulate_many(y0s, params=params, t_span=scenario.span, progress=False,
                                   **options, **events, **MODES[mode])
    np.testing.assert_array_equal(ensemble.t, scenario.times)
    assert ensemble.y.shape == (ENSEMBLE_RUNS, model.n_state, len(scenario.times))
    assert ensemble.success.any() and ensemble.success.all() != scenario.stops, ensemble.status
    for r, y0 in enumerate(y0s):
        single = model.simulate(scenario.span, y0, params=table.row(params, r), **options)
        assert_the_run(ensemble, r, single)
    if scenario.events:
        assert (ensemble.event_count > 8).any()  # some runs had more than they keep
    if scenario.parameter or scenario.spread:
        assert len(set(ensemble.nfev.tolist())) > 1  # the runs differ


def assert_the_run(ensemble, r: int, single) -> None:
    """Run R of ENSEMBLE is SINGLE, to the last bit (NaN where it had stopped)."""
    n = single.t.size
    np.testing.assert_array_equal(ensemble.y[r][:, :n], single.y)
    assert np.isnan(ensemble.y[r][:, n:]).all()
    assert ensemble.status[r] == single.status, single.message
    assert (ensemble.nfev[r], ensemble.njev[r], ensemble.nlu[r]) == \
        (single.nfev, single.njev, single.nlu)
    assert tuple(ensemble.event_names) == tuple(single.events)
    fired = sum(len(times) for times, _ in single.events.values())
    assert ensemble.event_count[r] == fired  # all counted, the first max_events kept
    for name, (times, _) in single.events.items():
        kept = ensemble.event_times(name)[r]
        np.testing.assert_array_equal(kept, times[: kept.size])
    kept = ensemble.event_t[r][: min(fired, ensemble.event_t.shape[1])]
    assert np.all(np.diff(kept) >= 0)


# ---- (c) backwards to the start, and the empty interval ----------------------------------------


@pytest.mark.parametrize("method", NATIVE)
def test_backwards_returns_to_the_start_and_an_empty_interval_is_the_start(method: str) -> None:
    """Alone, and in an ensemble (nemc.Taylor's in SIMD lanes)."""
    parts = ("lanes",) if method == "nemc.Taylor" else table.PARTS.get(method, ())
    model = table.model("double_pendulum", *parts)
    y0 = model.initial_state()
    forward = model.simulate((0.0, 3.0), y0, method=method, rtol=1e-12, atol=1e-14,
                             t_eval=[3.0])
    back = model.simulate((3.0, 0.0), forward.y[:, -1], method=method, rtol=1e-12, atol=1e-14,
                          t_eval=[3.0, 1.5, 0.0])
    assert back.success and list(back.t) == [3.0, 1.5, 0.0]
    np.testing.assert_allclose(back.y[:, -1], y0, rtol=0, atol=1e-8)
    empty = model.simulate((1.0, 1.0), y0, method=method, t_eval=[1.0])
    assert empty.success
    np.testing.assert_array_equal(empty.y, y0.reshape(-1, 1))
    y0s = table.starts("double_pendulum", 3, seed=2)
    for span in ((2.0, 0.0), (1.0, 1.0)):
        ensemble = model.simulate_many(y0s, t_span=span, method=method, rtol=1e-8, atol=1e-8,
                                       progress=False, threads=2)
        for r, start in enumerate(y0s):
            assert_the_run(ensemble, r, model.simulate(span, start, method=method, rtol=1e-8,
                                                       atol=1e-8))
