"""Reading a mechanism file, bounded: never more than MAX_BYTES + 1 bytes, never blocking on
open. Apart from nemc.parse so that a cache hit, which reads the file to hash it, imports no YAML.
"""

from __future__ import annotations

import os
import stat

from ..errors import InputError, Problem

# PyYAML's composer is pure Python (~0.6 s a megabyte to scan): with the node limits of
# nemc.parse this keeps any file under a few seconds and ~100 MB. The largest example is 2 KB;
# a 100-link chain is about 25 KB.
MAX_BYTES = 1_000_000


def read_file(path: str | os.PathLike[str]) -> bytes:
    """The bytes of the file at PATH, reading at most MAX_BYTES + 1 of them: a larger or endless
    file (/dev/zero, /dev/urandom) is refused without being read whole. A FIFO is opened without
    blocking (no writer: an empty file). OSError when it cannot be read; InputError when too big."""
    with open(path, "rb", opener=_open_without_blocking) as handle:
        os.set_blocking(handle.fileno(), True)
        data = handle.read(MAX_BYTES + 1)
        if len(data) > MAX_BYTES:
            info = os.fstat(handle.fileno())
            size = f"{info.st_size} bytes" if stat.S_ISREG(info.st_mode) else \
                f"more than {MAX_BYTES} bytes"
            message = f"file is too large ({size}, at most {MAX_BYTES})"
            raise InputError([Problem(os.fspath(path), 1, "", message)])
    return data


def _open_without_blocking(path: str, flags: int) -> int:
    return os.open(path, flags | os.O_NONBLOCK)
