"""Load: import a built package's compiled extension and return a Model. Never builds.

The model is built from nemc's own runtime (so its exceptions are nemc.runtime's); the package's
`__init__.py` and `_runtime.py` serve only standalone use of an exported package.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

from ..vocabulary import COMPLETE, PACKAGE_MARKER
from .model import Model, read_metadata

MAX_MANIFEST_BYTES = 1_000_000  # as the cache's and the export's own bounds


def load_package(folder: Path) -> Model:
    """The Model of the build in FOLDER; its extensions are imported once per process."""
    native = import_extension(folder, "_native")
    if native is None:
        raise ImportError(f"no compiled extension in the nemc build {folder}")
    return Model(read_metadata(folder / "model.json"), native.ffi, native.lib,
                 rhs_call(folder))


def load_system(folder: Path) -> ModuleType:
    """The native integrators for systems given by a function pointer, in FOLDER (built by
    nemc/build/systems.py): their cffi module (ffi, lib)."""
    module = import_extension(folder, "_system")
    if module is None:
        raise ImportError(f"no compiled extension in the nemc build {folder}")
    return module


def rhs_call(folder: Path) -> ModuleType | None:
    """The build's _rhs_call (Model.rhs's extension), or None where it cannot be imported (a
    stable-ABI build of it in CPython 3.10): Model.rhs then goes through cffi alone."""
    try:
        return import_extension(folder, "_rhs_call")
    except ImportError:
        return None


def import_extension(folder: Path, stem: str) -> ModuleType | None:
    """The extension STEM of the build in FOLDER (its init is PyInit_<stem>), or None when
    the build has none."""
    module_name = f"_nemc_build_{folder.name}.{stem}"
    module = sys.modules.get(module_name)
    if module is None:
        extension = extension_file(folder, stem)
        spec = importlib.util.spec_from_file_location(module_name, extension) if extension else None
        if spec is None or spec.loader is None:
            return None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules[module_name] = module
    return module


def extension_file(folder: Path, stem: str) -> Path | None:
    """The file of the extension STEM in FOLDER: STEM and a suffix this interpreter imports
    (its own first, then the stable ABI's), and in a cache entry only a file its manifest
    lists, which the cache verified. A stray _native.*.so beside it, which a glob could find
    first, is never imported (issue 51: another model's code, or a KeyError)."""
    listed = manifest_files(folder)
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = folder / f"{stem}{suffix}"
        if (listed is None or path.name in listed) and path.is_file():
            return path
    return None


def manifest_files(folder: Path) -> set[str] | None:
    """The names of the files the cache entry's manifest (COMPLETE) or the exported package's
    marker (PACKAGE_MARKER) lists, or None without either (a package exported before it)."""
    for manifest in (COMPLETE, PACKAGE_MARKER):
        path = folder / manifest
        try:
            if not path.is_file() or path.stat().st_size > MAX_MANIFEST_BYTES:
                continue  # absent, or a FIFO, a folder, a huge file: never read
            files = json.loads(path.read_text())["files"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if isinstance(files, dict):
            return set(files)
    return None
