"""Format v3 couplings (gear pairs, belts, racks): each against something it does not compute
itself: closed forms for a gear pair and a rack and pinion, the Lagrange-multiplier oracle
(tests/loop_reference.py, its coupling line written from the spec) for a belt inside a
four-bar loop (accelerations and every reaction on random consistent states), energy where it
must be kept; the offset "as at the start" per run; and one clear error per misuse."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from loop_reference import LoopReference

import nemc
from nemc.errors import InputError
from nemc.front.validate import load_mechanism, validate_text

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

GEARS = (EXAMPLES / "gear_train.yaml").read_text()

RACK = """\
name: rack_and_pinion
parameters: {r: 0.05, mr: 2.0, Ip: 0.01, F: 3.0, g: 9.81}
gravity: [0, -g]
bodies:
  rack: {mass: mr, inertia: 0.1}
  pinion: {mass: 0.5, inertia: Ip}
joints:
  slide: {type: prismatic, parent: ground, child: rack, coordinate: s}
  axle: {type: revolute, parent: ground, child: pinion, at: [0, 0.05], coordinate: q}
constraints:
  teeth: {type: coupling, a: slide, b: axle, ratio: r}  # the rack under the pinion
loads:
  - {force: [F, 0], body: rack}
outputs:
  reactions: [teeth, slide]
simulation:
  t_span: [0, 1]
  initial: {s: 0.2}
"""

# A four-bar whose crank drives a flywheel on the rocker's pivot by a belt (ratio 2): a coupling
# inside a loop, both conservative (gravity, a spring) and checked against the oracle.
BELTED_FOURBAR = """\
name: belted_fourbar
parameters: {L0: 0.4, L1: 0.1, L2: 0.35, L3: 0.3, m1: 0.5, m2: 1.5, m3: 1.2, g: 9.81, k: 20}
gravity: [0, -g]
bodies:
  crank: {mass: m1, inertia: m1*L1**2/12, com: [L1/2, 0], points: {B: [L1, 0]}}
  coupler: {mass: m2, inertia: m2*L2**2/12, com: [L2/2, 0], points: {C: [L2, 0]}}
  rocker: {mass: m3, inertia: m3*L3**2/12, com: [L3/2, 0], points: {C: [L3, 0]}}
  flywheel: {mass: 0.8, inertia: 0.004}
joints:
  A: {type: revolute, parent: ground, child: crank, coordinate: q1}
  B: {type: revolute, parent: crank, child: coupler, at: B, coordinate: q2, angle: absolute}
  D: {type: revolute, parent: ground, child: rocker, at: [L0, 0], coordinate: q3}
  W: {type: revolute, parent: ground, child: flywheel, at: [0, -0.3], coordinate: w}
constraints:
  C: {type: revolute, a: rocker.C, b: coupler.C}
  belt: {type: coupling, a: W, b: A, ratio: 2}
loads:
  - spring: {a: coupler.C, b: {body: ground, at: [0.2, 0.5]}, k: k, length: 0.2}
outputs:
  reactions: [A, D, W, C, belt]
  energy: true
simulation:
  t_span: [0, 2]
  initial: {q1: 1.5707963267948966, dot(q1): 3, w: 0.3}
  guess: {q2: 0.5, q3: 1.9}
"""


def compiled(text: str, folder: Path, name: str) -> nemc.runtime.Model:
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return nemc.compile(path)


def test_a_gear_pairs_pinion_accelerates_as_its_reduced_inertia_says(tmp_path: Path) -> None:
    """(Ia + Ib / k^2) qa'' = tau with k = -rb/ra; qa - k qb stays what it was at the start;
    the multiplier is the torque the wheel puts on the pinion, Ia qa'' - tau."""
    model = compiled(GEARS, tmp_path, "gears")
    times = np.linspace(0, 2, 9)
    result = model.simulate(method="nemc.Vern9", rtol=1e-11, atol=1e-12, t_eval=times)
    assert result.success, result.message
    k = -0.25 / 0.1
    accel = 1.0 / (0.02 + 0.3 / k**2)
    np.testing.assert_allclose(result.y[0], 0.4 + 0.5 * accel * times**2, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(result.y[0] - k * result.y[2], 0.4 - k * 0.1, atol=1e-11)
    np.testing.assert_allclose(result.outputs["mesh.Q"], 0.02 * accel - 1.0, rtol=1e-10)
    work = 1.0 * (result.y[0] - 0.4)  # the torque's work is the kinetic energy gained
    np.testing.assert_allclose(result.outputs["energy.total"], work, rtol=1e-9, atol=1e-12)


def test_a_rack_on_a_pinion(tmp_path: Path) -> None:
    """(mr + Ip / r^2) s'' = F along the rack (gravity across the rail): closed form."""
    model = compiled(RACK, tmp_path, "rack_and_pinion")
    times = np.linspace(0, 1, 5)
    result = model.simulate(method="nemc.DOP853", rtol=1e-11, atol=1e-12, t_eval=times)
    assert result.success, result.message
    accel = 3.0 / (2.0 + 0.01 / 0.05**2)
    np.testing.assert_allclose(result.y[0], 0.2 + 0.5 * accel * times**2, rtol=1e-10)
    np.testing.assert_allclose(result.y[0] - 0.05 * result.y[2], 0.2, atol=1e-11)
    # the teeth push the rack back by what the pinion's inertia takes: F - mr s''
    np.testing.assert_allclose(result.outputs["teeth.Q"], 2.0 * accel - 3.0, rtol=1e-9)


def test_a_belt_inside_a_loop_against_the_oracle(tmp_path: Path) -> None:
    """Accelerations and every reaction (joints, the loop's revolute, the belt) at random
    consistent states of a run, against the Lagrange-multiplier oracle."""
    model = compiled(BELTED_FOURBAR, tmp_path, "belted_fourbar")
    reference = LoopReference(load_mechanism(tmp_path / "belted_fourbar.yaml"))
    result = model.simulate(method="nemc.DOP853", rtol=1e-10, atol=1e-12,
                            t_eval=np.linspace(0.1, 2, 7))
    assert result.success, result.message
    for k in range(result.t.size):
        t, y = float(result.t[k]), result.y[:, k]
        np.testing.assert_allclose(model.rhs(t, y), reference.rhs(t, y), rtol=1e-10,
                                   atol=1e-10)
        ours, theirs = model.outputs(t, y), reference.outputs(t, y)
        for name in theirs:
            assert ours[name] == pytest.approx(theirs[name], rel=1e-9, abs=1e-9), name
    energy = result.outputs["energy.total"]
    assert np.ptp(energy) < 1e-8 * np.abs(energy).max()
    assert np.ptp(result.y[6] - 2 * result.y[0]) < 1e-9  # the belt's ratio, as at the start


def test_each_run_of_an_ensemble_keeps_its_own_offset(tmp_path: Path) -> None:
    model = compiled(GEARS, tmp_path, "gears")
    y0s = np.array([[0.4, 0.0, 0.1, 0.0], [0.0, 0.5, 1.0, -0.2], [1.0, 0.0, -1.0, 0.0]])
    runs = model.simulate_many(y0s, method="nemc.DOP853", t_span=(0, 1), t_eval=[1.0])
    for k, y0 in enumerate(y0s):
        single = model.simulate((0, 1), y0, method="nemc.DOP853", t_eval=[1.0])
        np.testing.assert_array_equal(runs.y[k][:, -1], single.y[:, -1])
        assert single.y[0, -1] + 2.5 * single.y[2, -1] == pytest.approx(y0[0] + 2.5 * y0[2],
                                                                         abs=1e-10)


def test_a_gear_pair_linearizes_in_one_coordinate(tmp_path: Path) -> None:
    model = compiled(GEARS, tmp_path, "gears")
    lin = model.linearize({"qa": 0.4, "qb": 0.1})
    assert len(lin.state_names) == 2 and lin.A[0, 1] == 1.0
    assert np.abs(lin.A[1]).max() < 1e-12  # no stiffness: the torque is constant


@pytest.mark.parametrize("change, where, message", [
    ("a: A, b: B", "a: A, b: A", "constraints.mesh.b: a coupling joins two joints, but a and b "
                                 "are both 'A'"),
    ("a: A, b: B", "a: A, b: X", "constraints.mesh.b: unknown joint 'X'"),
    ("ratio: -rb/ra", "ratio: t", "constraints.mesh.ratio"),
    ("ratio: -rb/ra}", "}", "constraints.mesh.ratio: missing required key 'ratio'"),
])
def test_a_bad_coupling_is_refused_with_its_line(change: str, where: str, message: str) -> None:
    with pytest.raises(InputError) as caught:
        validate_text(GEARS.replace(change, where).encode(), "gears.yaml")
    assert message in str(caught.value), str(caught.value)


def test_a_coupling_to_a_weld_is_refused() -> None:
    text = GEARS.replace("B: {type: revolute, parent: ground, child: wheel, at: [0.35, 0], "
                         "coordinate: qb}", "B: {type: weld, parent: ground, child: wheel}")
    text = text.replace("qb: 0.1", "qa: 0.4").replace("{qa: 0.4, qa: 0.4}", "{qa: 0.4}")
    with pytest.raises(InputError, match="a coupling joins two joints of one coordinate each"):
        validate_text(text.encode(), "gears.yaml")


def test_outside_a_run_a_state_is_its_own_start(tmp_path: Path) -> None:
    """rhs at any state is the gear pair's motion through it (the closed form's accelerations);
    constraint_residual measures the offset from the scene's start unless told another."""
    model = compiled(GEARS, tmp_path, "gears")
    k, accel = -2.5, 1.0 / (0.02 + 0.3 / 6.25)
    state = np.array([1.3, 0.2, -0.7, 0.2 / k])  # qa - k qb = -0.45, not the scene's 0.65
    np.testing.assert_allclose(model.rhs(0.0, state), [0.2, accel, 0.2 / k, accel / k],
                               rtol=1e-12)
    np.testing.assert_allclose(model.rhs_many(0.0, np.stack([state, state], axis=1))[:, 1],
                               model.rhs(0.0, state), rtol=0, atol=0)
    assert model.outputs(0.0, state)["mesh.Q"] == pytest.approx(0.02 * accel - 1.0, rel=1e-12)
    assert model.constraint_residual(state)[0] == pytest.approx(1.1, rel=1e-12)
    assert model.constraint_residual(state, start=state)[0] == 0.0


STEERING = EXAMPLES / "rack_pinion_steering.yaml"


def test_rack_and_pinion_steering_against_the_oracle() -> None:
    """The pinion's teeth slide the rack, whose tie-rods turn both knuckles (a coupling and two
    loops): accelerations and every reaction at random consistent states (each a run's, from a
    random start) against the Lagrange-multiplier oracle; the column's torque's work is the
    energy gained; the rack keeps r times the pinion's turn."""
    model, reference = nemc.compile(STEERING), LoopReference(load_mechanism(STEERING))
    rng = np.random.default_rng(4950)
    for _ in range(3):
        start = model.initial_state() + rng.normal(0, 0.05, model.n_state)
        p = model.loops.started(0.0, start, model.parameter_vector())
        start = model.loops.projected(np.zeros(1), start.reshape(-1, 1), p)[:, 0]
        result = model.simulate((0, 0.5), start, method="nemc.DOP853", rtol=1e-10, atol=1e-12,
                                t_eval=[0.5])
        assert result.success, result.message
        t, y = 0.5, result.y[:, -1]
        np.testing.assert_allclose(model.rhs(t, y), reference.rhs(t, y), rtol=1e-10,
                                   atol=1e-10)
        ours, theirs = model.outputs(t, y), reference.outputs(t, y)
        assert {"teeth.Q", "link_l.Fx", "link_r.Fy", "slide.M", "kingpin_l.Fx"} <= set(theirs)
        for name in theirs:
            assert ours[name] == pytest.approx(theirs[name], rel=1e-9, abs=1e-9), name


def test_rack_and_pinion_steering_steers_and_keeps_its_energy() -> None:
    """From the straight-ahead start the column's constant torque steers both wheels the same
    way; with no damping, kinetic plus spring energy is the torque's work tau * q."""
    model = nemc.compile(STEERING)
    result = model.simulate(method="nemc.DOP853", rtol=1e-11, atol=1e-12,
                            t_eval=np.linspace(0, 2, 21))
    assert result.success, result.message
    q, s = result.y[0], result.y[2]
    d_l, d_r = result.y[8], result.y[10]
    np.testing.assert_allclose(s - 0.04 * q, 0.0, atol=1e-11)
    assert (d_l[1:] < 0).all() and (d_r[1:] < 0).all() and q[1:].min() > 0
    work = 0.3 * q
    np.testing.assert_allclose(result.outputs["energy.total"], work, rtol=1e-9, atol=1e-11)
