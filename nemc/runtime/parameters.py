"""A model's parameters: the C parameter vector for a caller's overrides, checked (finite, known
by name, masses and inertias positive), the latest one kept; and a vector back as a dict. The
vector ends with the coefficients of the inputs' laws (inputs.py), at their defaults here, and
the offsets of constraints that hold "as at the start" (loops.py, set at a run's start).

A params dict passed again costs next to nothing (issue 46: each entry used to add about 1-7 us
to every model.rhs call): the latest dict that was checked is remembered by its names and the
very objects of its values, which must be immutable numbers (float, int, numpy's scalars). A
dict of the same names holding the same objects, in the same order, makes the same vector, so
it is not checked again; any other dict (a value replaced, even by an equal one, a name added
or removed) is checked in full."""

from __future__ import annotations

import math
from collections.abc import Mapping
from operator import is_
from typing import Any

import numpy as np

from .checks import finite_number
from .compiled import Compiled
from .failures import ModelError

# the values whose objects cannot change: a dict holding the same ones says the same thing
IMMUTABLE_NUMBERS = frozenset({float, int, np.float64, np.float32, np.int64, np.int32})


class Parameters:
    """The parameters of one build: names, defaults, derived ones (which cannot be set), and
    the checked vectors (Model.parameter_vector, parameters_at)."""

    def __init__(self, metadata: Mapping[str, Any], compiled: Compiled):
        self.names: tuple[str, ...] = tuple(metadata["parameter_names"])
        self.derived: dict[str, str] = dict(metadata["derived_parameters"])
        self.check_names: list[str] = metadata["check_names"]
        # each check > 0 (what a joint carries), else >= 0 (a mass, an inertia); a build before
        # format v3 says nothing: all > 0
        self.check_strict: list[bool] = metadata.get("check_strict",
                                                     [True] * len(self.check_names))
        self.compiled = compiled
        # the parameters, then the inputs' laws' coefficients (inputs.py): never written
        laws = (metadata.get("inputs") or {}).get("defaults", [])
        offsets = [0.0] * len(metadata.get("constraint_starts", []))  # set at a run's start
        items = len(metadata.get("friction", []))  # forces 0 (solved in C), modes NaN (from
        hidden = [0.0] * items + [np.nan] * items  # the state; a run sets its own)
        self.defaults = np.array([*metadata["parameter_defaults"], *laws, *offsets, *hidden],
                                 dtype=float)
        self._checked: tuple[tuple, np.ndarray] = ((), self.defaults)  # the latest vector
        # the latest dict checked: its names, its values (the objects), its vector (None: none)
        self._seen: tuple[tuple, tuple, np.ndarray] | None = None
        # at(the defaults), copied for each result: never handed out itself
        self._default_dict = dict(zip(self.names, self.defaults.tolist()))

    def vector(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The C parameter array for these overrides, checked (finite, masses positive)."""
        if params is None:  # the defaults (checked when compiled)
            return self.defaults
        seen = self._seen
        if (seen is not None and type(params) is dict and tuple(params) == seen[0]
                and all(map(is_, params.values(), seen[1]))):  # the same names and objects
            return seen[2]
        overrides = self.overrides(params)
        key = tuple(sorted(overrides.items()))
        if not key:
            p = self.defaults
        elif key == self._checked[0]:
            p = self._checked[1]
        else:
            p = self.defaults.copy()
            for name, value in overrides.items():
                p[self.index(name)] = value
            self.check_masses(p)
            self._checked = (key, p)
        self._remember(params, p)
        return p

    def _remember(self, params: Mapping[str, float], p: np.ndarray) -> None:
        """Keep a dict that was checked and made P, when its values are immutable numbers
        (an array's entry could change while the dict holds the same object)."""
        values = tuple(params.values())
        if type(params) is dict and all(type(v) in IMMUTABLE_NUMBERS for v in values):
            self._seen = (tuple(params), values, p)
        else:
            self._seen = None

    def at(self, p: np.ndarray) -> dict[str, float]:
        """The parameter vector p as name -> value (a new dict)."""
        if p is self.defaults:  # never written to (vector copies it)
            return self._default_dict.copy()
        return dict(zip(self.names, p.tolist()))

    def overrides(self, params: Any) -> dict[str, float]:
        """``params`` as name -> finite float; anything but a mapping of names is refused."""
        if params is None:
            return {}
        if not isinstance(params, Mapping):
            raise ModelError(f"params must be a mapping name -> value, got {type(params).__name__}")
        for name in params:
            if not isinstance(name, str):
                raise ModelError(f"parameter names are strings, got {name!r}")
        return {name: value if type(value) is float and math.isfinite(value)
                else finite_number(name, value) for name, value in params.items()}

    def index(self, name: str) -> int:
        """The position of parameter NAME in the vector; an unknown or derived name is refused
        (with the closest known name)."""
        if name in self.names:
            return self.names.index(name)
        if name in self.derived:
            raise ModelError(
                f"parameter {name!r} is derived ({name} = {self.derived[name]}):"
                " set its inputs instead"
            )
        import difflib

        close = difflib.get_close_matches(name, self.names, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ModelError(f"unknown parameter {name!r}{hint} (known: {list(self.names)})")

    def check_masses(self, p: np.ndarray) -> None:
        """Refuse p where a mass or inertia (the C's checks) is negative or not finite, or
        leaves a joint nothing to move."""
        values = np.empty(len(self.check_names))
        buffer = self.compiled.buffer
        self.compiled.functions["checks"](buffer(p), buffer(values))
        for key, value, strict in zip(self.check_names, values, self.check_strict):
            if not (value > 0 if strict else value >= 0) or not np.isfinite(value):
                raise ModelError(f"{key} must be {'>' if strict else '>='} 0 and finite, got "
                                 f"{value:g} at these parameters" + (
                                     " (the mass matrix would be singular)" if strict and
                                     key.startswith("joints.") else ""))

    def share_defaults(self, other: Parameters) -> None:
        """Take the default vector of OTHER, the same mechanism's (a variant's build): a run that
        one hands to the other then finds its defaults by identity (at, parameter_buffer)."""
        if np.array_equal(self.defaults, other.defaults):
            self.defaults = other.defaults
            self._checked = ((), other.defaults)
            self._seen = None
