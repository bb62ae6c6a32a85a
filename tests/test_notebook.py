"""A notebook as a user runs it, executed by a real Jupyter kernel (nbclient): `res.plot()`
shows as an image with no `%matplotlib inline`, and `res.animate()` as nemc's own player,
small and with nothing fetched from the network; its frames, put back together as the browser
does, are the frames drawn."""

from __future__ import annotations

import base64
import io
from pathlib import Path

import nbformat
import numpy as np
from nbclient import NotebookClient
from PIL import Image

import nemc
from nemc.tools.animate import patches, quantized_frames, scene_of_result

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "double_pendulum.yaml"
ANIMATION_BUDGET = 1_000_000  # bytes: the book's double pendulum's 5 s (126 frames) inline


def executed(cells: list[str], tmp_path: Path) -> list[list[dict]]:
    """Each cell's outputs after a kernel (this Python's ipykernel) ran the notebook."""
    book = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    NotebookClient(book, timeout=300, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    return [cell["outputs"] for cell in book.cells]


def test_a_notebook_shows_the_figure_and_a_light_animation(tmp_path: Path) -> None:
    outputs = executed([f"import nemc\nres = nemc.compile({str(EXAMPLE)!r}).simulate()",
                        "res.plot()", "res.animate()"], tmp_path)
    figure = [o["data"] for o in outputs[1] if o["output_type"] == "execute_result"][0]
    image = Image.open(io.BytesIO(base64.b64decode(figure["image/png"])))
    assert image.size[0] >= 400 and image.size[1] >= 300, image.size
    assert np.asarray(image.convert("L")).std() > 10  # drawn, not blank
    page = [o["data"] for o in outputs[2] if o["output_type"] == "execute_result"][0]
    html = page["text/html"]
    assert "<canvas" in html and "<script>" in html
    assert "background:url(data:image/png;base64," in html  # the first frame without scripts
    assert len(html.encode()) < ANIMATION_BUDGET, len(html.encode())
    assert "://" not in html and "<link" not in html  # nothing fetched: it plays offline


def test_the_players_patches_rebuild_every_frame() -> None:
    """Drawn in order onto one canvas, the stored rectangles give each frame back exactly."""
    res = nemc.compile(EXAMPLE).simulate(t_span=(0, 0.6))
    frames = quantized_frames(scene_of_result(res, fps=25), "double_pendulum", dpi=40)
    canvas = np.zeros(np.asarray(frames[0].convert("RGB")).shape, dtype=np.uint8)
    assert len(frames) > 10
    for frame, (left, top, uri) in zip(frames, patches(frames)):
        if uri:
            patch = Image.open(io.BytesIO(base64.b64decode(uri.split(",", 1)[1])))
            piece = np.asarray(patch.convert("RGB"))
            canvas[top:top + piece.shape[0], left:left + piece.shape[1]] = piece
        assert np.array_equal(canvas, np.asarray(frame.convert("RGB")))
