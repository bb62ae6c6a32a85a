"""Exporting a built package to the user's folder (`nemc compile X -o DIR`) without ever
deleting what nemc did not write.

DIR/<name>/ is written as a copy staged beside it (DIR/.nemc-export-<name>-*/) and swapped in by
rename. An existing DIR/<name>/ is replaced only when it is nemc's own output: it holds the
marker MARKER (or, from packages exported before the marker, the cache manifest BUILD_OK) and
nothing but the files listed there, unchanged, and Python's __pycache__. Anything else (the
user's YAML, notes, an edited C file, a symbolic link, a plain file) makes nemc refuse, naming
what it found. The folder is checked again after it is moved aside, so a file added meanwhile
is never deleted: the folder is put back.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import tempfile
from pathlib import Path

from ..errors import OutputRefused
from ..vocabulary import NEMC_VERSION as __version__
from ..vocabulary import PACKAGE_MARKER

MARKER = PACKAGE_MARKER
LEGACY_MARKER = "BUILD_OK"  # the cache's manifest, copied into packages exported before MARKER
LEGACY_RUNTIME_FILES = ("_runtime.py", "methods.py", "loops_runtime.py", "runs.py")
STAGING_PREFIX = ".nemc-export-"
MAX_MARKER_BYTES = 1_000_000
ATTEMPTS = 3  # another process may publish the same folder between our check and our rename


def export_package(package: Path, out_dir: Path, name: str, key: str,
                   extras: dict[str, Path] | None = None) -> Path:
    """Copy PACKAGE, and EXTRAS (path in the package -> file), to OUT_DIR/NAME/ (replacing
    nemc's own earlier output there); its path."""
    out_dir = Path(os.path.abspath(out_dir))  # before anything moves: the cwd may be the target
    target = out_dir / name
    refuse_foreign(target)
    out_dir.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f"{STAGING_PREFIX}{name}-", dir=out_dir))
    try:
        fresh = staging / name
        shutil.copytree(package, fresh, ignore=shutil.ignore_patterns("__pycache__"))
        for copied, source in (extras or {}).items():
            (fresh / copied).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, fresh / copied)
        write_marker(fresh, key)
        swap_in(fresh, target, staging)
    finally:
        remove_staging(staging)
    return target


def swap_in(fresh: Path, target: Path, staging: Path) -> None:
    """Rename FRESH to TARGET, moving nemc's previous output at TARGET aside into STAGING
    first (deleted with it, once the new package is in place)."""
    for attempt in range(ATTEMPTS):
        if os.path.lexists(target):
            old = staging / f"old{attempt}"
            os.rename(target, old)
            found = foreign_entries(old)
            if found:  # changed since it was checked: put it back, untouched
                os.rename(old, target)
                raise OutputRefused(refusal(target, found))
        try:
            os.rename(fresh, target)
            return
        except OSError:  # published meanwhile by another nemc: check and replace that one
            if attempt == ATTEMPTS - 1 or not os.path.lexists(target):
                raise
            refuse_foreign(target)


def refuse_foreign(target: Path) -> None:
    """Raise OutputRefused unless TARGET is absent or nemc's own output."""
    if os.path.lexists(target):
        found = foreign_entries(target)
        if found:
            raise OutputRefused(refusal(target, found))


def refusal(target: Path, found: list[str]) -> str:
    shown = ", ".join(found[:5]) + (f" and {len(found) - 5} more" if len(found) > 5 else "")
    return (f"will not replace {target}: {shown}; nemc replaces only a package it wrote. Move "
            "what you keep elsewhere (or delete the folder yourself), or choose another folder "
            "with -o/--output")


def remove_staging(staging: Path) -> None:
    """Delete the staging folder, unless it holds a folder nemc did not write (never: the
    swap puts such a folder back, but a failed rename must not turn into a deletion)."""
    if any(foreign_entries(old) for old in staging.glob("old*")):
        return
    shutil.rmtree(staging, ignore_errors=True)


# ---- the marker ---------------------------------------------------------------------------


def write_marker(folder: Path, key: str) -> None:
    """The marker, listing every file nemc wrote in FOLDER and its subfolders by its path there
    (e.g. _nemc/runtime/model.py), with its size and hash."""
    files = {path.relative_to(folder).as_posix(): {"bytes": path.stat().st_size,
                                                   "sha256": digest(path)}
             for path in sorted(folder.rglob("*"))
             if path.is_file() and not path.is_symlink() and "__pycache__" not in path.parts}
    (folder / MARKER).write_text(json.dumps(
        {"written_by": f"nemc {__version__}", "key": key, "files": files}, indent=1) + "\n")


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def listed_files(folder: Path) -> tuple[str, dict[str, dict]] | None:
    """(the marker's name, name -> {"sha256", maybe "bytes"}) of the files nemc wrote in
    FOLDER, or None without a readable marker."""
    for marker in (MARKER, LEGACY_MARKER):
        text = read_small(folder / marker)
        if text is None:
            continue
        try:
            files = json.loads(text)["files"]
            listed = {name: value if isinstance(value, dict) else {"sha256": value}
                      for name, value in files.items()}
        except (ValueError, KeyError, TypeError, AttributeError):
            return None
        if all(isinstance(entry.get("sha256"), str) for entry in listed.values()):
            return marker, listed
        return None
    return None


def read_small(path: Path) -> str | None:
    """The text of a regular file of at most MAX_MARKER_BYTES (never a FIFO or a link)."""
    try:
        info = os.lstat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_MARKER_BYTES:
            return None
        return path.read_text()
    except (OSError, UnicodeDecodeError):
        return None


def foreign_entries(folder: Path) -> list[str]:
    """What in FOLDER nemc did not write, as reasons (empty: FOLDER is nemc's own output)."""
    try:
        info = os.lstat(folder)
    except FileNotFoundError:
        return []
    if stat.S_ISLNK(info.st_mode):
        return ["it is a symbolic link"]
    if not stat.S_ISDIR(info.st_mode):
        return ["it is a file, not a package folder"]
    found = listed_files(folder)
    if found is None:
        return [f"it has no {MARKER} (nemc writes one in every package it exports)"]
    marker, listed = found
    try:
        foreign = unlisted_entries(Path(folder), "", marker, listed)
    except OSError as error:
        return [f"it cannot be listed ({error.strerror})"]
    if foreign:
        return [f"it holds {', '.join(foreign)}, which nemc did not write (or which changed "
                "since)"]
    return []


def unlisted_entries(folder: Path, prefix: str, marker: str, listed: dict[str, dict]
                     ) -> list[str]:
    """The entries of FOLDER (PREFIX: its path in the package) that the marker does not list
    as they are: a subfolder counts as nemc's when everything in it is listed."""
    foreign = []
    for entry in sorted(os.scandir(folder), key=lambda e: e.name):
        path = prefix + entry.name
        if path == marker or (marker == LEGACY_MARKER and is_legacy_runtime(entry, prefix)):
            continue
        if entry.name == "__pycache__" and entry.is_dir(follow_symlinks=False):
            foreign += [f"{path}/{name}" for name in foreign_in_pycache(Path(entry.path))]
        elif entry.is_dir(follow_symlinks=False) and any(name.startswith(path + "/")
                                                          for name in listed):
            foreign += unlisted_entries(Path(entry.path), path + "/", marker, listed)
        elif not is_listed(entry, listed.get(path)):
            foreign.append(path)
    return foreign


def is_legacy_runtime(entry: os.DirEntry, prefix: str) -> bool:
    """A runtime module nemc copied into a package exported before MARKER (BUILD_OK, the
    cache's manifest, does not list them): then flat, under these names."""
    return (not prefix and entry.name in LEGACY_RUNTIME_FILES
            and entry.is_file(follow_symlinks=False))


def is_listed(entry: os.DirEntry, listed: dict | None) -> bool:
    """Whether ENTRY is a regular file with the size and content the marker gives it."""
    if listed is None or not entry.is_file(follow_symlinks=False):
        return False
    try:
        size = entry.stat(follow_symlinks=False).st_size
        return listed.get("bytes", size) == size and digest(Path(entry.path)) == listed["sha256"]
    except OSError:
        return False


def foreign_in_pycache(folder: Path) -> list[str]:
    """What Python's bytecode cache holds besides its own .pyc files."""
    try:
        return [entry.name for entry in os.scandir(folder)
                if not (entry.is_file(follow_symlinks=False) and entry.name.endswith(".pyc"))]
    except OSError:
        return ["(unreadable)"]
