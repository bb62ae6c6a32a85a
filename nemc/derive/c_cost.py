"""What a straight-line program will cost as compiled C, estimated before it is written: which
of the accelerations' programs the right-hand side runs (derive.fastest_dynamics).

The estimate is a linear model in the program's operations, fitted to 36 programs timed as C
(12 mechanisms: the book's four, uniform chains of 2-4 links, the examples with prismatic, weld
and free joints and springs; each as the articulated-body program and the mass-matrix form with
and without linearization; gcc -O2, x86-64, rhs_many over 10,000 random states, best of 15;
docs/decisions.md "Which program computes the right-hand side"). It ranks the three forms of
each of the 12 mechanisms as measured; the fourth, the linearized form with the addition
formulas (nemc/angle_sums.py), came later, unfitted: on the same 12 on an AMD EPYC the form it
ranks first runs within 1.05x of the fastest (benchmarks/results/rhs_forms-latest.md).
Counting operations alone does not rank them (sympy's count_ops ranked the linearized form
first everywhere, 1.2x slower than the best at 4 links):

- a sine-cosine pair of one argument (gcc makes it one sincos call) costs about 7.4 ns, as
  much as 20 sums; other functions (sqrt, exp, pow, ...) are counted the same, a bound. (The
  right-hand side now computes the pairs of its angles together, two at a time: nemc/angles.py.
  The weight overstates them since, but its ranking was measured to hold: within 1.02x of
  the fastest form on 11 of the 12, benchmarks/results/rhs_forms-latest.md);
- a sum costs 0.35 ns and a product 0.08: the model's weights are each operation's share of
  the time, latency included (a sum's chain is serial; products of a step run side by side);
- divisions (a few per program, overlapped with the rest) add nothing measurable.

Constant offsets do not change a ranking and are left out, so the estimate is no time of its
own: compare programs of one mechanism with it, nothing else.
"""

from __future__ import annotations

import sympy

from .program import Guard, Program

NS_PER_SUM = 0.35
NS_PER_PRODUCT = 0.08
NS_PER_FUNCTION = 7.4  # a distinct argument of sin/cos, or any other function call


def estimated_ns(program: Program) -> float:
    """The program's estimated cost per evaluation (see the module's docstring)."""
    sums = products = 0
    calls: set[object] = set()  # sin(a) and cos(a) are one call
    for step in program.steps:
        if isinstance(step, Guard):
            continue
        for node in set(sympy.preorder_traversal(step[1])):  # a repeated subtree is named once
            if node.is_Add:
                sums += len(node.args) - 1
            elif node.is_Mul:
                products += len(node.args) - 1 - (node.args[0] is sympy.S.NegativeOne)
            elif node.is_Pow:
                products += power_products(node.exp)
                if not node.exp.is_Integer:
                    calls.add(node)
            elif isinstance(node, (sympy.sin, sympy.cos)):
                calls.add(("sincos", node.args[0]))
            elif isinstance(node, sympy.Function):
                calls.add(node)
    return NS_PER_SUM * sums + NS_PER_PRODUCT * products + NS_PER_FUNCTION * len(calls)


def power_products(exponent: sympy.Expr) -> int:
    """The products a power is written as (optimize.REWRITES): x**3 is x*x*x, x**-2 1/(x*x)."""
    if exponent.is_Integer:
        return max(abs(int(exponent)) - 1, 0)
    return 1 if exponent.is_Rational and abs(exponent.p) > 1 else 0
