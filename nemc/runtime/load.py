"""Load: import a built package's compiled extension and return a Model. Never builds.

The model is built from nemc's own runtime (so its exceptions are nemc.runtime's); the package's
`__init__.py` and `_runtime.py` serve only standalone use of an exported package.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from .model import Model, read_metadata


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
        extension = next((path for path in folder.glob(f"{stem}.*") if path.suffix != ".c"),
                         None)  # _rhs_call.c, its source, is beside it
        spec = importlib.util.spec_from_file_location(module_name, extension) if extension else None
        if spec is None or spec.loader is None:
            return None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules[module_name] = module
    return module
