"""Work measured without a clock, for the tests that say "refused fast" or "bounded": the Python
calls a function makes, the deepest its stack goes below the caller, and the most memory it
holds. Counts, not seconds: the same on an idle and on a busy machine, for a given interpreter
and libraries. A bound on them states what "fast" stood for (linear in the input, stopped at a
limit, no enormous number built), and fails when that breaks."""

from __future__ import annotations

import sys
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass
class Work:
    calls: int = 0  # Python function calls (C functions are not counted)
    depth: int = 0  # the deepest stack of Python frames below the caller's
    peak_bytes: int = 0  # the most memory held at once (tracemalloc), above what was held
    result: Any = None
    error: BaseException | None = None  # what it raised, if anything


def work_of(function: Callable[[], Any], memory: bool = True) -> Work:
    """FUNCTION() measured (its memory too if MEMORY: tracemalloc slows it further); what it
    raises is kept in .error, not raised."""
    work, level = Work(), [0]

    def profile(frame: Any, event: str, arg: Any) -> None:
        if event == "call":
            work.calls += 1
            level[0] += 1
            work.depth = max(work.depth, level[0])
        elif event == "return":
            level[0] -= 1

    tracing = tracemalloc.is_tracing()
    if memory and not tracing:
        tracemalloc.start()
    tracemalloc.reset_peak()
    held = tracemalloc.get_traced_memory()[0]
    sys.setprofile(profile)
    try:
        work.result = function()
    except Exception as error:  # noqa: BLE001 - kept for the caller to look at
        work.error = error
    finally:
        sys.setprofile(None)
        work.peak_bytes = tracemalloc.get_traced_memory()[1] - held
        if memory and not tracing:
            tracemalloc.stop()
    return work
