"""What each column a model reports measures, and its unit label from the YAML's `units:`.

nemc never converts: units are labels for figures, tables, CSV and MATLAB files. Each state and
output name gets a kind of quantity (angle, length, force, ...); its label is composed from the
declared length, mass and time units, with the usual names where a system has them (N and J
for kg, m, s; lb and ft*lb for slug, ft, s). Angles are always radians in the model's values;
`units.angle: deg` only changes how figures and animations show them.

The labels are computed at compile time and stored in the build's metadata (`quantities`,
`unit_labels`), so a standalone package needs no nemc to read them.
"""

from __future__ import annotations

from ..front import mechanism as m

# kind of quantity -> its unit as powers of (length, mass, time), or an angle's label
DIMENSIONS: dict[str, tuple[int, int, int]] = {
    "time": (0, 0, 1),
    "length": (1, 0, 0),
    "speed": (1, 0, -1),
    "acceleration": (1, 0, -2),
    "joint force": (1, 1, -2),
    "couple": (2, 1, -2),
    "energy": (2, 1, -2),
}
ANGULAR = {"angle": "rad", "angular rate": "rad/{T}", "angular acceleration": "rad/{T}^2"}
# (mass, length, time) -> names of force, couple (torque) and energy in that system
NAMED_SYSTEMS: dict[tuple[str, str, str], dict[str, str]] = {
    ("kg", "m", "s"): {"joint force": "N", "couple": "N*m", "energy": "J"},
    ("slug", "ft", "s"): {"joint force": "lb", "couple": "lb*ft", "energy": "ft*lb"},
    ("g", "cm", "s"): {"joint force": "dyn", "couple": "dyn*cm", "energy": "erg"},
}


def coordinate_kinds(mech: m.Mechanism) -> dict[str, str]:
    """Each coordinate's kind: "angle" (revolute, a free joint's th) or "length"."""
    return {q: kind for joint in mech.joints
            for q, kind in zip(joint.coordinates, joint.coordinate_kinds)}


def quantities(mech: m.Mechanism, output_names: list[str]) -> dict[str, str]:
    """name -> kind for t, the state and the outputs; an expression has no kind (left out)."""
    rate = {"angle": "angular rate", "length": "speed"}
    second = {"angle": "angular acceleration", "length": "acceleration"}
    found = {"t": "time"}
    for q, kind in coordinate_kinds(mech).items():
        found |= {q: kind, f"dot({q})": rate[kind], f"ddot({q})": second[kind]}
    joints = {joint.name: joint for joint in mech.joints}
    constraints = {constraint.name for constraint in mech.constraints}  # their reactions
    kind_of = coordinate_kinds(mech)
    joint_kind = {joint.name: kind_of.get(joint.coordinates[0], "angle") if joint.coordinates
                  else "angle" for joint in mech.joints}
    for name, index in mech.load_names:  # what a named load reports
        for suffix, kind in mech.loads[index].reported_kinds(joint_kind.__getitem__):
            found[name + suffix] = kind
    for name in output_names:
        if name in found:
            continue
        head, _, last = name.rpartition(".")
        if head in constraints and last in ("Fx", "Fy", "Fn", "Ft", "M"):
            found[name] = "couple" if last == "M" else "joint force"
        elif head in joints and last in ("Fx", "Fy", "Fn", "Ft"):
            found[name] = "joint force"
        elif head in joints and last == "M":
            found[name] = "couple"
        elif head in joints and last == "drive":  # format version 2's driven joints
            turns = joints[head].coordinate_kinds == ("angle",)
            found[name] = "couple" if turns else "joint force"
        elif head == "energy":
            found[name] = "energy"
        elif any(name.startswith(f"{p.label}.") for p in mech.outputs.points):
            found[name] = "length" if last in ("x", "y") else "speed"
    return found


def label(kind: str | None, units: m.Units) -> str:
    """The unit of a kind of quantity in these units ("" when the YAML does not say)."""
    if kind is None:
        return ""
    if kind in ANGULAR:
        return ANGULAR[kind].format(T=units.time) if units.time or kind == "angle" else ""
    named = NAMED_SYSTEMS.get((units.mass or "", units.length or "", units.time or ""), {})
    if kind in named:
        return named[kind]
    powers = DIMENSIONS[kind]
    symbols = (units.length, units.mass, units.time)
    if any(p and not s for p, s in zip(powers, symbols)):
        return ""
    top = [power_of(s, p) for s, p in zip(symbols, powers) if p > 0]
    bottom = [power_of(s, -p) for s, p in zip(symbols, powers) if p < 0]
    return "*".join(top) + ("/" + "/".join(bottom) if bottom else "")


def power_of(unit: str | None, power: int) -> str:
    text = unit if unit and " " not in unit and "/" not in unit else f"({unit})"
    return text if power == 1 else f"{text}^{power}"


def unit_metadata(mech: m.Mechanism, output_names: list[str]) -> dict:
    """What a build records of units: the declared ones, each column's kind and label (an
    output expression's as its `unit:` says)."""
    kinds = quantities(mech, output_names)
    units = mech.units
    return {
        "units": {"length": units.length, "mass": units.mass, "time": units.time,
                  "angle": units.angle},
        "quantities": kinds,
        "unit_labels": {**{name: label(kind, units) for name, kind in kinds.items()},
                        **dict(mech.outputs.units)},  # an expression's, as the YAML says
    }
