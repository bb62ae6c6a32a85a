"""optimize.REWRITES: powers written as C computes them fastest, with the same values."""

from __future__ import annotations

import pytest
import sympy

from nemc.emit.c_text import SymbolTablePrinter
from nemc.emit.optimize import rewrite

x, y = sympy.symbols("x y", positive=True)


@pytest.mark.parametrize("expr", [1 / sympy.sqrt(x + y), (x + y) ** sympy.Rational(3, 2),
                                  x / (x * y + 1) ** sympy.Rational(3, 2) + y**2])
def test_half_powers_are_written_with_sqrt(expr: sympy.Expr) -> None:
    """No pow() call in the C, and the rewritten expression is the original one."""
    rewritten = rewrite(expr)
    text = SymbolTablePrinter({x: "x", y: "y"}).doprint(rewritten)
    assert "pow(" not in text and "sqrt(" in text
    assert sympy.simplify(rewritten.doit() - expr) == 0
