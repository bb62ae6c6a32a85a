"""The mechanism's drawing: which points a picture of it needs, and their ground positions.

A drawing shows each body as the outline through its points (origin, com, named points; a body
with no named points as a bar from its origin through its mass centre to twice as far), each
joint where it connects, as the joint says it is drawn (Joint.drawing), each load the way it
says (Load.drawing: a spring between its ends, or on a joint) and the path of the points the
scene asks for. Their ground-frame positions are expressions of the coordinates and parameters; the
build compiles them into the model's C (`<name>_positions`, templates/positions.c.tmpl), so a
picture shows exactly what the compiled model computes. The drawing's structure (which point
belongs to which body, joint or spring) goes to the build's metadata (`drawing`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import sympy

from ..front import mechanism as m
from ..kinds.constraints.base import ConstraintDrawing
from .kinematics import Kinematics


@dataclass(frozen=True)
class Drawing:
    """Points (name, ground-frame x and y expressions) and what connects them, by index."""

    points: list[tuple[str, sympy.Expr, sympy.Expr]] = field(default_factory=list)
    bodies: dict[str, list[int]] = field(default_factory=dict)
    coms: dict[str, int] = field(default_factory=dict)
    joints: list[dict] = field(default_factory=list)
    springs: list[dict] = field(default_factory=list)
    traces: list[int] = field(default_factory=list)
    discs: list[dict] = field(default_factory=list)  # {center, rim}: a rolling disc
    surfaces: list[dict] = field(default_factory=list)  # {at, axis, origin}: what it rolls on
    blades: list[dict] = field(default_factory=list)  # {at, axis}: a knife edge
    segments: list[dict] = field(default_factory=list)  # {a, b}: a contact's surface with ends

    def metadata(self) -> dict:
        found = {"points": [name for name, _, _ in self.points], "bodies": self.bodies,
                 "coms": self.coms, "joints": self.joints, "springs": self.springs,
                 "traces": self.traces}
        # only where a constraint draws them
        for key in ("discs", "surfaces", "blades", "segments"):
            if getattr(self, key):
                found[key] = getattr(self, key)
        return found


# where a point fixed in a body (its name, body-frame xy) is in the ground frame: (x, y)
Locate = Callable[[str, m.Vec2], Sequence[sympy.Expr]]


class _Builder:
    def __init__(self, mech: m.Mechanism, locate: Locate | None):
        self.locate = locate or Kinematics(mech).position
        self.drawing = Drawing()
        self.index: dict[tuple[str, tuple], int] = {}

    def point(self, name: str, body: str, xy: m.Vec2) -> int:
        """The index of a point fixed in BODY at XY (body frame); the same point once."""
        key = (body, tuple(sympy.sympify(v) for v in xy))
        if key not in self.index:
            position = self.locate(body, xy)
            self.index[key] = len(self.drawing.points)
            self.drawing.points.append((name, position[0], position[1]))
        return self.index[key]


def drawing(mech: m.Mechanism, locate: Locate | None = None) -> Drawing:
    """Every point a picture of MECH needs, in a fixed order: bodies, joints, springs.
    locate: how a point's ground position is found (default: whole expressions from
    nemc.kinematics; the build passes names of a program, nemc.articulated.PointPositions)."""
    builder = _Builder(mech, locate)
    for body in mech.bodies:
        named = [("origin", (0, 0)), ("com", body.com), *body.points.items()]
        if not body.points and any(sympy.sympify(v) != 0 for v in body.com):
            # no named points: drawn as a uniform bar, origin to twice its mass centre
            named.append(("end", (2 * body.com[0], 2 * body.com[1])))
        indices = [builder.point(f"{body.name}.{point}", body.name, xy) for point, xy in named]
        builder.drawing.bodies[body.name] = list(dict.fromkeys(indices))
        builder.drawing.coms[body.name] = indices[1]
    drawn = [load.drawing() for load in mech.loads]
    sprung = {drawing.on_joint for drawing in drawn if drawing.on_joint is not None}
    for joint in mech.joints:
        at = builder.point(f"{joint.parent}.{joint.name}", joint.parent, joint.at)
        child = builder.point(f"{joint.child}.origin", joint.child, (0, 0))
        shown = joint.drawing()
        entry = {"name": joint.name, "symbol": shown.symbol, "parent": joint.parent,
                 "child": joint.child, "at": at, "origin": child, "sprung": joint.name in sprung}
        if shown.axis is not None:  # a point one length unit along the rail from `at`
            axis = shown.axis
            length = sympy.sqrt(axis[0] ** 2 + axis[1] ** 2)
            ahead = (joint.at[0] + axis[0] / length, joint.at[1] + axis[1] / length)
            entry["axis"] = builder.point(f"{joint.parent}.{joint.name}.axis", joint.parent, ahead)
        builder.drawing.joints.append(entry)
    for k, drawing in enumerate(drawn):
        if drawing.between is not None:
            found = [builder.point(f"loads[{k}].{end}" if ref.body == m.GROUND else ref.label,
                                   ref.body, ref.xy) for end, ref in zip("ab", drawing.between)]
            builder.drawing.springs.append({"a": found[0], "b": found[1], "load": k})
    for constraint in mech.constraints:
        constraint_drawing(builder, constraint.name, constraint.drawing())
    for contact in mech.contacts:  # drawn as a rolling constraint is: its line, its disc
        constraint_drawing(builder, contact.name, contact.shape())
    for ref in mech.outputs.points:
        builder.drawing.traces.append(builder.point(ref.label, ref.body, ref.xy))
    return builder.drawing


def constraint_drawing(builder: _Builder, name: str, shown: ConstraintDrawing) -> None:
    """A constraint's discs (center and a rim point), surfaces and blades (a point and one
    length unit along the axis from it), and segments (their two ends)."""
    picture = builder.drawing
    for body, radius in shown.discs:
        picture.discs.append({"center": builder.point(f"{body}.origin", body, (0, 0)),
                              "rim": builder.point(f"{name}.{body}.rim", body, (radius, 0))})
    for body, xy, axis, disc in shown.surfaces:
        at, ahead = along(builder, name, body, xy, axis)
        picture.surfaces.append({"at": at, "axis": ahead,
                                 "origin": builder.point(f"{disc}.origin", disc, (0, 0))})
    for body, xy, axis in shown.blades:
        at, ahead = along(builder, name, body, xy, axis)
        picture.blades.append({"at": at, "axis": ahead})
    for body, one, other in shown.segments:
        picture.segments.append({"a": builder.point(f"{name}.at", body, one),
                                 "b": builder.point(f"{name}.end", body, other)})


def along(builder: _Builder, name: str, body: str, xy: m.Vec2, axis: m.Vec2) -> tuple[int, int]:
    length = sympy.sqrt(axis[0] ** 2 + axis[1] ** 2)
    ahead = (xy[0] + axis[0] / length, xy[1] + axis[1] / length)
    return (builder.point(f"{name}.at", body, xy),
            builder.point(f"{name}.axis", body, ahead))
