"""Validate a parsed mechanism file and build the :class:`nemc.front.mechanism.Mechanism`.

Every rule of ``shared/spec/mechanism-format.md`` is checked, once: this module walks the file's
top level and hands each section to the module that checks it (names.py, parameters.py,
inputs.py, bodies.py, joints.py, constraints.py, loads.py, friction.py, contacts.py, outputs.py,
scene.py; the values themselves through fields.py and references.py, a kind's keys through
reader.Reader). Problems are collected in a context.Context (not raised one by one) so a user
can fix the whole file in one pass; each names the file, the line, the key path and what was
expected.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping

from ..errors import InputError, Problem
from .bodies import read_bodies
from .carried import check_carried
from .constraints import read_constraints
from .contacts import check_contact_method, read_contacts
from .context import Context, check_keys, entries_of
from .fields import ZERO2, read_string, read_vec2
from .friction import check_guides_without_contacts, read_friction
from .inputs import read_inputs
from .joints import read_joints
from .loads import read_loads
from .mechanism import Mechanism, Outputs, Simulation, Units
from .names import collect_names, model_name
from .outputs import read_outputs
from .parameters import read_parameters
from .parse import Node, parse_text
from .reading import read_file
from .scene import read_simulation, read_units

TOP_KEYS = ("name", "description", "parameters", "constants", "inputs", "gravity", "bodies",
            "joints", "constraints", "loads", "friction", "contacts", "outputs", "simulation",
            "units")
# The largest mechanism nemc builds. The build grows linearly with the bodies (issue 19): a
# 1000-body chain of revolute joints builds cold in 53 s with 224 MB at most (400 bodies 22 s,
# 200 bodies 16 s), 264 s and 710 MB with its Jacobian (whose derivation, sympy's diff of every
# step, is linear but slow); 2-core machine under a load of 2.3-2.9 (docs/decisions.md, "Size").
MAX_BODIES = 1000
MAX_COORDINATES = 1000


def load_mechanism(path: str | os.PathLike[str]) -> Mechanism:
    """Read, parse and validate the mechanism file at ``path``; raise InputError if it is bad."""
    file = os.fspath(path)
    try:
        data = read_file(file)
    except OSError as exc:
        raise InputError([Problem(file, 1, "", f"cannot read file: {exc.strerror}")]) from None
    return validate_text(data, file)


def validate_text(text: str | bytes, file: str) -> Mechanism:
    """Validate a mechanism given as text (or the file's bytes); ``file`` names it in messages."""
    data = text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass")
    tree = parse_text(text, file)
    ctx = Context(file)
    mechanism = _build(ctx, tree, hashlib.sha256(data).hexdigest())
    if ctx.problems or mechanism is None:
        raise InputError(sorted(ctx.problems, key=lambda p: p.line))
    return mechanism


def _build(ctx: Context, tree: Node, source_hash: str) -> Mechanism | None:
    if not check_keys(ctx, tree, "", TOP_KEYS, ("name", "bodies", "joints"),
                      what="a mapping of top-level keys (name, bodies, joints, ...)"):
        return None
    root = entries_of(tree)
    name = model_name(ctx, root.get("name"))
    description = ""
    if "description" in root:
        description = read_string(ctx, root["description"], "description", "text") or ""
    collect_names(ctx, root)
    _check_size(ctx, root)
    parameters, constants = read_parameters(ctx, root)
    inputs = read_inputs(ctx, root["inputs"]) if "inputs" in root else ()
    gravity = read_vec2(ctx, root["gravity"], "gravity") if "gravity" in root else ZERO2
    bodies = read_bodies(ctx, root.get("bodies"))
    joints = read_joints(ctx, root.get("joints"))
    check_carried(ctx)
    constraints = read_constraints(ctx, root["constraints"]) if "constraints" in root else ()
    loads, load_names = read_loads(ctx, root["loads"]) if "loads" in root else ((), ())
    frictions = read_friction(ctx, root["friction"], constraints) if "friction" in root else ()
    contacts = read_contacts(ctx, root["contacts"]) if "contacts" in root else ()
    check_contact_method(ctx, contacts, root.get("simulation"))
    check_guides_without_contacts(ctx, frictions, contacts)
    outputs = read_outputs(ctx, root["outputs"]) if "outputs" in root else Outputs()
    simulation = read_simulation(ctx, root["simulation"]) if "simulation" in root else Simulation()
    units = read_units(ctx, root["units"]) if "units" in root else Units()
    if ctx.problems or name is None or gravity is None:
        return None
    return Mechanism(name=name, description=description, source=ctx.file,
                     source_hash=source_hash, parameters=parameters, constants=constants,
                     gravity=gravity, bodies=bodies, joints=joints,
                     loads=loads + frictions + contacts,
                     outputs=outputs, simulation=simulation, constraints=constraints,
                     units=units, inputs=inputs, load_names=load_names,
                     friction_count=len(frictions), contacts=contacts)


def _check_size(ctx: Context, root: Mapping[str, Node]) -> None:
    """Refuse, at once, a mechanism larger than nemc builds in reasonable time (MAX_BODIES)."""
    sizes = (("bodies", len(ctx.body_keys), MAX_BODIES, "bodies"),
             ("joints", len(ctx.coordinates), MAX_COORDINATES, "coordinates"))
    too_large = [(key, count, most, what) for key, count, most, what in sizes if count > most]
    for key, count, most, what in too_large:
        ctx.problem(root[key].line, key, f"{count} {what}: nemc builds at most {most} {what} "
                    f"(a {MAX_BODIES}-body chain builds in about a minute, about five with its "
                    "Jacobian)")
    if too_large:  # validating the rest would take long and say nothing more useful
        raise InputError(sorted(ctx.problems, key=lambda p: p.line))
