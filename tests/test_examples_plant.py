"""The control tutorial's cart-pole end to end (docs/tutorials/control.md, its code in
docs/tutorials/control_figures.py): examples/cart_pole.yaml compiles, the LQR designed from
model.linearize has the gains and poles the tutorial quotes, and closed through lin.feedback(K)
it brings the pole from 0.3 rad back upright (within 1e-3) while the open loop lets it fall.
The example's A and B against complex steps of the Lagrange oracle (tests/reference.py, whose
other checks leave out files with inputs)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
from reference import complex_step_linearization

import nemc
from nemc.front.validate import validate_text

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "docs" / "tutorials" / "control_figures.py"
CART_POLE = ROOT / "examples" / "cart_pole.yaml"


def tutorial():
    spec = importlib.util.spec_from_file_location("control_figures", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_tutorials_lqr_holds_the_cart_pole_up() -> None:
    model, op, lin, K, closed, open_loop = tutorial().lqr_cart_pole()
    assert model.input_names == ("F",) and op.undetermined == ("x",)
    np.testing.assert_allclose(op.y, 0, atol=1e-12)
    assert lin.state_names == ("x", "dot(x)", "th", "dot(th)")
    # the numbers docs/tutorials/control.md quotes
    np.testing.assert_allclose(K.ravel(), [-3.1623, -5.9155, 49.5072, 12.8444], atol=1e-4)
    poles = np.sort(np.linalg.eigvals(lin.A - lin.B @ K).real)
    np.testing.assert_allclose(poles, [-6.9086, -3.2575, -1.5996, -1.2598], atol=1e-4)
    assert closed.success, closed.message
    assert np.abs(closed.y[:, -1] - op.y).max() < 1e-3  # upright, at rest, at x = 0
    assert np.abs(open_loop.y[2]).max() > np.pi / 2  # without the loop it falls


def test_the_cart_poles_a_and_b_are_the_oracles() -> None:
    model = nemc.compile(CART_POLE)
    mech = validate_text(CART_POLE.read_bytes(), CART_POLE.name)
    rng = np.random.default_rng(46)
    for _ in range(3):
        y, u = rng.uniform(-1.5, 1.5, 4), float(rng.uniform(-2, 2))
        lin = model.linearize(y, {"F": u})
        a, b = complex_step_linearization(mech, 0.0, y, {"F": u})
        scale = max(np.abs(a).max(), 1.0)
        assert np.abs(lin.A - a).max() < 1e-12 * scale and np.abs(lin.B - b).max() < 1e-12
