"""Shared test set-up: every test session builds into its own temporary nemc cache."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from pathlib import Path

import pytest


@pytest.fixture(scope="session", autouse=True)
def nemc_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    cache = tmp_path_factory.mktemp("nemc-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("NEMC_CACHE", str(cache))
        yield cache


@pytest.fixture(scope="session", autouse=True)
def sigint_as_python_sets_it() -> Iterator[None]:
    """A suite started in the background (`make test &`, nohup) inherits SIGINT ignored, and
    Python then leaves it ignored: the Ctrl-C tests would find no KeyboardInterrupt here, nor
    in the children they start (an ignored signal stays ignored across exec). The interpreter's
    own handler for the session, in this process and so in the children."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        yield
        return
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
