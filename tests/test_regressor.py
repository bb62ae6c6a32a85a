"""The inverse-dynamics regressor (issue 47: tau = Y(q, qd, qdd) phi - Q, nemc/derive/regressor.py,
nemc/runtime/regressor.py), against independent references:

- Y phi - Q equals M qdd - f of the tests' own Lagrangian derivation (tests/reference.py) at
  seeded random states, to 1e-12 relative, on the tree examples and on random mechanisms (every
  joint kind, springs, dampers, forces);
- a closed loop's rows equal the drive the compiled model computes (the articulated-body
  algorithm with the constraint forces, in C): the driven four-bar and slider-crank;
- the double pendulum's base parameters are the closed form's six, I1 + m2 L1^2, mx1 + m2 L1,
  my1, mx2, my2, I2 (the same row space, at L1 = 0.7);
- base parameters are recovered exactly from noise-free data, and from noisy drive torques of
  the driven four-bar within their 2-sigma intervals about 95% of the time (seeded draws);
- a linear load coefficient (a damper's) is a column of its own; bad input is one clear error.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from reference import (
    ReferenceModel,
    random_mechanism_yaml,
    relative_chain_yaml,
    tree_example_names,
)

import nemc
from nemc.derive.regressor import regressor_equations
from nemc.emit.regressor_code import regressor_code
from nemc.front.validate import validate_text
from nemc.front.values import resolve_values
from nemc.runtime.failures import ModelError
from nemc.runtime.load import load_package
from nemc.runtime.regressor import (
    Regressor,
    base_parameters,
    combination_name,
    identify,
    random_states,
)
from nemc.runtime.regressor_names import coefficient_texts

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
SAMPLES = 20


def derived(text: str, name: str, linear: tuple[str, ...] = ()):
    """(the mechanism, its regressor at the default parameters), without compiling C."""
    mech = validate_text(text.encode(), f"{name}.yaml")
    code = regressor_code(regressor_equations(mech, linear))
    values = resolve_values(mech)
    return mech, Regressor(code, np.array(values.runtime_defaults),
                           tuple(symbol.name for symbol in values.runtime_symbols))


def reference_forces(mech, t: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
                     ) -> np.ndarray:
    """M qdd - f of the Lagrangian reference, sample by sample: (n_t, n)."""
    ref = ReferenceModel(mech)
    rows = []
    for k in range(t.size):
        y = np.empty(2 * q.shape[0])
        y[0::2], y[1::2] = q[:, k], qd[:, k]
        mass, forcing = ref.mass_forcing(t[k], y)
        rows.append(mass @ qdd[:, k] - forcing)
    return np.array(rows)


def check_against_reference(mech, reg: Regressor, seed: int) -> None:
    t, q, qd, qdd = random_states(len(reg.coordinate_names), SAMPLES, seed)
    y, loads = reg.matrix(t, q, qd, qdd)
    mine = y @ reg.values() - loads
    theirs = reference_forces(mech, t, q, qd, qdd)
    scale = np.max(np.abs(theirs)) + 1.0
    assert np.max(np.abs(mine - theirs)) <= 1e-12 * scale


@pytest.mark.parametrize("name", tree_example_names(EXAMPLES))
def test_y_phi_is_the_lagrangian_inverse_dynamics_on_the_tree_examples(name: str) -> None:
    mech, reg = derived((EXAMPLES / f"{name}.yaml").read_text(), name)
    check_against_reference(mech, reg, seed=11)


@pytest.mark.parametrize("seed", range(6))
def test_y_phi_is_the_lagrangian_inverse_dynamics_on_random_mechanisms(seed: int) -> None:
    rng = np.random.default_rng(seed)
    text = random_mechanism_yaml(rng, 3, tree=bool(seed % 2), name=f"random{seed}")
    mech, reg = derived(text, f"random{seed}")
    check_against_reference(mech, reg, seed=100 + seed)


def with_accelerations(name: str, folder: Path) -> Path:
    """A driven example with the accelerations of its solved coordinates as outputs."""
    text = (EXAMPLES / f"{name}.yaml").read_text()
    path = folder / f"{name}.yaml"
    path.write_text(text.replace("  drives: [", "  accelerations: true\n  drives: ["))
    return path


def loop_samples(model, params=None, linear=()):
    """The scene's run as regressor samples: (t, q, qd, qdd, drive) over every coordinate,
    the driven one's from the outputs (its acceleration 0: constant speed)."""
    res = model.simulate(params=params, rtol=1e-12, atol=1e-13)
    out, (crank,) = res.outputs, model.regressor_at(params, linear).row_names
    solved = model.coordinate_names
    q = np.vstack([out[crank], *(res.y[model.state_names.index(n)] for n in solved)])
    qd = np.vstack([out[f"dot({crank})"], *(res.y[model.state_names.index(f"dot({n})")]
                                           for n in solved)])
    qdd = np.vstack([np.zeros_like(res.t), *(out[f"ddot({n})"] for n in solved)])
    drive = next(value for key, value in out.items() if key.endswith(".drive"))
    return res.t, q, qd, qdd, drive


@pytest.fixture(scope="module")
def fourbar(tmp_path_factory: pytest.TempPathFactory) -> nemc.runtime.Model:
    return nemc.compile(with_accelerations("fourbar_driven", tmp_path_factory.mktemp("fb")))


def test_a_closed_loops_rows_are_its_compiled_drive(fourbar) -> None:
    params = {"m2": 2.1, "L1": 0.12}
    t, q, qd, qdd, drive = loop_samples(fourbar, params)
    reg = fourbar.regressor_at(params)
    assert reg.row_names == ("q1",) and reg.coordinate_names == ("q1", "q2", "q3")
    y, loads = reg.matrix(t, q, qd, qdd)
    assert y.shape == (t.size, 1, 12)
    mine = (y @ reg.values() - loads)[:, 0]
    assert np.max(np.abs(mine - drive)) <= 1e-12 * np.max(np.abs(drive))
    assert np.array_equal(fourbar.regressor(t, q, qd, qdd, params=params), y)


def test_the_slider_cranks_damper_named_linear_and_its_drive(tmp_path: Path) -> None:
    """The driven slider-crank (a prismatic guide closing the loop, a damper c on the slider):
    its row with c a column equals the compiled drive; c is then identified exactly."""
    model = nemc.compile(with_accelerations("slider_crank_driven", tmp_path))
    t, q, qd, qdd, drive = loop_samples(model, linear=("c",))
    reg = model.regressor_at(linear=("c",))
    y, loads = reg.matrix(t, q, qd, qdd)
    assert reg.names[-1] == "c" and np.all(loads == 0.0)
    mine = (y @ reg.values() - loads)[:, 0]
    assert np.max(np.abs(mine - drive)) <= 1e-12 * np.max(np.abs(drive))
    found = nemc.identify(model, t, q, qd, qdd, drive, linear=("c",))
    assert "c" in found.names
    assert np.allclose(found.values, found.expected, rtol=1e-9)
    assert found.values[found.names.index("c")] == pytest.approx(4.0, rel=1e-10)


def test_a_driven_tree_joints_row_is_its_drive_the_free_ones_zero(tmp_path: Path) -> None:
    """Kapitza's pendulum (a prismatic pivot shaken by its motion, a free hinge): along the run,
    the shaker's row is the compiled drive and the hinge's is 0 (nothing acts on it)."""
    model = nemc.compile(with_accelerations("kapitza", tmp_path))
    res = model.simulate(rtol=1e-12, atol=1e-13)
    amplitude, rate = model.parameters["A"], model.parameters["W"]
    phase = rate * res.t
    q = np.vstack([amplitude * np.cos(phase), res.y[0]])
    qd = np.vstack([-amplitude * rate * np.sin(phase), res.y[1]])
    qdd = np.vstack([-amplitude * rate**2 * np.cos(phase), res.outputs["ddot(th)"]])
    reg = model.regressor_at()
    assert reg.row_names == ("s", "th")
    y, loads = reg.matrix(res.t, q, qd, qdd)
    tau = y @ reg.values() - loads
    drive = res.outputs["shaker.drive"]
    assert np.max(np.abs(tau[:, 0] - drive)) <= 1e-12 * np.max(np.abs(drive))
    assert np.max(np.abs(tau[:, 1])) <= 1e-12 * np.max(np.abs(drive))


def double_pendulum_base(l1: float) -> np.ndarray:
    """The closed form's base parameters of the double pendulum (absolute angles, link2 hung at
    L1 along link1) as rows over phi = (m1, mx1, my1, I1, m2, mx2, my2, I2)."""
    rows = np.zeros((6, 8))
    rows[0, [3, 4]] = 1.0, l1**2  # I1 + m2 L1^2
    rows[1, [1, 4]] = 1.0, l1  # mx1 + m2 L1
    rows[2, 2] = rows[3, 5] = rows[4, 6] = rows[5, 7] = 1.0  # my1, mx2, my2, I2
    return rows


@pytest.fixture(scope="module")
def double_pendulum() -> nemc.runtime.Model:
    return nemc.compile(EXAMPLES / "double_pendulum.yaml")


def test_the_double_pendulums_base_parameters_are_the_closed_forms(double_pendulum) -> None:
    base = double_pendulum.base_parameters(params={"L1": 0.7}, seed=3)
    known = double_pendulum_base(0.7)
    assert base.rank == 6
    assert np.linalg.matrix_rank(np.vstack([base.combination, known]), tol=1e-9) == 6
    assert base.names == ("link1.mx + L1*link2.m", "link1.my", "link1.I + L1**2*link2.m",
                          "link2.mx", "link2.my", "link2.I")
    assert base.parameter_names[0] == "link1.m" and 0 not in base.independent  # m1: none


@pytest.mark.parametrize("links", [3, 4])
def test_a_planar_chain_has_three_base_parameters_a_link(links: int) -> None:
    """A chain of revolute joints in the vertical plane: per link ZZ_R, MX_R and MY_R (Khalil
    and Dombre, the masses regrouped), 3 n; no mass kept alone."""
    mech, reg = derived(relative_chain_yaml(links, "chain", 1.2, 0.5), "chain")
    base = reg.base(*random_states(links, 40, seed=links))
    assert base.rank == 3 * links
    assert not any(reg.names[k].endswith(".m") for k in base.independent)
    if links == 3:  # each link's mass regrouped into those it hangs from, at its length L
        assert base.names == (
            "link1.mx + L*link2.m + L*link3.m", "link1.my",
            "link1.I + L**2*link2.m + L**2*link3.m", "link2.mx + L*link3.m", "link2.my",
            "link2.I + L**2*link3.m", "link3.mx", "link3.my", "link3.I")
        assert base.combination[2, 4] == pytest.approx(0.25, rel=1e-12)


def test_a_coefficient_is_named_in_the_parameters_only_when_it_is_a_monomial() -> None:
    """Synthetic columns x, y, L^2/(3 h) x and (L + h) y: the first coefficient is named, the
    sum keeps its number."""
    rng = np.random.default_rng(1)
    x, y = rng.standard_normal((2, 30))

    def restack(p: np.ndarray) -> np.ndarray:
        length, height = p
        return np.column_stack([x, y, length**2 / (3 * height) * x, (length + height) * y])

    p = np.array([0.7, 1.3])
    base = base_parameters(restack(p), ("a", "b", "c", "d"))
    texts = coefficient_texts(base.combination, base.independent, restack, p, ("L", "h"))
    assert texts == {(0, 2): "L**2/(3*h)"}
    assert combination_name(base.combination[1], ("a", "b", "c", "d")) == "b + 2*d"


def test_base_parameters_are_recovered_exactly_from_noise_free_data(double_pendulum) -> None:
    """tau from the Lagrangian reference (not from Y), at seeded random states."""
    params = {"L1": 0.7, "m2": 1.3}
    mech = validate_text((EXAMPLES / "double_pendulum.yaml").read_bytes(), "dp.yaml")
    t, q, qd, qdd = random_states(2, 40, seed=5)
    ref = ReferenceModel(mech)
    tau = []
    for k in range(t.size):
        mass, forcing = ref.mass_forcing(t[k], np.ravel(np.column_stack([q[:, k], qd[:, k]])),
                                         params)
        tau.append(mass @ qdd[:, k] - forcing)
    found = nemc.identify(double_pendulum, t, q, qd, qdd, np.array(tau).T, params=params)
    assert found.rank == 6
    assert np.allclose(found.values, found.expected, rtol=1e-10, atol=1e-12)
    l1, l2, m2 = 0.7, 0.5, 1.3  # uniform rods: mx = m L / 2, I about the end m L^2 / 3
    truth = double_pendulum_base(l1) @ np.array([1, l1 / 2, 0, l1**2 / 3, m2, m2 * l2 / 2, 0,
                                                 m2 * l2**2 / 3])
    assert np.allclose(np.sort(found.expected), np.sort(truth), rtol=1e-12)


def test_the_fourbars_base_parameters_from_noisy_drive_torque(fourbar) -> None:
    """1% noise on the drive torque: every base parameter within 2 sigma at seed 0, and the
    2-sigma intervals' coverage over 200 draws near 95%."""
    t, q, qd, qdd, drive = loop_samples(fourbar)
    sigma = 0.01 * np.max(np.abs(drive))
    rng = np.random.default_rng(0)
    inside = []
    for draw in range(200):
        noisy = drive + rng.normal(0.0, sigma, drive.size)
        found = nemc.identify(fourbar, t, q, qd, qdd, noisy)
        inside.append(np.abs(found.values - found.expected) <= 2 * found.stderr)
        if draw == 0:
            assert found.rank == 7 and all(inside[0])
            given = nemc.identify(fourbar, t, q, qd, qdd, noisy, sigma=2 * found.sigma)
            assert np.allclose(given.stderr, 2 * found.stderr, rtol=1e-12)
    coverage = np.mean(inside)
    assert 0.9 <= coverage <= 0.99, coverage


def test_a_damping_named_linear_is_a_column_of_its_own() -> None:
    text = (EXAMPLES / "damped_compound_pendulum.yaml").read_text()
    mech, reg = derived(text, "damped", linear=("c",))
    assert reg.names[-1] == "c" and reg.values()[-1] == 0.5
    t, q, qd, qdd = random_states(1, 5, seed=2)
    y, loads = reg.matrix(t, q, qd, qdd)
    assert np.allclose(y[:, 0, -1], qd[0], rtol=0, atol=0)  # torque -c dot(theta)
    assert np.all(loads == 0.0)
    check_against_reference(mech, reg, seed=4)


COULOMB = """\
name: coulomb
parameters: {m: 1.5, L: 0.8, g: 9.81, c: 0.3, fc: 0.7}
gravity: [0, -g]
bodies:
  rod: {mass: m, inertia: m*L**2/12, com: [L/2, 0]}
joints:
  O: {type: revolute, parent: ground, child: rod, at: [0, 0], coordinate: th}
loads:
  - {torque: -c*dot(th) - fc*tanh(dot(th)/0.05) + 0.2*sin(t), body: rod}
"""


def test_viscous_and_coulomb_coefficients_are_recovered_exactly() -> None:
    """A pendulum with a damper c and a smoothed Coulomb friction fc at its pin (and a known
    torque): c and fc are columns, the forcing the rest; from the Lagrangian reference's torque
    at seeded states, c and fc come back to 1e-10."""
    mech, reg = derived(COULOMB, "coulomb", linear=("c", "fc"))
    check_against_reference(mech, reg, seed=8)
    t, q, qd, qdd = random_states(1, 30, seed=9)
    tau = reference_forces(mech, t, q, qd, qdd)
    found = identify(reg, t, q, qd, qdd, tau.T)
    assert found.names == ("rod.mx", "rod.my", "rod.I", "c", "fc")
    assert np.allclose(found.values, [0.6, 0.0, 0.32, 0.3, 0.7], rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize(("name", "message"), [
    ("g", "does not enter the equations linearly through the loads alone"),
    ("nope", "is not a runtime parameter"), (("c", "c"), "names a parameter twice")])
def test_a_coefficient_not_linear_or_unknown_is_refused(name, message: str) -> None:
    text = (EXAMPLES / "damped_compound_pendulum.yaml").read_text()
    with pytest.raises(ValueError, match=message):
        derived(text, "damped", linear=name if isinstance(name, tuple) else (name,))


def test_bad_samples_are_one_clear_error_each(double_pendulum, fourbar) -> None:
    q = np.zeros((2, 3))
    with pytest.raises(ValueError, match=r"q: expected shape \(2,\) or \(2, n_t\)"):
        double_pendulum.regressor(0.0, np.zeros(3), q, q)
    with pytest.raises(ValueError, match="t: 2 samples where q has 3"):
        double_pendulum.regressor([0.0, 1.0], q, q, q)
    with pytest.raises(ValueError, match="qd: not finite"):
        double_pendulum.regressor(0.0, q, np.full((2, 3), np.nan), q)
    with pytest.raises(ValueError, match=r"tau: expected shape \(2, 3\)"):
        nemc.identify(double_pendulum, np.zeros(3), q, q, q, np.zeros(3))
    with pytest.raises(ValueError, match="identify no parameter"):
        nemc.identify(double_pendulum, np.zeros(3), q, q, q, np.zeros((2, 3)),
                      params={"g": 0.0})
    with pytest.raises(ValueError, match="come from data"):
        fourbar.base_parameters()


def test_a_loop_left_free_is_refused() -> None:
    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    with pytest.raises(ValueError, match="needs every degree of freedom driven"):
        model.regressor_at()


def test_a_standalone_package_says_the_regressor_needs_the_compiler(tmp_path: Path) -> None:
    from nemc.pipeline import compile_mechanism

    package = compile_mechanism(EXAMPLES / "double_pendulum.yaml").package
    model = load_package(package)
    with pytest.raises(ModelError, match="derived by nemc's compiler"):
        model.regressor(0.0, [0, 0], [0, 0], [0, 0])


def test_the_examples_uneven_crank_identifies_eight_base_parameters(tmp_path: Path) -> None:
    """examples/fourbar_regressor.py: the crank accelerating adds its own inertia (8 base
    parameters where a constant speed gives 7); exact from the noise-free torque, within 2
    sigma from its seeded 1 % noise."""
    spec = importlib.util.spec_from_file_location("fourbar_regressor",
                                                  EXAMPLES / "fourbar_regressor.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    model = nemc.compile(example.uneven_fourbar(tmp_path))
    t, q, qd, qdd, drive = example.measured(model)
    exact = nemc.identify(model, t, q, qd, qdd, drive)
    assert exact.rank == 8 and "crank.I + L1**2*coupler.m + 0.111111*rocker.I" in exact.names
    assert np.allclose(exact.values, exact.expected, rtol=1e-9, atol=1e-12)
    found, _, count = example.estimate()
    assert count == 401 and found.rank == 8
    assert np.all(np.abs(found.values - found.expected) <= 2 * found.stderr)
