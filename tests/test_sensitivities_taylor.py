"""nemc.Taylor's sensitivities (issue 47): the columns' Taylor coefficients as the tangent of the
state's (templates/taylor_sensitivities.c.tmpl), against independent paths: the double
pendulum's 9 columns against nemc.Vern9's variational equations at a tighter tolerance and
against central differences of tight plain runs; a linear damped oscillator's columns against
the derivatives of its closed form (sympy); an input table's and located events' against
scipy's and nemc.Vern9's, and Kapitza's driven pivot's (time in the equations); the bouncing
ball's through its impacts is tests/test_event_sensitivities.py's closed form, run with
nemc.Taylor too. What nemc.Taylor cannot run is refused by name."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import nemc
from nemc.build.builder import package_c_flags
from nemc.pipeline import compile_mechanism
from nemc.runtime.failures import ModelError

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
NAMES = ["y0", "m1", "m2", "L1", "L2", "g"]  # 4 initial values, 5 parameters: 9 columns
PARAMETERS = NAMES[1:]

# A rod on a pin with a torsional spring and a viscous damper, no gravity: I theta'' = -k theta
# - c theta', I = m L^2 / 3 about the pin. Underdamped: a closed form.
OSCILLATOR = """\
name: torsion_oscillator
parameters: {m: 2.0, L: 1.5, k: 3.0, c: 0.4, theta0: 0.6}
gravity: [0, 0]
bodies:
  rod: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  O: {type: revolute, parent: ground, child: rod, coordinate: theta}
loads:
  - {torque: -k*theta - c*dot(theta), body: rod}
simulation:
  t_span: [0, 6]
  initial: {theta: theta0}
"""


@pytest.fixture(scope="module")
def double_pendulum() -> nemc.runtime.Model:
    return nemc.compile(EXAMPLES / "double_pendulum.yaml")


def relative_error(ours: np.ndarray, reference: np.ndarray) -> float:
    return float(np.abs(ours - reference).max() / max(np.abs(reference).max(), 1e-300))


def columns(res) -> np.ndarray:
    """The 4 x 9 x n_t sensitivities in NAMES' order."""
    return np.concatenate([res.sensitivities["y0"],
                           *(res.sensitivities[name][:, None, :] for name in PARAMETERS)],
                          axis=1)


def test_the_double_pendulum_matches_vern9s_variational_equations(double_pendulum) -> None:
    """Over [0, 20] at rtol 1e-10, every column at 41 times against nemc.Vern9's sensitivity
    system at rtol 1e-12 (another method, another derivative: the forward tangent's dense
    Jacobian), and the state against nemc.Vern9's plain run."""
    t_eval = np.linspace(0.0, 20.0, 41)
    ours = double_pendulum.simulate((0, 20), method="nemc.Taylor", rtol=1e-10, atol=1e-12,
                                    t_eval=t_eval, sensitivities=NAMES)
    reference = double_pendulum.simulate((0, 20), method="nemc.Vern9", rtol=1e-12,
                                         atol=1e-14, t_eval=t_eval, sensitivities=NAMES)
    assert ours.success and ours.method == "nemc.Taylor", ours.message
    assert relative_error(columns(ours), columns(reference)) < 1e-8
    assert relative_error(ours.y, reference.y) < 1e-8
    assert ours.nfev > 0 and ours.t.size == t_eval.size


def test_the_forward_tangent_gives_the_same_columns(double_pendulum, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The other derivative of the program: built with the forward tangent per column (what a
    program whose tangent is not linear in its seeds gets: taylor_jacobian None), in a cache
    of its own, the same columns as the Jacobian's build and nemc.Vern9's over [0, 10]."""
    import nemc.emit.taylor_c as taylor_c

    monkeypatch.setenv("NEMC_CACHE", str(tmp_path))
    monkeypatch.setattr(taylor_c, "taylor_jacobian", lambda program, seeds: None)
    forward = compile_mechanism(EXAMPLES / "double_pendulum.yaml", taylor=True,
                                sensitivities=True)
    source = (forward.package / "double_pendulum.c").read_text()
    assert "tds" in source and "tj0" not in source  # the tangent's steps, no J entries
    assert warnings(forward.package / "double_pendulum.c", tmp_path) == ""
    t_eval = np.linspace(0.0, 10.0, 21)
    run = {"method": "nemc.Taylor", "rtol": 1e-10, "atol": 1e-12, "t_eval": t_eval,
           "sensitivities": NAMES}
    ours = forward.model.simulate((0, 10), **run)
    dense = double_pendulum.simulate((0, 10), **run)
    reference = double_pendulum.simulate((0, 10), method="nemc.Vern9", rtol=1e-12, atol=1e-14,
                                         t_eval=t_eval, sensitivities=NAMES)
    assert relative_error(columns(ours), columns(reference)) < 1e-8
    assert relative_error(columns(ours), columns(dense)) < 1e-8


def central_differences(model, name: str, t_eval: np.ndarray, h: float) -> np.ndarray:
    """d y(t) / d NAME by central differences of plain nemc.Vern9 runs at rtol 1e-13."""
    ends = []
    for sign in (1, -1):
        if name in model.parameter_names:
            run = {"params": {name: model.parameters[name] + sign * h}}
        else:
            y0 = np.array(model.initial_state(), dtype=float)
            y0[model.state_names.index(name)] += sign * h
            run = {"y0": y0}
        ends.append(model.simulate((0, t_eval[-1]), t_eval=t_eval, method="nemc.Vern9",
                                   rtol=1e-13, atol=1e-15, **run).y)
    return (ends[0] - ends[1]) / (2 * h)


@pytest.mark.parametrize("name", ["q1", "dot(q2)", "m2", "L1", "g"])
def test_the_double_pendulum_matches_central_differences(double_pendulum, name: str) -> None:
    """Over [0, 5], a column at 11 times against central differences of tight plain runs (no
    variational equations in them), to 1e-7 relative."""
    t_eval = np.linspace(0.0, 5.0, 11)
    res = double_pendulum.simulate((0, 5), method="nemc.Taylor", rtol=1e-12, atol=1e-14,
                                   t_eval=t_eval, sensitivities=[name])
    scale = (abs(double_pendulum.parameters[name]) if name in double_pendulum.parameter_names
             else 1.0)
    reference = central_differences(double_pendulum, name, t_eval, 1e-5 * scale)
    assert relative_error(res.sensitivities[name], reference) < 1e-7, name


def oscillator_closed_form() -> tuple[sp.Expr, dict[str, sp.Symbol], sp.Symbol]:
    """theta(t) of the underdamped I theta'' + c theta' + k theta = 0 from rest at theta0."""
    m, L, k, c, theta0, t = sp.symbols("m L k c theta0 t", positive=True)
    inertia = m * L**2 / 3
    decay = c / (2 * inertia)
    omega = sp.sqrt(k / inertia - decay**2)
    theta = theta0 * sp.exp(-decay * t) * (sp.cos(omega * t) + decay / omega * sp.sin(omega * t))
    return theta, {"m": m, "L": L, "k": k, "c": c, "theta0": theta0}, t


def test_a_damped_oscillator_matches_its_closed_form(tmp_path: Path) -> None:
    """Every parameter's column of theta and dot(theta) at 25 times against the closed form's
    derivatives, and the initial values' columns against d theta / d theta0 (the scene's
    initial value, a parameter: its column starts at d y0 / d theta0)."""
    path = tmp_path / "torsion_oscillator.yaml"
    path.write_text(OSCILLATOR)
    model = nemc.compile(path)
    theta, symbols, t = oscillator_closed_form()
    values = {symbols[name]: model.parameters[name] for name in symbols}
    t_eval = np.linspace(0.25, 6.0, 24)
    names = list(symbols)
    res = model.simulate((0, 6), method="nemc.Taylor", rtol=1e-11, atol=1e-13, t_eval=t_eval,
                         sensitivities=names)
    assert res.success, res.message
    for name in names:
        d_theta = sp.diff(theta, symbols[name])
        rows = [sp.lambdify(t, expr.subs(values))(t_eval)
                for expr in (d_theta, sp.diff(d_theta, t))]
        assert relative_error(res.sensitivities[name], np.array(rows)) < 1e-8, name


def test_the_columns_error_follows_the_tolerance(double_pendulum) -> None:
    """The columns are in the step control: their error at t = 10 against nemc.Vern9 at rtol
    1e-13 is within a hundred times the tolerance at rtol 1e-6 and 1e-10 (measured 2.3e-8 and
    1.2e-12), and falls by more than three orders between the two."""
    reference = double_pendulum.simulate((0, 10), method="nemc.Vern9", rtol=1e-13, atol=1e-15,
                                         t_eval=[10.0], sensitivities=NAMES)
    errors = [relative_error(columns(double_pendulum.simulate(
        (0, 10), method="nemc.Taylor", rtol=rtol, atol=rtol * 1e-2, t_eval=[10.0],
        sensitivities=NAMES)), columns(reference)) for rtol in (1e-6, 1e-10)]
    assert errors[0] < 1e-4 and errors[1] < 1e-8
    assert errors[1] < errors[0] / 1000


PUSHED = OSCILLATOR.replace("name: torsion_oscillator", "name: pushed_oscillator").replace(
    "gravity:", "inputs: {T: 0}\ngravity:").replace("- c*dot(theta)", "- c*dot(theta) + T")


def test_a_table_input_and_located_events(tmp_path: Path) -> None:
    """An input table's segments (each a new expansion with its law) and the scene's located
    events (their times' sensitivities from the states recorded before them): against scipy's
    DOP853 at rtol 1e-12 and nemc.Vern9's at 1e-12."""
    path = tmp_path / "pushed_oscillator.yaml"
    path.write_text(PUSHED)
    model = nemc.compile(path)
    table = ([0, 1, 2, 4], [0.0, 2.0, -1.0, 0.5])
    names = ["T", "c", "y0"]
    ours = model.simulate(inputs={"T": table}, sensitivities=names, rtol=1e-11, atol=1e-13,
                          method="nemc.Taylor")
    scipy = model.simulate(inputs={"T": table}, sensitivities=names, rtol=1e-12, atol=1e-14,
                           method="DOP853", t_eval=ours.t)
    assert ours.success and ours.t.size > 2, ours.message
    for name in names:
        assert relative_error(ours.sensitivities[name], scipy.sensitivities[name]) < 1e-9, name
    events = nemc.compile(EXAMPLES / "double_pendulum_events.yaml")
    run = {"sensitivities": ["m2", "y0"], "rtol": 1e-11, "atol": 1e-13}
    ours = events.simulate((0, 4), method="nemc.Taylor", **run)
    reference = events.simulate((0, 4), method="nemc.Vern9", **{**run, "rtol": 1e-12,
                                                                   "atol": 1e-14})
    assert set(ours.event_sensitivities) == {"tip_low", "tip_up", "swing"}
    for name, times in ours.events.items():
        assert times[0].size == reference.events[name][0].size > 0, name
        assert relative_error(ours.event_sensitivities[name]["m2"],
                              reference.event_sensitivities[name]["m2"]) < 1e-9, name


def test_time_in_the_equations() -> None:
    """Kapitza's pendulum, its pivot driven by A sin(W t) (the time's series in the columns'
    recurrences too): against nemc.Vern9's sensitivities at rtol 1e-12 (m is left out: the
    motion does not depend on it, its column is rounding)."""
    model = nemc.compile(EXAMPLES / "kapitza.yaml")
    names = ["y0", "L", "A", "W", "g"]
    ours = model.simulate((0, 3), method="nemc.Taylor", rtol=1e-11, atol=1e-13,
                          sensitivities=names)
    reference = model.simulate((0, 3), method="nemc.Vern9", rtol=1e-12, atol=1e-14,
                               sensitivities=names, t_eval=ours.t)
    assert ours.success, ours.message
    for name in names:
        assert relative_error(ours.sensitivities[name], reference.sensitivities[name]) < 1e-9


def test_a_closed_loop_is_refused_by_name() -> None:
    """nemc.Taylor has no closed loops (a Newton projection has no recurrence): its
    sensitivities are refused with the constraint's place in the file."""
    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    with pytest.raises(ModelError, match=r"sensitivities with nemc.Taylor: .*fourbar.yaml:\d+"):
        model.simulate((0, 1), sensitivities=["m1"], method="nemc.Taylor")


def warnings(source: Path, folder: Path) -> str:
    """What gcc -Wall -Wextra -Werror says compiling SOURCE ("" when it compiles)."""
    done = subprocess.run(["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror",
                           *package_c_flags(source), "-c", str(source), "-o",
                           str(folder / "x.o")], capture_output=True, text=True)
    return done.stderr if done.returncode else ""


def test_the_columns_series_compile_warning_free(tmp_path: Path) -> None:
    """The build with nemc.Taylor and the variational equations compiles under -Wall -Wextra
    -Werror, with the columns' coefficients in it (the forward tangent's build: the test
    above)."""
    package = compile_mechanism(EXAMPLES / "double_pendulum.yaml", taylor=True,
                                sensitivities=True).package
    source = package / "double_pendulum.c"
    assert "taylor_sensitivity_coefficient_k" in source.read_text()
    assert "tj0" in source.read_text()  # the Jacobian's entries: the cheaper route here
    assert warnings(source, tmp_path) == ""
