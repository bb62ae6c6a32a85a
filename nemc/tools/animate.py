"""The mechanism moving: `nemc animate` and `res.animate()`.

Each frame draws every body as the outline through its points (origin, mass centre, named
points: a bar for two, a filled polygon for more), its mass centre, the joints (pins as open
circles, sliders on their rails, welds as squares, ground supports hatched), springs as
zigzags (grey, thin, under the bodies), the paths of the traced points so far and a time stamp.
Symbols are sized by the picture but at most by a few typical bodies, and markers shrink with
the bodies on the page: a 20-link chain's springs and pins do not hide its links. The
positions come from the compiled model (`Model.positions_array`, the C function
`<name>_positions`), never from Python geometry: a frame shows what the model computes.
Frames are spaced for real time (`speed` 1) at `fps` frames per second.

Writers: Pillow for .gif, ffmpeg for .mp4 (when it is installed), and for .html and a notebook
nemc's own player (a canvas, a play button and a slider; the frames stored as the PNG rectangles
where each differs from the one before; no JavaScript library, nothing fetched, so it plays
offline and stays small: matplotlib's to_jshtml stores every frame whole and loads its buttons'
icons from a CDN).
"""

from __future__ import annotations

import base64
import io
import json
import math
import os
import uuid
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ..runtime.model import SimulationResult
from .figures import FAILED_INK, ShownFigure, dense, pretty_unit

FPS = 25  # a GIF stores frame delays in 1/100 s: 25 frames/s is exactly real time
BODY_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
                "#17becf")
INK = "#222222"
SPRING_COILS = 8
SPRING_INK = "#777777"  # springs lighter and thinner than the bodies, and under them
SYMBOL_LINKS = 6.0  # symbols are sized by the picture, at most this many typical bodies long
SMALLEST_MARKS = 0.4  # markers shrink with the bodies on the page, to this fraction at least
MAX_FRAMES = 3000
PLAYER_DPI = 80  # the notebook's player: 400 px for the default 5 in, as small as reads well


@dataclass
class Scene:
    """Everything a drawing needs: the drawing's structure and the points' positions at each
    frame (n_frames, n_points, 2), and for traces the positions on a finer grid."""

    drawing: dict
    t: np.ndarray
    xy: np.ndarray
    trace_t: np.ndarray
    trace_xy: np.ndarray
    traces: list[int]
    time_unit: str = ""
    length_unit: str = ""
    scale: float = 1.0  # a typical length of the picture
    symbol: float = 1.0  # the length symbols (springs, supports) are sized by
    note: str = ""  # written in red in the drawing's corner: a failed run's stop
    hulls: dict[str, list[int]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        lo, hi = self.extent()
        self.scale = max(float(np.max(hi - lo)), 1e-9)
        body = typical_body(self.xy[0], self.drawing["bodies"].values())
        self.symbol = self.scale if body is None else min(self.scale, SYMBOL_LINKS * body)
        self.hulls = {body: outline(self.xy[0], points)
                      for body, points in self.drawing["bodies"].items()}

    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        points = self.xy.reshape(-1, 2)
        for disc in self.drawing.get("discs", ()):  # a circle's whole box, not its rim point
            center, rim = self.xy[:, disc["center"]], self.xy[:, disc["rim"]]
            radius = np.hypot(*(rim - center).T)[:, None]
            points = np.vstack([points, center - radius, center + radius])
        points = points[np.all(np.isfinite(points), axis=1)]
        if not points.size:
            return np.zeros(2), np.ones(2)
        return points.min(axis=0), points.max(axis=0)


def typical_body(xy: np.ndarray, bodies: Any) -> float | None:
    """The median size of the bodies drawn (each its points' largest distance apart), None
    when no body has two distinct points: a 20-link chain's springs are sized by a link, not
    by the whole chain, so they do not hide the links."""
    sizes = []
    for points in bodies:
        at = xy[list(points)].reshape(-1, 2)
        at = at[np.all(np.isfinite(at), axis=1)]
        if len(at) >= 2:
            sizes.append(float(np.max(np.hypot(*(at[:, None, :] - at[None, :, :]).T))))
    sizes = [size for size in sizes if size > 1e-12]
    return float(np.median(sizes)) if sizes else None


def outline(xy: np.ndarray, points: list[int]) -> list[int]:
    """The body's outline: its points' convex hull in order (rigid motion keeps it), the two
    farthest points when they are collinear, one point when they coincide."""
    unique: list[int] = []
    for k in points:
        if all(np.hypot(*(xy[k] - xy[j])) > 1e-9 for j in unique):
            unique.append(k)
    if len(unique) < 3:
        return unique
    hull = convex_hull(xy, unique)
    if len(hull) < 3:  # collinear: the segment between the extreme points
        far = max(((a, b) for a in unique for b in unique), key=lambda p: np.hypot(
            *(xy[p[0]] - xy[p[1]])))
        return list(far)
    return hull


def convex_hull(xy: np.ndarray, indices: list[int]) -> list[int]:
    """Andrew's monotone chain over the given points; collinear points dropped."""
    order = sorted(indices, key=lambda k: (xy[k][0], xy[k][1]))

    def cross(o: int, a: int, b: int) -> float:
        return float((xy[a][0] - xy[o][0]) * (xy[b][1] - xy[o][1])
                     - (xy[a][1] - xy[o][1]) * (xy[b][0] - xy[o][0]))

    def chain(points: list[int]) -> list[int]:
        kept: list[int] = []
        for k in points:
            while len(kept) >= 2 and cross(kept[-2], kept[-1], k) <= 1e-12:
                kept.pop()
            kept.append(k)
        return kept

    lower, upper = chain(order), chain(order[::-1])
    return lower[:-1] + upper[:-1]


# ---- a scene from a model and states --------------------------------------------------------


def scene_of(model: Any, t: np.ndarray, y: np.ndarray, params: dict | None = None,
             trace_t: np.ndarray | None = None, trace_y: np.ndarray | None = None,
             traces: list[str] | None = None) -> Scene:
    """The scene at states y (n_state, n_t) at times t; traces from (trace_t, trace_y)."""
    drawing = model.metadata["drawing"]
    xy = model.positions_array(t, y, params)
    names = drawing["points"]
    if traces is None:
        chosen = list(drawing["traces"])
    else:
        unknown = [name for name in traces if name not in names]
        if unknown:
            raise ValueError(f"no point {', '.join(unknown)} to trace; the points: "
                             f"{', '.join(names)}")
        chosen = [names.index(name) for name in traces]
    if trace_t is None or trace_y is None:
        trace_t, trace_xy = t, xy
    else:
        trace_xy = model.positions_array(trace_t, trace_y, params)
    units = model.metadata.get("units", {})
    return Scene(drawing, np.asarray(t), xy, np.asarray(trace_t), trace_xy, chosen,
                 units.get("time") or "", units.get("length") or "")


def frame_times(t0: float, t1: float, fps: float, speed: float) -> np.ndarray:
    """Real time times speed: a frame every speed/fps units of model time."""
    step = speed / fps
    frames = (t1 - t0) / step * (1 + 1e-12)  # inf for a speed of 1e-300: no int of it
    count = MAX_FRAMES if not frames < MAX_FRAMES else int(math.floor(frames)) + 1
    return t0 + step * np.arange(count)


def scene_of_result(res: SimulationResult, fps: float = FPS, speed: float = 1.0,
                    traces: list[str] | None = None) -> Scene:
    """Frames at real-time spacing through the run's dense output (a failed run's up to where
    it stopped); traces densely sampled."""
    model = res.model
    if model is None:
        raise ValueError("this result does not know its model: animate a result of simulate()")
    if res.t.size == 0:
        raise ValueError("the run has no states to draw")
    if res.rerun is not None and res.success:
        frames = res.rerun(frame_times(float(res.t[0]), float(res.t[-1]), fps, speed))
        fine = dense(res)
        t, y, fine_t, fine_y = frames.t, frames.y, fine.t, fine.y
    else:  # a run that failed: its dense output to where it stopped, interpolated to frames
        fine = dense(res)  # (a run interrupted by Ctrl-C, or not simulate()'s: its own states)
        fine_t, fine_y = fine.t, fine.y
        t = frame_times(float(fine_t[0]), float(fine_t[-1]), fps, speed)
        y = np.array([np.interp(t, fine_t, row) for row in fine_y])
    scene = scene_of(model, t, y, res.params, fine_t, fine_y, traces)
    if not res.success:
        scene.note = f"run failed at t = {fine_t[-1]:.6g}"
    return scene


# ---- drawing --------------------------------------------------------------------------------


def zigzag(a: np.ndarray, b: np.ndarray, width: float, coils: int = SPRING_COILS) -> np.ndarray:
    """A spring's zigzag from a to b: straight ends, `coils` teeth of the given width."""
    d = b - a
    length = math.hypot(*d)
    if length < 1e-12:
        return np.array([a, b])
    along, across = d / length, np.array([-d[1], d[0]]) / length
    s = np.concatenate([[0.0, 0.15], 0.15 + 0.7 * (np.arange(2 * coils) + 0.5) / (2 * coils),
                        [0.85, 1.0]])
    offset = np.concatenate([[0, 0], width * (-1.0) ** np.arange(2 * coils), [0, 0]])
    return a + np.outer(s * length, along) + np.outer(offset, across)


def spiral(center: np.ndarray, radius: float, turns: float = 2.5) -> np.ndarray:
    u = np.linspace(0, 1, 80)
    angle = 2 * math.pi * turns * u
    r = radius * (0.25 + 0.75 * u)
    return center + np.column_stack([r * np.cos(angle), r * np.sin(angle)])


class Artist:
    """The artists of one scene on one axes, updated frame by frame."""

    def __init__(self, ax: Any, scene: Scene):
        self.ax, self.scene = ax, scene
        drawing = scene.drawing
        # markers and bars shrink with the bodies on the page (a long chain's), not before
        self.marks = marks = min(1.0, max(SMALLEST_MARKS, 1.5 * scene.symbol / scene.scale))
        self.body_colour = {body: BODY_COLOURS[k % len(BODY_COLOURS)]
                            for k, body in enumerate(drawing["bodies"])}
        self.rails = [ax.plot([], [], "-", color="#999999", lw=3, solid_capstyle="round",
                              zorder=1)[0] for j in drawing["joints"] if "axis" in j]
        self.traces = [ax.plot([], [], "-", lw=1.0, alpha=0.7, color=self.trace_colour(k),
                               zorder=2)[0] for k in scene.traces]
        self.springs = [ax.plot([], [], "-", color=SPRING_INK, lw=0.9, zorder=3)[0]
                        for _ in drawing["springs"]]
        self.joint_springs = [ax.plot([], [], "-", color=SPRING_INK, lw=0.8, zorder=3)[0]
                              for j in drawing["joints"] if j["sprung"]]
        self.surfaces = [ax.plot([], [], "-", color="#999999", lw=3, solid_capstyle="round",
                                 zorder=1)[0] for _ in drawing.get("surfaces", ())]
        self.segments = [ax.plot([], [], "-", color="#999999", lw=3, solid_capstyle="butt",
                                 zorder=1)[0] for _ in drawing.get("segments", ())]
        self.bodies = {body: self.body_artist(body) for body in drawing["bodies"]}
        self.discs = [self.disc_artist(disc) for disc in drawing.get("discs", ())]
        self.blades = [ax.plot([], [], "-", color=INK, lw=4, solid_capstyle="butt",
                               zorder=6)[0] for _ in drawing.get("blades", ())]
        self.coms = ax.plot([], [], "o", ms=5 * marks, mfc="white", mec=INK, mew=1.0 * marks,
                            zorder=6)[0]
        self.pins = ax.plot([], [], "o", ms=7 * marks, mfc="white", mec=INK, mew=1.4 * marks,
                            zorder=7)[0]
        self.welds = ax.plot([], [], "s", ms=5 * marks, color=INK, zorder=7)[0]
        self.sliders = ax.plot([], [], "s", ms=9 * marks, mfc="white", mec=INK,
                               mew=1.4 * marks, zorder=7)[0]
        self.supports = ax.plot([], [], "^", ms=12 * marks, mfc="#cccccc", mec=INK,
                                zorder=0)[0]
        anchors = [spring[end] for spring in drawing["springs"] for end in ("a", "b")
                   if drawing["points"][spring[end]].startswith("loads[")]
        self.anchors = anchors
        self.anchor_marks = ax.plot([], [], "s", ms=6 * marks, mfc="#cccccc", mec=INK,
                                    zorder=3)[0]
        if scene.note:  # fixed, in the lower left corner
            ax.text(0.01, 0.01, scene.note, transform=ax.transAxes, va="bottom", ha="left",
                    color=FAILED_INK, fontsize=10)
        # above the axes, right: never on the drawing
        self.stamp = ax.text(1.0, 1.01, self.stamp_text(scene.t[0]), transform=ax.transAxes,
                             va="bottom", ha="right", family="monospace", fontsize=10)

    def dynamic(self) -> list[Any]:
        """Every artist that moves (drawn over a fixed background, frame by frame)."""
        return [*self.rails, *self.surfaces, *self.segments, *self.traces, *self.springs,
                *self.joint_springs,
                *self.bodies.values(), *(a for disc in self.discs for a in disc),
                *self.blades, self.coms, self.pins, self.welds, self.sliders,
                self.supports, self.anchor_marks, self.stamp]

    def stamp_text(self, now: float) -> str:
        unit = f" {self.scene.time_unit}" if self.scene.time_unit else ""
        return f"t = {now:7.3f}{unit}"

    def trace_colour(self, point: int) -> str:
        name = self.scene.drawing["points"][point]
        body = name.split(".")[0]
        bodies = list(self.scene.drawing["bodies"])
        return BODY_COLOURS[bodies.index(body) % len(BODY_COLOURS)] if body in bodies else INK

    def body_artist(self, body: str) -> Any:
        colour = self.body_colour[body]
        hull = self.scene.hulls[body]
        if len(hull) >= 3:
            from matplotlib.patches import Polygon

            patch = Polygon(np.zeros((len(hull), 2)), closed=True, fc=colour, ec=colour,
                            alpha=0.45, lw=2, zorder=4)
            self.ax.add_patch(patch)
            return patch
        if len(hull) == 2:
            return self.ax.plot([], [], "-", color=colour, lw=6 * self.marks,
                                solid_capstyle="round", zorder=4)[0]
        return self.ax.plot([], [], "s", color=colour, ms=14 * self.marks, zorder=4)[0]

    def disc_artist(self, disc: dict) -> tuple[Any, Any]:
        """A rolling disc: its rim, and a spoke to its rim point that shows it turn."""
        from matplotlib.patches import Circle

        body = self.scene.drawing["points"][disc["center"]].split(".")[0]
        colour = self.body_colour.get(body, INK)
        rim = Circle((0.0, 0.0), 1.0, fill=False, ec=colour, lw=2, zorder=5)
        self.ax.add_patch(rim)
        return rim, self.ax.plot([], [], "-", color=colour, lw=1.5, zorder=5)[0]

    def update_discs(self, xy: np.ndarray) -> None:
        drawing = self.scene.drawing
        for (rim, spoke), disc in zip(self.discs, drawing.get("discs", ())):
            center, point = xy[disc["center"]], xy[disc["rim"]]
            rim.set_center(tuple(center))
            rim.set_radius(math.hypot(*(point - center)))
            spoke.set_data([center[0], point[0]], [center[1], point[1]])
        for artist, surface in zip(self.surfaces, drawing.get("surfaces", ())):
            self.draw_rail(artist, surface, xy)
        for artist, segment in zip(self.segments, drawing.get("segments", ())):
            ends = np.array([xy[segment["a"]], xy[segment["b"]]])
            artist.set_data(ends[:, 0], ends[:, 1])
        for artist, blade in zip(self.blades, drawing.get("blades", ())):
            at, ahead = xy[blade["at"]], xy[blade["axis"]]
            unit = (ahead - at) / max(math.hypot(*(ahead - at)), 1e-12)
            ends = np.array([at - 0.05 * self.scene.symbol * unit,
                             at + 0.05 * self.scene.symbol * unit])
            artist.set_data(ends[:, 0], ends[:, 1])

    def update(self, k: int) -> list[Any]:
        """Move every artist to frame k."""
        scene, xy = self.scene, self.scene.xy[k]
        drawing = scene.drawing
        for body, artist in self.bodies.items():
            points = xy[scene.hulls[body]]
            if hasattr(artist, "set_xy"):
                artist.set_xy(points)
            else:
                artist.set_data(points[:, 0], points[:, 1])
        coms = np.array([xy[k] for k in drawing["coms"].values()]).reshape(-1, 2)
        self.coms.set_data(coms[:, 0], coms[:, 1])
        self.update_joints(xy)
        self.update_discs(xy)
        for artist, spring in zip(self.springs, drawing["springs"]):
            line = zigzag(xy[spring["a"]], xy[spring["b"]], 0.02 * scene.symbol)
            artist.set_data(line[:, 0], line[:, 1])
        anchors = xy[self.anchors].reshape(-1, 2)
        self.anchor_marks.set_data(anchors[:, 0], anchors[:, 1])
        now = scene.t[k]
        shown = scene.trace_t <= now + 1e-12
        for artist, point in zip(self.traces, scene.traces):
            artist.set_data(scene.trace_xy[shown, point, 0], scene.trace_xy[shown, point, 1])
        self.stamp.set_text(self.stamp_text(now))
        return [self.stamp]

    def update_joints(self, xy: np.ndarray) -> None:
        joints = self.scene.drawing["joints"]
        symbols: dict[str, list[np.ndarray]] = {"pin": [], "fixed": [], "slider": [],
                                                "none": []}
        supports, rails, sprung = [], iter(self.rails), iter(self.joint_springs)
        for joint in joints:
            origin = xy[joint["origin"]]
            symbols[joint["symbol"]].append(origin)
            if joint["parent"] == "ground" and joint["symbol"] == "pin":
                supports.append(xy[joint["at"]] - [0, 0.035 * self.scene.symbol])
            if "axis" in joint:
                self.draw_rail(next(rails), joint, xy)
            if joint["sprung"]:
                size = self.scene.symbol
                line = (zigzag(xy[joint["at"]], origin, 0.02 * size)
                        if "axis" in joint else spiral(origin, 0.05 * size))
                next(sprung).set_data(line[:, 0], line[:, 1])
        for artist, symbol in ((self.pins, "pin"), (self.welds, "fixed"),
                               (self.sliders, "slider")):
            points = np.array(symbols[symbol]).reshape(-1, 2)
            artist.set_data(points[:, 0], points[:, 1])
        points = np.array(supports).reshape(-1, 2)
        self.supports.set_data(points[:, 0], points[:, 1])

    def draw_rail(self, artist: Any, joint: dict, xy: np.ndarray) -> None:
        """The rail through `at` along the axis, over the range the slider travels."""
        at, ahead = xy[joint["at"]], xy[joint["axis"]]
        unit = ahead - at
        unit = unit / max(math.hypot(*unit), 1e-12)
        travel = (self.scene.xy[:, joint["origin"]] - self.scene.xy[:, joint["at"]]) @ unit
        travel = travel[np.isfinite(travel)]
        low, high = (min(travel.min(), 0.0), max(travel.max(), 0.0)) if travel.size else (0, 0)
        margin = 0.08 * self.scene.symbol
        ends = np.array([at + (low - margin) * unit, at + (high + margin) * unit])
        artist.set_data(ends[:, 0], ends[:, 1])


def new_axes(scene: Scene, size: float = 5.0) -> tuple[Figure, Any]:
    """A figure with equal scales spanning every frame of the scene."""
    fig = ShownFigure(figsize=(size, size), layout="constrained")
    ax = fig.add_subplot()
    lo, hi = scene.extent()
    middle, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-9) * 1.15
    ax.set_xlim(middle[0] - half, middle[0] + half)
    ax.set_ylim(middle[1] - half, middle[1] + half)
    ax.set_aspect("equal")
    ax.grid(True, lw=0.4, alpha=0.5)
    unit = f" ({pretty_unit(scene.length_unit)})" if scene.length_unit else ""
    ax.set_xlabel(f"x{unit}")
    ax.set_ylabel(f"y{unit}")
    return fig, ax


def render_frame(model: Any, t: float, y: Any, params: dict | None = None,
                 size: float = 5.0) -> tuple[Figure, Any]:
    """One frame at state y (a figure and its axes): what tests and users can look at."""
    state = np.asarray(y, dtype=float).reshape(-1, 1)
    scene = scene_of(model, np.array([float(t)]), state, params)
    fig, ax = new_axes(scene, size)
    Artist(ax, scene).update(0)
    return fig, ax


# ---- animations -----------------------------------------------------------------------------


class Inline:
    """An animation a notebook shows inline: its HTML is nemc's own compact player
    (`player_html`), drawn once when first shown."""

    def __init__(self, scene: Scene, fps: float, title: str = "", size: float = 5.0):
        self.scene, self.fps, self.title, self.size = scene, fps, title, size
        self._html: str | None = None

    def _repr_html_(self) -> str:
        if self._html is None:
            self._html = player_html(self.scene, self.fps, self.title, self.size)
        return self._html


def animation_of(scene: Scene, fps: float = FPS, title: str = "", size: float = 5.0) -> Any:
    from matplotlib.animation import FuncAnimation

    fig, _, artist = laid_out(scene, title, size)
    return FuncAnimation(fig, artist.update, frames=len(scene.t), interval=1000.0 / fps,
                         blit=False)


def laid_out(scene: Scene, title: str = "", size: float = 5.0) -> tuple[Figure, Any, Artist]:
    """The figure, axes and artists of an animation, laid out once (the axes keep their place
    in every frame)."""
    fig, ax = new_axes(scene, size)
    if title:
        ax.set_title(title, loc="left")
    artist = Artist(ax, scene)
    artist.update(0)
    fig.draw_without_rendering()
    fig.set_layout_engine("none")
    return fig, ax, artist


def rendered_frames(scene: Scene, title: str = "", size: float = 5.0,
                    dpi: float | None = None) -> Iterator[Any]:
    """The scene's frames as RGB images (PIL), drawn the fast way: the axes once, then each
    frame's moving artists over them (matplotlib's own writers redraw the whole figure, ticks
    and all, for every frame)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    fig, ax, artist = laid_out(scene, title, size)
    if dpi is not None:
        fig.set_dpi(dpi)
    canvas = FigureCanvasAgg(fig)
    moving = artist.dynamic()
    for item in moving:
        item.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    for k in range(len(scene.t)):
        artist.update(k)
        canvas.restore_region(background)
        for item in moving:
            fig.draw_artist(item)
        yield Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba()
                               ).convert("RGB")


def quantized_frames(scene: Scene, title: str = "", size: float = 5.0,
                     dpi: float | None = None) -> list[Any]:
    """The frames in one palette of 96 colours, taken from the last frame (whose traces are
    complete): what the GIF and the notebook's player store."""
    from PIL import Image

    frames = list(rendered_frames(scene, title, size, dpi))
    palette = frames[-1].quantize(colors=96, method=Image.Quantize.FASTOCTREE)
    return [frame.quantize(palette=palette, dither=Image.Dither.NONE) for frame in frames]


def write_gif(scene: Scene, path: Path, fps: float, title: str = "", size: float = 5.0) -> None:
    """A GIF of the scene, real time at `fps`, looping."""
    frames = quantized_frames(scene, title, size)
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=1000.0 / fps,
                   loop=0)


def png_uri(image: Any) -> str:
    """An image as a data: URI of its PNG (palette images stay palette PNGs: small)."""
    buffer = io.BytesIO()
    image.save(buffer, format="PNG", optimize=True)
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def patches(frames: list[Any]) -> list[tuple[int, int, str]]:
    """The first frame whole, then each frame as the rectangle where it differs from the one
    before: (left, top, PNG data URI). Drawn in order onto one canvas they give every frame."""
    found = [(0, 0, png_uri(frames[0]))]
    for before, now in zip(frames, frames[1:]):
        changed = np.argwhere(np.asarray(before) != np.asarray(now))
        if changed.size == 0:
            found.append((0, 0, ""))
            continue
        (top, left), (bottom, right) = changed.min(axis=0), changed.max(axis=0) + 1
        box = (int(left), int(top), int(right), int(bottom))
        found.append((box[0], box[1], png_uri(now.crop(box))))
    return found


PLAYER_JS = """
(function () {
  var root = document.getElementById(%(id)s), patches = %(patches)s, times = %(times)s;
  var canvas = root.querySelector("canvas"), ctx = canvas.getContext("2d");
  var slider = root.querySelector("input"), button = root.querySelector("button");
  var label = root.querySelector("span"), shown = -1, timer = null, images = [], loaded = 0;
  function draw(k) {
    if (k < shown) { shown = -1; }
    for (var i = shown + 1; i <= k; i++) {
      if (patches[i][2]) { ctx.drawImage(images[i], patches[i][0], patches[i][1]); }
    }
    shown = k; slider.value = k; label.textContent = times[k];
  }
  function stop() { clearInterval(timer); timer = null; button.textContent = "\\u25B6"; }
  function play() {
    if (shown >= patches.length - 1) { draw(0); }
    button.textContent = "\\u275A\\u275A";
    timer = setInterval(function () {
      if (shown >= patches.length - 1) { stop(); } else { draw(shown + 1); }
    }, %(interval)s);
  }
  button.onclick = function () { if (timer) { stop(); } else { play(); } };
  slider.oninput = function () { stop(); draw(parseInt(slider.value, 10)); };
  patches.forEach(function (p, i) {
    var image = new Image(); images.push(image);
    image.onload = image.onerror = function () { if (++loaded === patches.length) { play(); } };
    if (p[2]) { image.src = p[2]; } else { image.onload(); }
  });
})();
"""


def player_html(scene: Scene, fps: float, title: str = "", size: float = 5.0) -> str:
    """A compact, self-contained player: a canvas, a play/pause button and a slider, the
    frames stored as the PNG rectangles where each differs from the one before (no
    JavaScript library and nothing fetched: it plays offline); without scripts (a notebook
    viewer that strips them), the first frame."""
    frames = quantized_frames(scene, title, size, dpi=PLAYER_DPI)
    width, height = frames[0].size
    element = f"nemc-player-{uuid.uuid4().hex}"
    unit = f" {scene.time_unit}" if scene.time_unit else ""
    times = [f"t = {t:.3f}{unit}" for t in scene.t]
    stored = patches(frames)
    script = PLAYER_JS % {"id": json.dumps(element), "patches": json.dumps(stored),
                          "times": json.dumps(times), "interval": f"{1000.0 / fps:.3f}"}
    # the first frame as the canvas's background: what a viewer that runs no script shows
    first = f"background:url({stored[0][2]}) 0 0 / 100% 100%"
    return (f'<div id="{element}" style="display:inline-block">'
            f'<canvas width="{width}" height="{height}" style="max-width:100%;{first}">'
            f"</canvas><br>"
            f'<button type="button" style="width:3em">&#9654;</button> '
            f'<input type="range" min="0" max="{len(frames) - 1}" value="0" step="1" '
            f'style="width:60%;vertical-align:middle"> <span></span>'
            f"<script>{script}</script></div>")


def save(animation: Any, path: Path, fps: float) -> None:
    """Write the animation as .mp4 (ffmpeg); .gif and .html are nemc's own (write_gif,
    write_html)."""
    from matplotlib import animation as anim

    suffix = path.suffix.lower()
    if suffix == ".mp4":
        if not anim.writers.is_available("ffmpeg"):
            raise ValueError("writing .mp4 needs ffmpeg, which is not installed here: write a"
                             " .gif or .html instead (or install ffmpeg)")
        animation.save(path, writer=anim.FFMpegWriter(fps=fps))
    else:
        raise ValueError(f"cannot write {path.name}: choose a .gif, .mp4 or .html file")


def write_html(scene: Scene, path: Path, fps: float, title: str = "", size: float = 5.0) -> None:
    """A web page of the player alone (`player_html`): it plays offline."""
    page = player_html(scene, fps, title, size)
    path.write_text(f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'></head><body>\n"
                    f"{page}\n</body></html>\n")


def animate_result(res: SimulationResult, path: str | os.PathLike | None = None, *,
                   fps: float = FPS, speed: float = 1.0, traces: list[str] | None = None,
                   size: float = 5.0) -> Any:
    """The run as an animation: written to PATH when given (returns the path), else an object
    a notebook displays inline."""
    if not (fps > 0 and speed > 0):
        raise ValueError(f"fps and speed must be > 0, got {fps} and {speed}")
    scene = scene_of_result(res, fps, speed, traces)
    title = res.model.name + (f" (speed x{speed:g})" if speed != 1 else "")
    if path is None:
        return Inline(scene, fps, title, size)
    suffix = Path(path).suffix.lower()
    if suffix == ".gif":
        write_gif(scene, Path(path), fps, title, size)
    elif suffix in (".html", ".htm"):
        write_html(scene, Path(path), fps, title, size)
    else:
        save(animation_of(scene, fps, title, size), Path(path), fps)
    return Path(path)
