"""The files a command reads and writes, checked before it runs: no output option may name a
file the command reads (the mechanism, fit's data), whatever the spelling (a relative path, a
symbolic or hard link: compared by `os.path.samefile`), and no output option may be empty
(`--csv ''` was silently ignored).
One guard for every command, in `nemc.tools.cli.main` (issue 51: `--csv X.yaml` wrote the table
over the mechanism file)."""

from __future__ import annotations

import argparse
import os

# The options (argparse dests) that name a file or folder a command reads, and those that
# name one it writes, across every command (a command lacking one has no such attribute).
INPUT_OPTIONS = ("mechanism", "data")
OUTPUT_OPTIONS = ("csv", "mat", "plot", "out", "output", "fmu")


def same_file(a: str, b: str) -> bool:
    """Whether A and B are one existing file (or folder); False when either is absent."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):  # absent, unreadable, or a NUL in the name
        return False


def output_refusal(args: argparse.Namespace) -> str | None:
    """The one-line refusal of ARGS' outputs (None when they are fine): an empty file name, or
    an output naming a file the command reads."""
    inputs = [(name, getattr(args, name)) for name in INPUT_OPTIONS
              if isinstance(getattr(args, name, None), str)]
    for option in OUTPUT_OPTIONS:
        path = getattr(args, option, None)
        if not isinstance(path, str):
            continue
        flag = "-o/--output" if option == "output" else f"--{option}"
        if not path.strip():  # `if args.csv:` skipped it: no file, no word
            return f"{flag}: expected a file name, got {path!r}"
        for name, read in inputs:
            if same_file(path, read):
                return (f"{flag} {path}: is the file nemc reads ({name} {read}); writing it "
                        "would destroy it: choose another file")
    return None
