"""Errors nemc reports to users."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Problem:
    """One thing wrong with an input file: ``FILE:LINE: key.path: message``."""

    file: str
    line: int
    key: str
    message: str

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}"
        return f"{where}: {self.key}: {self.message}" if self.key else f"{where}: {self.message}"


class InputError(Exception):
    """Bad input (exit status 2). Carries every problem found, so a user fixes the file at once."""

    def __init__(self, problems: Sequence[Problem]):
        self.problems = tuple(problems)
        super().__init__("\n".join(str(p) for p in self.problems))


class BuildError(Exception):
    """The build failed (exit status 1): names the C file and carries the compiler's output."""


class OutputRefused(BuildError):
    """nemc will not replace a folder it did not write (exit status 2: choose another -o)."""


def describe(error: OSError) -> str:
    """An OSError for a message: its text and file. shutil's copy errors (shutil.Error) carry
    neither strerror nor filename but a list of (source, destination, reason)."""
    if error.strerror:
        return f"{error.strerror}: {error.filename}" if error.filename else error.strerror
    details = error.args[0] if error.args else None
    if isinstance(details, list) and details and isinstance(details[0], tuple):
        source, _, reason = details[0]
        cause = re.match(r"\[Errno \d+\] ([^:]+)", str(reason))
        return f"{cause.group(1) if cause else reason}: copying {source}"
    return str(error) or type(error).__name__
