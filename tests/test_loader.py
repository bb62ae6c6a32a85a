"""The loader: valid files become the expected Mechanism; every rule refuses bad input."""

from __future__ import annotations

import hashlib
import textwrap
from pathlib import Path

import pytest
import sympy

from nemc.model import TIME, rate_symbol, symbol
from nemc.validate import METHODS, load_mechanism, validate_text

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "double_pendulum.yaml"

S = symbol

FULL = """\
name: full
description: every shape
constants:
  g: 9.81
parameters:
  W: 2
  m: W/g
  L: 1
  k1: 10
gravity: [0, -g]
bodies:
  cart: {mass: m, inertia: 1, points: {P: [0.5, 0]}}
  arm: {mass: 1, inertia: m*L**2/12, com: [L/2, 0], points: {tip: [L, 0]}}
  puck: {mass: 1, inertia: 0.1}
  slider: {mass: 1, inertia: 0.1}
  glued: {mass: 1, inertia: 0.1}
joints:
  J1: {type: prismatic, parent: ground, child: cart, at: [0, 1], coordinate: s, axis: [1, 1]}
  J2: {type: revolute, parent: cart, child: arm, at: P, coordinate: th, offset: 0.1}
  J3: {type: free, parent: ground, child: puck, coordinates: [x, y, phi]}
  J4: {type: weld, parent: arm, child: glued, at: tip, offset: -pi/2}
  J5: {type: prismatic, parent: arm, child: slider, coordinate: u, at: com}
loads:
  - torque: -0.1*dot(th) + sin(t)
    body: arm
    reaction: cart
  - force: [0, -2*sin(3*t)]
    body: arm
    at: tip
    frame: body
  - force: [1, 0]
    body: puck
  - spring: {a: arm.tip, b: {body: ground, at: [2, 0]}, k: k1, length: 0.5, damping: 0.2}
  - spring: {a: cart.origin, b: puck.com, k: 1, length: 0}
  - joint_spring: {joint: J2, k: 3, rest: 0.1, damping: 0.5}
  - joint_spring: {joint: J5, k: 3}
outputs:
  reactions: [J1, J4]
  energy: true
  points: [arm.tip, puck.com]
  accelerations: true
  expressions: {tip_x: "s + L*cos(th)", v: dot(x)}
simulation:
  t_span: [0, 2*pi]
  initial: {s: 0.1, dot(th): -L, phi: pi}
  t_eval: [0, 1, 2.5]
  method: LSODA
  rtol: 1e-8
  atol: 1e-10
"""


def load(text: str, tmp_path: Path, name: str = "m.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return load_mechanism(path)


# ----------------------------------------------------------------------------- valid files


def test_double_pendulum_example() -> None:
    m = load_mechanism(str(EXAMPLE))
    assert m.name == "double_pendulum"
    assert m.source == str(EXAMPLE)
    assert m.source_hash == hashlib.sha256(EXAMPLE.read_bytes()).hexdigest()
    assert [p.name for p in m.parameters] == ["m1", "m2", "L1", "L2", "g"]
    assert m.parameters[3].expr == sympy.Float(0.5)
    assert m.parameters[0].loc.line == 5 and m.parameters[0].loc.key == "parameters.m1"
    assert m.constants == ()
    assert m.gravity == (0, -S("g"))
    link1, link2 = m.bodies
    assert link1.mass == S("m1") and link1.inertia == S("m1") * S("L1") ** 2 / 12
    assert link1.com == (S("L1") / 2, 0) and dict(link1.points) == {"B": (S("L1"), 0)}
    assert link2.points["D"] == (S("L2"), 0)
    a, b = m.joints
    assert (a.type, a.parent, a.child, a.at, a.coordinates, a.angle) == (
        "revolute", "ground", "link1", (0, 0), ("q1",), "relative")
    assert (b.parent, b.child, b.at, b.coordinates, b.angle) == (
        "link1", "link2", (S("L1"), 0), ("q2",), "absolute")
    assert m.state_names == ("q1", "dot(q1)", "q2", "dot(q2)")
    assert m.outputs.reactions == ("A", "B") and m.outputs.energy
    sim = m.simulation
    assert sim.t_span == (0.0, 5.0) and sim.t_eval_step == 0.5 and sim.t_eval is None
    assert dict(sim.initial) == {"q1": -sympy.pi / 4, "q2": -sympy.pi / 3}
    assert (sim.method, sim.rtol, sim.atol) == ("RK45", 1e-6, 1e-9)


def test_every_shape(tmp_path: Path) -> None:
    m = load(FULL, tmp_path)
    assert m.description == "every shape"
    assert [c.name for c in m.constants] == ["g"] and m.parameters[1].expr == S("W") / S("g")
    j1, j2, j3, j4, j5 = m.joints
    assert (j1.type, j1.at, j1.axis, j1.coordinates) == ("prismatic", (0, 1), (1, 1), ("s",))
    assert j2.at == (sympy.Float(0.5), 0) and j2.offset == sympy.Float(0.1)
    assert (j3.type, j3.coordinates) == ("free", ("x", "y", "phi"))
    assert (j4.type, j4.coordinates, j4.at, j4.offset) == ("weld", (), (S("L"), 0), -sympy.pi / 2)
    assert j5.at == (S("L") / 2, 0) and j5.axis == (1, 0)
    assert m.coordinates == ("s", "th", "x", "y", "phi", "u")
    torque, force, force2, spring, spring2, js, js2 = m.loads
    assert torque.expr == -sympy.Float(0.1) * rate_symbol("th") + sympy.sin(TIME)
    assert (torque.body, torque.reaction) == ("arm", "cart")
    assert (force.body, force.at, force.frame) == ("arm", (S("L"), 0), "body")
    assert force.components == (0, -2 * sympy.sin(3 * TIME))
    assert (force2.at, force2.frame) == ((0, 0), "ground")
    assert (spring.a.label, spring.a.xy, spring.b.label, spring.b.body) == (
        "arm.tip", (S("L"), 0), "ground.[2, 0]", "ground")
    assert spring.k == S("k1") and spring2.damping == 0
    assert (spring2.a.label, spring2.b.label) == ("cart.origin", "puck.com")
    assert (js.joint, js.k, js.rest) == ("J2", 3, sympy.Float(0.1))
    assert (js2.rest, js2.damping) == (0, 0)
    out = m.outputs
    assert out.reactions == ("J1", "J4") and out.energy and out.accelerations
    assert [p.label for p in out.points] == ["arm.tip", "puck.com"]
    assert out.expressions == (("tip_x", S("s") + S("L") * sympy.cos(S("th"))),
                               ("v", rate_symbol("x")))
    sim = m.simulation
    assert sim.t_span == pytest.approx((0, 2 * 3.141592653589793))
    assert sim.t_eval == (0.0, 1.0, 2.5) and sim.t_eval_step is None
    assert dict(sim.initial) == {"s": sympy.Float(0.1), "dot(th)": -S("L"), "phi": sympy.pi}
    assert (sim.method, sim.rtol, sim.atol) == ("LSODA", 1e-8, 1e-10)


def test_minimal_defaults(tmp_path: Path) -> None:
    m = load("""\
        name: tiny
        bodies: {b: {mass: 1, inertia: 2}}
        joints: {j: {type: revolute, parent: ground, child: b, coordinate: q}}
        """, tmp_path)
    assert m.description == "" and m.gravity == (0, 0) and m.loads == ()
    assert m.bodies[0].com == (0, 0) and dict(m.bodies[0].points) == {}
    assert m.joints[0].at == (0, 0) and m.joints[0].offset == 0
    assert m.outputs.empty and m.simulation.t_span is None and dict(m.simulation.initial) == {}


def test_validate_text_accepts_str_and_bytes() -> None:
    text = EXAMPLE.read_text()
    assert validate_text(text, "x.yaml") == validate_text(text.encode(), "x.yaml")


def test_methods_table() -> None:
    assert METHODS == ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
