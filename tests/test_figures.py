"""Report figures: the book's state layout, outputs grouped by kind with their units, legends
off the data, curves through the dense output (no aliasing of fast motion)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.tools.figures import dense_times, figure

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def model_of(name: str):
    return nemc.compile(EXAMPLES / f"{name}.yaml")


def labels(fig) -> list[str]:
    return [ax.get_ylabel() for ax in fig.axes]


def test_one_coordinate_gets_angle_rate_and_phase_portrait_in_degrees() -> None:
    """The book's Fig. 5.6 (5.3) is in degrees, as the YAML's `units: {angle: deg}` says."""
    res = model_of("robot_arm").simulate()
    fig = figure(res)
    assert labels(fig) == [r"$\theta$ (deg)", r"$\dot{\theta}$ (deg/s)", r"$\dot{\theta}$ (deg/s)"]
    angle = fig.axes[0].lines[0]
    times, degrees = angle.get_xdata(), angle.get_ydata()
    assert degrees[0] == pytest.approx(10.0, rel=1e-9)  # theta(0) = pi/18
    assert degrees[-1] == pytest.approx(60.0, abs=0.2)  # settles at pi/3
    assert times[-1] == pytest.approx(10.0) and len(times) >= 1500  # dense, not the 11 rows
    phase = fig.axes[2].lines[0]
    np.testing.assert_allclose(phase.get_xdata(), degrees)


def test_several_coordinates_each_against_time_then_outputs_by_kind() -> None:
    res = model_of("double_pendulum").simulate()
    fig = figure(res)
    assert labels(fig) == ["$q_{1}$ (deg)", "$q_{2}$ (deg)", "reaction, ground axes (N)",
                           "reaction, body axes (N)", "energy (J)"]
    ground = fig.axes[2]
    assert [line.get_label() for line in ground.lines] == ["A.Fx", "A.Fy", "B.Fx", "B.Fy"]
    colours = [line.get_color() for line in ground.lines]
    assert len(set(colours)) == len(colours)  # distinct within a panel
    for ax in fig.axes:
        assert ax.get_xlabel() == "t (s)"


def test_constraint_reactions_join_the_joint_reactions() -> None:
    """A closed loop's constraint reactions are reactions: in the same panels as the joints'
    (they had a panel each), with the units of a force."""
    res = model_of("fourbar_driven").simulate()
    fig = figure(res)
    ground = next(ax for ax in fig.axes if ax.get_ylabel().startswith("reaction, ground"))
    assert [line.get_label() for line in ground.lines] == ["A.Fx", "A.Fy", "D.Fx", "D.Fy",
                                                           "C.Fx", "C.Fy"]
    assert not any(ax.get_ylabel().startswith("C.") for ax in fig.axes)
    assert res.model.metadata["quantities"]["C.Fn"] == "joint force"


def test_legends_sit_above_their_panels_not_on_the_data() -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = figure(model_of("double_pendulum").simulate())
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    legends = [(ax, ax.get_legend()) for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 3  # the outputs' panels; the state's axes name their curve
    for ax, legend in legends:
        box = legend.get_window_extent(renderer)
        assert box.y0 >= ax.get_window_extent(renderer).y1 - 1  # entirely above the axes


def test_panel_choice_and_output_choice() -> None:
    res = model_of("compound_pendulum").simulate()
    fig = figure(res, panels=["energy"])
    assert labels(fig) == ["energy (ft\u00b7lb)"]
    fig = figure(res, panels=["reactions", "accelerations"], outputs=["O.F?", "ddot(*)"])
    assert labels(fig) == ["reaction, ground axes (lb)", "reaction, body axes (lb)",
                           "acceleration (rad/s\u00b2)"]
    with pytest.raises(ValueError, match="unknown panel kind"):
        figure(res, panels=["torques"])


def test_points_get_position_velocity_and_path_panels() -> None:
    fig = figure(model_of("prismatic_cart_pendulum").simulate(t_span=(0, 2)), panels=["points"])
    assert labels(fig) == ["position (m)", "y (m)", "velocity (m/s)"]
    path = fig.axes[1].lines[0]
    assert path.get_label() == "pendulum.tip"


def test_dense_times_put_many_points_in_every_solver_step() -> None:
    steps = np.array([0.0, 0.1, 0.5, 3.0, 10.0])
    times = dense_times(steps)
    assert times[0] == 0.0 and times[-1] == 10.0 and np.all(np.diff(times) > 0)
    for a, b in zip(steps[:-1], steps[1:]):
        assert np.count_nonzero((times >= a) & (times < b)) >= 12


def test_curves_follow_fast_motion_that_the_table_would_alias() -> None:
    """A thruster pulsing at 2000 rad/s: the table's 0.1 s rows see sin(200 k), an alias; the
    figure's curve is sampled from the dense output, 12 points in each solver step (far more
    than a fixed count would give), and matches F0 sin(w t) everywhere, with one zero
    crossing per half period."""
    model = model_of("body_frame_thruster")
    w, f0 = 2000.0, 3.0
    res = model.simulate(t_span=(0, 2), params={"w": w})
    assert len(res.t) == 21
    steps = model.simulate(t_span=(0, 2), params={"w": w}, t_eval="steps").t
    assert len(steps) > 1000
    thrust = next(line for ax in figure(res, panels=["expressions"]).axes for line in ax.lines
                  if line.get_label() == "thrust")
    t, value = thrust.get_xdata(), thrust.get_ydata()
    assert np.max(np.diff(t)) < (2 * math.pi / w) / 8
    np.testing.assert_allclose(value, f0 * np.sin(w * t), atol=1e-9)
    crossings = np.count_nonzero(np.diff(np.sign(value[1:])) != 0)
    assert abs(crossings - 2 * w / (2 * math.pi) * 2) <= 2


def test_result_plot_writes_the_same_figure(tmp_path: Path) -> None:
    res = model_of("two_link_robot_arm").simulate()
    fig = res.plot(tmp_path / "arm.png")
    assert labels(fig) == ["$q_{1}$ (deg)", "$q_{2}$ (deg)"]
    final = fig.axes[0].lines[0].get_ydata()[-1]
    assert final == pytest.approx(29.53, abs=0.01)  # the 5.4 steady state (see the example)
    assert (tmp_path / "arm.png").stat().st_size > 10_000


def test_curves_drawn_against_a_state_entry_or_an_output(capsys) -> None:
    """x="q1": every curve over time takes q1's values at the same times (in degrees, as the
    YAML's units say); the panel of q1 against itself is left out; --x checks its name."""
    from nemc.tools.cli import main

    res = model_of("double_pendulum").simulate()
    over_time, against_q1 = figure(res), figure(res, x="q1")
    q1, q2 = (ax.lines[0] for ax in over_time.axes[:2])
    assert len(against_q1.axes) == len(over_time.axes) - 1
    assert labels(against_q1)[0] == r"$q_{2}$ (deg)"
    for ax in against_q1.axes:
        assert ax.get_xlabel() == r"$q_{1}$ (deg)"
        np.testing.assert_array_equal(ax.lines[0].get_xdata(), q1.get_ydata())
    np.testing.assert_array_equal(against_q1.axes[0].lines[0].get_ydata(), q2.get_ydata())
    energy = figure(res, panels=["energy"], x="energy.kinetic").axes[0]
    assert [line.get_label() for line in energy.lines[:2]] == ["energy.potential",
                                                               "energy.total"]
    with pytest.raises(ValueError, match=r"x: no state entry or output 'q9'; choose from t, q1"):
        figure(res, x="q9")
    assert main(["simulate", str(EXAMPLES / "double_pendulum.yaml"), "--plot", "x.png",
                 "--x", "A.Fq"]) == 2
    assert "--x: no state entry or output 'A.Fq'" in capsys.readouterr().err


def test_driven_coordinates_in_the_table_the_frame_and_the_figure(tmp_path: Path) -> None:
    """fourbar_driven's crank angle q1 = pi/2 + w t (w = 2 pi) and its rate are outputs of
    every run, against the closed form; in the CSV, the DataFrame (with their units) and the
    figure's state column; and the curves can be drawn against q1."""
    from nemc.tools.cli import main

    res = model_of("fourbar_driven").simulate()
    np.testing.assert_allclose(res.outputs["q1"], math.pi / 2 + 2 * math.pi * res.t,
                               rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(res.outputs["dot(q1)"], 2 * math.pi, rtol=1e-15)
    assert list(res.columns())[:7] == ["t", "q2", "dot(q2)", "q3", "dot(q3)", "q1", "dot(q1)"]
    assert res.to_pandas().attrs["units"]["q1"] == res.model.metadata["unit_labels"]["q1"]
    fig = figure(res)
    assert labels(fig)[:3] == ["$q_{2}$ (rad)", "$q_{3}$ (rad)", "$q_{1}$ (rad)"]
    assert not any(ax.get_ylabel() in ("q1", "dot(q1)") for ax in fig.axes)
    against_q1 = figure(res, panels=["state"], x="q1")
    assert labels(against_q1) == ["$q_{2}$ (rad)", "$q_{3}$ (rad)"]
    assert against_q1.axes[0].get_xlabel() == "$q_{1}$ (rad)"
    csv = tmp_path / "driven.csv"
    assert main(["simulate", str(EXAMPLES / "fourbar_driven.yaml"), "--csv", str(csv)]) == 0
    header = next(line for line in csv.read_text().splitlines() if line.startswith("t,"))
    header = header.split(",")
    assert header[5:7] == ["q1 [rad]", "dot(q1)"]


def test_an_output_expressions_unit_labels_its_axis_column_and_frame(tmp_path: Path) -> None:
    """cart_pole's `force: {value: F, unit: N}`: the unit in the figure's axis, the CSV's
    header and the DataFrame's units; the values are the expressions' (F, F dot(x))."""
    from nemc.tools.cli import main

    model = model_of("cart_pole")
    assert model.metadata["unit_labels"]["force"] == "N"
    assert model.metadata["unit_labels"]["power"] == "W"
    res = model.simulate(t_eval=[0.0, 0.1], inputs={"F": 2.5})
    np.testing.assert_array_equal(res.outputs["force"], 2.5)
    np.testing.assert_allclose(res.outputs["power"], 2.5 * res.y[1], rtol=1e-15)  # F dot(x)
    assert labels(figure(res, panels=["expressions"])) == ["force (N)", "power (W)"]
    assert res.to_pandas().attrs["units"]["force"] == "N"
    csv = tmp_path / "cart.csv"
    assert main(["simulate", str(EXAMPLES / "cart_pole.yaml"), "--csv", str(csv)]) == 0
    header = next(line for line in csv.read_text().splitlines() if line.startswith("t "))
    assert "force [N]" in header.split(",") and "power [W]" in header.split(",")


def test_title_size_and_only_the_curves_named(tmp_path: Path, capsys) -> None:
    """title=, size= (inches) and only= (names or patterns): the panels left empty are left
    out; the CLI's --title, --size W,H and --only write the same figure, 150 dpi."""
    from matplotlib.image import imread

    from nemc.tools.cli import main

    res = model_of("slider_crank").simulate(t_eval=[0.0, 1.0])
    fig = figure(res, title="crank and guide", size=(9, 6), only=["q1", "guide.F?"])
    assert fig.get_suptitle() == "crank and guide"
    assert tuple(fig.get_size_inches()) == (9.0, 6.0)
    assert labels(fig) == ["$q_{1}$ (rad)", "reaction, ground axes", "reaction, body axes"]
    assert [line.get_label() for line in fig.axes[1].lines] == ["guide.Fx", "guide.Fy"]
    with pytest.raises(ValueError, match=r"nothing to draw.*only: nothing"):
        figure(res, only=["nothing"])
    path = tmp_path / "sc.png"
    assert main(["simulate", str(EXAMPLES / "slider_crank.yaml"), "--t-eval", "1", "--plot",
                 str(path), "--title", "T", "--size", "9,6", "--only", "q1,guide.*"]) == 0
    assert imread(path).shape[:2] == (900, 1350)
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(["simulate", str(EXAMPLES / "slider_crank.yaml"), "--size", "9"])
    assert "--size: expected W,H in inches" in capsys.readouterr().err


def test_rounding_noise_is_drawn_as_zero_within_tolerance() -> None:
    """The slider's angle q3 and the guide's couple are 0 (the couple but for rounding, below
    the run's atol): flat at 0 with the note, not autoscaled noise; q1's panel is drawn as it is."""
    res = model_of("slider_crank").simulate()
    assert np.abs(res.y[4]).max() < res.atol  # q3
    assert 0 < np.abs(res.outputs["guide.M"]).max() < res.atol  # noise (1e-15), not exactly 0
    fig = figure(res, panels=["state", "reactions"])
    by_label = {ax.get_ylabel(): ax for ax in fig.axes}
    for name in ("$q_{3}$ (rad)", "constraint couple"):
        ax = by_label[name]
        assert [t.get_text() for t in ax.texts] == ["0 within tolerance (|values| < atol 1e-11)"]
        assert not ax.lines[0].get_ydata().any() and ax.get_ylim() == (-1.0, 1.0)
    assert not by_label["$q_{1}$ (rad)"].texts
    assert by_label["$q_{1}$ (rad)"].lines[0].get_ydata()[-1] > 100  # the crank turns


def chain_text(n: int) -> str:
    """An n-link chain of uniform rods under gravity (relative angles q1..qn)."""
    lines = [f"name: chain{n}", "parameters: {m: 1, L: 1, g: 9.81}", "gravity: [0, -g]",
             "bodies:"]
    lines += [f"  link{i}: {{mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {{tip: [L, 0]}}}}"
              for i in range(1, n + 1)]
    lines.append("joints:")
    lines += [f"  J{i}: {{type: revolute, parent: {'ground' if i == 1 else f'link{i - 1}'}, "
              f"child: link{i}, at: {'[0, 0]' if i == 1 else 'tip'}, coordinate: q{i}}}"
              for i in range(1, n + 1)]
    lines += ["simulation: {t_span: [0, 0.5], initial: {q1: 0.5}}"]
    return "\n".join(lines) + "\n"


def test_a_large_mechanism_is_laid_out_to_a_readable_size() -> None:
    """Past six coordinates, five to a panel with a legend; past eight rows of panels, more
    columns; the height at most MAX_HEIGHT (a 20-link chain's figure was 46 inches high)."""
    from nemc.tools import figures

    res = nemc.compile(text=chain_text(7), name="chain7.yaml").simulate()
    fig = figure(res)
    assert [[line.get_label() for line in ax.lines] for ax in fig.axes] == [
        ["q1", "q2", "q3", "q4", "q5"], ["q6", "q7"]]
    assert labels(fig) == ["angle (rad)", "angle (rad)"]
    places = figures.capped(figures.grid(20, 3))
    rows, columns = (max(p[k] for p in places) + 1 for k in (0, 1))
    assert rows <= figures.MAX_ROWS and columns <= figures.MAX_COLUMNS
    assert len(set(places)) == 23  # no two panels in one place
    panels = [figures.Panel("y", [figures.Curve("a", np.arange(3.0), np.arange(3.0))], "t")]
    tall = figures.draw(panels * 20, panels * 3, "20 panels")
    assert tall.get_size_inches()[1] <= figures.MAX_HEIGHT


NAMED_LOADS = """\
name: named_loads
parameters: {m: 2, k: 30, L0: 1.5, c: 0.4, kj: 5, cj: 0.3, T0: 0.7, F: 1.2}
gravity: [0, -9.81]
bodies:
  cart: {mass: m, inertia: 0.1}
  pole: {mass: 1, inertia: 0.08, com: [0.5, 0]}
joints:
  slide: {type: prismatic, parent: ground, child: cart, axis: [1, 0], coordinate: x}
  hinge: {type: revolute, parent: cart, child: pole, coordinate: q}
loads:
  - {spring: {a: {body: ground, at: [-2, 0]}, b: cart.origin, k: k, length: L0, damping: c},
     name: pull}
  - {joint_spring: {joint: hinge, k: kj, rest: 0.2, damping: cj}, name: wrist}
  - {torque: T0*cos(t), body: pole, name: motor}
  - {force: [F, 0], body: pole, at: [1, 0], frame: body, name: push}
simulation: {t_span: [0, 1], initial: {x: 0.3, q: -0.4, dot(x): 0.5}}
units: {length: m, mass: kg, time: s}
"""


def test_named_loads_are_reported_as_outputs() -> None:
    """`name:` on a load: a torque's value (motor), a force's ground components (push.Fx,
    .Fy: a body-frame force turned with the pole), a spring's and a joint spring's tension,
    each against its law evaluated here from the state; their units; their own panels."""
    model = nemc.compile(text=NAMED_LOADS, name="named_loads.yaml")
    assert list(model.output_names) == ["pull.tension", "wrist.tension", "motor", "push.Fx",
                                        "push.Fy"]
    units = model.metadata["unit_labels"]
    assert [units[n] for n in model.output_names] == ["N", "N*m", "N*m", "N", "N"]
    res = model.simulate(t_eval=np.linspace(0, 1, 11))
    x, dx, q, dq = res.y
    out = res.outputs
    np.testing.assert_allclose(out["pull.tension"], 30 * (x + 2 - 1.5) + 0.4 * dx,
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(out["wrist.tension"], -5 * (q - 0.2) - 0.3 * dq,
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(out["motor"], 0.7 * np.cos(res.t), rtol=1e-14)
    np.testing.assert_allclose(out["push.Fx"], 1.2 * np.cos(q), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(out["push.Fy"], 1.2 * np.sin(q), rtol=1e-12, atol=1e-14)
    fig = figure(res, panels=["loads"])
    assert [[line.get_label() for line in ax.lines] for ax in fig.axes] == [
        ["pull.tension", "push.Fx", "push.Fy"], ["wrist.tension", "motor"]]
    assert labels(fig) == ["load (N)", "load (N·m)"]


@pytest.mark.parametrize(("name", "message"), [
    ("k", "load name 'k' is already used by the parameter at parameters.k"),
    ("motor", "load name 'motor' is already used by the load at loads[2].name"),
    ("3", "load name must be an identifier"),
])
def test_a_load_name_must_be_new_and_an_identifier(name: str, message: str) -> None:
    from nemc.errors import InputError

    text = NAMED_LOADS.replace("frame: body, name: push}", f"frame: body, name: {name}}}")
    with pytest.raises(InputError) as error:
        nemc.compile(text=text, name="named_loads.yaml")
    assert "loads[3].name" in str(error.value) and message in str(error.value)


def budgeted_double_pendulum(tmp_path: Path) -> Path:
    """The book's double pendulum (RK45, 0 .. 5 s) with a step budget of 60: it stops early."""
    text = (EXAMPLES / "double_pendulum.yaml").read_text()
    old = "  atol: 1.0e-9\n"
    assert old in text
    path = tmp_path / "dp_budget.yaml"
    path.write_text(text.replace("name: double_pendulum", "name: dp_budget")
                    .replace(old, old + "  max_steps: 60\n"))
    return path


def test_a_failed_runs_figure_is_drawn_densely_to_where_it_stopped_and_marked(
        tmp_path: Path, monkeypatch, capsys) -> None:
    """nemc simulate --plot of a run that stops at its step budget (t = 1.66 of 5; the table
    has rows 0.5 s apart): its curves come from the run's dense output up to the time it
    stopped, and equal an independent tight run there (not the table's rows joined by straight
    lines: those are degrees off); the title says, in red, that it failed, when and why; every
    time panel marks the stop and spans the whole 0 .. 5 s asked for."""
    from nemc.tools import figures
    from nemc.tools.cli import main

    drawn = []
    monkeypatch.setattr(figures, "figure", lambda *a, **k: drawn.append(
        figure(*a, **k)) or drawn[-1])
    path = budgeted_double_pendulum(tmp_path)
    png = tmp_path / "failed.png"
    assert main(["simulate", str(path), "--plot", str(png)]) == 1
    assert png.stat().st_size > 10_000
    message = capsys.readouterr().err
    stop = float(re.search(r"stopped at t = (\S+) after 60 steps", message).group(1))
    assert 1.0 < stop < 5.0
    fig = drawn[0]
    title = fig.get_suptitle()
    assert f"run failed at t = {stop:.6g} of 0 .. 5: stopped at t" in title
    assert "(max_steps)" in title and fig._suptitle.get_color() == figures.FAILED_INK
    q1 = fig.axes[0].lines[0]
    t, degrees = q1.get_xdata(), q1.get_ydata()
    assert len(t) >= 1500 and t[-1] == pytest.approx(stop, abs=1e-8)
    tight = nemc.compile(EXAMPLES / "double_pendulum.yaml").simulate(
        t_span=(0, 5), t_eval=t, method="nemc.DOP853", rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(degrees, np.degrees(tight.y[0]), atol=0.01)
    for ax in fig.axes:
        assert ax.get_xlim() == (0.0, 5.0)
        assert any(len(line.get_xdata()) == 2 and np.allclose(line.get_xdata(), stop, atol=1e-8)
                   and line.get_color() == figures.FAILED_INK for line in ax.lines)


def test_a_run_that_could_not_start_is_drawn_as_its_one_state_and_marked(
        tmp_path: Path) -> None:
    """A linkage at rest at its flat (singular) position stops at t = 0 with no outputs: the
    figure shows the state it has as points and says it failed there and why (it raised a
    KeyError for the missing outputs before)."""
    text = (EXAMPLES / "double_fourbar.yaml").read_text()
    for old, new in (("name: double_fourbar", "name: locked"),
                     ("initial: {q1: pi/2, dot(q1): -1}", "initial: {q1: 1.0e-4, dot(q1): 0}"),
                     ("guess: {q2: 0, q3: pi/2, q4: 0, q5: pi/2}",
                      "guess: {q2: 0, q3: 0, q4: 0, q5: 0}")):
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "locked.yaml"
    path.write_text(text)
    res = nemc.compile(path).simulate((0.0, 1.0))
    assert not res.success and not res.outputs
    fig = figure(res)
    assert "run failed at t = 0 of 0 .. 1: constraint 'C" in fig.get_suptitle()
    first = fig.axes[0].lines[0]
    assert list(first.get_xdata()) == [0.0] and first.get_marker() == "o"


def test_a_successful_runs_figure_is_not_marked() -> None:
    fig = figure(model_of("double_pendulum").simulate(t_span=(0, 1)))
    assert "failed" not in fig.get_suptitle() and fig._suptitle.get_color() == "black"
