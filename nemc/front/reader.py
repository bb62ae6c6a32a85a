"""How a joint, load or constraint kind reads its YAML: the keys each kind takes (the tables
the fuzzers and tests use), and the `Reader` it reads them through, which implements the
protocol nemc/kinds/contract.py: Reader.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import sympy

from ..kinds.constraints import CONSTRAINT_KINDS, Constraint
from ..kinds.joints import JOINT_KINDS, Joint
from ..kinds.loads import LOAD_KINDS
from .context import Context, check_keys, entries_of, join_path
from .fields import ZERO2, read_choice, read_expr, read_fixed, read_flag, read_vec2
from .mechanism import Loc, PointRef, Vec2
from .parse import Node
from .references import body_name, joint_name, point_of, point_ref, read_axis


def joint_keys(kind: type[Joint]) -> tuple[str, ...]:
    """Every YAML key a joint of this kind takes (read from the kind, when asked)."""
    return ("type", "parent", "child", *kind.keys, *(("motion",) if kind.drivable else ()))


def constraint_keys(kind: type[Constraint]) -> tuple[str, ...]:
    return ("type", *kind.keys)


def every_key(keys) -> list[str]:
    """Every key any kind of a table takes: a sibling kind's key 'does not apply'."""
    return sorted({key for kind_keys in keys for key in kind_keys})


# The registries as tables of keys, for the fuzzers and tests (validation reads the kinds).
JOINT_TYPES = tuple(JOINT_KINDS)
JOINT_KEYS = {name: joint_keys(kind) for name, kind in JOINT_KINDS.items()}
CONSTRAINT_KEYS = {name: constraint_keys(kind) for name, kind in CONSTRAINT_KINDS.items()}
LOAD_KEYS = {name: kind.keys for name, kind in LOAD_KINDS.items()}


class Reader:
    """One YAML mapping of a joint, a load or a constraint, as its kind reads it (nemc/kinds/):
    a typed value per key, checked with its location. A wrong value records a problem and
    reads as None; a missing key reads as its default."""

    def __init__(self, ctx: Context, node: Node, path: str, parent: str | None = None):
        self.ctx, self.node, self.path = ctx, node, path
        self.parent = parent  # the joint's parent body, where its points are read
        self.entries = entries_of(node)
        self._problems_before = len(ctx.problems)

    @property
    def location(self) -> Loc:
        return self.ctx.loc(self.node, self.path)

    def fields(self, **values: Any) -> dict[str, Any] | None:
        """The values read, or None when one is None or a problem was recorded meanwhile."""
        if len(self.ctx.problems) > self._problems_before or None in values.values():
            return None
        return values

    def problem(self, key: str, message: str) -> None:
        self.ctx.problem(self.entries.get(key, self.node).line, join_path(self.path, key), message)

    def has(self, key: str) -> bool:
        """Whether the mapping gives this key."""
        return key in self.entries

    def flag(self, key: str, default: bool) -> bool:
        """true or false."""
        found = self._at(key)
        return default if found is None else read_flag(self.ctx, *found)

    def _at(self, key: str) -> tuple[Node, str] | None:
        return (self.entries[key], join_path(self.path, key)) if key in self.entries else None

    def expr(self, key: str, default: sympy.Expr | None = None) -> sympy.Expr | None:
        """An expression of t, coordinates, rates, parameters and constants (as loads take)."""
        found = self._at(key)
        return default if found is None else read_expr(self.ctx, *found, self.ctx.scope("load"))

    def fixed(self, key: str, default: sympy.Expr, positive: bool = False,
              nonnegative: bool = False) -> sympy.Expr | None:
        """An expression of parameters and constants, finite (and > 0, or >= 0) at their
        defaults."""
        found = self._at(key)
        return default if found is None else read_fixed(self.ctx, *found, positive, nonnegative)

    def vec2(self, key: str) -> Vec2 | None:
        """[x, y], each as `expr` reads it."""
        found = self._at(key)
        return None if found is None else read_vec2(self.ctx, *found, self.ctx.scope("load"))

    def axis(self, key: str) -> Vec2 | None:
        """A fixed direction [x, y], not zero; default [1, 0]."""
        found = self._at(key)
        return (sympy.S.One, sympy.S.Zero) if found is None else read_axis(self.ctx, *found)

    def choice(self, key: str, choices: tuple[str, ...], default: str) -> str | None:
        found = self._at(key)
        return default if found is None else read_choice(self.ctx, *found, choices, key)

    def parent_point(self, key: str) -> Vec2 | None:
        """A point of the joint's parent: a point name or [x, y]; default its origin."""
        found = self._at(key)
        return ZERO2 if found is None else point_of(self.ctx, *found, self.parent)

    def body_point(self, key: str, body: str | None, moving: bool = False) -> Vec2 | None:
        """A point of `body`: a point name or [x, y]; default its mass center. `moving`: [x, y]
        may be expressions of the coordinates, inputs and t (no rates)."""
        found = self._at(key)
        if found is not None:
            return point_of(self.ctx, *found, body, moving)
        return self.ctx.bodies[body].com if body in self.ctx.bodies else None

    def body(self, key: str, ground: bool, default: str | None = None) -> str | None:
        found = self._at(key)
        return default if found is None else body_name(self.ctx, *found, ground=ground)

    def point_ref(self, key: str) -> PointRef | None:
        """BODY.POINT or {body: BODY, at: [x, y]} (ground allowed)."""
        found = self._at(key)
        return None if found is None else point_ref(self.ctx, *found, ground=True)

    def joint(self, key: str, accepts: Callable[[type[Joint]], bool], needs: str) -> str | None:
        """A joint's name; `needs` says what a joint of a kind that `accepts` refuses lacks."""
        found = self._at(key)
        name = None if found is None else joint_name(self.ctx, *found)
        joint = self.ctx.joints.get(name) if name is not None else None
        if joint is not None and not accepts(type(joint)):
            self.problem(key, f"{needs}; {name!r} is a {joint.type} joint")
        return name

    def mapping(self, key: str, allowed: tuple[str, ...], required: tuple[str, ...]
                ) -> Reader | None:
        """The mapping under `key`, to read in turn (None: not a mapping of these keys)."""
        found = self._at(key)
        if found is None or not check_keys(self.ctx, *found, allowed, required,
                                           what=f"a mapping {{{', '.join(allowed)}}}"):
            return None
        return Reader(self.ctx, *found)
