"""Shared test set-up: every test session builds into its own temporary nemc cache."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest


@pytest.fixture(scope="session", autouse=True)
def nemc_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    cache = tmp_path_factory.mktemp("nemc-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("NEMC_CACHE", str(cache))
        yield cache
