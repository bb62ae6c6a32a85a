"""Animation frames draw the bodies where the state puts them: pixel checks on rendered
frames, real-time frame spacing, and the files nemc animate writes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb

import nemc
from nemc.tools.animate import BODY_COLOURS, frame_times, render_frame, zigzag
from nemc.tools.cli import main

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
LINK1, LINK2 = (np.array(to_rgb(c)) * 255 for c in BODY_COLOURS[:2])
WHITE = np.array([255.0, 255.0, 255.0])


def model_of(name: str):
    return nemc.compile(EXAMPLES / f"{name}.yaml")


def pixels(fig, ax, points: list[tuple[float, float]]) -> list[np.ndarray]:
    """The RGB colour of the rendered frame at data points (x, y)."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    image = np.asarray(canvas.buffer_rgba())[:, :, :3].astype(float)
    height = image.shape[0]
    found = []
    for x, y in points:
        px, py = ax.transData.transform((x, y))
        found.append(image[int(round(height - py)), int(round(px))])
    return found


def close(colour: np.ndarray, expected: np.ndarray) -> bool:
    return bool(np.max(np.abs(colour - expected)) < 30)


@pytest.mark.parametrize(("q1", "q2"), [(0.0, -math.pi / 2), (-math.pi / 2, 0.0),
                                         (2.2, 0.4)])
def test_frame_draws_each_link_where_the_state_puts_it(q1: float, q2: float) -> None:
    """Double pendulum (absolute angles): link 1 from O along q1, link 2 from B along q2.
    A point three quarters along each link has its colour; the centroid of O, B and D (on
    no link) is background."""
    model = model_of("double_pendulum")
    fig, ax = render_frame(model, 0.0, [q1, 0.0, q2, 0.0])
    b = np.array([math.cos(q1), math.sin(q1)])
    on1 = 0.75 * b
    on2 = b + 0.75 * 0.5 * np.array([math.cos(q2), math.sin(q2)])
    d = b + 0.5 * np.array([math.cos(q2), math.sin(q2)])
    away = (b + d) / 3
    got = pixels(fig, ax, [tuple(on1), tuple(on2), tuple(away)])
    assert close(got[0], LINK1), got[0]
    assert close(got[1], LINK2), got[1]
    assert close(got[2], WHITE), got[2]


def test_frame_follows_a_parameter_change() -> None:
    """L1 = 1.6 at run time: link 1 now reaches 1.6 m, drawn from the compiled positions."""
    model = model_of("double_pendulum")
    fig, ax = render_frame(model, 0.0, [0.0, 0.0, math.pi / 2, 0.0], params={"L1": 1.6})
    got = pixels(fig, ax, [(1.4, 0.0), (1.6, 0.4), (0.5, 0.4)])
    assert close(got[0], LINK1) and close(got[1], LINK2) and close(got[2], WHITE), got


def test_slider_and_spring_are_drawn_on_the_rail() -> None:
    """The cart slides on its rail through (1, 0) along (0.8, 0.6): at s = -1 its hinge is at
    (0.2, -0.7) and the pendulum (phi = 0) hangs 0.8 m below it; the rail is grey where the
    cart has been, the spring's wall anchor is marked."""
    model = model_of("prismatic_cart_pendulum")
    fig, ax = render_frame(model, 0.0, [-1.0, 0.0, 0.0, 0.0])
    rail = np.array([1.0, 0.0]) - 0.5 * np.array([0.8, 0.6])
    got = pixels(fig, ax, [tuple(rail), (0.2, -0.7 - 0.6), (-2.2, -2.4), (0.2, -2.0)])
    assert close(got[0], np.full(3, 153.0)), got[0]  # the rail
    assert close(got[1], LINK2), got[1]  # the pendulum, second body
    assert close(got[2], np.full(3, 204.0)), got[2]  # the anchor
    assert close(got[3], WHITE), got[3]  # below the pendulum's tip


def test_zigzag_runs_from_end_to_end() -> None:
    a, b = np.array([0.0, 0.0]), np.array([3.0, 4.0])
    line = zigzag(a, b, 0.1)
    np.testing.assert_allclose(line[0], a)
    np.testing.assert_allclose(line[-1], b)
    across = (line - a) @ np.array([-0.8, 0.6])
    assert np.max(np.abs(across)) == pytest.approx(0.1)


def test_frames_are_spaced_for_real_time() -> None:
    times = frame_times(0.0, 5.0, fps=25, speed=1.0)
    assert len(times) == 126 and np.allclose(np.diff(times), 0.04)
    assert len(frame_times(0.0, 5.0, fps=25, speed=2.0)) == 63


def test_animate_writes_a_real_time_gif_whose_frames_show_the_run(tmp_path: Path) -> None:
    """5.3 over 2 s: 51 frames 40 ms apart; in the first and last frame, the link is where an
    independent run's state at that time puts it (pixel three quarters along the link)."""
    from PIL import Image

    from nemc.tools.animate import laid_out, scene_of_result

    out = tmp_path / "arm.gif"
    assert main(["animate", str(EXAMPLES / "robot_arm.yaml"), "--out", str(out),
                 "--t-end", "2"]) == 0
    gif = Image.open(out)
    assert gif.n_frames == 51 and gif.info["duration"] == 40  # 2 s at 25 frames per second
    model = model_of("robot_arm")
    run = model.simulate(t_span=(0, 2))
    _, ax, _ = laid_out(scene_of_result(run), "robot_arm")  # the GIF's axes
    states = model.simulate(t_span=(0, 2), t_eval=[0.0, 2.0], rtol=1e-10, atol=1e-12).y[0]
    for frame, theta in ((0, states[0]), (50, states[-1])):
        gif.seek(frame)
        image = np.asarray(gif.convert("RGB")).astype(float)
        on = (0.75 * math.cos(theta), 0.75 * math.sin(theta))
        off = (0.75 * math.cos(theta + 0.5), 0.75 * math.sin(theta + 0.5))
        colours = [image[int(round(image.shape[0] - py)), int(round(px))]
                   for px, py in ax.transData.transform([on, off])]
        assert close(colours[0], LINK1) and close(colours[1], WHITE), (frame, colours)


def test_animate_html_and_inline(tmp_path: Path) -> None:
    res = model_of("double_pendulum").simulate(t_span=(0, 0.2))
    out = res.animate(tmp_path / "dp.html", fps=10)
    page = out.read_text()
    assert page.startswith("<!DOCTYPE html>") and "<script" in page and "data:image/png" in page
    inline = res.animate(fps=10)
    assert "<script" in inline._repr_html_()


def test_animate_refuses_what_it_cannot_write(tmp_path: Path, capsys) -> None:
    arm = str(EXAMPLES / "robot_arm.yaml")
    assert main(["animate", arm, "--out", str(tmp_path / "arm.avi")]) == 2
    assert "choose a .gif, .mp4 or .html" in capsys.readouterr().err
    assert main(["animate", arm, "--out", str(tmp_path / "a.gif"), "--trace", "link.nose"]) == 2
    assert "no point link.nose to trace" in capsys.readouterr().err
    assert not (tmp_path / "a.gif").exists()


def sprung_chain_yaml(n: int) -> str:
    """An n-link chain of 1 m rods hanging from the origin, every third joint prismatic, a
    joint spring on every joint (as benchmarks/common.py's mixed chain)."""
    lines = [f"name: sprung{n}", "parameters: {g: 9.81}", "gravity: [0, -g]", "bodies:"]
    lines += [f"  link{i}: {{mass: 1, inertia: 1/12, com: [0.5, 0], points: {{tip: [1, 0]}}}}"
              for i in range(1, n + 1)]
    lines.append("joints:")
    loads, initial = [], []
    for i in range(1, n + 1):
        parent, at = ("ground", "[0, 0]") if i == 1 else (f"link{i - 1}", "tip")
        kind, q = ("prismatic", f"s{i}") if i % 3 == 0 else ("revolute", f"q{i}")
        lines.append(f"  J{i}: {{type: {kind}, parent: {parent}, child: link{i}, at: {at}, "
                     f"coordinate: {q}}}")
        loads.append(f"  - joint_spring: {{joint: J{i}, k: 20, damping: 0.05}}")
        initial.append(f"{q}: {0.05 if kind == 'prismatic' else (-0.8 if i == 1 else 0.1)}")
    return "\n".join([*lines, "loads:", *loads, "simulation:",
                      f"  initial: {{{', '.join(initial)}}}"]) + "\n"


def test_a_long_chains_springs_leave_its_links_visible(tmp_path: Path) -> None:
    """A 20-link chain with a spring on every joint (issue 52: its springs hid the links):
    each spring is drawn within a third of a link of its joint, lighter than the links and
    under them, and between each link's ends and its mass centre its own colour shows (pins,
    mass centres and springs no longer cover it)."""
    from nemc.tools.animate import SPRING_INK, Artist, new_axes, scene_of

    path = tmp_path / "sprung20.yaml"
    path.write_text(sprung_chain_yaml(20))
    model = nemc.compile(path)
    y0 = model.state_vector(None)
    scene = scene_of(model, np.array([0.0]), y0.reshape(-1, 1))
    fig, ax = new_axes(scene)
    artist = Artist(ax, scene)
    artist.update(0)
    names = scene.drawing["points"]
    xy = scene.xy[0]
    assert len(artist.joint_springs) == 20
    for line, joint in zip(artist.joint_springs,
                           [j for j in scene.drawing["joints"] if j["sprung"]]):
        assert line.get_color() == SPRING_INK and line.get_zorder() < 4
        drawn = np.column_stack(line.get_data())
        assert np.max(np.hypot(*(drawn - xy[joint["origin"]]).T)) < 1.0 / 3
    starts = [xy[joint["origin"]] for joint in scene.drawing["joints"]]  # each link's origin
    tips = [xy[names.index(f"link{i}.tip")] for i in range(1, 21)]
    fractions = (0.25, 0.3, 0.7, 0.75)  # between its ends' pins and its mass centre
    along = [tuple(starts[i] + f * (tips[i] - starts[i])) for i in range(20) for f in fractions]
    got = pixels(fig, ax, along)  # one drawing
    for i in range(20):
        colour = np.array(to_rgb(BODY_COLOURS[i % len(BODY_COLOURS)])) * 255
        shown = [close(c, colour) for c in got[4 * i:4 * i + 4]]
        assert all(shown), (f"link{i + 1}", got[4 * i:4 * i + 4], colour)


def test_a_failed_runs_animation_follows_its_dense_output_to_where_it_stopped(
        tmp_path: Path) -> None:
    """The double pendulum stopped by a step budget at t = 1.66 (its table's rows 0.5 s apart):
    frames every 40 ms up to the stop, the mechanism where an independent tight run puts it
    at each (not the rows joined by straight lines: tens of centimetres off), and the drawing
    says in red where the run failed."""
    from nemc.tools.animate import laid_out, scene_of_result
    from nemc.tools.figures import FAILED_INK

    text = (EXAMPLES / "double_pendulum.yaml").read_text()
    path = tmp_path / "dp_budget.yaml"
    path.write_text(text.replace("name: double_pendulum", "name: dp_budget")
                    .replace("  atol: 1.0e-9\n", "  atol: 1.0e-9\n  max_steps: 60\n"))
    res = nemc.compile(path).simulate()
    assert not res.success and res.t[-1] == 1.5
    stop = float(res.message.split("stopped at t = ")[1].split()[0])
    scene = scene_of_result(res)
    assert len(scene.t) == math.floor(stop / 0.04) + 1 and scene.trace_t[-1] == pytest.approx(
        stop, abs=1e-8)
    assert scene.note == f"run failed at t = {stop:.6g}"
    model = model_of("double_pendulum")
    tight = model.simulate(t_span=(0, 5), t_eval=scene.t, method="nemc.DOP853", rtol=1e-11,
                           atol=1e-12)
    np.testing.assert_allclose(scene.xy, model.positions_array(scene.t, tight.y), atol=2e-3)
    _, ax, _ = laid_out(scene)
    assert [t.get_text() for t in ax.texts if t.get_color() == FAILED_INK] == [scene.note]
