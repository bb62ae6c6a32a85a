"""Run a tutorial's Python blocks as written and compare what they print with the text.

A tutorial (docs/tutorials/*.md) is a sequence of ```python blocks run in one namespace, in
order, from a directory where `examples/` is the repository's; a ```text block right after a
Python block is what that block prints, and must be exactly that. The figures the blocks save
(`*.png`) are the tutorial's figures.

    .venv/bin/python docs/tutorials/blocks.py docs/tutorials/events.md     # check
    .venv/bin/python docs/tutorials/blocks.py --show docs/tutorials/events.md   # print outputs
    .venv/bin/python docs/tutorials/blocks.py --figures docs/figures docs/tutorials/*.md

tests/test_tutorials.py runs the same check; `make figures` writes the figures.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^```(\w*)\s*\n(.*?)^```\s*$", re.S | re.M)


@dataclass
class Block:
    """One Python block, its line in the file, and the text the tutorial says it prints."""

    line: int
    code: str
    expected: str | None


@dataclass
class Outcome:
    """A block's printed text against the tutorial's."""

    block: Block
    printed: str

    @property
    def matches(self) -> bool:
        return self.block.expected is None or self.block.expected == self.printed


def python_blocks(text: str) -> list[Block]:
    """The Python blocks of a markdown text, each with the ```text block right after it."""
    fences = list(FENCE.finditer(text))
    blocks = []
    for i, fence in enumerate(fences):
        if fence.group(1) != "python":
            continue
        expected = None
        if i + 1 < len(fences) and fences[i + 1].group(1) == "text":
            between = text[fence.end():fences[i + 1].start()]
            if not between.strip():
                expected = normalized(fences[i + 1].group(2))
        blocks.append(Block(text.count("\n", 0, fence.start()) + 1, fence.group(2), expected))
    return blocks


def normalized(text: str) -> str:
    """Printed text without trailing spaces and trailing blank lines."""
    return "\n".join(line.rstrip() for line in text.rstrip().splitlines())


def run_blocks(path: Path, workdir: Path) -> list[Outcome]:
    """Run a tutorial's blocks in order in one namespace, in workdir (with `examples/` linked)."""
    import matplotlib

    matplotlib.use("Agg")
    link = workdir / "examples"
    if not link.exists():
        link.symlink_to(ROOT / "examples")
    namespace: dict = {"__name__": "__tutorial__"}
    outcomes = []
    here = Path.cwd()
    os.chdir(workdir)
    try:
        for block in python_blocks(path.read_text()):
            printed = io.StringIO()
            with contextlib.redirect_stdout(printed):
                exec(compile(block.code, f"{path.name}:{block.line}", "exec"), namespace)
            outcomes.append(Outcome(block, normalized(printed.getvalue())))
    finally:
        os.chdir(here)
        import matplotlib.pyplot as plt

        plt.close("all")
    return outcomes


def report(path: Path, outcomes: list[Outcome], show: bool) -> bool:
    """Print each mismatch (or every block's output with show); True when all match."""
    ok = True
    for outcome in outcomes:
        if show or not outcome.matches:
            mark = "" if outcome.matches else "  MISMATCH"
            print(f"--- {path}:{outcome.block.line}{mark}\n{outcome.printed}")
            if not outcome.matches:
                print(f"--- the text says\n{outcome.block.expected}")
        ok = ok and outcome.matches
    return ok


def main(argv: list[str] | None = None) -> int:
    """Check the tutorials given; copy their figures to --figures when all match."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--figures", type=Path, help="copy the PNGs the blocks save here")
    parser.add_argument("--show", action="store_true", help="print every block's output")
    args = parser.parse_args(argv)
    ok = True
    for path in args.files:
        with tempfile.TemporaryDirectory() as work:
            outcomes = run_blocks(path.resolve(), Path(work))
            ok = report(path, outcomes, args.show) and ok
            if args.figures is not None:
                for png in sorted(Path(work).glob("*.png")):
                    shutil.copy(png, args.figures / png.name)
                    print(f"{path}: wrote {args.figures / png.name}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
