"""The mass-matrix form as a program (nemc/mass_form.py), nemc.Taylor's program on small
mechanisms: its accelerations against the articulated-body program's (two derivations: Newton-Euler
projected onto the joints and solved by LDL^T, against Featherstone's recursion), the choice of
the cheaper program, and Taylor's method on it against Vern9."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy
from reference import random_mechanism_yaml

import nemc
from nemc.derive.equations import ARTICULATED, derive, with_taylor
from nemc.derive.mass_form import (
    MAX_COORDINATES,
    inverse_solve_2x2,
    ldl_solve,
    linearized,
    mass_form_program,
)
from nemc.derive.program import Guard, Program, ProgramBuilder
from nemc.derive.taylor import series_cost
from nemc.front import mechanism as m
from nemc.front.validate import validate_text
from nemc.runtime.model import IntegrationFailure

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
BOOK = ["compound_pendulum", "double_pendulum", "robot_arm", "two_link_robot_arm"]


def evaluate(program: Program, values: dict[sympy.Symbol, float]
             ) -> tuple[np.ndarray | None, int]:
    """The program's results at these values of its free symbols, to 30 digits: (results, 0),
    or (None, the status of the first guard that fails)."""
    env: dict[sympy.Symbol, sympy.Expr] = {k: sympy.Float(v, 30) for k, v in values.items()}
    for step in program.steps:
        if isinstance(step, Guard):
            if not float(step.value.xreplace(env)) > 0:
                return None, step.status
            continue
        env[step[0]] = sympy.N(step[1].xreplace(env), 30)
    return np.array([float(sympy.N(r.xreplace(env), 30)) for r in program.results]), 0


def run(program: Program, values: dict[sympy.Symbol, float]) -> np.ndarray:
    """The program's results at these values of its free symbols (guards must hold)."""
    results, status = evaluate(program, values)
    assert status == 0 and results is not None
    return results


def equations_of(text: str, name: str):
    return derive(validate_text(text.encode(), f"{name}.yaml"))


def random_values(eqs, rng: np.random.Generator) -> dict[sympy.Symbol, float]:
    values = dict(zip(eqs.parameters, eqs.parameter_defaults))
    for q, u in zip(eqs.coordinates, eqs.speeds):
        values[q], values[u] = rng.uniform(-1.5, 1.5), rng.uniform(-2, 2)
    values[m.TIME] = rng.uniform(0, 3)
    return values


def assert_same_accelerations(eqs, rng: np.random.Generator, trials: int = 3) -> None:
    """Every form of the accelerations derived (the one the RHS runs among them) and the
    linearized mass-matrix form against the articulated-body program."""
    forms = [mass_form_program(*eqs.mass_forcing), eqs.dynamics, *eqs.forms.values()]
    assert eqs.dynamics in eqs.forms.values() and len(eqs.forms) >= 2
    for _ in range(trials):
        values = random_values(eqs, rng)
        expected = run(eqs.forms[ARTICULATED], values)
        for form in forms:
            np.testing.assert_allclose(run(form, values), expected, rtol=1e-11,
                                       atol=1e-11 * max(1.0, np.abs(expected).max()))


@pytest.mark.parametrize("name", BOOK)
def test_book_systems_agree_with_the_articulated_body_program(name: str) -> None:
    path = EXAMPLES / f"{name}.yaml"
    assert_same_accelerations(equations_of(path.read_text(), name), np.random.default_rng(3))


@pytest.mark.parametrize("seed", range(4))
def test_random_mechanisms_agree_with_the_articulated_body_program(seed: int) -> None:
    """Prismatic, weld and free joints, springs, loads in t and dot(q)."""
    rng = np.random.default_rng(100 + seed)
    text = random_mechanism_yaml(rng, 2 + seed % 2, tree=seed >= 2, name=f"small{seed}")
    assert_same_accelerations(equations_of(text, f"small{seed}"), rng)


def test_linearized_collects_sines_and_cosines() -> None:
    a, b = sympy.symbols("a b", real=True)
    assert linearized(sympy.sin(a) ** 2 + sympy.cos(a) ** 2) == 1
    assert linearized(sympy.cos(a) * sympy.cos(b) + sympy.sin(a) * sympy.sin(b)) == sympy.cos(a - b)


def test_taylor_uses_the_cheaper_program() -> None:
    """The double pendulum: the mass-matrix form has under half the Cauchy sums; a chain past
    MAX_COORDINATES keeps the articulated-body program (the form is not derived; its products
    are shared: tests/test_products.py)."""
    eqs = with_taylor(equations_of((EXAMPLES / "double_pendulum.yaml").read_text(), "dp"))
    assert eqs.taylor_form.startswith("mass matrix")
    assert (series_cost(eqs.taylor, eqs.coordinates, eqs.speeds, m.TIME)
            < series_cost(eqs.forms[ARTICULATED], eqs.coordinates, eqs.speeds, m.TIME) / 2)
    chain = equations_of(random_mechanism_yaml(np.random.default_rng(5), 7, tree=False), "long")
    assert chain.n > MAX_COORDINATES
    taylor = with_taylor(chain).taylor  # the articulated-body program, its products shared
    assert "mass_forcing" not in vars(chain) and chain.derived_mass_forcing is None  # not derived
    assert list(chain.forms) == [ARTICULATED] and chain.dynamics_form == ARTICULATED
    values = random_values(chain, np.random.default_rng(6))
    np.testing.assert_allclose(run(taylor, values), run(chain.dynamics, values), rtol=1e-11)


@pytest.mark.parametrize("seed", range(2))
def test_taylor_on_the_mass_form_against_vern9(tmp_path: Path, seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    path = tmp_path / f"small{seed}.yaml"
    path.write_text(random_mechanism_yaml(rng, 2, tree=False, name=f"small{seed}"))
    model = nemc.compile(path, taylor=True)
    assert model.metadata["taylor_program"].startswith("mass matrix")
    y0, t_eval = model.initial_state(), np.linspace(0.0, 2.0, 9)
    result = model.simulate((0.0, 2.0), y0, method="nemc.Taylor", rtol=1e-11, atol=1e-13,
                            t_eval=t_eval)
    assert result.success, result.message
    reference = model.simulate((0.0, 2.0), y0, method="nemc.Vern9", rtol=1e-13, atol=1e-15,
                               t_eval=t_eval).y
    assert np.abs(result.y - reference).max() < 1e-8 * max(1.0, np.abs(reference).max())


def test_a_singular_mass_form_names_its_pivot() -> None:
    """The double pendulum's RHS is the mass-matrix form: with link 2 massless (parameters the
    Model refuses, so its C is called directly) pivot 2 of M's LDL^T is zero, and the failure
    says so rather than naming an articulated inertia."""
    model = nemc.compile(EXAMPLES / "double_pendulum.yaml")
    assert model.metadata["dynamics_program"].startswith("mass matrix")
    p = model.parameter_vector()
    p[model.parameter_names.index("m2")] = 0.0
    y, dy = model.initial_state(), np.empty(model.n_state)
    c, buffer = model.compiled, model.compiled.buffer
    status = c.functions["rhs"](0.0, buffer(y), buffer(p), buffer(dy))
    assert status == 2
    failure = IntegrationFailure(0.0, y, status, model.state_names, c.status_cause(status))
    assert "pivot 2 of its LDL^T factorization is not positive" in str(failure)
    assert "articulated" not in str(failure)


def quotients(program: Program) -> int:
    """The program's divisions by a value that is not a number."""
    return sum(1 for step in program.steps if not isinstance(step, Guard)
               for node in sympy.preorder_traversal(step[1])
               if isinstance(node, sympy.Pow) and node.exp.is_negative
               and not node.base.is_number)


def solved(solve, mass: np.ndarray, forcing: np.ndarray) -> tuple[np.ndarray | None, int]:
    """SOLVE's program at these numbers: (x, 0), or (None, the status of the failing guard)."""
    builder = ProgramBuilder("s")
    symbols = sympy.symbols("a b d f0 f1", real=True)
    a, b, d, f0, f1 = symbols
    program = builder.finish(solve(builder, {(0, 0): a, (1, 0): b, (1, 1): d}, [f0, f1]))
    return evaluate(program, dict(zip(symbols, (mass[0, 0], mass[1, 0], mass[1, 1], *forcing))))


def test_the_inverse_solves_as_ldl_with_its_guards() -> None:
    """Two coordinates: adj(M) f / det M gives LDL^T's solution (and numpy's), and fails on the
    same guard where M is not positive definite (pivot 1: M[0, 0]; pivot 2: det M / M[0, 0])."""
    rng = np.random.default_rng(11)
    for _ in range(20):
        root = rng.normal(size=(2, 2))
        mass, forcing = root @ root.T + 0.1 * np.eye(2), rng.normal(size=2)
        x, status = solved(inverse_solve_2x2, mass, forcing)
        assert status == 0
        np.testing.assert_allclose(x, np.linalg.solve(mass, forcing), rtol=1e-12)
        np.testing.assert_allclose(x, solved(ldl_solve, mass, forcing)[0], rtol=1e-12)
    for mass in (np.array([[0.0, 1.0], [1.0, 2.0]]), np.array([[-1.0, 0.0], [0.0, 2.0]]),
                 np.array([[1.0, 2.0], [2.0, 4.0]]), np.array([[1.0, 2.0], [2.0, 3.0]])):
        assert solved(inverse_solve_2x2, mass, np.ones(2))[1] \
            == solved(ldl_solve, mass, np.ones(2))[1] > 0


def test_two_coordinates_run_the_inverse_and_taylor_keeps_ldl() -> None:
    """The double pendulum's right-hand side divides once (the determinant), where LDL^T
    divides three times, one division waiting for the other; nemc.Taylor's program is LDL^T's
    (a quotient by the constant M[0, 0] costs it no Cauchy sum): 13 sums an order."""
    eqs = with_taylor(equations_of((EXAMPLES / "double_pendulum.yaml").read_text(), "dp"))
    assert eqs.dynamics_form.startswith("mass matrix") and quotients(eqs.dynamics) == 1
    assert quotients(mass_form_program(*eqs.mass_forcing, solve=ldl_solve)) == 3
    assert eqs.taylor_form.startswith("mass matrix") and eqs.taylor_sums == 13
