"""The benchmark scripts run end to end (tiny subsets; speed is never asserted in tests). They
check the scripts, not nemc's answers, and take 2.5 minutes together: `make test-slow` runs
them (CI too), `make test` leaves them out."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from children import HANG

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.slow


def run_script(script: str, tmp_path: Path, mode: str = "--smoke") -> Path:
    env = {**os.environ, "NEMC_CACHE": str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    out = tmp_path / "results"
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / script), mode, "--out", str(out)],
        capture_output=True, text=True, env=env, timeout=HANG,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return out


def test_suite_smoke_mode_writes_results(tmp_path: Path) -> None:
    out = run_script("run.py", tmp_path)
    result = json.loads((out / "latest.json").read_text())
    assert set(result) >= {"environment", "rhs", "work_precision", "phases", "peers"}
    assert result["environment"]["git"]["commit"], result["environment"]["git"]
    # every contender that was measured agrees with nemc's RHS
    for name, rhs in result["rhs"].items():
        assert max(rhs["agreement"].values()) < 1e-10, (name, rhs["agreement"])
    rows = result["work_precision"]["double_pendulum"]["rows"]
    assert {r["contender"] for r in rows} >= {"nemc", "lambdify(cse)"}
    assert all(r["success"] and r["error"] < 1e-2 for r in rows), rows
    assert (out / "latest.md").read_text().startswith("# nemc benchmark results")
    assert (out / "work_precision_double_pendulum.png").stat().st_size > 0


def test_scaling_smoke_mode_fits_exponents(tmp_path: Path) -> None:
    out = run_script("scaling.py", tmp_path)
    result = json.loads((out / "scaling-latest.json").read_text())
    assert sorted(int(n) for n in result["rows"]) == [2, 3]
    fitted = result["fits"]["nemc generated C (bytes)"]
    assert fitted["n"] == [2, 3] and fitted["exponent"] > 0, fitted
    assert (out / "scaling_rhs.png").stat().st_size > 0


def test_native_smoke_mode_writes_the_equal_error_table(tmp_path: Path) -> None:
    out = run_script("native.py", tmp_path)
    result = json.loads((out / "native-latest.json").read_text())
    assert result["environment"]["git"]["commit"], result["environment"]["git"]
    rows = result["rows"]
    assert {r["section"] for r in rows} == {"equal error", "5.4", "ensemble"}
    for row in rows:  # every contender ran: a positive time and a finite error
        assert row["median"] > 0 and row["min"] > 0, row
        assert math.isfinite(row["error"]), row
    equal = {r["contender"]: r for r in rows if r["section"] == "equal error"}
    assert {"solve_ivp DOP853 + lambdify(cse)", "nemc.DOP853"} <= set(equal), sorted(equal)
    for name, row in equal.items():  # the ladder found an rtol reaching the target
        assert row["reached"] and row["error"] <= row["target_error"], (name, row)
    if result["peers"]["heyoka"]:
        assert "heyoka taylor_adaptive" in equal, sorted(equal)
    else:
        assert any(n.startswith("heyoka: skipped") for n in result["notes"]), result["notes"]
    arm = {r["contender"]: r for r in rows if r["section"] == "5.4"}
    assert arm["nemc.Radau"]["error"] < 1e-6, arm  # rtol 1e-8 against the tight reference
    ensemble = [r for r in rows if r["section"] == "ensemble"]
    assert all(r["all_succeeded"] and r["error"] < 1e-12 for r in ensemble), ensemble
    text = (out / "native-latest.md").read_text()
    assert text.startswith("# nemc native integrators at equal error")
    assert "speed-up vs lambdify(cse)" in text


def test_loops_smoke_mode_writes_its_tables(tmp_path: Path) -> None:
    """The closed-loop benchmark: the baseline reaches its target against the extended-precision
    reference; nemc's rows are measured or marked "not supported yet" with a reason."""
    out = run_script("loops.py", tmp_path)
    result = json.loads((out / "loops-latest.json").read_text())
    ref = result["references"]["fourbar"]
    assert ref["error_bound"] < 1e-7, ref
    rows = result["rows"]
    baseline = [r for r in rows if r["contender"].startswith("DOP853 + lambdify")]
    assert baseline and all(r["reached"] and r["median"] > 0 for r in baseline), baseline
    for row in rows:
        if "reason" in row:
            assert row["reason"].startswith("nemc: not supported yet"), row
        else:
            assert row["median"] > 0, row
    assert (out / "loops-latest.md").read_text().startswith("# Closed loops")
    kinds = [r for r in rows if r["section"] == "kinds"]
    assert {r["system"] for r in kinds} == {"revolute loop (four-bar)",
                                            "gear train (3 gears, 2 couplings)",
                                            "rolling wheel (free disc, rolling)"}, kinds
    assert all(r["median"] > 0 and r["vs_revolute_loop"] > 0 for r in kinds), kinds
    assert "## 4. RHS cost: a gear train" in (out / "loops-latest.md").read_text()


def test_sweep_smoke_mode_compares_clusters_and_machinery(tmp_path: Path) -> None:
    out = run_script("sweep.py", tmp_path)
    result = json.loads((out / "sweep-latest.json").read_text())
    assert all(result["identical_to_simulate_many"].values()), result
    assert set(result["ratios"]) >= {"2 workers vs 1 (throughput)", "sweep (zarr) / simulate_many"}
    assert all(math.isfinite(r["median"]) for r in result["ratios"].values())


def test_batch_smoke_mode_compares_lanes_with_one_by_one(tmp_path: Path) -> None:
    out = run_script("batch.py", tmp_path)
    result = json.loads((out / "batch-latest.json").read_text())
    pendulum = result["systems"]["double pendulum"]
    assert pendulum["checks"]["lanes_equal_one_by_one"] and pendulum["checks"]["all_succeeded"]
    assert pendulum["checks"]["heyoka"]  # its contender, or why it is absent
    assert pendulum["checks"]["errors"]["lanes"]["median"] < 1e-3  # rtol 1e-8, chaotic runs
    assert all(math.isfinite(r["median"]) for r in pendulum["ratios"].values())
    assert result["environment"]["loadavg_start"] is not None


def test_dop853_peer_smoke_mode_measures_or_says_why_not(tmp_path: Path) -> None:
    out = run_script("dop853_peer.py", tmp_path)
    result = json.loads((out / "dop853_peer-latest.json").read_text())
    if result["environment"]["numbalsoda"] is None:
        assert "not installed" in result["note"] and not result["systems"]
        return
    run = result["systems"]["double pendulum"]["runs"]["1e-06"]
    assert run["succeeded"] and run["difference"] < 1e-2  # two DOP853s at rtol 1e-6, [0, 20]
    calls = run["rhs_calls"]
    assert abs(calls["nemc.DOP853"] / calls["numbalsoda dop853"] - 1) < 0.2  # nearly equal steps
    assert math.isfinite(run["ratio"]["median"])



def test_rhs_forms_smoke_mode_times_every_form(tmp_path: Path) -> None:
    out = run_script("rhs_forms.py", tmp_path)
    result = json.loads((out / "rhs_forms-latest.json").read_text())
    pendulum = result["systems"]["double pendulum"]
    assert set(pendulum["forms"]) == {"articulated body", "mass matrix",
                                      "mass matrix, linearized",
                                      "mass matrix, linearized, addition formulas"}
    assert pendulum["chosen"] in pendulum["forms"]
    assert max(r["difference"] for r in pendulum["forms"].values()) < 1e-9  # one system
    assert "chosen / fastest" in (out / "rhs_forms-latest.md").read_text()


def test_overhead_reports_every_row() -> None:
    """benchmarks/overhead.py (quoted by README for the fixed costs) runs and prints its rows."""
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "overhead.py"),
                           "--rounds", "1"], capture_output=True, text=True, env=env,
                          timeout=HANG)
    assert done.returncode == 0, done.stderr[-3000:]
    for row in ("| model.rhs(t, y) |", "| simulate over [0, 0], nemc.Taylor |",
                "| simulate over [0, 0], auto (chose nemc.", "at the run's states",
                "- nemc.DOP853: the driver adds "):
        assert row in done.stdout, (row, done.stdout)


def test_plant_quick_mode_measures_every_section(tmp_path: Path) -> None:
    """benchmarks/plant.py --quick (issue 46): sympy's A and B agree with nemc's, Pinocchio's
    derivatives too where it is installed (else it is absent, not failed), every contender is
    timed, and the zero-gain feedback takes the open loop's very steps."""
    out = run_script("plant.py", tmp_path, "--quick")
    result = json.loads((out / "plant-latest.json").read_text())
    cart = result["cart"]
    assert all(t["median"] > 0 for t in cart["times"].values()), cart["times"]
    if cart["sympy"]["why_not"] is None:
        assert cart["sympy"]["agreement"] < 1e-10, cart["sympy"]
        assert any(name.startswith("sympy") for name in cart["times"])
    for n, row in result["chains"]["rows"].items():
        assert {"nemc: Jacobian d/dy in C", "nemc: linearization d/d(y, u) in C"} <= set(
            row["times"]), (n, row["times"])
        assert all(v < 1e-10 for v in row["checks"].values()), (n, row["checks"])
        assert row["program"]["jacobian"]["steps"] > 0
    params = result["params"]["times"]
    assert {"model.rhs, no params", "model.rhs, the same dict of 25"} <= set(params)
    for system in result["feedback"].values():
        for method, found in system["methods"].items():
            assert found["zero_gain_same_steps"], (method, found["steps"])
            assert found["held_upright_within"] < 0.05, (method, found["held_upright_within"])
    assert (out / "plant-latest.md").read_text().startswith("# The model as a plant")
def test_sensitivities_smoke_mode_writes_its_table(tmp_path: Path) -> None:
    out = run_script("sensitivities.py", tmp_path)
    result = json.loads((out / "sensitivities-latest.json").read_text())
    assert result["environment"]["loadavg_end"] is not None or os.name != "posix"
    (row,) = result["rows"]
    assert row["contender"] == "nemc.Vern9"
    assert row["plain"]["median"] > 0 and row["sensitivities"]["median"] > 0
    assert row["error"] < 1e-8  # the sensitivities against scipy's tight run
    assert (out / "sensitivities-latest.md").read_text().startswith("# Sensitivities")


def test_loop_sensitivities_smoke_mode_writes_its_table(tmp_path: Path) -> None:
    out = run_script("loop_sensitivities.py", tmp_path)
    result = json.loads((out / "loop_sensitivities-latest.json").read_text())
    (row,) = result["rows"]
    assert row["example"] == "fourbar" and len(row["columns"]) == 5
    for clock in ("wall", "cpu"):
        assert row["times"]["plain"][clock]["median"] > 0
        assert row["times"]["sensitivities"][clock]["median"] > 0
    assert row["nfev"][1] > row["nfev"][0]  # the columns in the error control
    assert row["error"] < 1e-8  # the columns against scipy's tight run of the same system
    text = (out / "loop_sensitivities-latest.md").read_text()
    assert text.startswith("# A closed loop's sensitivities")


def test_ensemble_sensitivities_smoke_mode_writes_its_table(tmp_path: Path) -> None:
    out = run_script("ensemble_sensitivities.py", tmp_path)
    result = json.loads((out / "ensemble_sensitivities-latest.json").read_text())
    assert set(result["times"]) == {"simulate_many with sensitivities",
                                    "single runs with sensitivities", "simulate_many plain",
                                    "simulate_many with sensitivities, nemc.Taylor"}
    assert result["largest_difference_from_single_runs"] < 1e-12
    assert result["taylor_largest_difference_from_single_runs"] < 1e-12
    assert all(r["median"] > 0 for r in result["ratios"])
    assert (out / "ensemble_sensitivities-latest.md").read_text().startswith(
        "# Sensitivities in ensembles")


def test_friction_smoke_mode_compares_exact_friction_with_the_tanh_law(tmp_path: Path) -> None:
    out = run_script("friction.py", tmp_path)
    result = json.loads((out / "friction-latest.json").read_text())
    contenders = [row["contender"] for row in result["rows"]]
    assert contenders[0] == "nemc.Vern9" and any("tanh" in c for c in contenders)
    exact = result["rows"][0]
    assert exact["stick_error"] == 0.0 and exact["switch_error"] < 1e-8
    assert "| nemc.Vern9 | exact |" in (out / "friction-latest.md").read_text()


def test_fitting_smoke_mode_times_the_chains_fit(tmp_path: Path) -> None:
    out = run_script("fitting.py", tmp_path)
    result = json.loads((out / "fitting-latest.json").read_text())
    assert result["rank"] == 12 and result["nfev"] >= 1
    assert result["first_fit"] > 0 and result["fits"]["median"] > 0
    share = result["share"]
    assert set(share) >= {"evaluation_seconds", "fit_seconds"}  # measured, never ranked here
    assert result["runs"]["sensitivities"]["median"] > 0 and result["runs"]["plain"]["median"] > 0
    assert (out / "fitting-latest.md").read_text().startswith("# Fitting")
