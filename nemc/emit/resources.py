"""nemc's data files: the C and Python templates the emitter fills in.

Their source is the top-level templates/ folder; an installed nemc (a wheel, `pip install .` or
`pip install -e .`) has them as the package data `nemc.templates` (pyproject.toml maps the
folder into the package), found by its module spec (a folder on disk) or, for any other kind
of install (a zip), read with importlib.resources, imported only then: it costs a cached
compile a few milliseconds (its tempfile, shutil, bz2, lzma...). Sympy-free, as what imports
only it (the drivers of a sensitivity system, found in the cache: nemc/build/systems.py).
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from string import Template
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from importlib.abc import Traversable

SOURCE_TEMPLATES = Path(__file__).resolve().parents[2] / "templates"


def templates() -> Traversable:
    """The folder of templates: the package data of an installed nemc, else the source tree's."""
    try:
        spec = importlib.util.find_spec("nemc.templates")
    except ModuleNotFoundError:  # pragma: no cover (nemc itself is imported)
        spec = None
    if spec is None:  # run from a source tree that is not installed
        return SOURCE_TEMPLATES
    for location in spec.submodule_search_locations or ():
        folder = Path(location)
        if (folder / "model.c.tmpl").is_file():
            return folder
    return _packaged_templates()


def _packaged_templates() -> Traversable:
    """The templates of an install not on disk as a folder (a zip), else the source tree's."""
    from importlib import resources

    try:
        folder = resources.files("nemc.templates")
    except ModuleNotFoundError:
        return SOURCE_TEMPLATES
    return folder if folder.joinpath("model.c.tmpl").is_file() else SOURCE_TEMPLATES


def read_template(name: str) -> str:
    return templates().joinpath(name).read_text(encoding="utf-8")


def template(name: str) -> Template:
    return Template(read_template(name))


def comment_text(text: str) -> str:
    """Text safe inside a C block comment: printable ASCII, no comment terminator."""
    text = re.sub(r"[^\x20-\x7e]", "?", text)
    return text.replace("*/", "* /").replace("/*", "/ *")


def template_files() -> list[Traversable]:
    """Every template, in name order (their content is part of every build key)."""
    return sorted((f for f in templates().iterdir() if f.name.endswith(".tmpl")),
                  key=lambda f: f.name)
