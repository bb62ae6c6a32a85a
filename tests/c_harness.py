"""A template's C compiled alone, with a test's own callers, into a cffi module (the tests of
templates/taylor_math.c.tmpl and templates/spectrum.c.tmpl): warning-free or it fails."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import cffi


def compiled_harness(name: str, cdef: str, source: str, folder: Path) -> ModuleType:
    """The cffi module NAME of SOURCE (C99, -O2, -Wall -Wextra -Werror) declaring CDEF, built
    in FOLDER and imported without being registered in sys.modules."""
    ffi = cffi.FFI()
    ffi.cdef(cdef)
    ffi.set_source(name, source, libraries=["m"],
                   extra_compile_args=["-O2", "-std=c99", "-Wall", "-Wextra", "-Werror"])
    library = ffi.compile(tmpdir=str(folder))
    spec = importlib.util.spec_from_file_location(name, library)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sys.modules.pop(name, None)
    return module
