"""What every load kind is and answers: the base class of the kinds in this package.

A load kind is a frozen dataclass (what its YAML mapping holds, ending with its location) whose
methods answer every question the pipeline asks about a load of that kind: its YAML keys and
how they are read (the front end), the expressions it holds, what it does to the bodies (`act`:
its force law, written once against a LoadView and told to a LoadSink, nemc/kinds/contract.py;
the articulated-body algorithm, the Newton-Euler balances of the mass-matrix form and the
reaction outputs all take it from there), its potential energy, and how it is drawn. Nothing
outside nemc/kinds/loads/ tests a load's kind; it asks the load.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy

from ..terms import Loc, PointRef, with_expressions_mapped

if TYPE_CHECKING:
    from ..contract import KinematicsView, LoadSink, LoadView, Reader

Expr = sympy.Expr


@dataclass(frozen=True)
class LoadDrawing:
    """How a picture shows a load: as a spring between two points, or on a joint (None: not
    at all)."""

    between: tuple[PointRef, PointRef] | None = None
    on_joint: str | None = None


@dataclass(frozen=True)
class Load:
    """A load of the mechanism. Subclasses: one per kind, in this package."""

    kind: ClassVar[str]  # the key that marks a load of this kind in the YAML's `loads` list
    keys: ClassVar[tuple[str, ...]]  # every key of its mapping (the kind's key first)
    required: ClassVar[tuple[str, ...]] = ()  # keys besides the kind's own that must be there

    @classmethod
    def read(cls, read: Reader) -> dict[str, Any] | None:
        """The load's fields from its YAML entries (None: a problem was recorded)."""
        raise NotImplementedError

    @property
    def location(self) -> Loc:
        return self.loc  # type: ignore[attr-defined]  (every kind's last field)

    def expressions(self) -> list[tuple[str, Expr]]:
        """(key path under its location, expression) of every expression of t, q, dq it
        holds."""
        return []

    def map_expressions(self, f: Callable[[Expr], Expr]) -> Load:
        """The load with f applied to every expression it holds (e.g. constants folded)."""
        return with_expressions_mapped(self, f)

    def act(self, view: LoadView, sink: LoadSink) -> None:
        """What the load does to the bodies: forces, couples and tensions into SINK, computed
        from what VIEW shows (its expressions already in the derivation's symbols)."""
        raise NotImplementedError

    def potential(self, kin: KinematicsView) -> Expr | None:
        """Its potential energy, for the kinds that have one."""
        return None

    def drawing(self) -> LoadDrawing:
        """How a picture of the mechanism shows it (default: not at all)."""
        return LoadDrawing()

    def reported(self, kin: KinematicsView, rate: Callable[[Expr], Expr]
                 ) -> list[tuple[str, Expr]]:
        """What a named load reports as outputs: (suffix, value) ("" the load's name itself,
        ".Fx" NAME.Fx, ...); RATE: an expression's time derivative."""
        raise NotImplementedError

    def reported_kinds(self, coordinate_kind: Callable[[str], str]) -> list[tuple[str, str]]:
        """(suffix, kind of quantity) of what reported() gives, for the units: "couple" or
        "joint force"; COORDINATE_KIND: a joint's name -> "angle" or "length"."""
        raise NotImplementedError
