"""Fewer Cauchy products in nemc.Taylor's program (nemc/products.py): each rewrite computes
what the program it rewrites computes (evaluated at seeded random values, 30 digits), has no
more Cauchy sums per order, and fewer where its rule applies; pairs are defined before their
first use, guards included."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy
from reference import random_mechanism_yaml
from test_hostile import chain_yaml
from test_mass_form import equations_of, random_values, run

from nemc.derive.equations import with_taylor
from nemc.derive.mass_form import mass_form_program
from nemc.derive.products import distributed, fewer_products, shared_pairs, time_varying
from nemc.derive.program import Guard, Program, split_deep
from nemc.derive.taylor import series_cost
from nemc.front import mechanism as m

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
q1, q2, u1, u2 = sympy.symbols("q1 q2 u1 u2", real=True)
k = sympy.Symbol("k", positive=True)  # a parameter
w = sympy.symbols("w0:6", real=True)


def cost_of(eqs):
    return lambda program: series_cost(program, eqs.coordinates, eqs.speeds, m.TIME)


def toy_cost(program: Program) -> float:
    return series_cost(program, (q1, q2), (u1, u2), m.TIME)


TOY_VARYING = frozenset({q1, q2, u1, u2, m.TIME})


def toy_values(rng: np.random.Generator) -> dict[sympy.Symbol, float]:
    return {s: rng.uniform(0.5, 1.5) for s in (q1, q2, u1, u2, k, m.TIME)}


def assert_same(program: Program, rewritten: Program, values: dict) -> None:
    expected = run(program, values)
    np.testing.assert_allclose(run(rewritten, values), expected, rtol=1e-13,
                               atol=1e-13 * max(1.0, np.abs(expected).max()))


def test_distributed_takes_a_common_factor_out_of_a_sum() -> None:
    """w1 = q1 u1 u2 + k w0 u1 - q1 q2 u1 with w0 = q1 q2 (a named product, seen through):
    q1 u1 (k q2 - q2 + u2), two products where the sum had four (w0 u1, q1 q2 u1 after its
    shared q1 q2, q1 u1, q1 u1 u2)."""
    program = Program(((w[0], q1 * q2), (w[1], q1 * u1 * u2 + k * w[0] * u1 - q1 * u1 * q2)),
                      (w[1], w[0]))
    rewritten = distributed(program, time_varying(program, TOY_VARYING))
    assert toy_cost(program) == 5  # w0 itself is the fifth
    assert toy_cost(rewritten) == 3
    assert_same(program, rewritten, toy_values(np.random.default_rng(1)))


def test_distributed_leaves_sums_of_quotients_and_nested_sums() -> None:
    """Taking a factor out next to a quotient or a sum measured dearer: such sums are kept."""
    step = q1 * u1 / (q2 + 2) + q1 * u2 * (u1 + q2)
    program = Program(((w[0], step),), (w[0], w[0]))
    assert distributed(program, time_varying(program, TOY_VARYING)).steps == program.steps


def test_shared_pairs_names_the_pair_in_the_most_products() -> None:
    """q1 u1 in three products of three factors: named once, each product one more sum."""
    program = Program(((w[0], sympy.sin(q1)),
                       (w[1], w[0] * u1 * u2 + q2),
                       (w[2], k * w[0] * u1 * q2),
                       (w[3], w[0] * u1 * q1 * u2)), (w[2], w[3] + w[1]))
    rewritten = shared_pairs(program, time_varying(program, TOY_VARYING))
    pair = [name for name, expr in rewritten.assignments() if expr == w[0] * u1]
    assert len(pair) == 1
    assert toy_cost(rewritten) < toy_cost(program)
    names = [name for name, _ in rewritten.assignments()]
    assert names.index(w[0]) < names.index(pair[0]) < names.index(w[1])
    assert_same(program, rewritten, toy_values(np.random.default_rng(2)))


def test_a_pair_first_used_in_a_guard_is_defined_before_it() -> None:
    program = Program((Guard(q1 * u1 * u2 + 3, 1), (w[0], q1 * u1 * q2)), (w[0], w[0]))
    rewritten = shared_pairs(program, time_varying(program, TOY_VARYING))
    assert isinstance(rewritten.steps[1], Guard)
    assert rewritten.steps[0][1] == q1 * u1
    assert_same(program, rewritten, toy_values(np.random.default_rng(3)))


def test_no_pair_in_two_products_leaves_the_program() -> None:
    program = Program(((w[0], q1 * u1 * u2), (w[1], q2 * u2)), (w[0], w[1]))
    assert shared_pairs(program, time_varying(program, TOY_VARYING)) is program


@pytest.mark.parametrize("links", [2, 3, 4, 8])
def test_chains_compute_the_same_with_fewer_sums(links: int) -> None:
    """Both programs (the mass-matrix form where it is derived, the articulated-body one) and
    both rewrites: the same accelerations, never more sums; and nemc.Taylor's program has
    fewer than either program had before (measured: 17 -> 15.5, 54.5 -> 44, 118 -> 88.5 and
    368.5 -> 337 sums per order)."""
    eqs = equations_of(chain_yaml(links), f"chain{links}")
    cost, rng = cost_of(eqs), np.random.default_rng(10 + links)
    varying = (*eqs.coordinates, *eqs.speeds, m.TIME)
    programs = [eqs.accelerations_program]
    if links <= 4:
        programs.append(split_deep(mass_form_program(*eqs.mass_forcing), "vt"))
    for program in programs:
        names = time_varying(program, varying)
        rewrites = [distributed(program, names), shared_pairs(program, names),
                    fewer_products(program, varying, cost)]
        values = random_values(eqs, rng)
        for rewritten in rewrites:
            assert_same(program, rewritten, values)
        assert cost(rewrites[-1]) <= cost(program)
    assert cost(with_taylor(eqs).taylor) < min(cost(program) for program in programs)


@pytest.mark.parametrize("seed", range(4))
def test_random_mechanisms_compute_the_same(seed: int) -> None:
    """Prismatic, weld and free joints, springs, loads in t and dot(q): nemc.Taylor's program
    (rewritten) against the articulated-body program, a separate derivation when the mass
    form is chosen."""
    rng = np.random.default_rng(300 + seed)
    text = random_mechanism_yaml(rng, 2 + seed, tree=seed % 2 == 1, name=f"mech{seed}")
    eqs = equations_of(text, f"mech{seed}")
    taylor = with_taylor(eqs).taylor
    values = random_values(eqs, rng)
    expected = run(eqs.dynamics, values)
    np.testing.assert_allclose(run(taylor, values), expected, rtol=1e-11,
                               atol=1e-11 * max(1.0, np.abs(expected).max()))
