"""The Jacobian's tangent program: the chain rule over each step's tree (tangent.py's
directional_derivative) against sympy's diff of the whole expression, symbol by symbol
(derivative_by_diff), on random expressions of every kind a step holds."""

from __future__ import annotations

import numpy as np
import pytest
import sympy

from nemc.derive.tangent import derivative_by_diff, directional_derivative, product

X, Y, Z = sympy.symbols("x y z", real=True)
K = sympy.Symbol("k", positive=True)  # a parameter: no tangent
TANGENTS = {X: sympy.Symbol("dx"), Y: sympy.Symbol("dy"), Z: sympy.Symbol("dz")}


def random_expression(rng: np.random.Generator, depth: int) -> sympy.Expr:
    """Sums, products, powers (integer, rational, negative, of a varying exponent), sine,
    cosine and functions the chain rule leaves to sympy (exp, atan2, |x|, sign, min, a
    conditional)."""
    leaves = [X, Y, Z, K, sympy.Rational(int(rng.integers(-5, 6)), int(rng.integers(1, 4)))]
    if depth == 0:
        return leaves[int(rng.integers(len(leaves)))]
    a, b = random_expression(rng, depth - 1), random_expression(rng, depth - 1)
    makers = [
        lambda: a + b, lambda: a * b, lambda: a * b * X - K * a,
        lambda: (a ** 2 + 1) ** sympy.Rational(1, 2), lambda: 1 / (a ** 2 + 2), lambda: a ** 3,
        lambda: (b ** 2 + 1) ** (X / 3), lambda: sympy.sin(a), lambda: sympy.cos(a) * b,
        lambda: sympy.exp(a / 4), lambda: sympy.atan2(a, b ** 2 + 1), lambda: sympy.Abs(a),
        lambda: sympy.sign(a) * b, lambda: sympy.Min(a, b),
        lambda: sympy.Piecewise((a, b > 0), (a * b, True)),
    ]
    return makers[int(rng.integers(len(makers)))]()


@pytest.mark.parametrize("seed", range(40))
def test_chain_rule_agrees_with_sympy_diff(seed: int) -> None:
    rng = np.random.default_rng(seed)
    expr = random_expression(rng, 3)
    fast = directional_derivative(expr, TANGENTS, {})
    reference = derivative_by_diff(expr, TANGENTS, {})
    symbols = [X, Y, Z, K, *TANGENTS.values()]
    f_fast, f_ref = (sympy.lambdify(symbols, e, "math") for e in (fast, reference))
    checked = 0
    for _ in range(20):
        point = [*rng.uniform(-2, 2, 3), rng.uniform(0.5, 2), *rng.uniform(-1, 1, 3)]
        try:
            expected = float(f_ref(*point))
        except (ValueError, ZeroDivisionError, OverflowError):  # outside the domain
            continue
        if not np.isfinite(expected):
            continue
        assert float(f_fast(*point)) == pytest.approx(expected, rel=1e-9, abs=1e-9), expr
        checked += 1
    assert checked >= 5, f"too few points in the domain of {expr}"


def test_derivatives_use_the_primal_names() -> None:
    """d cos(x) = -sin(x) dx is written with the primal's name of sin(x), and d(1/b) with the
    primal's reciprocal instead of a division."""
    w_sin, w_rec = sympy.symbols("w_sin w_rec")
    known = {sympy.sin(X): w_sin, 1 / (X + Y): w_rec}
    dx, dy = TANGENTS[X], TANGENTS[Y]
    assert directional_derivative(sympy.cos(X), TANGENTS, known) == -w_sin * dx
    assert directional_derivative(1 / (X + Y), TANGENTS, known) == -w_rec ** 2 * (dx + dy)


def test_constants_have_no_tangent() -> None:
    assert directional_derivative(K ** 2 * sympy.sin(K), TANGENTS, {}) == 0
    assert directional_derivative(K * X, TANGENTS, {}) == K * TANGENTS[X]


def random_factor(rng: np.random.Generator, symbols: list[sympy.Symbol]) -> sympy.Expr:
    """A rational, a symbol, a rational times symbols, or something else (a sum, a power)."""
    numbers = [sympy.Integer(k) for k in (-2, -1, 0, 1, 3)] + [sympy.Rational(-3, 4)]
    kind = int(rng.integers(5))
    if kind == 0:
        return numbers[int(rng.integers(len(numbers)))]
    if kind == 1:
        return symbols[int(rng.integers(len(symbols)))]
    if kind == 4:
        return [X + Y, X ** 2, sympy.Float(0.5), sympy.sin(Z)][int(rng.integers(4))]
    picked = rng.choice(len(symbols), size=int(rng.integers(1, 4)), replace=False)
    return sympy.Mul(numbers[int(rng.integers(len(numbers)))], *(symbols[k] for k in picked))


def test_product_is_sympys_mul_exactly() -> None:
    """tangent.product builds the monomials' products itself: the same expression sympy.Mul
    makes, args in the same order (the C printed from it, and so the Jacobian's bits, must not
    change), with Dummy symbols (the programs' names) and repeated symbols (powers) among them."""
    rng = np.random.default_rng(11)
    symbols = [X, Y, Z, K, *(sympy.Dummy(f"w{k}", real=True) for k in range(4))]
    for _ in range(3000):
        factors = [random_factor(rng, symbols) for _ in range(int(rng.integers(1, 4)))]
        made, expected = product(*factors), sympy.Mul(*factors)
        assert made == expected and made.args == expected.args, factors
