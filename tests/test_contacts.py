"""Contacts that last (format v3 `contacts`, issue 50; decision 0041): reading them (every bad
item refused at its FILE:LINE with its key), the kind's geometry against closed forms (a ball on
a floor, Housner's block's corner) and against a second derivation on a moving surface (the
normal speed is the gap's time derivative; the tangent speed is the rate of the rolling
constraint's holonomic form, nemc/kinds/constraints/rolling.py), and the build's refusal while
the dynamics are not built."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
import sympy

from nemc.derive.kinematics import Kinematics
from nemc.errors import InputError
from nemc.front.validate import load_mechanism, validate_text
from nemc.kinds.terms import rate_symbol, symbol

DATA = Path(__file__).parent / "data" / "friction"
BALL = """name: ball
parameters:
  m: 0.2
  r: 0.05
  e: 0.5
  mu: 0.02
gravity: [0, -9.81]
bodies:
  ball: {mass: m, inertia: 2*m*r**2/5}
  plate: {mass: 1, inertia: 0.1}
joints:
  flight: {type: free, parent: ground, child: ball, coordinates: [x, y, th]}
  tilt: {type: revolute, parent: ground, child: plate, coordinate: a}
contacts:
  floor: {point: ball.origin, radius: r, surface: {body: ground, at: [0, 0], axis: [1, 0]},
          restitution: e, mu: mu}
simulation:
  t_span: [0, 1]
  method: nemc.Vern9
"""
CONTACT_LINE = BALL.splitlines().index("contacts:") + 2  # the floor's line
ITEM = ("{point: ball.origin, radius: r, surface: {body: ground, at: [0, 0], axis: [1, 0]},\n"
        "          restitution: e, mu: mu}")

# item (replacing the floor's), its problem's line, its key path, the message's words
BAD = {
    "ground point": ("{point: ground.origin, surface: {body: plate}}", CONTACT_LINE,
                     "contacts.floor.point", "point of the ground"),
    "ground point as a mapping": ("{point: {body: ground, at: [1, 0]}, surface: {body: plate}}",
                                  CONTACT_LINE, "contacts.floor.point", "point of the ground"),
    "unknown surface body": ("{point: ball.origin, surface: {body: flor}}", CONTACT_LINE,
                             "contacts.floor.surface.body", "unknown body 'flor'"),
    "no surface": ("{point: ball.origin, radius: r}", CONTACT_LINE, "contacts.floor",
                   "surface"),
    "itself": ("{point: ball.origin, surface: {body: ball}}", CONTACT_LINE,
               "contacts.floor.surface.body", "cannot touch itself"),
    "negative radius": ("{point: ball.origin, radius: -r, surface: {body: ground}}",
                        CONTACT_LINE, "contacts.floor.radius", "must be >= 0"),
    "negative restitution": ("{point: ball.origin, surface: {body: ground},\n"
                             "          restitution: -e}", CONTACT_LINE + 1,
                             "contacts.floor.restitution", "must be >= 0"),
    "restitution above 1": ("{point: ball.origin, surface: {body: ground},\n"
                            "          restitution: 2*e + 0.1}", CONTACT_LINE + 1,
                            "contacts.floor.restitution", "restitution must be <= 1"),
    "negative mu": ("{point: ball.origin, surface: {body: ground},\n          mu: -mu}",
                    CONTACT_LINE + 1, "contacts.floor.mu", "must be >= 0"),
    "unknown key": ("{point: ball.origin, surface: {body: ground}, bogus: 1}", CONTACT_LINE,
                    "contacts.floor", "bogus"),
    "unknown surface key": ("{point: ball.origin, surface: {body: ground, normal: [0, 1]}}",
                            CONTACT_LINE, "contacts.floor.surface", "normal"),
    "zero axis": ("{point: ball.origin, surface: {body: ground, axis: [0, 0]}}", CONTACT_LINE,
                  "contacts.floor.surface.axis", "must not be [0, 0]"),
    "unknown point": ("{point: ball.rim, surface: {body: ground}}", CONTACT_LINE,
                      "contacts.floor.point", "no point 'rim'"),
}


def _refusal(text: str, tmp_path: Path) -> InputError:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as caught:
        load_mechanism(path)
    return caught.value


@pytest.mark.parametrize("case", BAD)
def test_a_bad_contact_is_refused_at_its_line_with_its_key(case: str, tmp_path: Path) -> None:
    item, line, key, words = BAD[case]
    assert ITEM in BALL
    error = _refusal(BALL.replace(ITEM, item), tmp_path)
    text = str(error)
    assert f"{tmp_path / 'bad.yaml'}:{line}: {key}" in text, text
    assert words in text


@pytest.mark.parametrize("method", ["BDF", "Radau", "nemc.Radau", "nemc.Taylor"])
def test_a_method_that_cannot_run_contacts_is_refused_at_its_line(method: str,
                                                                   tmp_path: Path) -> None:
    text = str(_refusal(BALL.replace("method: nemc.Vern9", f"method: {method}"), tmp_path))
    line = BALL.splitlines().index("  method: nemc.Vern9") + 1
    assert f"bad.yaml:{line}: simulation.method: {method} cannot run a mechanism with " \
           "contacts (floor)" in text, text


def test_a_contact_named_like_a_body_is_refused(tmp_path: Path) -> None:
    text = str(_refusal(BALL.replace("  floor: {point", "  plate: {point"), tmp_path))
    assert f"bad.yaml:{CONTACT_LINE}: contacts.plate" in text and "already used" in text


@pytest.mark.parametrize("text", ["contacts: [1, 2]", "contacts: {}"])
def test_contacts_that_are_not_a_mapping_are_refused(text: str, tmp_path: Path) -> None:
    bad = BALL.replace("contacts:\n  floor: " + ITEM, text)
    line = bad.splitlines().index(text) + 1
    assert f"bad.yaml:{line}: contacts: expected a mapping of contacts" in \
        str(_refusal(bad, tmp_path))


def test_nemc_check_says_the_contacts_are_read_but_not_built(capsys) -> None:
    from nemc.tools.cli import main

    assert main(["check", str(DATA / "rocking_block.yaml")]) == 0
    assert "3 coordinates, 2 contacts, 3 degrees" in capsys.readouterr().out


def _speeds(mech, contact) -> tuple[Kinematics, sympy.Expr, sympy.Expr, sympy.Expr]:
    kin = Kinematics(mech)
    normal, tangent = contact.speeds(kin)
    return kin, contact.gap(kin), normal, tangent


def _numbers(seed: int, names: list[str]) -> dict[sympy.Symbol, float]:
    """Random values of the coordinates and rates named (seeded)."""
    draw = random.Random(seed)
    return {s: draw.uniform(-2, 2) for name in names for s in (symbol(name), rate_symbol(name))}


def _equal(a: sympy.Expr, b: sympy.Expr, at: dict) -> bool:
    return abs(float((a - b).xreplace(at))) <= 1e-13 * (1 + abs(float(b.xreplace(at))))


def test_a_ball_on_the_floor_has_the_closed_form_gap_speeds_and_jacobian() -> None:
    """gap = y - r, normal speed dot(y), slip dot(x) + r dot(th) (ball_to_rest.yaml's `slip`);
    Jacobian rows [0, 1, 0] and [1, 0, r] in (dot(x), dot(y), dot(th))."""
    mech = load_mechanism(DATA / "ball_to_rest.yaml")
    contact = mech.contacts[0]
    kin, gap, normal, tangent = _speeds(mech, contact)
    x, y, th, r = (symbol(n) for n in ("x", "y", "th", "r"))
    assert sympy.simplify(gap - (y - r)) == 0
    assert sympy.simplify(normal - rate_symbol("y")) == 0
    assert sympy.simplify(tangent - (rate_symbol("x") + r * rate_symbol("th"))) == 0
    rows = contact.jacobian_rows(kin, kin.u)
    assert [[sympy.simplify(v) for v in row] for row in rows] == [[0, 1, 0], [1, 0, r]]
    assert {x, th}.isdisjoint(gap.free_symbols)


def test_a_corner_of_the_rocking_block_has_the_closed_form_gap_and_speeds() -> None:
    """Corner cl = (-b, -h): gap y - b sin(th) - h cos(th), its rate the normal speed, and the
    corner's horizontal velocity dot(x) + (b sin(th) + h cos(th)) dot(th) the slip."""
    mech = load_mechanism(DATA / "rocking_block.yaml")
    left = mech.contacts[0]
    _, gap, normal, tangent = _speeds(mech, left)
    y, th, b, h = (symbol(n) for n in ("y", "th", "b", "h"))
    at = {**_numbers(1, ["x", "y", "th"]), b: 0.1, h: 0.4}
    dy, dth = rate_symbol("y"), rate_symbol("th")
    assert _equal(gap, y - b * sympy.sin(th) - h * sympy.cos(th), at)
    assert _equal(normal, dy - b * sympy.cos(th) * dth + h * sympy.sin(th) * dth, at)
    assert _equal(tangent, rate_symbol("x") + (b * sympy.sin(th) + h * sympy.cos(th)) * dth, at)


MOVING = """name: moving
parameters: {R: 0.3, c: 0.7, d: -0.2}
bodies:
  disc: {mass: 1, inertia: 0.1}
  cart: {mass: 2, inertia: 0.2}
  plate: {mass: 1, inertia: 0.1}
joints:
  flight: {type: free, parent: ground, child: disc, coordinates: [x, y, th]}
  rail: {type: prismatic, parent: ground, child: cart, coordinate: s, axis: [1, 2]}
  tilt: {type: revolute, parent: cart, child: plate, coordinate: a, at: [0.5, 0.1]}
contacts:
  touch: {point: disc.origin, radius: R, surface: {body: plate, at: [c, d], axis: [2, 1]}}
"""


@pytest.mark.parametrize("seed", range(3))
def test_on_a_moving_surface_the_speeds_are_rates_of_the_geometry(seed: int) -> None:
    """A disc against a line of a plate that slides and turns: the normal speed is d/dt of the
    gap, and the tangent speed d/dt(u . (p - a)) + R (dot(th) - dot(a)) (the rate of the
    rolling constraint's holonomic form: what rolling without slip keeps at 0)."""
    mech = validate_text(MOVING, "moving.yaml")
    contact = mech.contacts[0]
    kin, gap, normal, tangent = _speeds(mech, contact)
    plate, disc = kin.frame("plate"), kin.frame("disc")
    axis = sympy.Matrix([2, 1]) / sympy.sqrt(5)
    u = plate.rotate((axis[0], axis[1]))
    p, a = disc.origin, plate.point((symbol("c"), symbol("d")))
    along = u[0] * (p[0] - a[0]) + u[1] * (p[1] - a[1])
    rolled = kin.rate(along) + symbol("R") * (rate_symbol("th") - rate_symbol("a"))
    at = {**_numbers(seed, ["x", "y", "th", "s", "a"]), symbol("R"): 0.3, symbol("c"): 0.7,
          symbol("d"): -0.2}
    assert _equal(normal, kin.rate(gap), at)
    assert _equal(tangent, rolled, at)
    assert abs(float(gap.xreplace(at))) > 1e-3  # away from touching: the identities are general


@pytest.mark.parametrize("name, discs, surfaces", [("ball_to_rest", 1, 1),
                                                    ("rocking_block", 0, 2)])
def test_a_contact_is_drawn_as_its_line_and_disc(name: str, discs: int, surfaces: int) -> None:
    """Figures and animations show each contact's line and, for a disc around a body's origin,
    the disc (nemc/derive/geometry.py, as for a rolling constraint)."""
    from nemc.derive.geometry import drawing

    picture = drawing(load_mechanism(DATA / f"{name}.yaml"))
    assert (len(picture.discs), len(picture.surfaces)) == (discs, surfaces)
    for surface in picture.surfaces:  # the floor: through (0, 0), along (1, 0)
        at, ahead = (picture.points[surface[key]][1:] for key in ("at", "axis"))
        assert [sympy.sympify(v) for v in (*at, *ahead)] == [0, 0, 1, 0]
