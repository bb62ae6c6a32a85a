"""The analytic Jacobian against central differences of the compiled RHS, and stiff scenes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from reference import ReferenceModel, random_mechanism_yaml
from scipy.integrate import solve_ivp

import nemc
from nemc.front.validate import load_mechanism

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
ARM = EXAMPLES / "two_link_robot_arm.yaml"


@pytest.fixture(autouse=True)
def cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NEMC_CACHE", str(tmp_path_factory.getbasetemp() / "jacobian-cache"))


def central_differences(model, t: float, y: np.ndarray, step: float = 1e-3) -> np.ndarray:
    """Fourth-order central differences of the compiled RHS, column by column; equations that
    hold "as at the start" (a gear pair's, a rolling disc's) keep y's start, as in a run from y
    and as model.jacobian holds it (model.rhs would take each moved state as its own start)."""
    rhs = model.rhs
    if model.loops.starts:
        rhs = model.compiled.integrator_rhs(model.loops.started(t, y, model.parameter_vector()))
    columns = []
    for j in range(y.size):
        h = step * max(1.0, abs(y[j]))
        e = np.zeros_like(y)
        e[j] = h
        f = [rhs(t, y + k * e) for k in (-2, -1, 1, 2)]
        columns.append((f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * h))
    return np.column_stack(columns)


def assert_jacobian_matches(model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    # A closed loop's Jacobian is itself a (second-order) difference quotient of the projected
    # right-hand side, which curves more: a finer reference step and a looser bound.
    step, tolerance = (1e-4, 1e-6) if model.has_loops else (1e-3, 1e-7)
    for _ in range(3):
        t, y = float(rng.uniform(0, 2)), rng.uniform(-1, 1, model.n_state)
        if model.has_loops:  # a state the loops can take: one of the scene's own run
            t0, t_end = model.scene["t_span"] or (0.0, 2.0)
            t = t0 + (t - t0) * (t_end - t0) / 2.0
            y = model.simulate((t0, t), t_eval=[t]).y[:, 0]
        exact, approx = model.jacobian(t, y), central_differences(model, t, y, step)
        scale = max(np.abs(exact).max(), 1.0)
        assert np.abs(exact - approx).max() <= tolerance * scale


# A mechanism with Coulomb friction has no derivative across its mode switches (a stuck
# joint's rate perturbed is a slipping one): tests/test_friction.py checks it is refused where
# one is needed.
SMOOTH = [path for path in sorted(EXAMPLES.glob("*.yaml"))
          if "\nfriction:" not in path.read_text() and "\ncontacts:" not in path.read_text()]


@pytest.mark.parametrize("example", SMOOTH, ids=lambda p: p.stem)
def test_example_jacobians_match_differences(example: Path) -> None:
    assert_jacobian_matches(nemc.compile(example, jacobian=True), seed=3)


@pytest.mark.parametrize("seed", range(6))
def test_random_chain_and_tree_jacobians(seed: int, tmp_path: Path) -> None:
    path = tmp_path / f"random{seed}.yaml"
    rng = np.random.default_rng(100 + seed)
    path.write_text(random_mechanism_yaml(rng, 2 + seed, seed % 2 == 1, f"random{seed}"))
    assert_jacobian_matches(nemc.compile(path, jacobian=True), seed=seed)


def test_jacobian_generated_only_when_needed() -> None:
    explicit = nemc.compile(EXAMPLES / "double_pendulum.yaml")
    assert "jacobian" not in explicit.metadata["generated"]
    implicit = nemc.compile(ARM)  # the scene's method is Radau
    assert "jacobian" in implicit.metadata["generated"]
    y = np.array([0.2, 0.1, -0.3, 0.0])
    assert np.allclose(explicit.jacobian(0.0, y), central_differences(explicit, 0.0, y),
                       rtol=1e-7, atol=1e-7)  # built on first need


def test_the_mass_matrix_is_a_part_of_its_own() -> None:
    """A scene's implicit method builds the Jacobian, not M^-1 (which no integrator reads);
    Model.mass_matrix builds it on first need, and it agrees with the Lagrange reference."""
    implicit = nemc.compile(ARM)  # the scene's method is Radau
    assert implicit.has_part("jacobian") and not implicit.has_part("mass_matrix")
    reference = ReferenceModel(load_mechanism(ARM))
    for y in np.random.default_rng(5).uniform(-1.5, 1.5, (3, implicit.n_state)):
        expected = reference.mass_forcing(0.0, y)[0]
        assert np.allclose(implicit.mass_matrix(y), expected, rtol=1e-12, atol=1e-12)
    with_mass = implicit.compiled_with("mass_matrix")
    assert with_mass.has_part("mass_matrix") and with_mass.has_part("jacobian")


@pytest.mark.parametrize("gain", [1.0, 100.0])
def test_stiff_arm_with_analytic_jacobian(gain: float) -> None:
    model = nemc.compile(ARM)
    params = {name: value * gain for name, value in model.parameters.items()
              if name in ("b01", "g01", "b12", "g12")}
    span, times = (0.0, 2.0), np.linspace(0.0, 2.0, 5)
    tight = model.simulate(span, method="Radau", t_eval=times, rtol=1e-12, atol=1e-12,
                           params=params)
    analytic = model.simulate(span, method="Radau", t_eval=times, rtol=1e-8, atol=1e-10,
                              params=params)
    p = model.parameter_vector(params)
    numeric = solve_ivp(model.compiled.integrator_rhs(p), span, model.initial_state(params),
                        method="Radau", t_eval=times, rtol=1e-8, atol=1e-10)
    explicit = model.simulate(span, method="RK45", rtol=1e-8, atol=1e-10, params=params)
    assert analytic.success and analytic.njev > 0
    np.testing.assert_allclose(analytic.y, tight.y, atol=1e-6)
    assert analytic.nfev < numeric.nfev  # no finite-difference columns
    assert analytic.nfev < explicit.nfev  # stiffness, not accuracy, limits RK45


@pytest.mark.slow  # 10 s: make test-slow
def test_stiff_joint_spring(tmp_path: Path) -> None:
    text = (EXAMPLES / "double_pendulum.yaml").read_text().replace(
        "outputs:", "loads:\n  - joint_spring: {joint: B, k: 1.0e6, damping: 10}\noutputs:"
    )
    path = tmp_path / "stiff.yaml"
    path.write_text(text)
    model = nemc.compile(path)
    assert_jacobian_matches(model, seed=5)
    bdf = model.simulate((0, 0.2), method="BDF", rtol=1e-8, atol=1e-10, t_eval=[0.2])
    tight = model.simulate((0, 0.2), method="Radau", rtol=1e-10, atol=1e-12, t_eval=[0.2])
    assert bdf.success and bdf.njev > 0
    np.testing.assert_allclose(bdf.y, tight.y, atol=1e-5)
