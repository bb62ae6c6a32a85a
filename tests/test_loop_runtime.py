"""Closed loops at run time, against what must hold whatever the formulation: the returned states
satisfy the constraints to rounding, the right-hand side of a state off the constraints is the
one of the state brought onto them, a parallelogram linkage passes its flat (singular)
positions on its own branch or stops saying where and why, and bad initial states are refused
by name. (The dynamics themselves are checked against an independent Lagrange-multiplier
derivation in tests/test_loops.py and tests/test_scenarios.py, which also checks ensembles
against single runs.)"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.runtime.model import ModelError
from nemc.tools.cli import main

# A parallelogram: crank and rocker of length L, coupler and ground of length d. Flat (all four
# pivots on a line, the loop's equations losing rank) whenever the crank angle is a multiple of
# pi. Its branch: rocker angle = crank angle, coupler horizontal (absolute angle 0).
PARALLELOGRAM = """\
name: parallelogram
constants: {L: 1.0, d: 2.0}
parameters: {m: 1.0}
bodies:
  crank: {mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {B: [L, 0]}}
  coupler: {mass: m, inertia: m*d**2/12, com: [d/2, 0], points: {C: [d, 0]}}
  rocker: {mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {C: [L, 0]}}
joints:
  A: {type: revolute, parent: ground, child: crank, coordinate: q1}
  B: {type: revolute, parent: crank, child: coupler, at: B, coordinate: q2, angle: absolute}
  D: {type: revolute, parent: ground, child: rocker, at: [d, 0], coordinate: q3}
constraints:
  C: {type: revolute, a: coupler.C, b: rocker.C}
outputs:
  energy: true
simulation:
  t_span: [0, 10]
  initial: {q1: 0.5, dot(q1): 2.0}
  guess: {q2: 0.0, q3: 0.5}
"""

FOURBAR = """\
name: fourbar_g
parameters: {g: 9.81, m: 1.0}
constants: {L1: 1.0, L2: 2.5, L3: 2.0, L0: 2.5}
gravity: [0, -g]
bodies:
  crank: {mass: m, inertia: m*L1**2/12, com: [L1/2, 0], points: {B: [L1, 0]}}
  coupler: {mass: m, inertia: m*L2**2/12, com: [L2/2, 0], points: {C: [L2, 0]}}
  rocker: {mass: m, inertia: m*L3**2/12, com: [L3/2, 0], points: {C: [L3, 0]}}
joints:
  A: {type: revolute, parent: ground, child: crank, coordinate: q1}
  B: {type: revolute, parent: crank, child: coupler, at: B, coordinate: q2}
  D: {type: revolute, parent: ground, child: rocker, at: [L0, 0], coordinate: q3}
constraints:
  C: {type: revolute, a: coupler.C, b: rocker.C}
outputs:
  energy: true
simulation:
  t_span: [0, 10]
  initial: {q1: 1.0}
  guess: {q2: 0.5, q3: 2.0}
"""


def compiled(tmp_path: Path, text: str, name: str):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return nemc.compile(path)


@pytest.fixture(scope="module")
def fourbar(tmp_path_factory: pytest.TempPathFactory):
    return compiled(tmp_path_factory.mktemp("fourbar"), FOURBAR, "fourbar_g")


@pytest.fixture(scope="module")
def parallelogram(tmp_path_factory: pytest.TempPathFactory):
    return compiled(tmp_path_factory.mktemp("parallelogram"), PARALLELOGRAM, "parallelogram")


@pytest.mark.parametrize("method", ["RK45", "LSODA", "nemc.DOP853", "nemc.Vern9",
                                    "nemc.Radau"])
def test_returned_states_hold_the_constraints(fourbar, method: str) -> None:
    result = fourbar.simulate(method=method, rtol=1e-8, atol=1e-10,
                              t_eval=np.linspace(0, 10, 101))
    assert result.success, result.message
    position, rate = fourbar.constraint_residual(result.y, result.t)
    assert position.max() < 1e-13 and rate.max() < 1e-12


def test_rhs_off_the_constraints_is_the_rhs_on_them(fourbar) -> None:
    """The right-hand side projects its state first: a state pushed off the constraints by a
    small error gives the accelerations of the nearby consistent state."""
    on = fourbar.simulate(t_eval=[2.0]).y[:, 0]
    rng = np.random.default_rng(11)
    off = on + rng.normal(scale=1e-7, size=on.size)
    assert fourbar.constraint_residual(off)[0] > 1e-8
    projected = fourbar.loops.projected(np.array([0.0]), off.reshape(-1, 1),
                                  fourbar.parameter_vector())[:, 0]
    assert fourbar.constraint_residual(projected).max() < 1e-13
    np.testing.assert_allclose(fourbar.rhs(0.0, off), fourbar.rhs(0.0, projected),
                               rtol=1e-12, atol=1e-12)


def test_energy_of_the_free_fourbar_stays(fourbar) -> None:
    result = fourbar.simulate(method="nemc.Vern9", rtol=1e-11, atol=1e-13,
                              t_eval=np.linspace(0, 10, 201))
    energy = result.outputs["energy.total"]
    assert np.ptp(energy) < 1e-8 * abs(energy[0])


@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Vern9", "RK45", "LSODA"])
def test_the_parallelogram_passes_its_flat_positions_on_its_branch(parallelogram,
                                                                   method: str) -> None:
    result = parallelogram.simulate(method=method, rtol=1e-9, atol=1e-11,
                                    t_eval=np.linspace(0, 10, 2001))
    assert result.success, result.message
    q1, q2, q3 = result.y[0], result.y[2], result.y[4]
    assert q1[-1] - q1[0] > 6 * np.pi  # six flat positions passed
    assert np.abs(q1 - q3).max() < 1e-8 and np.abs(q2).max() < 1e-8  # the parallelogram's
    energy = result.outputs["energy.total"]
    # nemc.Vern9 reaches t_eval points between its steps by one more, unchecked, step: one of
    # 2001 was seen 1e-6 off in energy (issue 19: Verner's interpolant); the rest keep it
    assert np.ptp(energy) < 1e-5
    assert np.median(np.abs(energy - energy[0])) < 1e-10


def test_a_stop_at_a_singular_position_says_where_and_why(parallelogram) -> None:
    """At rtol 1e-12 the step size collapses at a flat position: the run stops there, naming
    the time, the constraint and the singular configuration (never a silent other branch)."""
    result = parallelogram.simulate(method="nemc.DOP853", rtol=1e-12, atol=1e-14,
                                    t_eval=np.linspace(0, 10, 501))
    if result.success:  # it may pass: then on its branch
        assert np.abs(result.y[0] - result.y[4]).max() < 1e-8
        return
    assert "constraint 'C' is at a singular configuration" in result.message
    if "q1=" in result.message:  # the step size collapsed: the message gives the state
        crank = float(result.message.split("q1=")[1].split(",")[0])
        assert abs(np.sin(crank)) < 1e-3  # where the linkage lies flat
    else:  # the pace rule stopped it first: its last state, at most one t_eval step before
        assert abs(np.sin(result.y[0, -1])) < 5e-2


def test_a_full_initial_state_must_hold_the_constraints(fourbar) -> None:
    good = fourbar.simulate(t_eval=[0.0]).y[:, 0]
    assert fourbar.simulate((0, 0.1), good).success
    bad = good.copy()
    bad[1] += 1.0  # a crank rate the rocker and coupler do not follow
    with pytest.raises(ModelError, match="the given rates cannot satisfy constraint 'C'"):
        fourbar.simulate((0, 0.1), bad)


def test_partial_initial_values_are_assembled(fourbar) -> None:
    start = fourbar.simulate((0, 0), y0={"q1": 0.3, "dot(q1)": 1.5}, t_eval=[0.0]).y[:, 0]
    assert start[0] == pytest.approx(0.3, abs=1e-15) and start[1] == pytest.approx(1.5, abs=1e-14)
    assert fourbar.constraint_residual(start).max() < 1e-10


def test_taylor_is_refused_by_name(fourbar) -> None:
    with pytest.raises(ModelError, match=r"nemc.Taylor is not available .*constraints.C: a "
                                         "closed loop's state is projected"):
        fourbar.simulate(method="nemc.Taylor")


def test_check_prints_the_degrees_of_freedom(tmp_path: Path, capsys) -> None:
    path = tmp_path / "fourbar_g.yaml"
    path.write_text(FOURBAR)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "1 loop constraint (2 equations), 1 degree of freedom" in out


def test_a_loop_that_cannot_close_is_refused_with_its_line(tmp_path: Path, capsys) -> None:
    path = tmp_path / "short.yaml"
    path.write_text(FOURBAR.replace("L2: 2.5, L3: 2.0", "L2: 0.5, L3: 0.5").replace(
        "name: fourbar_g", "name: short"))
    for command in ("check", "compile"):
        assert main([command, str(path), *(["-o", str(tmp_path / "out")]
                                           if command == "compile" else [])]) == 2
        err = capsys.readouterr().err
        assert f"{path}:14: constraints.C: the mechanism cannot be assembled" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("method", ["nemc.DOP853", "nemc.Vern9"])
def test_a_loose_tolerance_shortens_steps_the_loop_cannot_take(fourbar, method: str) -> None:
    """At rtol 1e-3 a trial stage of a long step lies where the four-bar cannot close (the
    projection fails there): the step is rejected and shortened, as one with too large an
    error, instead of ending the run (it ended at t = 0.23 with 'cannot be brought onto
    constraint C')."""
    times = np.linspace(0, 1, 11)
    truth = fourbar.simulate((0, 1), method="nemc.Vern9", rtol=1e-13, atol=1e-15, t_eval=times)
    loose = fourbar.simulate((0, 1), method=method, rtol=1e-3, atol=1e-6, t_eval=times)
    assert loose.success, loose.message
    assert fourbar.constraint_residual(loose.y, loose.t).max() < 1e-12
    assert np.abs(loose.y - truth.y).max() < 1.0  # a loose run's error, not a wrong branch
