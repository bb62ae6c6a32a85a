"""Child processes that never outlive their test.

The Ctrl-C tests start a long run in a child and send it SIGINT. If the child does not stop
(the behaviour under test is broken, or SIGINT is ignored), `communicate(timeout=...)` raises,
and the child would go on computing after the test failed: killed here instead."""

from __future__ import annotations

import subprocess
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
