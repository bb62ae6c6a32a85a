"""The loader: valid files become the expected Mechanism; every rule refuses bad input."""

from __future__ import annotations

import hashlib
import textwrap
from pathlib import Path

import pytest
import sympy
from budgets import work_of

from nemc.errors import InputError
from nemc.front.mechanism import TIME, rate_symbol, symbol
from nemc.front.scene import METHODS  # what the scene accepts
from nemc.front.validate import load_mechanism, validate_text

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
    from nemc.runtime import model as runtime

    assert METHODS == ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA",
                       *runtime.NATIVE_METHODS, "auto")
    assert METHODS == runtime.METHODS  # the scene accepts what simulate accepts


# ----------------------------------------------------------------------------- bad input

BASE = """\
name: t
parameters: {m: 1, L: 2}
bodies:
  b1: {mass: m, inertia: 1, points: {P: [L, 0]}}
  b2: {mass: 1, inertia: 1}
joints:
  A: {type: revolute, parent: ground, child: b1, coordinate: q1}
  B: {type: revolute, parent: b1, child: b2, at: P, coordinate: q2}
"""


def variant(old: str, new: str) -> str:
    """BASE with ``old`` replaced by ``new`` (lines stay where they are)."""
    assert old in BASE, old
    return BASE.replace(old, new)


def extra(text: str) -> str:
    """BASE with ``text`` appended from line 9."""
    return BASE + textwrap.dedent(text)


def problems(text: str | bytes) -> str:
    with pytest.raises(InputError) as info:
        validate_text(text, "m.yaml")
    assert info.value.problems
    return str(info.value)


def test_base_is_valid() -> None:
    assert validate_text(BASE, "m.yaml").state_names == ("q1", "dot(q1)", "q2", "dot(q2)")


BAD = [
    # top level
    ("top-unknown", variant("name: t", "nme: t"), "1: nme:",
     "unknown key 'nme' (did you mean 'name'?)"),
    ("top-missing-name", variant("name: t", "description: x"), "1: name:",
     "missing required key 'name'"),
    ("top-missing-joints", BASE.split("joints:")[0], "1: joints:", "missing required key"),
    ("name-keyword", variant("name: t", "name: class"), "1: name:", "not a Python keyword"),
    ("name-identifier", variant("name: t", "name: 3d"), "1: name:", "identifier"),
    ("name-number", variant("name: t", "name: 12"), "1: name:", "got number 12"),
    ("description-list", extra("description: [a]"), "9: description:", "expected text"),
    ("top-list", "- a\n- b\n", "m.yaml:1:", "expected a mapping of top-level keys"),
    # expressions
    ("caret", variant("mass: m", "mass: m^2"), "4: bodies.b1.mass:", "write '**'"),
    ("import", variant("mass: m", "mass: \"__import__('os')\""), "4: bodies.b1.mass:",
     "strings are not allowed"),
    ("attribute", variant("mass: m", "mass: m.real"), "4: bodies.b1.mass:", "attribute access"),
    ("lambda", variant("mass: m", "mass: 'lambda: 1'"), "4: bodies.b1.mass:",
     "unexpected character ':'"),
    ("string-literal", variant("mass: m", "mass: \"'abc'\""), "4: bodies.b1.mass:",
     "strings are not allowed"),
    ("unknown-name", variant("mass: m", "mass: mm"), "4: bodies.b1.mass:",
     "unknown name 'mm' (did you mean 'm'?)"),
    ("coordinate-in-body", variant("mass: m", "mass: q1"), "4: bodies.b1.mass:",
     "'q1' is a coordinate, not allowed in body"),
    ("time-in-body", variant("mass: m", "mass: 1 + t"), "4: bodies.b1.mass:",
     "time 't' is not allowed"),
    ("deep-parens", variant("mass: m", "mass: " + "(" * 10_000 + "m" + ")" * 10_000),
     "4: bodies.b1.mass:", "nested too deeply"),
    ("bool-expression", variant("mass: m", "mass: true"), "4: bodies.b1.mass:",
     "expected a number or an expression, got boolean true"),
    ("null-expression", variant("mass: m", "mass: null"), "4: bodies.b1.mass:",
     "got nothing (null)"),
    ("yes-is-a-name", variant("mass: m", "mass: yes"), "4: bodies.b1.mass:",
     "unknown name 'yes'"),
    # parameters and constants
    ("param-cycle", variant("{m: 1, L: 2}", "{m: L, L: 2*m}"), "2: parameters.m:",
     "cycle: m -> L -> m"),
    ("param-self", variant("{m: 1, L: 2}", "{m: m, L: 2}"), "2: parameters.m:", "cycle: m -> m"),
    ("param-nonfinite", variant("{m: 1, L: 2}", "{m: 1, L: .inf}"), "2: parameters.L:",
     "finite"),
    ("param-divide-zero", variant("{m: 1, L: 2}", "{m: 1, L: 1/(m-1)}"), "2: parameters.L:",
     "finite"),
    ("param-complex", variant("{m: 1, L: 2}", "{m: 1, L: sqrt(-m)}"), "2: parameters.L:",
     "finite real number"),
    ("param-reserved", variant("{m: 1, L: 2}", "{m: 1, L: 2, sin: 1}"), "2: parameters.sin:",
     "'sin' is reserved"),
    ("param-pi", variant("{m: 1, L: 2}", "{m: 1, L: 2, pi: 3}"), "2: parameters.pi:",
     "reserved"),
    ("param-t", variant("{m: 1, L: 2}", "{m: 1, L: 2, t: 3}"), "2: parameters.t:", "reserved"),
    ("param-identifier", variant("{m: 1, L: 2}", "{m: 1, L: 2, 2x: 3}"), "2: parameters.2x:",
     "identifier"),
    ("param-list", variant("{m: 1, L: 2}", "[m, L]"), "2: parameters:", "expected a mapping"),
    ("param-time", variant("{m: 1, L: 2}", "{m: 1, L: t}"), "2: parameters.L:",
     "time 't' is not allowed"),
    ("constant-uses-param", extra("constants: {c: m}"), "9: constants.c:",
     "'m' is a parameter, not allowed in constants"),
    ("constant-collides", extra("constants: {m: 1}"), "9: constants.m:",
     "already used by the parameter"),
    ("body-collides", variant("{m: 1, L: 2}", "{m: 1, L: 2, b1: 1}"), "4: bodies.b1:",
     "body name 'b1' is already used by the parameter at parameters.b1"),
    ("joint-collides", variant("{m: 1, L: 2}", "{m: 1, L: 2, A: 1}"), "7: joints.A:",
     "already used"),
    ("coordinate-collides", variant("{m: 1, L: 2}", "{m: 1, L: 2, q1: 1}"),
     "7: joints.A.coordinate:", "coordinate name 'q1' is already used by the parameter"),
    ("coordinate-twice", variant("coordinate: q2", "coordinate: q1"), "8: joints.B.coordinate:",
     "already used by the coordinate at joints.A.coordinate"),
    ("coordinate-ground", variant("coordinate: q2", "coordinate: ground"),
     "8: joints.B.coordinate:", "reserved"),
    ("body-ground", variant("  b2: {mass", "  ground: {mass"), "5: bodies.ground:",
     "'ground' is reserved"),
    ("joint-ddot", variant("  B: {type", "  ddot: {type"), "8: joints.ddot:", "reserved"),
    ("output-name-collides", extra("outputs: {expressions: {L: q1}}"),
     "9: outputs.expressions.L:", "already used by the parameter"),
    # gravity
    ("gravity-3", extra("gravity: [0, 0, 1]"), "9: gravity:", "2 entries, got a list of 3"),
    ("gravity-unknown", extra("gravity: [0, -g]"), "9: gravity[1]:", "unknown name 'g'"),
    ("gravity-scalar", extra("gravity: 9.8"), "9: gravity:", "[x, y]"),
    # bodies
    ("mass-negative", variant("mass: m", "mass: -m"), "4: bodies.b1.mass:", "must be >= 0, got -1"),
    ("mass-zero", variant("{mass: 1, inertia: 1}", "{mass: 0, inertia: 0}"), "5: bodies.b2:",
     "joint 'B' would move nothing"),
    ("mass-nan", variant("mass: m", "mass: .nan"), "4: bodies.b1.mass:", "finite"),
    ("mass-missing", variant("mass: m, ", ""), "4: bodies.b1.mass:", "missing required key"),
    ("inertia-negative", variant("inertia: 1, points", "inertia: -L, points"),
     "4: bodies.b1.inertia:", "must be >= 0"),
    ("body-unknown-key", variant("{mass: 1, inertia: 1}", "{mass: 1, inertia: 1, mas: 2}"),
     "5: bodies.b2.mas:", "unknown key 'mas'"),
    ("body-not-mapping", variant("{mass: 1, inertia: 1}", "5"), "5: bodies.b2:",
     "expected a mapping, got number 5"),
    ("com-3", variant("{mass: 1, inertia: 1}", "{mass: 1, inertia: 1, com: [1, 2, 3]}"),
     "5: bodies.b2.com:", "2 entries"),
    ("point-com", variant("{P: [L, 0]}", "{com: [L, 0]}"), "4: bodies.b1.points.com:",
     "implicit point"),
    ("point-origin", variant("{P: [L, 0]}", "{P: [L, 0], origin: [0, 1]}"),
     "4: bodies.b1.points.origin:", "cannot be redefined"),
    ("point-vector", variant("{P: [L, 0]}", "{P: [L]}"), "4: bodies.b1.points.P:",
     "2 entries, got a list of 1"),
    ("point-bad-name", variant("{P: [L, 0]}", "{P: [L, 0], 1P: [0, 0]}"),
     "4: bodies.b1.points.1P:", "identifier"),
    ("bodies-empty", variant("  b1: {mass: m, inertia: 1, points: {P: [L, 0]}}\n"
                             "  b2: {mass: 1, inertia: 1}\n", "  {}\n"),
     "4: bodies:", "at least one body"),
    # joints
    ("joint-type", variant("type: revolute, parent: ground", "type: revolut, parent: ground"),
     "7: joints.A.type:", "unknown joint type 'revolut' (did you mean 'revolute'?)"),
    ("joint-no-type", variant("type: revolute, parent: ground", "parent: ground"),
     "7: joints.A.type:", "missing required key"),
    ("joint-axis-on-revolute", variant("coordinate: q1}", "coordinate: q1, axis: [1, 0]}"),
     "7: joints.A.axis:", "does not apply to a revolute joint"),
    ("joint-unknown-key", variant("coordinate: q1}", "coordinate: q1, offest: 1}"),
     "7: joints.A.offest:", "unknown key 'offest' (did you mean 'offset'?)"),
    ("joint-angle", variant("coordinate: q1}", "coordinate: q1, angle: absolut}"),
     "7: joints.A.angle:", "did you mean 'absolute'?"),
    ("joint-no-coordinate", variant(", coordinate: q1}", "}"), "7: joints.A.coordinate:",
     "missing required key"),
    ("joint-coordinate-number", variant("coordinate: q1", "coordinate: 5"),
     "7: joints.A.coordinate:", "identifier"),
    ("unknown-parent", variant("parent: b1", "parent: b3"), "8: joints.B.parent:",
     "unknown body 'b3'"),
    ("unknown-child", variant("child: b2", "child: b22"), "8: joints.B.child:",
     "unknown body 'b22' (did you mean 'b2'?)"),
    ("ground-child", variant("child: b2", "child: ground"), "8: joints.B.child:",
     "ground is not allowed"),
    ("two-parents", variant("child: b2", "child: b1"), "8: joints.B.child:",
     "already the child of joint 'A'"),
    ("no-parent", variant("child: b2", "child: b1"), "5: bodies.b2:",
     "not attached: no joint has child: b2"),
    ("joint-cycle", variant("parent: ground, child: b1", "parent: b2, child: b1"),
     "7: joints.A.parent:", "form a cycle"),
    ("self-parent", variant("parent: b1, child: b2", "parent: b2, child: b2"),
     "8: joints.B.parent:", "form a cycle"),
    ("free-non-ground", variant("type: revolute, parent: b1, child: b2, at: P, coordinate: q2",
                                "type: free, parent: b1, child: b2, coordinates: [x, y, th]"),
     "8: joints.B.parent:", "a free joint's parent must be ground, got 'b1'"),
    ("free-two-coordinates",
     variant("type: revolute, parent: ground, child: b1, coordinate: q1",
             "type: free, parent: ground, child: b1, coordinates: [x, y]"),
     "7: joints.A.coordinates:", "3 coordinate names"),
    ("at-unknown-point", variant("at: P", "at: Q"), "8: joints.B.at:",
     "body 'b1' has no point 'Q'"),
    ("at-misspelled", variant("at: P", "at: cmo"), "8: joints.B.at:", "did you mean 'com'?"),
    ("at-ground-point", variant("coordinate: q1}", "coordinate: q1, at: com}"),
     "7: joints.A.at:", "ground has no point 'com'"),
    ("at-vector", variant("at: P", "at: [1, 2, 3]"), "8: joints.B.at:", "2 entries"),
    ("axis-zero", variant("type: revolute, parent: b1, child: b2, at: P, coordinate: q2",
                          "type: prismatic, parent: b1, child: b2, coordinate: s, axis: [0, m-1]"),
     "8: joints.B.axis:", "must not be [0, 0]"),
    ("weld-coordinate", variant("type: revolute, parent: b1, child: b2, at: P, coordinate: q2",
                                "type: weld, parent: b1, child: b2, coordinate: q2"),
     "8: joints.B.coordinate:", "does not apply to a weld joint"),
    ("joints-not-mapping", variant("  A: {type", "  - A: {type").replace("  B: {", "  - B: {"),
     "7: joints:", "expected a mapping joint name -> joint"),
    # loads
    ("loads-mapping", extra("loads: {torque: 1}"), "9: loads:", "expected a list of loads"),
    ("load-scalar", extra("loads: [x]"), "9: loads[0]:", "expected a load mapping"),
    ("load-two-kinds", extra("loads:\n  - torque: 1\n    force: [1, 2]\n    body: b1\n"),
     "10: loads[0]:", "exactly one of torque, force, spring, joint_spring; got torque and force"),
    ("load-misspelled", extra("loads:\n  - torqe: 1\n    body: b1\n"), "10: loads[0]:",
     "did you mean 'torque'?"),
    ("torque-reaction-same", extra("loads:\n  - torque: 1\n    body: b1\n    reaction: b1\n"),
     "12: loads[0].reaction:", "reaction must differ from body"),
    ("torque-no-body", extra("loads:\n  - torque: 1\n"), "10: loads[0].body:",
     "missing required key"),
    ("torque-ground-body", extra("loads:\n  - torque: 1\n    body: ground\n"),
     "11: loads[0].body:", "ground is not allowed"),
    ("torque-unknown-reaction", extra("loads:\n  - torque: 1\n    body: b1\n    reaction: b3\n"),
     "12: loads[0].reaction:", "unknown body 'b3'"),
    ("torque-frame-key", extra("loads:\n  - torque: 1\n    body: b1\n    frame: body\n"),
     "12: loads[0].frame:", "key 'frame' does not apply to a torque load"),
    ("torque-bad-rate", extra("loads:\n  - torque: dot(q3)\n    body: b1\n"),
     "10: loads[0].torque:", "dot() takes a coordinate, 'q3' is not one"),
    ("spring-map-no-body", extra("loads:\n  - spring: {a: b1.P, b: {at: [1, 0]}, k: 1, "
                                 "length: 1}\n"),
     "10: loads[0].spring.b.body:", "missing required key"),
    ("force-frame", extra("loads:\n  - force: [1, 0]\n    body: b1\n    frame: world\n"),
     "12: loads[0].frame:", "unknown frame 'world'"),
    ("force-vector", extra("loads:\n  - force: 1\n    body: b1\n"), "10: loads[0].force:",
     "[x, y]"),
    ("force-at", extra("loads:\n  - force: [1, 0]\n    body: b2\n    at: P\n"),
     "12: loads[0].at:", "body 'b2' has no point 'P'"),
    ("spring-point", extra("loads:\n  - spring: {a: b1.Q, b: ground.origin, k: 1, length: 1}\n"),
     "10: loads[0].spring.a:", "body 'b1' has no point 'Q'"),
    ("spring-ground-point", extra("loads:\n  - spring: {a: b1.P, b: ground.P, k: 1, length: 1}\n"),
     "10: loads[0].spring.b:", "ground has no point 'P'"),
    ("spring-shape", extra("loads:\n  - spring: {a: b1, b: ground.origin, k: 1, length: 1}\n"),
     "10: loads[0].spring.a:", "expected BODY.POINT"),
    ("spring-at-body", extra("loads:\n  - spring: {a: b1.P, b: {body: grond, at: [1, 0]}, "
                             "k: 1, length: 1}\n"),
     "10: loads[0].spring.b.body:", "unknown body 'grond' (did you mean 'ground'?)"),
    ("spring-k", extra("loads:\n  - spring: {a: b1.P, b: ground.origin, k: kk, length: 1}\n"),
     "10: loads[0].spring.k:", "unknown name 'kk'"),
    ("spring-length", extra("loads:\n  - spring: {a: b1.P, b: ground.origin, k: 1}\n"),
     "10: loads[0].spring.length:", "missing required key"),
    ("spring-not-mapping", extra("loads:\n  - spring: 3\n"), "10: loads[0].spring:",
     "expected a mapping {a, b, k, length, damping}"),
    ("joint-spring-unknown", extra("loads:\n  - joint_spring: {joint: C, k: 1}\n"),
     "10: loads[0].joint_spring.joint:", "unknown joint 'C'"),
    ("joint-spring-weld",
     variant("type: revolute, parent: b1, child: b2, at: P, coordinate: q2",
             "type: weld, parent: b1, child: b2, at: P")
     + "loads:\n  - joint_spring: {joint: B, k: 1}\n",
     "10: loads[0].joint_spring.joint:", "needs a revolute or prismatic joint; 'B' is a weld"),
    ("joint-spring-key", extra("loads:\n  - joint_spring: {joint: A, k: 1, length: 2}\n"),
     "10: loads[0].joint_spring.length:", "unknown key 'length'"),
    # outputs
    ("outputs-unknown-key", extra("outputs:\n  energie: true\n"), "10: outputs.energie:",
     "did you mean 'energy'?"),
    ("reaction-unknown", extra("outputs:\n  reactions: [A, C]\n"), "10: outputs.reactions[1]:",
     "unknown joint or constraint 'C'"),
    ("reaction-twice", extra("outputs:\n  reactions: [A, A]\n"), "10: outputs.reactions[1]:",
     "listed twice"),
    ("reactions-scalar", extra("outputs:\n  reactions: A\n"), "10: outputs.reactions:",
     "expected a list"),
    ("energy-yes", extra("outputs:\n  energy: yes\n"), "10: outputs.energy:",
     "expected true or false, got 'yes'"),
    ("accelerations-number", extra("outputs:\n  accelerations: 1\n"),
     "10: outputs.accelerations:", "expected true or false"),
    ("output-point-ground", extra("outputs:\n  points: [ground.origin]\n"),
     "10: outputs.points[0]:", "ground is not allowed"),
    ("output-point-unknown", extra("outputs:\n  points: [b2.X]\n"), "10: outputs.points[0]:",
     "body 'b2' has no point 'X'"),
    ("output-point-shape", extra("outputs:\n  points: [b1]\n"), "10: outputs.points[0]:",
     "expected BODY.POINT"),
    ("output-expression", extra("outputs:\n  expressions: {e: ddot(q1)}\n"),
     "10: outputs.expressions.e:", "unknown function 'ddot'"),
    ("output-uses-output", extra("outputs:\n  expressions: {e1: q1, e2: 2*e1}\n"),
     "10: outputs.expressions.e2:", "'e1' is an output expression, not allowed"),
    ("output-expression-name", extra("outputs:\n  expressions: {2e: q1}\n"),
     "10: outputs.expressions.2e:", "identifier"),
    ("output-unit-key", extra("outputs:\n  expressions: {e: {value: q1, units: m}}\n"),
     "10: outputs.expressions.e.units:", "did you mean 'unit'?"),
    ("output-unit-no-value", extra("outputs:\n  expressions: {e: {unit: m}}\n"),
     "10: outputs.expressions.e.value:", "missing required key 'value'"),
    ("output-unit-number", extra("outputs:\n  expressions: {e: {value: q1, unit: 3}}\n"),
     "10: outputs.expressions.e.unit:", "expected a unit label"),
    ("output-unit-empty", extra("outputs:\n  expressions: {e: {value: q1, unit: ' '}}\n"),
     "10: outputs.expressions.e.unit:", "the unit label is empty"),
    # simulation
    ("simulation-on", extra("simulation: on\n"), "9: simulation:",
     "expected a mapping, got 'on'"),
    ("simulation-unknown", extra("simulation:\n  tspan: [0, 1]\n"), "10: simulation.tspan:",
     "did you mean 't_span'?"),
    ("t-span-order", extra("simulation:\n  t_span: [1, 0]\n"), "10: simulation.t_span:",
     "end must be after the start"),
    ("t-span-shape", extra("simulation:\n  t_span: [1]\n"), "10: simulation.t_span:",
     "expected [t0, t1]"),
    ("t-span-name", extra("simulation:\n  t_span: [0, m]\n"), "10: simulation.t_span[1]:",
     "unknown name 'm'"),
    ("t-span-bool", extra("simulation:\n  t_span: [0, true]\n"), "10: simulation.t_span[1]:",
     "got boolean true"),
    ("method", extra("simulation:\n  method: rk45\n"), "10: simulation.method:",
     "unknown method 'rk45' (did you mean 'RK45'?)"),
    ("rtol-negative", extra("simulation:\n  rtol: -1\n"), "10: simulation.rtol:", "> 0"),
    ("atol-bool", extra("simulation:\n  atol: true\n"), "10: simulation.atol:",
     "got boolean true"),
    ("atol-inf", extra("simulation:\n  atol: .inf\n"), "10: simulation.atol:", "finite"),
    ("initial-unknown", extra("simulation:\n  initial: {q3: 1}\n"), "10: simulation.initial.q3:",
     "unknown coordinate or rate 'q3'"),
    ("initial-bad-rate", extra("simulation:\n  initial: {dot(q3): 1}\n"),
     "10: simulation.initial.dot(q3):", "unknown coordinate or rate"),
    ("initial-uses-coordinate", extra("simulation:\n  initial: {dot(q2): q1}\n"),
     "10: simulation.initial.dot(q2):", "'q1' is a coordinate"),
    ("initial-nonfinite", extra("simulation:\n  initial: {q1: log(0)}\n"),
     "10: simulation.initial.q1:", "not finite"),
    ("t-eval-step-zero", extra("simulation:\n  t_span: [0, 1]\n  t_eval: {step: 0}\n"),
     "11: simulation.t_eval.step:", "must be a number > 0"),
    ("t-eval-step-key", extra("simulation:\n  t_span: [0, 1]\n  t_eval: {stp: 1}\n"),
     "11: simulation.t_eval.stp:", "did you mean 'step'?"),
    ("t-eval-needs-span", extra("simulation:\n  t_eval: {step: 0.1}\n"), "10: simulation.t_eval:",
     "t_eval needs simulation.t_span"),
    ("t-eval-order", extra("simulation:\n  t_span: [0, 1]\n  t_eval: [0, 0.5, 0.4]\n"),
     "11: simulation.t_eval[2]:", "times must increase"),
    ("t-eval-outside", extra("simulation:\n  t_span: [0, 1]\n  t_eval: [0, 2]\n"),
     "11: simulation.t_eval:", "inside t_span"),
    ("t-eval-scalar", extra("simulation:\n  t_span: [0, 1]\n  t_eval: 0.1\n"),
     "11: simulation.t_eval:", "expected {step: h} or a list of times"),
    # YAML level
    ("duplicate-key", variant("name: t", "name: t\nname: u"), "2: name:", "duplicate key"),
    ("duplicate-nested", variant("{mass: 1, inertia: 1}", "{mass: 1, inertia: 1, mass: 2}"),
     "5: bodies.b2.mass:", "duplicate key (first at line 5)"),
    ("tab", variant("  b2:", "\tb2:"), "m.yaml:5:", "tabs are not allowed"),
    ("unclosed", variant("{P: [L, 0]}}", "{P: [L, 0}}"), "m.yaml:4:", "YAML syntax error"),
    ("two-documents", BASE + "---\nname: u\n", "m.yaml:9:", "single document"),
    ("complex-key", variant("name: t", "[a]: t"), "m.yaml:1:", "mapping key must be"),
    ("empty", "", "m.yaml:1:", "file is empty"),
    ("comment-only", "# nothing\n", "m.yaml:1:", "file is empty"),
    ("non-utf8", BASE.encode() + b"# caf\xe9\n", "m.yaml:9:", "not valid UTF-8"),
    ("control-character", BASE + "# \x07\n", "m.yaml:9:", "invalid character"),
    ("recursive-alias", extra("loads: &a [*a]\n"), "m.yaml:9:", "recursive alias"),
]


@pytest.mark.parametrize("text, where, message", [case[1:] for case in BAD],
                         ids=[case[0] for case in BAD])
def test_bad_input(text: str | bytes, where: str, message: str) -> None:
    report = problems(text)
    prefix = where if where.startswith("m.yaml:") else f"m.yaml:{where}"
    lines = [line for line in report.splitlines() if line.startswith(prefix)]
    assert lines, f"no problem at {prefix!r} in:\n{report}"
    assert any(message in line for line in lines), report


def test_every_problem_is_reported_at_once() -> None:
    text = variant("mass: m", "mass: -m").replace("parent: b1", "parent: b3")
    report = problems(extra("simulation: {method: rk45}\n").replace("mass: m", "mass: -m")
                      .replace("parent: b1", "parent: b3"))
    assert "bodies.b1.mass" in report and "joints.B.parent" in report
    assert "simulation.method" in report
    assert problems(text).count("\n") >= 1


def test_on_yes_are_strings(tmp_path: Path) -> None:
    m = load(extra("description: on\nsimulation: {method: RK45}\n"), tmp_path)
    assert m.description == "on"
    assert "got 'yes'" in problems(extra("outputs: {energy: yes}\n"))
    assert "got 'off'" in problems(extra("outputs: {accelerations: off}\n"))


def test_quoted_numbers_are_expressions(tmp_path: Path) -> None:
    m = load(variant("{m: 1, L: 2}", "{m: '1', L: \"2e-3\"}"), tmp_path)
    assert m.parameters[0].expr == 1 and m.parameters[1].expr == sympy.Float(0.002)


def test_yaml_12_numbers(tmp_path: Path) -> None:
    m = load(variant("{m: 1, L: 2}", "{m: 0x1F, L: 0o17, c: 1.0e-6, d: 017, e: +.5}"), tmp_path)
    values = {p.name: p.expr for p in m.parameters}
    assert values == {"m": 31, "L": 15, "c": sympy.Float(1e-6), "d": 17, "e": sympy.Float(0.5)}


def test_alias_bomb_is_refused_within_the_node_limits_work() -> None:
    """10^9 nodes by aliases, refused at the 100,000th: the work and memory of about 100,000
    nodes (a few calls and a few hundred bytes each), not of 10^9."""
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]
    work = work_of(lambda: problems("\n".join(lines) + "\n"))
    assert "more than 100000 nodes" in work.result
    assert work.calls < 20 * 100_000 and work.peak_bytes < 1000 * 100_000, work


def test_small_aliases_are_fine(tmp_path: Path) -> None:
    m = load(variant("{mass: 1, inertia: 1}", "&b {mass: 1, inertia: 1}")
             .replace("{mass: m, inertia: 1, points: {P: [L, 0]}}",
                      "{mass: m, inertia: 1, points: {P: &p [L, 0]}}"), tmp_path)
    assert m.bodies[0].points["P"] == (S("L"), 0)


def test_deep_yaml_is_refused() -> None:
    assert "nested" in problems("a: " + "[" * 10_000 + "]" * 10_000 + "\n")


def test_too_large_file() -> None:
    assert "too large" in problems(b"#" * 10_000_001)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot read file"):
        load_mechanism(tmp_path / "nope.yaml")


def test_problem_names_the_file_as_given(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "bad.yaml").write_text(variant("mass: m", "mass: -m"))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError) as info:
        load_mechanism("bad.yaml")
    assert str(info.value).startswith("bad.yaml:4: bodies.b1.mass: must be >= 0")
