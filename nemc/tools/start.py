"""The state a command starts from when options set some of its values (`nemc simulate
--initial`, `nemc linearize --at`): the scene's, those values set; a closed loop's handed on as
the values it keeps, the scene's `initial` ones and the options', so that the run (or the
linearization) assembles it from them and solves the others, never moving a value set."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np


def kept_over_scene(model: Any, names: Iterable[str]) -> set[str]:
    """The values a closed loop keeps when NAMES are set over the scene's state (options,
    a sweep's columns): the scene's `initial` ones and NAMES."""
    return {*model.metadata.get("initial_given", ()), *names}


def start_values(model: Any, params: Mapping[str, float], values: Sequence[tuple[str, float]],
                 option: str) -> np.ndarray | dict[str, float]:
    """The scene's state at PARAMS (a closed loop's: model.guess_state) with VALUES (name,
    number) set, each name checked (OPTION: the option's name in the error); a closed loop's
    as the dict of the values it keeps (kept_over_scene), which simulate or linearize
    assembles."""
    from ..runtime.failures import ModelError

    state = model.guess_state(params)
    for name, value in values:
        if name not in model.state_names:
            import difflib  # here: only a mistyped name needs it

            close = difflib.get_close_matches(name, model.state_names, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise ModelError(f"{option}: unknown coordinate or rate {name!r}{hint}; the state "
                             f"is {', '.join(model.state_names)}")
        state[model.state_names.index(name)] = value
    if not model.has_loops:
        return state
    kept = kept_over_scene(model, (name for name, _ in values))
    return {name: float(state[k]) for k, name in enumerate(model.state_names) if name in kept}
