"""The drawing's point positions (issue 20), appended to every model's C: `<name>_positions`,
and the drawing's structure for model.json.
"""

from __future__ import annotations

import dataclasses

from ..derive.equations import Equations
from .c_text import SymbolTablePrinter
from .optimize import Block
from .parts import Units, print_program
from .printing import STATE_INPUTS, Caller, comment_text, symbol_table, template

POSITIONS = Caller("positions", "The drawing's point positions", STATE_INPUTS, ("POINT", "xy"),
                  "v", indent=" " * 8)


def positions_part(eqs: Equations, block: Block, prefix: str, chunk_steps: int,
                   units: Units | None = None) -> tuple[str, dict]:
    """The C of `<name>_positions` (declared in templates/model.h.tmpl: the ground positions of
    the points nemc.geometry's drawing needs) and the drawing's structure for model.json. The
    positions are a straight-line program placing each body once from its parent (linear in the
    number of bodies)."""
    from ..derive.articulated import PointPositions
    from ..derive.equations import runtime_values
    from ..derive.geometry import drawing
    from .optimize import rewrite_program

    places = PointPositions(eqs.mechanism, runtime_values(eqs.mechanism))
    picture = drawing(eqs.mechanism, places.position)
    program = rewrite_program(places.prog.finish(
        [v for _, x, y in picture.points for v in (x, y)]))
    names = {**symbol_table(eqs, block), **{s: s.name for s, _ in program.assignments()}}
    targets = [f"{('POINT_X', 'POINT_Y')[k % 2]}({k // 2})" for k in range(len(program.results))]
    positions = print_program(SymbolTablePrinter(names), program,
                              dataclasses.replace(POSITIONS, targets=tuple(targets)), chunk_steps,
                              units)
    source = template("positions.c.tmpl").substitute(
        prefix=prefix, n_points=len(picture.points), n_values=2 * len(picture.points),
        point_names=comment_text(", ".join(name for name, _, _ in picture.points)),
        positions_parts=positions.functions, positions=positions.body,
    )
    return source, picture.metadata()
