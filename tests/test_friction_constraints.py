"""Coulomb friction along a loop-closing constraint (format v3 `friction: [{constraint: NAME}]`,
issue 50): the slider-crank with its friction on a prismatic constraint against the same
mechanism with its friction on the tree's prismatic joint (examples/slider_crank_friction.yaml,
a different tree and a different code path: the joint's rate and reaction rather than the
constraint's sliding speed and multiplier), and the spec's own slider-crank file against the
event-driven reference of tests/contact_reference.py, as is a block on a driven, tilting
guide; a block on an incline held by a prismatic or slot constraint against the closed forms
(it slides up, stops and sticks or slides back; pushed from rest it breaks free), with the
energy its friction takes; an ensemble; and bad items, one clear error each."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from contact_reference import (
    Incline,
    SliderCrank,
    incline_friction_work,
    incline_run,
    slider_crank_run,
)

import nemc
from nemc.errors import InputError

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent / "examples"
M, G, MU, MU_S = 2.0, 9.81, 0.25, 0.4

INCLINE = """
name: incline_guide
parameters: {m: 2.0, g: 9.81, alpha: ALPHA, mu: 0.25, mu_s: 0.4, v0: 1.5, c: 0.0}
gravity: [0, -g]
bodies:
  block: {mass: m, inertia: 0.1}
joints:
  F: {type: free, parent: ground, child: block, coordinates: [x, y, th]}
constraints:
  guide: {type: KIND, a: block.origin, b: {body: ground, at: [0, 0]},
          axis: [cos(alpha), sin(alpha)]}
loads:
  - {force: [c*t*cos(alpha), c*t*sin(alpha)], body: block}
friction:
  - {constraint: guide, mu: mu, mu_static: mu_s}
outputs:
  energy: true
simulation:
  t_span: [0, 1.5]
  initial: {dot(x): v0*cos(alpha), dot(y): v0*sin(alpha)}
  rtol: 1.0e-12
  atol: 1.0e-14
"""


def incline(tmp_path: Path, kind: str, alpha: float) -> nemc.Model:
    """The block on an incline of angle ALPHA, held on it by a KIND constraint."""
    path = tmp_path / f"incline_{kind}.yaml"
    path.write_text(INCLINE.replace("KIND", kind).replace("ALPHA", repr(alpha)))
    return nemc.compile(path)


def along(result, alpha: float) -> np.ndarray:
    """The block's position along the incline."""
    return result.y[0] * math.cos(alpha) + result.y[2] * math.sin(alpha)


@pytest.fixture(scope="module")
def crank_both_ways() -> tuple:
    """The slider-crank's runs at rtol 1e-13, friction on the tree's joint and on the guide."""
    times = np.linspace(0.0, 1.0, 501)
    runs = []
    for path in (EXAMPLES / "slider_crank_friction.yaml",
                 HERE / "data" / "friction" / "slider_crank_guide_friction.yaml"):
        result = nemc.compile(path).simulate(rtol=1e-13, atol=1e-15, t_eval=times)
        assert result.success
        runs.append(result)
    return tuple(runs)


def test_the_slider_crank_switches_alike_both_ways(crank_both_ways) -> None:
    """The same seven switches (break free, sticks and slips as the motor's torque builds)."""
    joint, guide = crank_both_ways
    joint_times = joint.events["S.stick_slip"][0]
    guide_times = guide.events["guide.stick_slip"][0]
    assert len(joint_times) == 7
    np.testing.assert_allclose(guide_times, joint_times, rtol=0, atol=1e-9)


def test_the_slider_crank_moves_alike_both_ways(crank_both_ways) -> None:
    """The crank's angle, the slider's position and the friction force agree to 1e-9, the
    crank's rate (up to 57 rad/s) and the normal force (up to 40 N) to 1e-9 of their scale."""
    joint, guide = crank_both_ways
    r, length = 0.1, 0.35
    q1, q2 = guide.y[0], guide.y[2]
    np.testing.assert_allclose(guide.y[0], joint.y[2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(guide.y[1], joint.y[3], rtol=0, atol=1e-9 * 60)
    np.testing.assert_allclose(r * np.cos(q1) + length * np.cos(q1 + q2), joint.y[0],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(guide.outputs["guide.friction"], joint.outputs["S.friction"],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(guide.outputs["guide.Fy"], joint.outputs["S.Fy"], rtol=0,
                               atol=1e-9 * 40)
    np.testing.assert_array_equal(guide.outputs["guide.stuck"], joint.outputs["S.stuck"])
    assert 0 < guide.outputs["guide.stuck"].sum() < len(guide.t)  # both modes are seen


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_the_specs_slider_crank_on_its_guide_switches_as_the_reference(method: str) -> None:
    """tests/data/friction/slider_crank_friction.yaml as the spec writes it (friction on the
    prismatic constraint `guide`, absolute angles, a flywheel pushed in pulses): its six
    switches (slip, stick, ..., the dead centre) and its state at 3 s as
    tests/contact_reference.py's slider_crank_run (maximal coordinates, hand-derived) to 1e-9;
    the energy's change the reference's motor work plus friction work."""
    model = nemc.compile(HERE / "data" / "friction" / "slider_crank_friction.yaml")
    result = model.simulate(t_eval=[0.0, 3.0], method=method)
    assert result.success
    reference = slider_crank_run(SliderCrank(), 3.0, np.pi / 3)
    times, _ = result.events["guide.stick_slip"]
    np.testing.assert_allclose(times, [t for t, _ in reference.switches], rtol=0, atol=1e-9)
    index = [model.state_names.index(name) for name in ("q1", "dot(q1)")]
    np.testing.assert_allclose(result.y[index, -1], reference.state(3.0), rtol=1e-9)
    energy = result.outputs["energy.total"]
    assert energy[-1] - energy[0] == pytest.approx(0.589905901708 - 0.635128975419, abs=1e-9)


@pytest.mark.parametrize("method", ["nemc.Vern9", "nemc.DOP853"])
def test_a_block_on_a_tilting_guide_slips_as_the_reference(method: str) -> None:
    """The guide turns (its incline driven): the block's slip instant and its position and
    sliding speed along the incline at 4 s as tests/contact_reference.py's incline_run (its
    normal force with the Coriolis term) to 1e-9."""
    model = nemc.compile(HERE / "data" / "friction" / "block_incline_guide.yaml")
    result = model.simulate(t_eval=[0.0, 4.0], method=method)
    assert result.success
    reference = incline_run(Incline(), 4.0)
    times, _ = result.events["guide.stick_slip"]
    np.testing.assert_allclose(times, [t for t, _ in reference.switches], rtol=0, atol=1e-9)
    x, dx, y, dy = result.y[:4, -1]
    angle = 0.2 + 0.1 * 4.0  # the incline's at 4 s
    along_it = [x * math.cos(angle) + y * math.sin(angle),
                dx * math.cos(angle) + dy * math.sin(angle)]
    np.testing.assert_allclose(along_it, reference.state(4.0), rtol=1e-9)


@pytest.mark.parametrize("kind", ["prismatic", "slot"])
def test_a_block_sliding_up_a_gentle_incline_stops_and_sticks(tmp_path: Path, kind: str) -> None:
    """tan(alpha) < mu_s: it decelerates at g (sin + mu cos) until v0 / that, then stays held by
    the friction m g sin(alpha); the energy lost is mu m g cos(alpha) times its path."""
    alpha, v0 = 0.3, 1.5
    result = incline(tmp_path, kind, alpha).simulate(t_eval=np.linspace(0, 1.5, 151))
    assert result.success
    deceleration = G * (math.sin(alpha) + MU * math.cos(alpha))
    stop, path = v0 / deceleration, v0**2 / (2 * deceleration)
    times, states = result.events["guide.stick_slip"]
    np.testing.assert_allclose(times, [stop], rtol=0, atol=1e-9)
    s = along(result, alpha)
    moving = result.t < stop
    np.testing.assert_allclose(s[moving], v0 * result.t[moving]
                               - deceleration * result.t[moving]**2 / 2, rtol=0, atol=1e-9)
    np.testing.assert_allclose(s[~moving], path, rtol=0, atol=1e-9)
    force, stuck = result.outputs["guide.friction"], result.outputs["guide.stuck"]
    np.testing.assert_allclose(force[moving], -MU * M * G * math.cos(alpha), rtol=1e-10)
    np.testing.assert_allclose(force[~moving], M * G * math.sin(alpha), rtol=1e-10)
    np.testing.assert_array_equal(stuck, (~moving).astype(float))
    energy = result.outputs["energy.total"]
    assert energy[0] - energy[-1] == pytest.approx(MU * M * G * math.cos(alpha) * path,
                                                   abs=1e-9)


@pytest.mark.parametrize("kind", ["prismatic", "slot"])
def test_a_block_on_a_steep_incline_turns_and_slides_back(tmp_path: Path, kind: str) -> None:
    """tan(alpha) > mu_s: at the top it cannot be held and slides back down at
    g (sin - mu cos), the friction now pointing up the incline."""
    alpha, v0 = 0.6, 1.5
    assert math.tan(alpha) > MU_S
    result = incline(tmp_path, kind, alpha).simulate(t_eval=np.linspace(0, 1.5, 151))
    assert result.success
    up = G * (math.sin(alpha) + MU * math.cos(alpha))
    down = G * (math.sin(alpha) - MU * math.cos(alpha))
    stop, top = v0 / up, v0**2 / (2 * up)
    times, _ = result.events["guide.stick_slip"]
    np.testing.assert_allclose(times, [stop], rtol=0, atol=1e-9)
    after = result.t > stop
    s = along(result, alpha)
    np.testing.assert_allclose(s[after], top - down * (result.t[after] - stop)**2 / 2,
                               rtol=0, atol=1e-9)
    force = result.outputs["guide.friction"]
    np.testing.assert_allclose(force[after], MU * M * G * math.cos(alpha), rtol=1e-10)
    assert np.all(result.outputs["guide.stuck"][after] == 0.0)


def test_a_block_pushed_from_rest_breaks_free_where_static_friction_ends(tmp_path: Path
                                                                         ) -> None:
    """At rest on a gentle incline under a push c t up it: held until c t reaches
    m g (sin + mu_s cos), then sliding up under c t - m g (sin + mu cos), s in closed form."""
    alpha, c = 0.3, 8.0
    path = tmp_path / "pushed.yaml"
    path.write_text(INCLINE.replace("KIND", "prismatic").replace("ALPHA", repr(alpha))
                    .replace("v0: 1.5, c: 0.0", f"v0: 0.0, c: {c}")
                    .replace("t_span: [0, 1.5]", "t_span: [0, 4]"))
    result = nemc.compile(path).simulate(t_eval=np.linspace(0, 4, 201))
    assert result.success
    free = M * G * (math.sin(alpha) + MU_S * math.cos(alpha)) / c
    times, _ = result.events["guide.stick_slip"]
    np.testing.assert_allclose(times, [free], rtol=0, atol=1e-9)
    t = result.t
    dt = t - free
    kinetic = G * (math.sin(alpha) + MU * math.cos(alpha))
    s = np.where(t > free, c * (t**3 - free**3) / (6 * M) - c * free**2 * dt / (2 * M)
                 - kinetic * dt**2 / 2, 0.0)
    np.testing.assert_allclose(along(result, alpha), s, rtol=0, atol=1e-9)
    held = t < free
    np.testing.assert_allclose(result.outputs["guide.friction"][held],
                               M * G * math.sin(alpha) - c * t[held], rtol=0, atol=1e-9)


def test_the_guides_friction_work_is_the_energy_it_takes(tmp_path: Path) -> None:
    """The power balance (nemc stress's: NAME.friction times NAME.speed, Simpson's rule): the
    block sliding up a steep incline and back loses exactly its friction's work (to 1e-8 of
    it); on the tilting guide the friction's work is the reference's since the slip (the
    drive's work is the rest)."""
    from nemc.tools.stress import energy_balance

    model = incline(tmp_path, "slot", 0.6)
    balance = energy_balance(model, model.scene["t_span"])
    assert balance.change < -10.0 and abs(balance.rest) < 1e-8 * abs(balance.change)
    tilting = nemc.compile(HERE / "data" / "friction" / "block_incline_guide.yaml")
    work = energy_balance(tilting, tilting.scene["t_span"]).friction_work
    assert work == pytest.approx(incline_friction_work(Incline(), 4.0), abs=5e-8)


def test_the_outputs_and_the_switch_count_take_the_states_at_the_switches(crank_both_ways
                                                                          ) -> None:
    """At the state just before a dead centre's switch the guide's speed is about 0, which
    reads as stuck, but no force can hold a slider there (the kinematics set its sliding
    acceleration): the outputs read it slipping instead. nemc stress counts the guide's events
    as one kind (the joint's: one slip, six reversals through the dead centres)."""
    from nemc.tools.switches import count_switches

    model = nemc.compile(HERE / "data" / "friction" / "slider_crank_guide_friction.yaml")
    _, guide = crank_both_ways
    times, states = guide.events["guide.stick_slip"]
    for t, y in zip(times, states):
        assert np.isfinite(model.outputs(float(t), y)["guide.friction"])
    assert count_switches(model, guide).counts == {"guide": {"guide stick/slip": 7}}


def test_scipys_explicit_method_runs_the_guide_too(tmp_path: Path) -> None:
    """RK45 (the switch applied around solve_ivp) stops the block where the closed form says."""
    alpha, v0 = 0.3, 1.5
    result = incline(tmp_path, "prismatic", alpha).simulate(method="RK45", rtol=1e-10,
                                                            atol=1e-12)
    assert result.success
    stop = v0 / (G * (math.sin(alpha) + MU * math.cos(alpha)))
    np.testing.assert_allclose(result.events["guide.stick_slip"][0], [stop], rtol=0, atol=1e-7)


def test_an_ensemble_stops_each_block_where_its_closed_form_says(tmp_path: Path) -> None:
    """simulate_many starts each run in its own mode: blocks launched up a gentle incline at
    four speeds stop (and stick) at v0 / (g (sin + mu cos)), v0^2 / (2 g (sin + mu cos)) up."""
    alpha = 0.3
    speeds = np.array([0.5, 1.0, 1.5, 2.0])
    starts = np.zeros((len(speeds), 6))
    starts[:, 1], starts[:, 3] = speeds * math.cos(alpha), speeds * math.sin(alpha)
    result = incline(tmp_path, "prismatic", alpha).simulate_many(starts, t_eval=[0.0, 1.5])
    assert np.all(result.success)
    deceleration = G * (math.sin(alpha) + MU * math.cos(alpha))
    stops = result.event_times("guide.stick_slip")
    np.testing.assert_allclose(np.concatenate(stops), speeds / deceleration, rtol=0, atol=1e-9)
    ends = result.y[:, 0, -1] * math.cos(alpha) + result.y[:, 2, -1] * math.sin(alpha)
    np.testing.assert_allclose(ends, speeds**2 / (2 * deceleration), rtol=0, atol=1e-9)


BAD = """
name: bad
bodies:
  block: {mass: 1, inertia: 0.1}
  arm: {mass: 1, inertia: 0.1}
joints:
  F: {type: free, parent: ground, child: block, coordinates: [x, y, th]}
  A: {type: revolute, parent: ground, child: arm, coordinate: a}
constraints:
  guide: {type: slot, a: block.origin, b: {body: ground, at: [0, 0]}, axis: [1, 0]}
  pin: {type: revolute, a: arm.origin, b: block.origin}
  blade: {type: knife_edge, at: block.origin, axis: [1, 0]}
friction:
  - FIRST
  - ITEM
"""
JOINT_ITEM = "{joint: A, mu: 0.2, radius: 0.01}"


@pytest.mark.parametrize("item, key, message", [
    ("{constraint: pin, mu: 0.2}", "friction[1].constraint",
     "constraint 'pin' has no sliding direction"),
    ("{constraint: blade, mu: 0.2}", "friction[1].constraint",
     "constraint 'blade' has no sliding direction"),
    ("{constraint: guide, mu: 0.3}", "friction[1].constraint",
     "constraint 'guide' already has a friction item"),  # after FIRST's on it
    ("{constraint: track, mu: 0.3}", "friction[1].constraint", "no constraint named 'track'"),
    ("{constraint: guide}", "friction[1].mu", "needs `mu`"),
    ("{constraint: guide, mu: 0.3, mu_static: 0.2}", "friction[1].mu_static",
     "mu_static must be >= mu"),
    ("{constraint: guide, mu: -0.3}", "friction[1].mu", "must be > 0"),
    ("{constraint: guide, mu: 0.3, radius: 0.01}", "friction[1].radius",
     "unknown key 'radius'"),
    ("{constraint: guide, joint: A, mu: 0.3}", "friction[1].joint", "unknown key 'joint'"),
    ("{constraint: [guide], mu: 0.3}", "friction[1].constraint", "expected a constraint's name"),
])
def test_a_bad_friction_item_on_a_constraint_is_refused_at_its_line(
        tmp_path: Path, item: str, key: str, message: str) -> None:
    path = tmp_path / "bad.yaml"
    first = "{constraint: guide, mu: 0.2}" if "already" in message else JOINT_ITEM
    path.write_text(BAD.replace("FIRST", first).replace("ITEM", item))
    with pytest.raises(InputError, match=message) as caught:
        nemc.compile(path)
    text = str(caught.value)
    assert f"{path}:15:" in text and key in text, text


def test_friction_along_a_constraint_together_with_contacts_is_refused_at_its_line(
        tmp_path: Path) -> None:
    """An impact's impulses take the joints' friction (Coulomb's law in the impulse), not a
    guide's: refused at the guide's item rather than run with the guide ignored in impacts."""
    path = tmp_path / "guide_and_contact.yaml"
    path.write_text(BAD.replace("FIRST", "{constraint: guide, mu: 0.2}").replace(
        "ITEM", JOINT_ITEM) + "contacts:\n  floor: {point: arm.origin, radius: 0.1, "
                              "surface: {body: ground, at: [0, -1]}}\n")
    with pytest.raises(InputError, match="friction along a constraint together with "
                                         "`contacts` is not built yet") as caught:
        nemc.compile(path)
    assert f"{path}:14: friction[0]" in str(caught.value), str(caught.value)
