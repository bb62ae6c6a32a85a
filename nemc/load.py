"""Load: import a built package and return its Model. Never builds."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

from .runtime import Model


def load_package(folder: Path) -> Model:
    """Import the package in FOLDER under a name unique to its build, once per process."""
    module_name = "_nemc_build_" + folder.name
    module = sys.modules.get(module_name)
    if module is None:
        spec = importlib.util.spec_from_file_location(
            module_name, folder / "__init__.py", submodule_search_locations=[str(folder)]
        )
        if spec is None or spec.loader is None:
            raise ImportError(f"cannot load the nemc build in {folder}")
        module = importlib.util.module_from_spec(spec)
        sys.modules[module_name] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[module_name]
            raise
    return module.model
