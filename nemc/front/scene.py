"""The scene: `simulation` (time span, initial values and the assembly's guess, output times,
method and tolerances, the inputs' values), its run control (events, max_step, tstops, the step
budget) and the `units` labels.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import sympy

from ..vocabulary import METHODS  # the scene accepts exactly what simulate accepts
from .context import Context, check_keys, described, entries_of, items_of, join_path, suggestion
from .fields import read_choice, read_expr, read_fixed, read_number, read_string
from .mechanism import Event, Simulation, Units
from .names import register_name
from .parse import Node


def read_simulation(ctx: Context, node: Node) -> Simulation:
    keys = ("t_span", "initial", "t_eval", "method", "rtol", "atol", "guess", "inputs",
            *RUN_CONTROL_KEYS)
    if not check_keys(ctx, node, "simulation", keys):
        return Simulation()
    entries = entries_of(node)
    t_span = _t_span(ctx, entries["t_span"]) if "t_span" in entries else None
    initial = _initial(ctx, entries["initial"]) if "initial" in entries else {}
    t_eval = step = None
    if "t_eval" in entries:
        t_eval, step = _t_eval(ctx, entries["t_eval"], t_span, "t_span" in entries)
    method = None
    if "method" in entries:
        method = read_choice(ctx, entries["method"], "simulation.method", METHODS, "method")
    tolerances = {key: _positive(ctx, entries[key], join_path("simulation", key))
                  if key in entries else None for key in ("rtol", "atol")}
    if tolerances["rtol"] is not None and not tolerances["rtol"] < 1:  # as every run refuses
        ctx.problem(entries["rtol"].line, "simulation.rtol", "must be a number > 0 and < 1 (a "
                    f"relative error), got {tolerances['rtol']:g}")
        tolerances["rtol"] = None
    guess = {}
    if "guess" in entries:
        guess = _initial(ctx, entries["guess"], "simulation.guess", rates=False)
    initial_loc = (ctx.loc(entries["initial"], "simulation.initial") if "initial" in entries
                   else None)
    inputs = _scene_inputs(ctx, entries["inputs"]) if "inputs" in entries else {}
    return Simulation(t_span, initial, t_eval, step, method, tolerances["rtol"],
                      tolerances["atol"], guess, initial_loc, **_run_control(ctx, entries, t_span),
                      inputs=inputs)


def _scene_inputs(ctx: Context, node: Node) -> dict[str, sympy.Expr]:
    """The scene's values of inputs: input name -> expression of parameters, constants and t."""
    path = "simulation.inputs"
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a mapping input name -> value, {described(node)}")
        return {}
    found = {}
    for name, value in entries_of(node).items():
        key = join_path(path, name)
        if name not in ctx.inputs:
            known = ", ".join(ctx.inputs) or "none: declare them under inputs:"
            ctx.problem(node.key_lines[name], key, f"unknown input {name!r}"
                        f"{suggestion(name, ctx.inputs)}; the inputs: {known}")
            continue
        expr = read_expr(ctx, value, key, ctx.scope("scene inputs"))
        if expr is not None:
            found[name] = expr
    return found


def _positive(ctx: Context, node: Node, path: str) -> float | None:
    value = read_number(ctx, node, path)
    if value is not None and value <= 0:
        ctx.problem(node.line, path, f"must be a number > 0, got {value:g}")
        return None
    return value


def _t_span(ctx: Context, node: Node) -> tuple[float, float] | None:
    path = "simulation.t_span"
    if not node.is_list or len(items_of(node)) != 2:
        ctx.problem(node.line, path, f"expected [t0, t1], {described(node)}")
        return None
    t0, t1 = (read_number(ctx, item, join_path(path, i)) for i, item in enumerate(items_of(node)))
    if t0 is None or t1 is None:
        return None
    if not t1 > t0:
        ctx.problem(node.line, path, f"the end must be after the start, got [{t0:g}, {t1:g}]")
        return None
    return (t0, t1)


LARGEST_STATE = 1e150  # a state's value whose square (centripetal terms, distances) is finite


def _initial(ctx: Context, node: Node, path: str = "simulation.initial",
             rates: bool = True) -> dict[str, sympy.Expr]:
    """Values of the state's coordinates (and, where `rates`, of their rates): `initial`, or
    the assembly's `guess`."""
    what = "q or dot(q)" if rates else "q"
    if not node.is_map:
        ctx.problem(node.line, path, f"expected a mapping {what} -> value, {described(node)}")
        return {}
    driven = driven_coordinates(ctx)
    free = [q for q in ctx.coordinates if q not in driven]
    states = [name for q in free for name in ((q, f"dot({q})") if rates else (q,))]
    initial: dict[str, sympy.Expr] = {}
    for key, value in entries_of(node).items():
        match = re.fullmatch(r"dot\(\s*(\w+)\s*\)", key)
        name = f"dot({match.group(1)})" if match else key
        coordinate = match.group(1) if match else key
        if coordinate in driven:
            ctx.problem(node.key_lines[key], join_path(path, key), f"{coordinate} is driven "
                        f"(joints.{driven[coordinate]}.motion): its value is prescribed, not "
                        "given here")
            continue
        if name not in states:
            ctx.problem(node.key_lines[key], join_path(path, key), f"unknown coordinate"
                        f"{' or rate' if rates else ''} {key!r}{suggestion(key, states)}; "
                        f"expected a coordinate {what}")
            continue
        if name in initial:
            ctx.problem(node.key_lines[key], join_path(path, key), f"{name} is given twice")
            continue
        expr = read_fixed(ctx, value, join_path(path, key))
        if expr is not None and expr.is_number and not abs(float(expr)) <= LARGEST_STATE:
            ctx.problem(node.key_lines[key], join_path(path, key), f"{float(expr):g} is too "
                        f"large: a state's values are at most {LARGEST_STATE:g} in size (their "
                        "squares, in every centripetal term and loop distance, must stay "
                        "finite)")
            continue
        if expr is not None:
            initial[name] = expr
    return initial


def _t_eval(ctx: Context, node: Node, t_span: tuple[float, float] | None,
            has_span: bool) -> tuple[tuple[float, ...] | None, float | None]:
    path = "simulation.t_eval"
    if not has_span:
        ctx.problem(node.line, path, "t_eval needs simulation.t_span")
    if node.is_map:
        if not check_keys(ctx, node, path, ("step",), ("step",), what="{step: h}"):
            return None, None
        step = entries_of(node).get("step")
        return None, _positive(ctx, step, join_path(path, "step")) if step is not None else None
    if not node.is_list or not node.value:
        ctx.problem(node.line, path, f"expected {{step: h}} or a list of times, {described(node)}")
        return None, None
    return _times(ctx, node, path, t_span), None


def _times(ctx: Context, node: Node, path: str, t_span: tuple[float, float] | None
           ) -> tuple[float, ...] | None:
    """A non-empty list of increasing times inside t_span (when the scene gives one)."""
    times = [read_number(ctx, item, join_path(path, i)) for i, item in enumerate(items_of(node))]
    if None in times:
        return None
    for i, (before, after) in enumerate(zip(times, times[1:])):
        if not after > before:  # type: ignore[operator]
            ctx.problem(node.line, join_path(path, i + 1), "times must increase, got "
                                                       f"{after:g} after {before:g}")
            return None
    if t_span is not None and (times[0] < t_span[0] or times[-1] > t_span[1]):  # type: ignore
        ctx.problem(node.line, path, f"times must lie inside t_span [{t_span[0]:g}, "
                                     f"{t_span[1]:g}], got [{times[0]:g} .. {times[-1]:g}]")
        return None
    return tuple(times)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- run control
# Format v2: events, max_step, tstops and the step budget (docs/decisions.md, "Format v2:
# events, max_step, tstops").

RUN_CONTROL_KEYS = ("events", "max_step", "tstops", "max_steps")
EVENT_KEYS = ("when", "direction", "action")
EVENT_DIRECTIONS = ("rising", "falling", "both")
EVENT_ACTIONS = ("record", "stop")  # or a mapping: an impact law
MAX_STEPS_LIMIT = 2**62  # a C long


def _run_control(ctx: Context, entries: Mapping[str, Node],
                 t_span: tuple[float, float] | None) -> dict:
    """The scene's events, max_step, tstops and max_steps, as Simulation's keyword arguments."""
    found: dict = {}
    if "events" in entries:
        found["events"] = _events(ctx, entries["events"])
    if "max_step" in entries:
        found["max_step"] = _positive(ctx, entries["max_step"], "simulation.max_step")
    if "tstops" in entries:
        found["tstops"] = _tstops(ctx, entries["tstops"], t_span)
    if "max_steps" in entries:
        found["max_steps"] = _max_steps(ctx, entries["max_steps"])
    return {key: value for key, value in found.items() if value is not None}


def _events(ctx: Context, node: Node) -> tuple[Event, ...]:
    path = "simulation.events"
    if not node.is_map or not node.value:
        ctx.problem(node.line, path, "expected a mapping event name -> {when, direction, "
                                     f"action}}, {described(node)}")
        return ()
    events = []
    for name, item in entries_of(node).items():
        item_path = join_path(path, name)
        if not register_name(ctx, name, node.key_lines[name], item_path, "event"):
            continue
        event = _event(ctx, name, item, item_path)
        if event is not None:
            events.append(event)
    return tuple(events)


def _event(ctx: Context, name: str, node: Node, path: str) -> Event | None:
    if not check_keys(ctx, node, path, EVENT_KEYS, ("when",), what="{when, direction, action}"):
        return None
    entries = entries_of(node)
    if "when" not in entries:
        return None
    when = read_expr(ctx, entries["when"], join_path(path, "when"), ctx.scope("event"))
    direction = "both"
    if "direction" in entries:
        direction = read_choice(ctx, entries["direction"], join_path(path, "direction"),
                                EVENT_DIRECTIONS, "direction")
    action, law = "record", ()
    if "action" in entries:
        action, law = _event_action(ctx, entries["action"], join_path(path, "action"))
    if when is None or direction is None or action is None:
        return None
    return Event(name, when, direction, action, law, ctx.loc(node, path))  # type: ignore


def driven_coordinates(ctx: Context) -> dict[str, str]:
    """Each driven coordinate -> its joint's name (its value is the joint's motion)."""
    return {q: joint.name for joint in ctx.joints.values() if joint.driven
            for q in joint.coordinates}


def _event_action(ctx: Context, node: Node, path: str
                  ) -> tuple[str | None, tuple[tuple[str, sympy.Expr], ...]]:
    """record, stop, or an impact law {q or dot(q): new value, ...} (action "impact")."""
    if not node.is_map:
        if not isinstance(node.value, str):
            ctx.problem(node.line, path, "expected record, stop, or a mapping of new values "
                                         "{q or dot(q): expression} (an impact), "
                                         f"{described(node)}")
            return None, ()
        return read_choice(ctx, node, path, EVENT_ACTIONS, "action"), ()
    if not node.value:
        ctx.problem(node.line, path, "an impact law needs at least one new value "
                                     "{q or dot(q): expression}")
        return None, ()
    states = [name for q in ctx.coordinates for name in (q, f"dot({q})")]
    driven = driven_coordinates(ctx)
    law: dict[str, sympy.Expr] = {}
    ok = True
    for key, value in entries_of(node).items():
        match = re.fullmatch(r"dot\(\s*(\w+)\s*\)", key)
        state = f"dot({match.group(1)})" if match else key
        key_path, line = join_path(path, key), node.key_lines[key]
        coordinate = match.group(1) if match else key
        if coordinate in driven:
            ctx.problem(line, key_path, f"{coordinate} is driven (joints.{driven[coordinate]}"
                                        ".motion): its value is prescribed; an impact law "
                                        "cannot set it")
            ok = False
        elif state not in states:
            ctx.problem(line, key_path, f"unknown coordinate or rate {key!r}"
                                        f"{suggestion(key, states)}; an impact law sets "
                                        "coordinates q and rates dot(q)")
            ok = False
        elif state in law:
            ctx.problem(line, key_path, f"{state} is given twice")
            ok = False
        else:
            expr = read_expr(ctx, value, key_path, ctx.scope("event"))
            ok = ok and expr is not None
            if expr is not None:
                law[state] = expr
    return ("impact" if ok else None), tuple(law.items())


def _tstops(ctx: Context, node: Node, t_span: tuple[float, float] | None
            ) -> tuple[float, ...] | None:
    path = "simulation.tstops"
    if not node.is_list or not node.value:
        ctx.problem(node.line, path, f"expected a list of times, {described(node)}")
        return None
    return _times(ctx, node, path, t_span)


def _max_steps(ctx: Context, node: Node) -> int | None:
    path = "simulation.max_steps"
    value = read_number(ctx, node, path)
    if value is None:
        return None
    if not (0 <= value <= MAX_STEPS_LIMIT and value == int(value)):
        ctx.problem(node.line, path, "expected a whole number of steps >= 0 (0: no budget), "
                                     f"got {value:g}")
        return None
    return int(value)


# ----------------------------------------------------------------------------- units

UNIT_KEYS = ("length", "mass", "time", "angle")
ANGLE_DISPLAYS = ("rad", "deg")
# A unit label goes into figures, CSV headers and MATLAB files: letters, digits and a few
# signs, never `$` (matplotlib's mathtext), quotes, commas or control characters.
UNIT_LABEL = re.compile(r"[^\W\d][\w .*/^()\u00b7\u00b0-]{0,23}")


def read_units(ctx: Context, node: Node) -> Units:
    """`units: {length: m, mass: kg, time: s, angle: deg}`: labels, every key optional."""
    if not check_keys(ctx, node, "units", UNIT_KEYS, what="a mapping {length, mass, time, angle}"):
        return Units()
    entries = entries_of(node)
    labels: dict[str, str | None] = {}
    for key in UNIT_KEYS[:3]:
        labels[key] = _unit_label(ctx, entries[key], join_path("units", key)) if key in entries \
            else None
    angle = "rad"
    if "angle" in entries:
        angle = read_choice(ctx, entries["angle"], "units.angle", ANGLE_DISPLAYS,
                            "angle display (how figures show angles)") or angle
    return Units(labels["length"], labels["mass"], labels["time"], angle)  # type: ignore[arg-type]


def _unit_label(ctx: Context, node: Node, path: str) -> str | None:
    label = read_string(ctx, node, path, "a unit label such as m, kg, s, ft or slug")
    if label is not None and not UNIT_LABEL.fullmatch(label):
        ctx.problem(node.line, path, "a unit label starts with a letter and has at most 24 "
                                     "letters, digits, spaces and . * / ^ ( ) - signs, "
                                     f"got {label!r}")
        return None
    return label
