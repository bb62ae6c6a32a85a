"""The estimate that chooses the right-hand side's program (nemc/c_cost.py): what it counts,
and the choice it makes on the book's systems. Whether the choice is the fastest as measured is
benchmarks/rhs_forms.py's question (timings do not belong in tests)."""

from __future__ import annotations

from pathlib import Path

import pytest
import sympy

from nemc.derive.c_cost import NS_PER_FUNCTION, NS_PER_PRODUCT, NS_PER_SUM, estimated_ns
from nemc.derive.equations import ADDITION_FORMULAS, ARTICULATED, LINEARIZED, derive
from nemc.derive.program import Guard, Program
from nemc.front.validate import validate_text

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
a, b, c, d = sympy.symbols("a b c d", real=True)
w0, w1 = sympy.symbols("w0 w1", real=True)


def cost_of(*exprs: sympy.Expr) -> float:
    return estimated_ns(Program(tuple((sympy.Symbol(f"s{k}"), e) for k, e in enumerate(exprs)),
                                ()))


def test_a_sine_and_cosine_of_one_argument_are_one_call() -> None:
    one = cost_of(sympy.sin(a + b), sympy.cos(a + b))  # a + b in each step
    two = cost_of(sympy.sin(a + b), sympy.cos(a - b))
    assert one == pytest.approx(NS_PER_FUNCTION + 2 * NS_PER_SUM)
    assert two == pytest.approx(2 * NS_PER_FUNCTION + 2 * NS_PER_SUM)


def test_operations_are_counted_as_the_c_writes_them() -> None:
    assert cost_of(a + b + c) == pytest.approx(2 * NS_PER_SUM)
    assert cost_of(a * b * c) == pytest.approx(2 * NS_PER_PRODUCT)
    assert cost_of(-a * b) == pytest.approx(NS_PER_PRODUCT)  # the sign is the subtraction's
    assert cost_of(a**3) == pytest.approx(2 * NS_PER_PRODUCT)  # a*a*a
    assert cost_of(1 / a) == 0.0  # divisions weigh nothing measurable (the fit)
    assert cost_of(1 / sympy.sqrt(a)) == pytest.approx(NS_PER_FUNCTION)  # a call
    # a subtree repeated in one step is one value (gcc shares it); guards cost nothing
    assert cost_of((a + b) * c + (a + b) * d) == pytest.approx(2 * NS_PER_SUM
                                                               + 2 * NS_PER_PRODUCT)
    guarded = Program((Guard(a, 1), (w0, a + b)), (w0,))
    assert estimated_ns(guarded) == pytest.approx(NS_PER_SUM)


def equations(name: str):
    path = EXAMPLES / f"{name}.yaml"
    return derive(validate_text(path.read_bytes(), str(path)))


# the form each ran fastest as C (benchmarks/results/rhs_forms-latest.md: the arm 3 ns against
# 16 and 18; the pendulum 35 ns against 39, 44 and 46); a closed loop has no mass-matrix candidate
@pytest.mark.parametrize("name, form", [
    ("robot_arm", LINEARIZED),  # the 5.4 arm: sin^2 + cos^2 = 1 leaves no call at all
    ("double_pendulum", ADDITION_FORMULAS),
    ("fourbar", ARTICULATED),
])
def test_the_right_hand_side_runs_the_form_measured_fastest(name: str, form: str) -> None:
    eqs = equations(name)
    assert eqs.dynamics_form == form and eqs.dynamics is eqs.forms[form]
