"""Print the path of the newest CPython >= 3.10 other than this one (its minor version differs), or
nothing: `make test` makes a small virtual environment with it (cffi and numpy) in which
tests/test_package.py loads a standalone package's stable-ABI extension."""

from __future__ import annotations

import glob
import os
import shutil
import subprocess
import sys


def candidates() -> list[str]:
    found = [shutil.which(f"python3.{minor}") for minor in range(10, 20)]
    found += sorted(glob.glob(os.path.expanduser("~/.pyenv/versions/3.*/bin/python3")))
    found += sorted(glob.glob("/usr/bin/python3.*")) + sorted(glob.glob("/usr/local/bin/python3.*"))
    return [path for path in dict.fromkeys(found) if path]


def version(path: str) -> tuple[int, int] | None:
    """The interpreter's version, if it runs (a pyenv shim without its version does not)."""
    try:
        out = subprocess.run([path, "-c", "import sys; print(*sys.version_info[:2])"],
                             capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired):
        return None
    parts = out.stdout.split()
    return (int(parts[0]), int(parts[1])) if out.returncode == 0 and len(parts) == 2 else None


def main() -> None:
    """The newest other version found."""
    mine = sys.version_info[:2]
    others = [(found, path) for path in candidates()
              if (found := version(path)) is not None and found >= (3, 10) and found != mine]
    if others:
        print(max(others)[1])


if __name__ == "__main__":
    main()
