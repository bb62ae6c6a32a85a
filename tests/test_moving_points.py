"""Forces at moving points (format v3): a force's `at: [x, y]` may be expressions of the
coordinates, inputs and t (a follower sliding on a link, a cam's contact point). Checked
against what nemc does not compute itself: a closed form for a pendulum pushed at a sliding
point, and for a three-body tree the generalized force J^T F worked out here with sympy (J the
Jacobian of the body's material point at `at`, the point held while differentiating) on top of
the Lagrangian reference's M and f; every derived form of the accelerations agrees; a rate in
a point is one clear error."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from reference import ReferenceModel
from test_mass_form import assert_same_accelerations, equations_of

import nemc
from nemc.errors import InputError
from nemc.front.validate import load_mechanism, validate_text

# A rod pivoted at the ground, no gravity; a constant ground force pushes it at a point that
# slides out along the rod as it turns: x(q) = a + b q, y = 0.
FOLLOWER = """\
name: follower
parameters: {m: 1.5, c: 0.4, I: 0.08, a: 0.3, b: 0.2, Fx: 1.2, Fy: -2.5}
bodies:
  rod: {mass: m, inertia: I, com: [c, 0]}
joints:
  pivot: {type: revolute, parent: ground, child: rod, coordinate: q}
loads:
  - force: [Fx, Fy]
    body: rod
    at: [a + b*q, 0]
simulation:
  t_span: [0, 1]
  initial: {q: 0.3}
"""

# A cart, a pendulum on it and a second link; a force (body frame, with a damper's term) at a
# point of link 2 that moves with every coordinate and with t.
TREE = """\
name: moving_tree
parameters: {g: 9.81, L: 0.6, P: 3.0}
gravity: [0, -g]
bodies:
  cart: {mass: 2.0, inertia: 0.1}
  arm: {mass: 0.8, inertia: 0.03, com: [0.3, 0], points: {tip: [L, 0]}}
  hand: {mass: 0.5, inertia: 0.02, com: [0.2, 0.05]}
joints:
  rail: {type: prismatic, parent: ground, child: cart, coordinate: x}
  shoulder: {type: revolute, parent: cart, child: arm, coordinate: q1}
  elbow: {type: revolute, parent: arm, child: hand, at: tip, coordinate: q2}
loads:
  - force: [P*cos(t), -0.4*dot(q2)]
    body: hand
    frame: body
    at: [0.2 + 0.1*sin(q2) + 0.05*x, 0.3*q1*q2 - 0.1*cos(t)]
simulation:
  t_span: [0, 1]
  initial: {q1: 0.4, q2: -0.3}
"""


def compiled(text: str, folder: Path, name: str) -> tuple[nemc.runtime.Model, Path]:
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return nemc.compile(path), path


def test_a_pendulum_pushed_at_a_sliding_point(tmp_path: Path) -> None:
    """(I + m c^2) q'' = x(q) (Fy cos q - Fx sin q), x(q) = a + b q: the force's moment about
    the pivot from where it acts now, nothing from the point's sliding."""
    model, _ = compiled(FOLLOWER, tmp_path, "follower")
    m, c, inertia, a, b, fx, fy = 1.5, 0.4, 0.08, 0.3, 0.2, 1.2, -2.5
    rng = np.random.default_rng(49)
    for _ in range(5):
        q, u = rng.uniform(-3, 3, 2)
        expected = (a + b * q) * (fy * np.cos(q) - fx * np.sin(q)) / (inertia + m * c**2)
        assert model.rhs(0.0, np.array([q, u]))[1] == pytest.approx(expected, rel=1e-12)


def generalized_force() -> tuple[sp.Matrix, tuple]:
    """J^T F of the tree's one force, by hand: the hand's material point at `at` (held while
    differentiating) in ground axes, its Jacobian in (x, q1, q2), the force turned to ground."""
    x, q1, q2, t = sp.symbols("x q1 q2 t", real=True)
    hx, hy = sp.symbols("hx hy", real=True)
    arm_angle, hand_angle = q1, q1 + q2
    rot = lambda angle: sp.Matrix([[sp.cos(angle), -sp.sin(angle)],  # noqa: E731
                                   [sp.sin(angle), sp.cos(angle)]])
    elbow = sp.Matrix([x, 0]) + rot(arm_angle) * sp.Matrix([0.6, 0])
    material = elbow + rot(hand_angle) * sp.Matrix([hx, hy])
    jacobian = material.jacobian(sp.Matrix([x, q1, q2]))
    dq2 = sp.Symbol("dot(q2)", real=True)
    force = rot(hand_angle) * sp.Matrix([3.0 * sp.cos(t), -0.4 * dq2])
    at = {hx: 0.2 + 0.1 * sp.sin(q2) + 0.05 * x, hy: 0.3 * q1 * q2 - 0.1 * sp.cos(t)}
    return (jacobian.T * force).xreplace(at), (x, q1, q2, t, dq2)


def test_a_force_at_a_moving_point_of_a_tree_against_j_transpose_f(tmp_path: Path) -> None:
    """The tree without the force from the Lagrangian reference, plus J^T F by hand: nemc's
    accelerations to 1e-10 at seeded random states; the point's sliding (J from the moving
    point's total derivative) would give other numbers, so the check tells them apart."""
    model, path = compiled(TREE, tmp_path, "moving_tree")
    tree = ReferenceModel(dataclasses.replace(load_mechanism(path), loads=()))
    q_force, names = generalized_force()
    force_at = sp.lambdify(names, q_force, modules="numpy")
    rng = np.random.default_rng(7)
    for _ in range(5):
        t = float(rng.uniform(0, 3))
        y = rng.uniform(-1.5, 1.5, 6)
        M, f = tree.mass_forcing(t, y)
        extra = np.asarray(force_at(y[0], y[2], y[4], t, y[5]), dtype=float).reshape(3)
        expected = np.linalg.solve(M, f + extra)
        ours = model.rhs(t, y)[1::2]
        np.testing.assert_allclose(ours, expected, rtol=1e-10, atol=1e-10)
        sliding = sliding_force(q_force, names, y, t)
        assert np.abs(np.linalg.solve(M, f + sliding) - expected).max() > 1e-3


def sliding_force(q_force: sp.Matrix, names: tuple, y: np.ndarray, t: float) -> np.ndarray:
    """The generalized force a derivation that differentiated the moving point itself would
    add: F . (R d(at)/dq) (not the virtual work of a force on the body)."""
    x, q1, q2, time, dq2 = names
    at = sp.Matrix([0.2 + 0.1 * sp.sin(q2) + 0.05 * x, 0.3 * q1 * q2 - 0.1 * sp.cos(time)])
    angle = q1 + q2
    rot = sp.Matrix([[sp.cos(angle), -sp.sin(angle)], [sp.sin(angle), sp.cos(angle)]])
    force = rot * sp.Matrix([3.0 * sp.cos(time), -0.4 * dq2])
    extra = (rot * at.jacobian(sp.Matrix([x, q1, q2]))).T * force
    values = {x: y[0], q1: y[2], q2: y[4], time: t, dq2: y[5]}
    return np.array([float(v) for v in (q_force + extra).xreplace(values)])


def test_the_lagrangian_reference_agrees(tmp_path: Path) -> None:
    """tests/reference.py's virtual power holds the point too: the whole tree against it."""
    model, path = compiled(TREE, tmp_path, "moving_tree")
    reference = ReferenceModel(load_mechanism(path))
    rng = np.random.default_rng(11)
    for _ in range(3):
        t, y = float(rng.uniform(0, 3)), rng.uniform(-1.5, 1.5, 6)
        np.testing.assert_allclose(model.rhs(t, y), reference.rhs(t, y), rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("text, name", [(FOLLOWER, "follower"), (TREE, "moving_tree")])
def test_every_form_of_the_accelerations_agrees(text: str, name: str) -> None:
    """The mass-matrix form (virtual power through the material point's velocity) against the
    articulated-body program (the force's moment from where it acts)."""
    assert_same_accelerations(equations_of(text, name), np.random.default_rng(5))


@pytest.mark.parametrize("where, message", [
    ("at: [a + b*dot(q), 0]", "follower.yaml:10: loads[0].at[0]: dot() is not allowed in a load's "
                         "point"),
    ("at: [a + b*qq, 0]", "follower.yaml:10: loads[0].at[0]: unknown name 'qq'"),
    ("at: [a + b*q]", "follower.yaml:10: loads[0].at: expected a vector [x, y] of 2 entries"),
])
def test_a_bad_moving_point_is_refused_with_its_line(where: str, message: str) -> None:
    text = FOLLOWER.replace("at: [a + b*q, 0]", where)
    with pytest.raises(InputError) as caught:
        validate_text(text.encode(), "follower.yaml")
    assert message in str(caught.value), str(caught.value)
