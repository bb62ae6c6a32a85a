"""The tutorials beyond the book (docs/tutorials/*.md listed below) run as written: each one's
Python blocks, in order, in one namespace, from a fresh directory with `examples/` linked; what
each block prints is exactly the ```text block that follows it on the page (so every number the
text quotes is the code's), and each saves its figure. The independent checks (closed forms,
energy balances) are printed by the blocks themselves and so compared here too. The runner,
docs/tutorials/blocks.py, is also what `make figures` uses to draw the figures."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TUTORIALS = ROOT / "docs" / "tutorials"
# tutorial -> the figures its blocks save
PAGES = {
    "slider-crank.md": ["slider_crank_driven.png"],
    "events.md": ["events.png"],
    "sweep.md": ["fourbar_sweep.png"],
    "control.md": [],  # its figures: docs/tutorials/control_figures.py
    "fitting.md": ["fitting.png"],
    "friction.md": ["friction.png"],
}


def runner():
    spec = importlib.util.spec_from_file_location("tutorial_blocks", TUTORIALS / "blocks.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("page", sorted(PAGES))
def test_the_tutorial_prints_what_its_text_says(page: str, tmp_path: Path) -> None:
    blocks = runner()
    outcomes = blocks.run_blocks(TUTORIALS / page, tmp_path)
    assert sum(o.block.expected is not None for o in outcomes) >= 2
    for outcome in outcomes:
        assert outcome.printed == outcome.block.expected or outcome.block.expected is None, (
            f"{page}:{outcome.block.line} prints\n{outcome.printed}\nbut the page says\n"
            f"{outcome.block.expected}")
    for figure in PAGES[page]:
        assert (tmp_path / figure).stat().st_size > 10_000
        assert (TUTORIALS.parent / "figures" / figure).exists()  # `make figures` drew it


def test_a_changed_number_is_caught(tmp_path: Path) -> None:
    """The comparison is not vacuous: a page whose quoted output differs by one digit fails."""
    page = tmp_path / "page.md"
    page.write_text("```python\nprint(f'{2**0.5:.4f}')\n```\n\n```text\n1.4143\n```\n")
    (tmp_path / "work").mkdir()
    outcome, = runner().run_blocks(page, tmp_path / "work")
    assert outcome.printed == "1.4142" and not outcome.matches
