"""Sensitivities in ensembles (issue 47: simulate_many(..., sensitivities=[...])): each member's
columns against its own single run's (the same system, method and tolerance: the same numbers,
to the bit where the drivers do the same operations) and against central differences of tight
runs at the member's parameters (an independent path); each member's columns start at its own
d y0 / d p; through impacts; and one clear refusal for each thing an ensemble's sensitivities
cannot do."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.runtime.failures import ModelError

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
TIGHT = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-14}
NAMES = ["y0", "m1", "m2", "L1", "L2", "g"]  # the double pendulum's 9 columns
SPAN = (0.0, 3.0)
TIMES = np.linspace(0.0, 3.0, 7)

# The book's 5.1 pendulum with a damper and its initial angle a parameter: a member's column by
# theta0 starts at d y0 / d theta0 = (1, 0) at its own parameters.
DAMPED_PENDULUM = """\
name: damped_pendulum_many
parameters: {W: 12, L: 3, g: 32.2, m: W/g, c: 0.4, theta0: 0.7}
gravity: [0, -g]
bodies:
  rod: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  O: {type: revolute, parent: ground, child: rod, coordinate: theta}
loads:
  - {torque: -c*dot(theta), body: rod}
simulation:
  t_span: [0, 4]
  initial: {theta: theta0}
  t_eval: {step: 0.5}
"""


@pytest.fixture(scope="module")
def double_pendulum() -> nemc.runtime.Model:
    return nemc.compile(EXAMPLES / "double_pendulum.yaml")


@pytest.fixture(scope="module")
def damped(tmp_path_factory: pytest.TempPathFactory) -> nemc.runtime.Model:
    path = tmp_path_factory.mktemp("many") / "damped_pendulum_many.yaml"
    path.write_text(DAMPED_PENDULUM)
    return nemc.compile(path)


def members(model: nemc.runtime.Model, k: int, seed: int) -> tuple[dict, np.ndarray]:
    """K members' parameters (m2, L2 within 20 % of the defaults) and initial states (the
    scene's, perturbed), seeded."""
    rng = np.random.default_rng(seed)
    defaults = model.parameters
    params = {"m2": defaults["m2"] * rng.uniform(0.8, 1.2, k),
              "L2": defaults["L2"] * rng.uniform(0.8, 1.2, k)}
    y0s = model.initial_state() + rng.uniform(-0.2, 0.2, (k, model.n_state))
    return params, y0s


def member_params(params: dict, r: int) -> dict[str, float]:
    return {name: float(values[r]) for name, values in params.items()}


def relative_error(ours: np.ndarray, reference: np.ndarray) -> float:
    return float(np.abs(ours - reference).max() / max(np.abs(reference).max(), 1e-300))


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853", "nemc.Radau"])
def test_each_member_is_its_single_run(double_pendulum, method: str) -> None:
    """Every member's states and columns are its single run's (the same drivers, system and
    tolerance), to the bit; and the counts are the single run's."""
    params, y0s = members(double_pendulum, 5, seed=47)
    run = {"t_span": SPAN, "t_eval": TIMES, "method": method, "rtol": 1e-10, "atol": 1e-12}
    many = double_pendulum.simulate_many(y0s, params=params, sensitivities=NAMES, threads=2,
                                         **run)
    assert many.method == method and np.all(many.success)
    assert many.sensitivities["y0"].shape == (5, 4, 4, TIMES.size)
    assert many.sensitivities["g"].shape == (5, 4, TIMES.size)
    for r in range(5):
        single = double_pendulum.simulate(y0=y0s[r], params=member_params(params, r),
                                          sensitivities=NAMES, **run)
        assert np.array_equal(many.y[r], single.y)
        for name in NAMES:
            assert np.array_equal(many.sensitivities[name][r], single.sensitivities[name])
        assert many.nfev[r] == single.nfev and many.njev[r] == single.njev


def test_members_against_central_differences(double_pendulum) -> None:
    """Two members' columns by a parameter and an initial value against central differences
    of tight runs (scipy's DOP853 at rtol 1e-13) at the member's own parameters."""
    params, y0s = members(double_pendulum, 4, seed=7)
    many = double_pendulum.simulate_many(y0s, params=params, sensitivities=["m2", "q2", "g"],
                                         t_span=SPAN, t_eval=TIMES, method="nemc.Vern9",
                                         rtol=1e-12, atol=1e-14)
    for r in (1, 3):
        base = {**double_pendulum.parameters, **member_params(params, r)}
        for name in ("m2", "g", "q2"):
            h = 1e-5 * (base[name] if name in base else 1.0)  # relative for a parameter
            ends = []
            for sign in (1, -1):
                y0, p = y0s[r].copy(), dict(base)
                if name in p:
                    p[name] += sign * h
                else:
                    y0[double_pendulum.state_names.index(name)] += sign * h
                ends.append(double_pendulum.simulate(SPAN, y0, params=p, t_eval=TIMES,
                                                     **TIGHT).y)
            reference = (ends[0] - ends[1]) / (2 * h)
            assert relative_error(many.sensitivities[name][r], reference) < 1e-7, (r, name)


def test_each_member_starts_at_its_own_initial_tangent(damped) -> None:
    """The scene's initial state at each member's theta0 and L: the columns by theta0 and L are
    the single runs' (theta0's starting at 1), and differ member to member."""
    theta0 = np.array([0.3, 0.7, 1.1])
    lengths = np.array([2.5, 3.0, 3.5])
    many = damped.simulate_many(params={"theta0": theta0, "L": lengths},
                                sensitivities=["theta0", "L", "c"], method="nemc.DOP853",
                                rtol=1e-10, atol=1e-12)
    assert np.allclose(many.sensitivities["theta0"][:, :, 0], [[1.0, 0.0]] * 3)
    for r in range(3):
        single = damped.simulate(params={"theta0": theta0[r], "L": lengths[r]},
                                 sensitivities=["theta0", "L", "c"], method="nemc.DOP853",
                                 rtol=1e-10, atol=1e-12)
        for name in ("theta0", "L", "c"):
            assert np.array_equal(many.sensitivities[name][r], single.sensitivities[name])
    assert relative_error(many.sensitivities["theta0"][0], many.sensitivities["theta0"][2]) > 0.1


def test_impacts_jump_every_members_columns() -> None:
    """The bouncing ball's members (e and the drop height per member) through their bounces:
    each member's columns (which jump at every impact) and its event times' sensitivities are
    its single run's."""
    ball = nemc.compile(EXAMPLES / "bouncing_ball.yaml")
    restitution = np.array([0.75, 0.8, 0.85])  # at rest after 2.6 s and more
    heights = np.array([1.0, 1.05, 1.2])
    run = {"t_span": (0.0, 2.0), "method": "nemc.Vern9", "rtol": 1e-11, "atol": 1e-13}
    many = ball.simulate_many({"y": heights}, params={"e": restitution},
                              sensitivities=["e", "g", "y"], **run)
    assert np.all(many.success) and np.all(many.event_count >= 4)
    for r in range(3):
        single = ball.simulate(y0={"y": heights[r]}, params={"e": restitution[r]},
                               sensitivities=["e", "g", "y"], t_eval=many.t, **run)
        assert list(many.event_times("bounce")[r]) == list(single.events["bounce"][0])
        assert many.event_count[r] == sum(len(t) for t, _ in single.events.values())
        for name in ("e", "g", "y"):
            assert np.array_equal(many.sensitivities[name][r], single.sensitivities[name])
            for event in ("bounce", "apex"):  # the event times' own
                assert np.array_equal(many.event_sensitivities[event][name][r],
                                      single.event_sensitivities[event][name])
    assert many.event_sensitivities["bounce"]["e"][2].shape == many.event_times("bounce")[2].shape


def test_members_share_an_input_table() -> None:
    """The cart-pole pushed by a table of F (shared), its cart's mass per member: each member's
    columns by F's constant term and by M are its single run's."""
    cart_pole = nemc.compile(EXAMPLES / "cart_pole.yaml")
    table = ([0.0, 0.5, 1.0, 2.0], [0.0, 1.0, -1.0, 0.5])
    masses = np.array([0.8, 1.0, 1.3])
    run = {"t_span": (0.0, 2.0), "t_eval": np.linspace(0.0, 2.0, 9), "method": "nemc.DOP853",
           "rtol": 1e-10, "atol": 1e-12}
    many = cart_pole.simulate_many(params={"M": masses}, inputs={"F": table},
                                   sensitivities=["F", "M"], **run)
    for r in range(3):
        single = cart_pole.simulate(params={"M": masses[r]}, inputs={"F": table},
                                    sensitivities=["F", "M"], **run)
        for name in ("F", "M"):
            assert np.array_equal(many.sensitivities[name][r], single.sensitivities[name])


def test_closed_loop_members_are_their_single_runs() -> None:
    """The four-bar's members (L2 and m2 per member, q1 and dot(q1) given per member): each
    starts from its own assembly, its columns in its own tangent space, and its states (brought
    onto the constraints) and columns are its single run's, to the bit; one member's column by
    L2 against central differences of tight runs."""
    fourbar = nemc.compile(EXAMPLES / "fourbar.yaml")
    rng = np.random.default_rng(35)
    lengths, masses = rng.uniform(0.33, 0.37, 3), rng.uniform(1.3, 1.7, 3)
    starts = {"q1": rng.uniform(1.4, 1.7, 3), "dot(q1)": rng.uniform(6.0, 9.0, 3)}
    names = ["q1", "dot(q1)", "L2", "m2"]
    run = {"t_span": (0.0, 1.0), "t_eval": np.linspace(0.0, 1.0, 5), "method": "nemc.Vern9",
           "rtol": 1e-11, "atol": 1e-13}
    many = fourbar.simulate_many(starts, params={"L2": lengths, "m2": masses},
                                 sensitivities=names, **run)
    assert np.all(many.success)
    for r in range(3):
        params = {"L2": lengths[r], "m2": masses[r]}
        y0 = {name: values[r] for name, values in starts.items()}
        single = fourbar.simulate(y0=y0, params=params, sensitivities=names, **run)
        assert np.array_equal(many.y[r], single.y)
        for name in names:
            assert np.array_equal(many.sensitivities[name][r], single.sensitivities[name])
    h = 3e-4 * lengths[1]
    y0 = {name: values[1] for name, values in starts.items()}
    ends = [fourbar.simulate(y0=y0, params={"L2": lengths[1] + sign * h, "m2": masses[1]},
                             t_span=run["t_span"], t_eval=run["t_eval"], method="nemc.Vern9",
                             rtol=1e-13, atol=1e-15).y for sign in (1, -1)]
    assert relative_error(many.sensitivities["L2"][1], (ends[0] - ends[1]) / (2 * h)) < 1e-6
    with pytest.raises(ModelError, match="the initial value 'q2' is solved by the assembly"):
        fourbar.simulate_many(starts, sensitivities=["q2"], **run)


def test_a_member_that_ends_early_has_nan_columns_after(double_pendulum) -> None:
    """A step budget that stops the members part way: each member's status is its single
    run's, its columns its single run's where it reached, NaN after."""
    run = {"t_span": (0.0, 20.0), "t_eval": np.linspace(0.0, 20.0, 11), "method": "nemc.DOP853",
           "rtol": 1e-10, "atol": 1e-12, "max_steps": 300}
    many = double_pendulum.simulate_many(params={"m2": [0.9, 1.1]}, sensitivities=["g"], **run)
    for r, m2 in enumerate((0.9, 1.1)):
        single = double_pendulum.simulate(params={"m2": m2}, sensitivities=["g"], **run)
        reached = single.t.size
        assert not single.success and many.status[r] == single.status and 0 < reached < 11
        assert np.array_equal(many.sensitivities["g"][r][:, :reached], single.sensitivities["g"])
        assert np.all(np.isnan(many.sensitivities["g"][r][:, reached:]))


def test_the_default_method_is_a_single_runs(double_pendulum) -> None:
    """method None: the scene's RK45 is not native, so "auto"'s rule for sensitivities:
    nemc.Vern9 below rtol 1e-4, nemc.DOP853 above; an implicit scene's is nemc.Radau."""
    params = {"m2": [1.0, 1.1]}
    for rtol, method in ((1e-8, "nemc.Vern9"), (1e-3, "nemc.DOP853")):
        many = double_pendulum.simulate_many(params=params, t_span=(0, 0.5), rtol=rtol,
                                             sensitivities=["g"])
        assert many.method == method
    arm = nemc.compile(EXAMPLES / "two_link_robot_arm.yaml")
    many = arm.simulate_many(params={arm.parameter_names[0]: [1.0, 1.2]}, t_span=(0, 0.2),
                             sensitivities=[arm.parameter_names[0]])
    assert many.method == "nemc.Radau" and np.all(many.success)


def test_event_times_sensitivities_under_an_input_table(tmp_path: Path) -> None:
    """The damped pendulum pushed by a table of T (shared), c per member, an event where it
    swings through the vertical: each member's event times' sensitivities (taken at the table's
    law of the event's segment) are its single run's."""
    path = tmp_path / "pushed_pendulum.yaml"
    path.write_text(DAMPED_PENDULUM.replace("name: damped_pendulum_many", "name: pushed")
                    .replace("loads:\n", "inputs: {T: 0}\nloads:\n  - {torque: T, body: rod}\n")
                    + "  events:\n    down: {when: theta, direction: falling}\n")
    model = nemc.compile(path)
    table = ([0.0, 1.0, 2.0, 4.0], [0.0, 2.0, -1.0, 0.5])
    damping = np.array([0.3, 0.4, 0.5])
    run = {"method": "nemc.Vern9", "rtol": 1e-10, "atol": 1e-12}
    many = model.simulate_many(params={"c": damping}, inputs={"T": table},
                               sensitivities=["T", "c", "theta"], **run)
    assert np.all(many.event_count >= 1)
    for r in range(3):
        single = model.simulate(params={"c": damping[r]}, inputs={"T": table},
                                sensitivities=["T", "c", "theta"], **run)
        for name in ("T", "c", "theta"):
            assert np.array_equal(many.event_sensitivities["down"][name][r],
                                  single.event_sensitivities["down"][name])


def test_taylor_members_are_their_single_runs(tmp_path: Path) -> None:
    """nemc.Taylor's ensemble with sensitivities (the scene's method, so simulate_many's
    default): every member's states, columns and counts are its single nemc.Taylor run's, to
    the bit (the same series of the system, one member after the other, not in SIMD lanes);
    and its columns agree with nemc.Vern9's ensemble at a tight tolerance (another method's
    integration of the same system)."""
    path = tmp_path / "taylor_scene.yaml"
    path.write_text(DAMPED_PENDULUM.replace("name: damped_pendulum_many", "name: taylor_scene")
                    .replace("  t_eval: {step: 0.5}",
                             "  t_eval: {step: 0.5}\n  method: nemc.Taylor"))
    model = nemc.compile(path)
    rng = np.random.default_rng(470)
    damping, theta0 = rng.uniform(0.2, 0.6, 5), rng.uniform(0.3, 1.2, 5)
    names = ["c", "theta0", "g", "y0"]
    run = {"rtol": 1e-12, "atol": 1e-14}
    many = model.simulate_many(params={"c": damping, "theta0": theta0}, sensitivities=names,
                               threads=2, **run)
    assert many.method == "nemc.Taylor" and np.all(many.success)
    for r in range(5):
        single = model.simulate(params={"c": damping[r], "theta0": theta0[r]},
                                sensitivities=names, method="nemc.Taylor", **run)
        assert np.array_equal(many.y[r], single.y) and many.nfev[r] == single.nfev
        for name in names:
            assert np.array_equal(many.sensitivities[name][r], single.sensitivities[name])
    vern9 = model.simulate_many(params={"c": damping, "theta0": theta0}, sensitivities=names,
                                method="nemc.Vern9", **run)
    for name in names:
        assert relative_error(many.sensitivities[name], vern9.sensitivities[name]) < 1e-9


def test_what_ensembles_cannot_differentiate_is_refused_by_name(double_pendulum,
                                                                tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="method must be one of nemc.DOP853, nemc.Vern9, "
                                         "nemc.Radau, nemc.Taylor or auto, got 'RK45'"):
        double_pendulum.simulate_many(params={"m2": [1.0, 1.1]}, sensitivities=["g"],
                                      method="RK45")
    with pytest.raises(ModelError, match="sensitivities with nemc.Taylor: .*fourbar.yaml:[0-9]+: "
                                         ".*closed loop"):
        nemc.compile(EXAMPLES / "fourbar.yaml").simulate_many(sensitivities=["y0"],
                                                              method="nemc.Taylor")
    with pytest.raises(ModelError, match="unknown name 'gg'; did you mean 'g'"):
        double_pendulum.simulate_many(params={"m2": [1.0, 1.1]}, sensitivities=["gg"])
    with pytest.raises(ModelError, match="t_span is empty"):
        double_pendulum.simulate_many(t_span=(1.0, 1.0), sensitivities=["g"])
    with pytest.raises(ModelError, match="simulate_many runs in C: .*not Python functions"):
        nemc.compile(EXAMPLES / "cart_pole.yaml").simulate_many(
            inputs={"F": lambda t, y: 0.0}, sensitivities=["y0"])
    with pytest.raises(ModelError, match="Coulomb friction are not available"):
        nemc.compile(EXAMPLES / "coulomb_block.yaml").simulate_many(sensitivities=["y0"])
    with pytest.raises(ModelError, match="ball_to_rest.yaml:[0-9]+: .*contacts are not "
                                         "available"):
        nemc.compile(EXAMPLES / "ball_to_rest.yaml").simulate_many(sensitivities=["y0"])
