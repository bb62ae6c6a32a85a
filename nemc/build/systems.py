"""The native integrators for a system given by a function pointer (a model's sensitivity
system, nemc/runtime/sensitivities.py), one extension per size: nemc_drivers.c at that size and
nemc_system.c's entry points (nemc/emit/native.py's system_code), compiled once and kept in the
cache folder `systems/<key>/`, published by one rename as the models' builds are. It names no
model: every model whose system has that many states uses it."""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import platform
import shutil
import sys
from pathlib import Path

from ..emit.native import SystemCode, system_code
from ..errors import BuildError, describe
from ..vocabulary import NEMC_VERSION
from .builder import (
    CFLAGS,
    DRIVERS_CFLAGS,
    SCRATCH_PREFIX,
    WRAPPER_CFLAGS,
    cache_root,
    compiler,
    extension_suffix,
    limited_api_flags,
    link,
    run_jobs,
)

SYSTEMS_FOLDER = "systems"
SYSTEM_EXTENSION = "_system"
DONE = "SYSTEM_OK"  # written last: a folder without it is not a finished build


def system_key(code: SystemCode) -> str:
    """What the extension depends on: its C, the compiler and flags, the Python ABI, cffi."""
    import cffi

    identity = {"cc": compiler(), "cflags": DRIVERS_CFLAGS, "platform": sys.platform,
                "machine": platform.machine(), "suffix": extension_suffix(),
                "cffi": cffi.__version__, "nemc": NEMC_VERSION}
    digest = hashlib.sha256(json.dumps(identity, sort_keys=True).encode())
    for text in (code.drivers, code.entry, *(text for _, text in code.headers)):
        digest.update(text.encode() + b"\0")
    return digest.hexdigest()[:24]


def system_extension(n_state: int) -> Path:
    """The folder of the extension for systems of N_STATE states: the cache's, else built."""
    code = system_code(n_state)
    final = cache_root() / SYSTEMS_FOLDER / f"{n_state}-{system_key(code)}"
    if (final / DONE).is_file():
        return final
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        scratch = Path(final.parent / f"{SCRATCH_PREFIX}{final.name}-{os.getpid()}")
        shutil.rmtree(scratch, ignore_errors=True)
        scratch.mkdir()
        try:
            compile_system(code, scratch)
            (scratch / DONE).write_text(f"{n_state}\n")
            with contextlib.suppress(OSError):  # another process published one meanwhile
                os.rename(scratch, final)
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
    except OSError as error:
        raise BuildError(f"cannot write the nemc cache folder {final.parent} "
                         f"({describe(error)}): set NEMC_CACHE to a writable folder") from None
    if not (final / DONE).is_file():
        raise BuildError(f"the native integrators for {n_state} states were not built in "
                         f"{final}")
    return final


def compile_system(code: SystemCode, folder: Path) -> None:
    """The C files, the cffi wrapper, compiled in parallel and linked into the extension."""
    import sysconfig

    import cffi

    for name, text in (*code.headers, ("nemc_drivers.c", code.drivers),
                       ("nemc_system.c", code.entry)):
        (folder / name).write_text(text)
    ffi = cffi.FFI()
    ffi.cdef(code.cdef)
    ffi.set_source(SYSTEM_EXTENSION, code.cdef)
    wrapper = folder / f"{SYSTEM_EXTENSION}.c"
    with contextlib.redirect_stdout(io.StringIO()):  # cffi announces what it writes
        ffi.emit_c_code(str(wrapper))
    include = sysconfig.get_paths()["include"]
    cc = compiler()
    c_files = {folder / "nemc_drivers.c": DRIVERS_CFLAGS, folder / "nemc_system.c": CFLAGS,
               wrapper: [*WRAPPER_CFLAGS, *limited_api_flags(), "-I", include]}
    run_jobs([[*cc, *flags, "-c", str(c), "-o", str(c.with_suffix(".o"))]
              for c, flags in c_files.items()], 2)
    link(cc, [c.with_suffix(".o") for c in c_files],
         folder / (SYSTEM_EXTENSION + extension_suffix()))
    for c in c_files:  # the extension is what is kept (and what the loader looks for)
        c.with_suffix(".o").unlink()
