"""nemc's data files: the C and Python templates the emitter fills in.

Their source is the top-level templates/ folder; an installed nemc (a wheel, `pip install .` or
`pip install -e .`) has them as the package data `nemc.templates` (pyproject.toml maps the
folder into the package), read with importlib.resources.
"""

from __future__ import annotations

from importlib import resources
from importlib.abc import Traversable
from pathlib import Path

SOURCE_TEMPLATES = Path(__file__).resolve().parent.parent / "templates"


def templates() -> Traversable:
    """The folder of templates: the package data of an installed nemc, else the source tree's."""
    try:
        folder = resources.files("nemc.templates")
    except ModuleNotFoundError:  # run from a source tree that is not installed
        return SOURCE_TEMPLATES
    return folder if folder.joinpath("model.c.tmpl").is_file() else SOURCE_TEMPLATES


def read_template(name: str) -> str:
    return templates().joinpath(name).read_text(encoding="utf-8")


def template_files() -> list[Traversable]:
    """Every template, in name order (their content is part of every build key)."""
    return sorted((f for f in templates().iterdir() if f.name.endswith(".tmpl")),
                  key=lambda f: f.name)
