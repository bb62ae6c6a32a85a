"""The fast path of the C printer (nemc/c_text.py) against sympy's own C99 printer: the same
text for every expression a set of models prints (their programs, Jacobians, outputs, events,
Taylor's code), and for random expressions of the same grammar, in both orders of terms."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
import sympy
from reference import random_mechanism_yaml
from sympy.printing.c import C99CodePrinter

from nemc.derive.equations import derive, with_diagnostics, with_taylor
from nemc.emit.c_text import SymbolTablePrinter
from nemc.emit.emitted import emit
from nemc.emit.optimize import optimize_equations
from nemc.front.validate import validate_text

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
MODELS = ("double_pendulum", "robot_arm", "fourbar", "fourbar_driven", "slider_crank",
          "double_pendulum_events", "bouncing_ball", "kapitza", "free_body_on_spring",
          "joint_spring_telescope", "weld_t_pendulum", "tree7")


def sympy_text(printer: SymbolTablePrinter, expr: sympy.Basic) -> str:
    return C99CodePrinter.doprint(printer, expr)


def printed_by_emit(name: str, monkeypatch: pytest.MonkeyPatch
                    ) -> list[tuple[SymbolTablePrinter, sympy.Basic]]:
    """Every (printer, expression) that emit prints for the model, with its Jacobian and
    Taylor's code."""
    if name == "tree7":
        path = Path("tree7.yaml")
        text = random_mechanism_yaml(np.random.default_rng(11), 7, True, name)
    else:
        path = EXAMPLES / f"{name}.yaml"
        text = path.read_text()
    equations = with_taylor(with_diagnostics(derive(validate_text(text, str(path)))))
    calls = []
    original = SymbolTablePrinter.doprint

    def recording(self: SymbolTablePrinter, expr: sympy.Basic, assign_to: object = None) -> str:
        calls.append((self, expr))
        return original(self, expr, assign_to)

    monkeypatch.setattr(SymbolTablePrinter, "doprint", recording)
    emit(equations, optimize_equations(equations))
    return calls


@pytest.mark.parametrize("name", MODELS)
def test_models_print_as_sympy_prints_them(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    calls = printed_by_emit(name, monkeypatch)
    monkeypatch.undo()
    fast = 0
    for printer, expr in calls:
        try:
            text = printer.fast.text(expr)
        except Exception:  # noqa: BLE001 (left to sympy's printer)
            continue
        fast += 1
        assert text == sympy_text(printer, expr), expr
    # the fast path must carry nearly all of it, or the speed is silently gone
    assert fast >= 0.95 * len(calls), f"{fast} of {len(calls)} printed by the fast path"


def random_expression(rng: random.Random, symbols: list[sympy.Symbol], depth: int) -> sympy.Expr:
    """An expression of the programs' grammar: symbols, numbers of every sign and kind, sums,
    products, integer and rational powers, sin, cos and unevaluated groupings."""
    if depth == 0 or rng.random() < 0.25:
        kind = rng.random()
        if kind < 0.6:
            return rng.choice(symbols)
        if kind < 0.75:
            return sympy.Integer(rng.choice([-3, -2, -1, 1, 2, 5, 10**20]))
        if kind < 0.9:
            return sympy.Rational(rng.choice([-7, -1, 1, 3]), rng.choice([2, 3, 12]))
        return sympy.Float(rng.choice([-2.5, 0.1, 9.81, 1e-300]))
    shape = rng.random()
    parts = [random_expression(rng, symbols, depth - 1) for _ in range(rng.randint(2, 4))]
    if shape < 0.3:
        return sympy.Add(*parts)
    if shape < 0.6:
        return sympy.Mul(*parts)
    if shape < 0.75:
        exponent = rng.choice([-3, -2, -1, 2, 3, 5, sympy.S.Half, -sympy.S.Half,
                               sympy.Rational(1, 3), sympy.Rational(3, 2)])
        return sympy.Pow(parts[0], exponent)
    if shape < 0.9:  # of a sum or product without groupings (sympy's sin recursed on some)
        argument = parts[0] if not parts[0].has(sympy.UnevaluatedExpr) else symbols[0]
        return rng.choice([sympy.sin, sympy.cos])(argument)
    grouped = sympy.UnevaluatedExpr(sympy.Mul(parts[0], parts[1], evaluate=False))
    return sympy.Mul(rng.choice([-2, -1, 1, 3]), grouped, parts[-1])


def test_random_expressions_print_as_sympy_prints_them() -> None:
    rng = random.Random(20261124)
    symbols = [*sympy.symbols("a b c"), *(sympy.Dummy(f"d{k}") for k in range(3))]
    names = {s: f"v{k}" for k, s in enumerate(symbols)}
    printers = [SymbolTablePrinter(names), SymbolTablePrinter(names, order="none")]
    fast = 0
    for _ in range(1500):
        expr = random_expression(rng, symbols, 4)
        for printer in printers:
            try:
                text = printer.fast.text(expr)
            except Exception:  # noqa: BLE001
                continue
            fast += 1
            assert text == sympy_text(printer, expr), expr
    assert fast >= 0.75 * 3000  # powers of numbers (M_SQRT2, ...) and I go to sympy


@pytest.mark.parametrize("expr", [sympy.pi * sympy.Symbol("a"), sympy.sqrt(2),
                                  sympy.exp(sympy.Symbol("a")), sympy.Abs(sympy.Symbol("a")),
                                  1 / sympy.sqrt(2), sympy.Symbol("a") ** sympy.Symbol("a")])
def test_the_rest_goes_to_sympy(expr: sympy.Expr) -> None:
    """What the fast path does not know (constants, sympy's math macros, other functions) is
    printed by sympy's printer: M_SQRT2, not pow(2, 1/2)."""
    printer = SymbolTablePrinter({sympy.Symbol("a"): "v0"})
    assert printer.doprint(expr) == sympy_text(printer, expr)


def test_a_symbol_without_a_name_is_refused() -> None:
    with pytest.raises(ValueError, match="no C name for symbol 'b'"):
        SymbolTablePrinter({}).doprint(sympy.Symbol("b") + 1)
