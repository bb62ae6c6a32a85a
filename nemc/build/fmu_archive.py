"""An FMU file: a zip written atomically that never replaces a file nemc did not write.

The archive is reproducible (its entries in a fixed order with a fixed date) and carries a
marker in its zip comment: `nemc-fmu <version> <sha256>`, the hash of its entries' names, sizes
and CRC-32s. A file at the target is replaced only when it is such an archive, unchanged (a
zip tool that rewrites an entry keeps the comment, but the hash no longer matches); anything
else (another FMU, the user's file, a folder, a symbolic link) makes nemc refuse, naming what
it found. The new file is written beside the target and renamed into place; nemc's old one is
first moved aside and checked again, so a file that changed meanwhile is put back, never lost.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import stat
import tempfile
import zipfile
from collections.abc import Mapping
from pathlib import Path

from ..errors import OutputRefused
from ..vocabulary import NEMC_VERSION

MARKER = b"nemc-fmu"
FIXED_DATE = (1980, 1, 1, 0, 0, 0)  # the zip format's earliest: the same bytes every export
STAGING_PREFIX = ".nemc-fmu-"
ATTEMPTS = 3


def entries_digest(archive: zipfile.ZipFile) -> str:
    digest = hashlib.sha256()
    for info in archive.infolist():
        digest.update(f"{info.filename}\0{info.file_size}\0{info.CRC}\n".encode())
    return digest.hexdigest()


def write_archive(target: Path, files: Mapping[str, bytes], executable: set[str]) -> Path:
    """FILES (name in the archive -> content) as the FMU TARGET, replacing only nemc's own
    earlier FMU there."""
    target = Path(os.path.abspath(target))
    refuse_foreign(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, staged = tempfile.mkstemp(prefix=f"{STAGING_PREFIX}{target.stem}-", suffix=".tmp",
                                      dir=target.parent)
    os.close(handle)
    try:
        write_zip(Path(staged), files, executable)
        publish(Path(staged), target)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(staged)
    return target


def write_zip(path: Path, files: Mapping[str, bytes], executable: set[str]) -> None:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name in sorted(files):
            info = zipfile.ZipInfo(name, FIXED_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if name in executable else 0o644) << 16
            archive.writestr(info, files[name])
        archive.comment = MARKER + f" {NEMC_VERSION} {entries_digest(archive)}".encode()


def publish(staged: Path, target: Path) -> None:
    """Rename STAGED to TARGET: into an empty place by a hard link (which fails rather than
    replace a file that appeared meanwhile), over nemc's own FMU by moving it aside first."""
    for _ in range(ATTEMPTS):
        if not os.path.lexists(target):
            try:
                os.link(staged, target)
                return
            except FileExistsError:
                continue  # written meanwhile: look at it
            except OSError:  # no hard links here: a rename (a file may appear meanwhile)
                os.rename(staged, target)
                return
        aside = target.with_name(f"{STAGING_PREFIX}old-{target.name}-{os.getpid()}")
        try:
            os.rename(target, aside)
        except FileNotFoundError:
            continue  # removed meanwhile: an empty place again
        found = foreign(aside)
        if found:
            os.rename(aside, target)
            raise OutputRefused(refusal(target, found))
        os.rename(staged, target)
        os.unlink(aside)
        return
    raise OutputRefused(f"will not write {target}: another process keeps writing it")


def refuse_foreign(target: Path) -> None:
    found = foreign(target)
    if found:
        raise OutputRefused(refusal(target, found))


def refusal(target: Path, found: str) -> str:
    return (f"will not replace {target}: {found}; nemc replaces only an FMU it wrote. Move it "
            "elsewhere (or delete it yourself), or choose another file name")


def foreign(path: Path) -> str:
    """Why PATH is not nemc's own unchanged FMU ("" when it is, or when nothing is there)."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return ""
    if stat.S_ISLNK(info.st_mode):
        return "it is a symbolic link"
    if not stat.S_ISREG(info.st_mode):
        return "it is not a regular file"
    try:
        with zipfile.ZipFile(path) as archive:
            comment = archive.comment
            if not comment.startswith(MARKER + b" "):
                return "it is not an FMU nemc wrote (no nemc marker)"
            if comment.rsplit(b" ", 1)[-1].decode(errors="replace") != entries_digest(archive):
                return "it changed since nemc wrote it"
    except (zipfile.BadZipFile, OSError, ValueError):
        return "it is not an FMU nemc wrote (not a zip archive)"
    return ""
