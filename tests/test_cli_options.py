"""nemc simulate's options (--initial, --t-eval, --outputs, --csv, --mat, --plot, --panels) and
nemc compile --jacobian --taylor, each checked against what it must produce."""

from __future__ import annotations

import csv
import importlib.metadata
import json
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

import nemc
from nemc.tools.cli import main

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
COMPOUND = str(EXAMPLES / "compound_pendulum.yaml")
DOUBLE = str(EXAMPLES / "double_pendulum.yaml")


def table(out: str) -> tuple[list[str], np.ndarray]:
    lines = [line for line in out.splitlines() if line and not line.startswith("#")]
    rows = [line.split() for line in lines[1:]  # the header; its units' line, [s] [rad]
            if not line.startswith("figure written") and not line.split()[0].startswith("[")]
    return lines[0].split(), np.array(rows, dtype=float)


def test_initial_values_give_the_books_release_from_rest(capsys) -> None:
    """Book (5.18), (5.19): released from rest at theta = 0, alpha(0) = -3g/2L = -16.1 rad/s^2,
    F_Ox(0) = 0 and F_Oy(0) = W/4 = 3 lb."""
    assert main(["simulate", COMPOUND, "--initial", "theta=0", "--t-eval", "0,",
                 "--outputs", "ddot(theta),O.Fx,O.Fy"]) == 0
    names, rows = table(capsys.readouterr().out)
    assert names == ["t", "theta", "dot(theta)", "ddot(theta)", "O.Fx", "O.Fy"]
    assert rows.shape == (1, 6)
    assert rows[0, 3] == pytest.approx(-16.1, rel=1e-5)
    assert rows[0, 4] == pytest.approx(0.0, abs=1e-9)
    assert rows[0, 5] == pytest.approx(3.0, rel=1e-5)


def test_initial_rates_and_expressions(capsys) -> None:
    assert main(["simulate", DOUBLE, "--initial", "q1=-pi/2", "--initial", "dot( q2 )=0.5",
                 "--t-eval", "0,1", "--outputs", "none"]) == 0
    names, rows = table(capsys.readouterr().out)
    assert names == ["t", "q1", "dot(q1)", "q2", "dot(q2)"]
    # q2's start is the scene's (-pi/3), the others as given
    assert list(rows[0, 1:]) == pytest.approx([-math.pi / 2, 0.0, -math.pi / 3, 0.5], rel=1e-5)
    model = nemc.compile(DOUBLE)
    expected = model.simulate(y0=[-math.pi / 2, 0, -math.pi / 3, 0.5], t_eval=[0, 1]).y[:, 1]
    assert list(rows[1, 1:]) == pytest.approx(list(expected), rel=1e-5, abs=1e-6)


@pytest.mark.parametrize(("option", "message"), [
    (["--initial", "q3=1"], "--initial: unknown coordinate or rate 'q3'; the state is q1, "
                            "dot(q1), q2, dot(q2)"),
    (["--initial", "dot(qq1)=1"], "'dot(qq1)' (did you mean dot(q1)?)"),
    (["--initial", "q1=nope"], "expected a number or an expression of numbers and pi"),
    (["--t-eval", "-0.5"], "expected a number > 0"),
    (["--t-eval", "0,9"], "--t-eval: times must increase within [0, 5]"),
    (["--outputs", "A.Fz"], "--outputs: no output 'A.Fz'; the outputs: A.Fx"),
    (["--panels", "state,torque"], "unknown panel kind(s) torque"),
])
def test_bad_options_exit_2_with_a_message(option: list[str], message: str, capsys) -> None:
    try:  # argparse's own checks exit, nemc's return
        status = main(["simulate", DOUBLE, *option])
    except SystemExit as stop:
        status = stop.code
    assert status == 2
    assert message in capsys.readouterr().err


def test_t_eval_step_and_list(capsys) -> None:
    assert main(["simulate", DOUBLE, "--t-eval", "2", "--outputs", "none"]) == 0
    _, rows = table(capsys.readouterr().out)
    assert list(rows[:, 0]) == [0.0, 2.0, 4.0]
    assert main(["simulate", DOUBLE, "--t-eval", "0.25, 1.5,4.75", "--t-end", "4.75"]) == 0
    _, rows = table(capsys.readouterr().out)
    assert list(rows[:, 0]) == [0.25, 1.5, 4.75]


def test_outputs_patterns_choose_columns(capsys) -> None:
    assert main(["simulate", DOUBLE, "--outputs", "B.F?,energy.total"]) == 0
    names, _ = table(capsys.readouterr().out)
    assert names[5:] == ["B.Fx", "B.Fy", "B.Fn", "B.Ft", "energy.total"]


def test_csv_has_units_in_its_headers(tmp_path: Path, capsys) -> None:
    out = tmp_path / "dp.csv"
    assert main(["simulate", DOUBLE, "--csv", str(out), "--outputs", "A.Fx,energy.*"]) == 0
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["t [s]", "q1 [rad]", "dot(q1) [rad/s]", "q2 [rad]", "dot(q2) [rad/s]",
                       "A.Fx [N]", "energy.kinetic [J]", "energy.potential [J]",
                       "energy.total [J]"]
    assert float(rows[1][1]) == pytest.approx(-math.pi / 4)  # radians, whatever figures show
    assert len(rows) == 12


def test_mat_file_holds_ts_xs_columns_names_and_units(tmp_path: Path, capsys) -> None:
    out = tmp_path / "dp.mat"
    assert main(["simulate", DOUBLE, "--mat", str(out)]) == 0
    data = loadmat(out)
    model = nemc.compile(DOUBLE)
    res = model.simulate()
    np.testing.assert_allclose(data["ts"][:, 0], res.t)
    np.testing.assert_allclose(data["xs"], res.y.T)  # the book's [ts, xs]
    np.testing.assert_allclose(data["dot_q1"][:, 0], res.y[1])
    np.testing.assert_allclose(data["B_Fy"][:, 0], res.outputs["B.Fy"])
    names = [str(n[0]) for n in data["names"].ravel()]
    units = [str(u[0]) if u.size else "" for u in data["units"].ravel()]
    variables = [str(v[0]) for v in data["variables"].ravel()]
    assert names[:3] == ["t", "q1", "dot(q1)"] and variables[:3] == ["t", "q1", "dot_q1"]
    assert dict(zip(names, units))["B.Fy"] == "N"


def test_plot_with_panels_writes_the_chosen_panels(tmp_path: Path, capsys) -> None:
    out = tmp_path / "fig.png"
    assert main(["simulate", COMPOUND, "--plot", str(out), "--panels", "state,energy"]) == 0
    assert "figure written to" in capsys.readouterr().out
    from PIL import Image

    width, height = Image.open(out).size
    assert width >= 1500 and height >= 900  # two columns of panels at 150 dpi


def test_compile_jacobian_and_taylor(tmp_path: Path, capsys) -> None:
    assert main(["compile", str(EXAMPLES / "robot_arm.yaml"), "-o", str(tmp_path),
                 "--jacobian", "--taylor"]) == 0
    meta = json.loads((tmp_path / "robot_arm" / "model.json").read_text())
    assert {"jacobian", "taylor"} <= set(meta["generated"])
    assert main(["compile", str(EXAMPLES / "double_pendulum.yaml"), "-o", str(tmp_path)]) == 0
    meta = json.loads((tmp_path / "double_pendulum" / "model.json").read_text())
    assert "jacobian" not in meta["generated"] and "taylor" not in meta["generated"]


def test_the_command_line_keeps_numpys_blas_to_one_thread_unless_told(monkeypatch,
                                                                        capsys) -> None:
    """A command's arrays are small: OpenBLAS's spinning threads are set to one before numpy
    is imported, and a user's own setting is left as it is."""
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    assert main(["simulate", COMPOUND, "--t-eval", "0,"]) == 0
    assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "3")
    assert main(["simulate", COMPOUND, "--t-eval", "0,"]) == 0
    assert os.environ["OPENBLAS_NUM_THREADS"] == "3"
    capsys.readouterr()


def test_version_is_the_packages(capsys) -> None:
    """`nemc --version` prints the installed package's version, which is pyproject.toml's and
    the one nemc stamps into generated code (vocabulary.NEMC_VERSION)."""
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    pyproject = (EXAMPLES.parent / "pyproject.toml").read_text()
    declared = re.search(r'^version = "([^"]+)"', pyproject, re.MULTILINE).group(1)
    assert capsys.readouterr().out == f"nemc {declared}\n"
    assert importlib.metadata.version("nemc") == declared == nemc.__version__


NOTE = re.compile(r"nemc: note: the scene's method (\S+) is scipy's, its loop in Python: "
                  r"[\d.e+]+ ms; (.*): [\d.e+-]+ ms, \d+x faster \((.*)\)\n")


def test_a_scene_naming_scipys_method_is_told_what_the_native_one_takes(tmp_path: Path,
                                                                         capsys) -> None:
    """A scene's scipy name runs scipy's method (the table is scipy's run: its rows equal the
    Python API's with method DOP853), and one line on stderr says what nemc.DOP853, which takes
    the same steps, takes; RK45 has no port: the note measures auto. A method from --method,
    or a native one, gets no note."""
    text = Path(COMPOUND).read_text()
    scene = tmp_path / "compound_dop853.yaml"
    scene.write_text(text.replace("  method: RK45", "  method: DOP853  #"))
    assert main(["simulate", str(scene)]) == 0
    out, err = capsys.readouterr()
    found = NOTE.fullmatch(err)
    assert found and found[1] == "DOP853", err
    assert found[2] == "nemc.DOP853 takes the same steps in C"
    assert found[3] == "write `method: nemc.DOP853`, or leave method out for auto"
    _, rows = table(out)
    scipy = nemc.compile(scene).simulate(method="DOP853")
    assert np.allclose(rows[:, 1], scipy.y[0], rtol=1e-5, atol=1e-6)  # 6 digits printed
    assert main(["simulate", COMPOUND]) == 0
    found = NOTE.fullmatch(capsys.readouterr().err)
    assert found and found[1] == "RK45" and found[3] == "leave method out for auto"
    assert re.fullmatch(r"the default, auto \(nemc\.\S+ here\), at the same tolerances", found[2])
    for method in ("DOP853", "auto"):
        assert main(["simulate", COMPOUND, "--method", method]) == 0
        assert "note" not in capsys.readouterr().err


def test_the_printed_tables_give_each_columns_unit(capsys) -> None:
    """Under each column's name its unit, right-aligned with it (issue 52): from the YAML's
    `units:` (m, N, J; angles in rad, as the values are) and an output expression's `unit:`
    (cart_pole's force N, power W); nemc linearize's matrices name their rows' and columns'
    units; a mechanism without `units:` prints no units' line."""
    assert main(["simulate", str(EXAMPLES / "cart_pole.yaml"), "--t-eval", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    header, units = lines[0], lines[1]
    expected = {"t": "[s]", "x": "[m]", "dot(x)": "[m/s]", "th": "[rad]", "dot(th)": "[rad/s]",
                "energy.total": "[J]", "pole.tip.vx": "[m/s]", "force": "[N]", "power": "[W]"}
    for name, unit in expected.items():
        end = header.index(f" {name} " if name != "power" else " power") + len(name) + 1
        assert units[end - len(unit):end] == unit, (name, units)
    assert len(units.split()) == len(header.split())  # every column has one here
    assert [float(v) for v in lines[2].split()[:2]] == [0.0, 0.0]  # then the rows
    assert main(["linearize", str(EXAMPLES / "cart_pole.yaml"), "--trim"]) == 0
    printed = capsys.readouterr().out
    assert "  dot(th) [rad/s]           0           0     15.7756           0" in printed
    assert "                          [m]       [m/s]       [rad]     [rad/s]" in printed
    assert "     force [N]           0           0           0           0" in printed
