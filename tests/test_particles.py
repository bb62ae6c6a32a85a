"""Format v3 particles and massless links: a body's mass and inertia may be 0 while the mass
matrix stays positive definite. Checked against the Lagrangian reference (tests/reference.py)
and the point-mass pendulum's closed form; a massless body at the end of a chain is refused at
the file (naming the body) and at a run whose parameters make it so."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from reference import reference_rhs

import nemc
from nemc.errors import InputError
from nemc.front.validate import load_mechanism, validate_text
from nemc.runtime.model import ModelError

# Two point masses on massless rods, the second hung from a massless slider on the first rod's
# end (a massless body in the middle of a chain: it carries the second mass).
PARTICLES = """\
name: particles
parameters: {m1: 1.0, m2: 0.5, L1: 1.0, L2: 0.7, g: 9.81}
gravity: [0, -g]
bodies:
  rod1: {mass: m1, inertia: 0, com: [L1, 0]}
  slider: {mass: 0, inertia: 0}
  rod2: {mass: m2, inertia: 0, com: [L2, 0]}
joints:
  A: {type: revolute, parent: ground, child: rod1, coordinate: q1}
  S: {type: prismatic, parent: rod1, child: slider, at: [L1, 0], axis: [1, 0], coordinate: s}
  B: {type: revolute, parent: slider, child: rod2, coordinate: q2}
loads:
  - spring: {a: rod1.com, b: slider.origin, k: 30, length: 0}
outputs:
  energy: true
simulation:
  t_span: [0, 3]
  initial: {q1: -0.6, q2: -1.2, s: 0.1}
"""

PENDULUM = """\
name: point_pendulum
parameters: {m: 2.0, L: 0.8, g: 9.81}
gravity: [0, -g]
bodies:
  bob: {mass: m, inertia: 0, com: [L, 0]}
joints:
  A: {type: revolute, parent: ground, child: bob, coordinate: q}
simulation:
  t_span: [0, 2]
  initial: {q: -1.5707963267948966, dot(q): 0.0}
"""


def test_point_masses_on_massless_links_against_the_reference(tmp_path: Path) -> None:
    path = tmp_path / "particles.yaml"
    path.write_text(PARTICLES)
    model = nemc.compile(path)
    reference = reference_rhs(load_mechanism(path))
    rng = np.random.default_rng(49)
    for _ in range(5):
        y = rng.uniform(-1.5, 1.5, model.n_state)
        np.testing.assert_allclose(model.rhs(0.0, y), reference(0.0, y), rtol=1e-11,
                                   atol=1e-11)
    result = model.simulate(method="nemc.DOP853", rtol=1e-11, atol=1e-12)
    assert result.success, result.message
    energy = result.outputs["energy.total"]
    assert np.ptp(energy) < 1e-9 * np.abs(energy).max()


def test_a_point_mass_pendulum_has_the_simple_pendulums_small_period(tmp_path: Path) -> None:
    """g / L, whatever the mass: the linearization at the bottom has the frequency
    sqrt(g / L) (no inertia of its own)."""
    path = tmp_path / "pendulum.yaml"
    path.write_text(PENDULUM)
    model = nemc.compile(path)
    lin = model.linearize({"q": -math.pi / 2})
    assert np.sort(np.abs(lin.modes().eigenvalues.imag))[-1] == pytest.approx(
        math.sqrt(9.81 / 0.8), rel=1e-12)


def test_a_massless_body_at_the_end_of_a_chain_is_refused_naming_it() -> None:
    text = PARTICLES.replace("rod2: {mass: m2, inertia: 0, com: [L2, 0]}",
                             "rod2: {mass: 0, inertia: 0, com: [L2, 0]}")
    with pytest.raises(InputError) as caught:
        validate_text(text.encode(), "particles.yaml")
    message = str(caught.value)
    assert "particles.yaml:7: bodies.rod2: body 'rod2' and what it carries have no mass or " \
           "inertia" in message, message
    assert "joint 'B'" in message


def test_a_free_particle_has_no_inertia_for_its_angle() -> None:
    text = """\
name: free_particle
bodies:
  ball: {mass: 1, inertia: 0}
joints:
  fly: {type: free, parent: ground, child: ball, coordinates: [x, y, th]}
"""
    with pytest.raises(InputError, match="body 'ball' and what it carries have no inertia"):
        validate_text(text.encode(), "free_particle.yaml")


def test_negative_masses_are_refused() -> None:
    with pytest.raises(InputError, match=r"bodies.rod1.mass: must be >= 0, got -1"):
        validate_text(PARTICLES.replace("m1: 1.0", "m1: -1.0").encode(), "particles.yaml")


def test_a_run_whose_parameters_leave_a_joint_nothing_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "particles.yaml"
    path.write_text(PARTICLES)
    model = nemc.compile(path)
    with pytest.raises(ModelError, match=r"joints.S \(mass of body 'slider' and what it "
                       r"carries\) must be > 0"):
        model.simulate(params={"m2": 0.0})
    with pytest.raises(ModelError, match=r"bodies.rod2.mass must be >= 0"):
        model.simulate(params={"m2": -0.1})
    # every joint still carries a mass, but one particle cannot fill three coordinates: the
    # run's own guard stops it at its first step, saying why
    result = model.simulate(params={"m1": 0.0}, t_span=(0, 0.1))
    assert not result.success and "mass matrix is singular" in result.message
