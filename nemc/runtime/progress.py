"""Progress on a terminal: one line on stderr for work that lasts (runs of an ensemble, a
build, a stress report). Like runs.py it needs nothing but the standard library: `nemc compile`
copies it into every standalone package."""

from __future__ import annotations

import sys
import time
from typing import Any


class Progress:
    """One line on stderr, only when stderr is a terminal and the work lasts longer than `delay`
    seconds, refreshed at most 10 times a second and erased when done."""

    def __init__(self, what: str, total: int | None = None, delay: float = 0.5,
                 stream: Any = None):
        self.what, self.total, self.delay = what, total, delay
        self.stream = stream or sys.stderr
        self.start = self.last = time.monotonic()
        self.shown = False
        self.enabled = bool(getattr(self.stream, "isatty", lambda: False)())

    def update(self, done: int | None = None, note: str = "") -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self.start < self.delay or (self.shown and now - self.last < 0.1):
            return
        self.last, self.shown = now, True
        count = "" if done is None else f" {done:,}" + (f"/{self.total:,}" if self.total else "")
        line = f"{self.what}{count}{': ' + note if note else ''} ({now - self.start:.0f} s)"
        self.stream.write("\r\x1b[K" + line[:200])
        self.stream.flush()

    def close(self) -> None:
        if self.shown:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
            self.shown = False
