"""Load: import a built package's compiled extension and return a Model. Never builds.

The model is built from nemc's own runtime (so its exceptions are nemc.runtime's); the package's
`__init__.py` and `_runtime.py` serve only standalone use of an exported package.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

from .runtime import Model, read_metadata


def load_package(folder: Path) -> Model:
    """The Model of the build in FOLDER; its extension is imported once per process."""
    module_name = f"_nemc_build_{folder.name}._native"  # the extension's init is PyInit__native
    module = sys.modules.get(module_name)
    if module is None:
        extension = next(folder.glob("_native.*"), None)
        spec = importlib.util.spec_from_file_location(module_name, extension) if extension else None
        if spec is None or spec.loader is None:
            raise ImportError(f"no compiled extension in the nemc build {folder}")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules[module_name] = module
    return Model(read_metadata(folder / "model.json"), module.ffi, module.lib)
