"""Child processes that never outlive their test.

The Ctrl-C tests start a long run in a child and send it SIGINT. If the child does not stop
(the behaviour under test is broken, or SIGINT is ignored), `communicate(timeout=...)` raises,
and the child would go on computing after the test failed: killed here instead."""

from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def child_process(command: list[str], **options: Any) -> Iterator[subprocess.Popen]:
    """subprocess.Popen(command, **options), killed if it still runs when the block ends."""
    child = subprocess.Popen(command, **options)
    try:
        yield child
    finally:
        if child.poll() is None:
            child.kill()
            child.communicate()


def interrupted_output(child: subprocess.Popen, wait: float = 1.0, timeout: float = 20.0
                       ) -> str:
    """CHILD's output after its line "started": SIGINT sent WAIT seconds after that line, and
    the child must have ended within a second of it."""
    assert child.stdout is not None and child.stdout.readline().strip() == "started"
    time.sleep(wait)
    sent = time.perf_counter()
    child.send_signal(signal.SIGINT)
    out, _ = child.communicate(timeout=timeout)
    assert time.perf_counter() - sent < 1.0
    return out
