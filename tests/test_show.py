"""nemc show: what it prints equals the compiled model, in seconds, with textbook LaTeX."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy

import nemc
from nemc.derive.equations import derive
from nemc.front.validate import load_mechanism
from nemc.tools.cli import main
from nemc.tools.show import sections, show
from nemc.tools.typeset import latex_name

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@pytest.mark.parametrize(("name", "latex"), [
    ("q1", "q_{1}"), ("dot(q1)", r"\dot{q}_{1}"), ("ddot(q1)", r"\ddot{q}_{1}"),
    ("theta", r"\theta"), ("dot(theta)", r"\dot{\theta}"), ("ddot(phi)", r"\ddot{\phi}"),
    ("th", r"\mathrm{th}"), ("dot(x)", r"\dot{x}"), ("q12", "q_{12}"), ("x_tip", "x_{tip}"),
])
def test_names_are_typeset_as_in_a_textbook(name: str, latex: str) -> None:
    assert latex_name(name) == latex


def test_latex_of_the_double_pendulum(capsys) -> None:
    assert main(["show", str(EXAMPLES / "double_pendulum.yaml"), "--latex"]) == 0
    out = capsys.readouterr().out
    assert (r"M = \left[\begin{matrix}L_{1}^{2} \left(\frac{m_{1}}{3} + m_{2}\right) & "
            r"\frac{L_{1} L_{2} m_{2} \cos{\left(q_{1} - q_{2} \right)}}{2}\\"
            r"\frac{L_{1} L_{2} m_{2} \cos{\left(q_{1} - q_{2} \right)}}{2} & "
            r"\frac{L_{2}^{2} m_{2}}{3}\end{matrix}\right]") in out
    assert (r"f = \left[\begin{matrix}- L_{1} \left(\frac{L_{2} \dot{q}_{2}^{2} m_{2} "
            r"\sin{\left(q_{1} - q_{2} \right)}}{2}") in out
    assert r"\ddot{q} = " in out and "dot(" not in out and "ddot(" not in out


def test_latex_names_parameters_as_one_symbol(capsys) -> None:
    assert main(["show", str(EXAMPLES / "robot_arm.yaml"), "--latex"]) == 0
    out = capsys.readouterr().out
    assert (r"f = \left[\begin{matrix}- \beta \dot{\theta} - \gamma \theta + "
            r"\gamma \mathrm{thetaf}\end{matrix}\right]") in out  # the book's Rrobot


@pytest.mark.parametrize("name", ["double_pendulum", "prismatic_cart_pendulum",
                                  "free_body_on_spring"])
def test_printed_equations_equal_the_compiled_model(name: str) -> None:
    """M^-1 f of the printed (tidied) M and f, and the printed explicit accelerations, give the
    compiled right-hand side at random states."""
    mech = load_mechanism(EXAMPLES / f"{name}.yaml")
    eqs = derive(mech)
    parts = dict(sections(eqs))
    model = nemc.compile(EXAMPLES / f"{name}.yaml")
    state = eqs.state
    values = dict(zip(eqs.parameters, model.parameter_vector()))
    rng = np.random.default_rng(7)
    for _ in range(5):
        y = rng.uniform(-1.5, 1.5, len(state))
        at = {**values, **dict(zip(state, y)), sympy.Symbol("t", real=True): 0.3}
        mass = np.array(parts["M"].xreplace(at).evalf(), dtype=float)
        force = np.array(parts["f"].xreplace(at).evalf(), dtype=float).ravel()
        expected = model.rhs(0.3, y)[1::2]
        np.testing.assert_allclose(np.linalg.solve(mass, force), expected, rtol=1e-10,
                                   atol=1e-10)
        if "qdd" in parts:
            explicit = np.array(parts["qdd"].xreplace(at).evalf(), dtype=float).ravel()
            np.testing.assert_allclose(explicit, expected, rtol=1e-10, atol=1e-10)


def test_show_prints_every_section_at_three_coordinates() -> None:
    text = show(load_mechanism(EXAMPLES / "free_body_on_spring.yaml"))
    assert "mass matrix M:" in text and "forcing f:" in text and "energy.total = " in text
    assert "explicit accelerations" not in text  # only up to two coordinates
