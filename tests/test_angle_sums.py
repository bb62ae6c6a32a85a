"""Sines and cosines of sums from those of their parts (nemc/angle_sums.py): the values against
sympy's own sin and cos, the calls left, and the chain's right-hand side that runs it against the
articulated-body program (a different derivation: Featherstone's recursion, no mass matrix)."""

from __future__ import annotations

import numpy as np
import sympy
from reference import program_results, relative_chain_yaml

import nemc
from nemc.derive.angle_sums import split_angle_sums
from nemc.derive.equations import ADDITION_FORMULAS, ARTICULATED, LINEARIZED, derive
from nemc.front.validate import validate_text

a, b, c, x = sympy.symbols("a b c x", real=True)


def calls(exprs) -> set[sympy.Expr]:
    """The distinct arguments of sin and cos in the expressions (one sincos call each)."""
    return {node.args[0] for expr in exprs for node in sympy.preorder_traversal(expr)
            if isinstance(node, (sympy.sin, sympy.cos))}


def evaluated(definitions, exprs, values: dict) -> list[float]:
    """The rewritten expressions' values, their definitions computed in order."""
    env = dict(values)
    for symbol, value in definitions:
        env[symbol] = value.xreplace(env).evalf(30)
    return [float(expr.xreplace(env).evalf(30)) for expr in exprs]


def test_sums_and_differences_take_the_values_of_sin_and_cos() -> None:
    exprs = [x * sympy.sin(a + b), sympy.cos(a - b), sympy.sin(a) + sympy.cos(b),
             sympy.sin(c) * sympy.cos(a + b + c), sympy.sin(b - a - c) ** 2]
    definitions, rewritten = split_angle_sums(exprs)
    assert calls(rewritten) | calls(value for _, value in definitions) == {a, b, c}
    rng = np.random.default_rng(7)
    for _ in range(5):
        values = {s: sympy.Float(rng.uniform(-4, 4), 30) for s in (a, b, c, x)}
        expected = [float(expr.xreplace(values).evalf(30)) for expr in exprs]
        np.testing.assert_allclose(evaluated(definitions, rewritten, values), expected,
                                   rtol=1e-25, atol=1e-25)


def test_no_call_is_added() -> None:
    """A sum whose parts are not computed anyway stays one call; nothing else changes."""
    for exprs in ([sympy.sin(a + b)], [sympy.sin(a + b), sympy.cos(a)], [sympy.sin(2 * a)]):
        definitions, rewritten = split_angle_sums(exprs)
        assert definitions == [] and rewritten == exprs


CHAIN = relative_chain_yaml(4, "chain4", mass=1.3, length=0.8)


def test_a_chain_in_relative_angles_keeps_one_call_per_joint(tmp_path) -> None:
    """The 4-link chain's linearized mass-matrix form takes sin and cos of 10 distinct sums of
    its joint angles; with the addition formulas, of its 4 joint angles alone. The right-hand
    side runs that form (estimated fastest), and its accelerations are the articulated-body
    program's, compiled to C, at random states."""
    eqs = derive(validate_text(CHAIN.encode(), "chain4.yaml"))

    def arguments(form: str) -> set[sympy.Expr]:
        return calls(value for _, value in eqs.forms[form].assignments())

    assert len(arguments(LINEARIZED)) == 10
    assert arguments(ADDITION_FORMULAS) == set(eqs.coordinates)
    assert eqs.dynamics_form == ADDITION_FORMULAS
    path = tmp_path / "chain4.yaml"
    path.write_text(CHAIN)
    model = nemc.compile(path)
    assert model.metadata["dynamics_program"] == ADDITION_FORMULAS
    rng = np.random.default_rng(11)
    states = rng.uniform(-2.0, 2.0, (20, 8))
    program = eqs.forms[ARTICULATED]
    for y in states:
        env = {eqs.parameters[k]: v for k, v in enumerate(eqs.parameter_defaults)}
        env.update(zip((*eqs.coordinates, *eqs.speeds), (*y[0::2], *y[1::2])))
        expected = program_results(program, env)
        np.testing.assert_allclose(model.rhs(0.0, y)[1::2], expected, rtol=1e-12, atol=1e-12)
