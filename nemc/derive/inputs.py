"""The inputs as the generated code computes them: one law for every way a run may set them.

An input u (the YAML's `inputs:`) is set at run time as a constant, a table of samples, a
linear state feedback, or the YAML's own expression (its default, or the scene's value, an
expression of parameters and t). Every one of these is, over a step, an affine law

    u = s * yaml(t, p) + a + b (t - t0) + G y

with runtime coefficients (s, a, b, t0, G) appended to the parameter vector p: the YAML's
expression (s = 1, the rest 0: a build's default), a constant (a), a table's segment (a: its
value at the segment's start t0, b: its slope; the drivers move to the next segment at its
sample times, which are the run's tstops), a feedback u_ref - K (y - y_ref) (a = u_ref + K y_ref,
G = -K). So the right-hand side, the Jacobian (closed-loop: G enters it), nemc.Taylor's
recurrences and every native method take inputs with no Python in the loop, and an input costs
a few multiply-adds per evaluation. The derivative of the right-hand side by an input is its
derivative by `a` (B of a linearization).

Loads, outputs and events name an input by its symbol; the derivation replaces the symbol by
the law (`substitutions`), wherever it replaces constants by their values.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from ..front import mechanism as m

# The coefficients of one input's law, in the parameter vector in this order, then its gains
# on each entry of the state.
COEFFICIENTS = ("scale", "value", "slope", "start")


@dataclass(frozen=True)
class InputLaw:
    """The inputs' symbols, the runtime coefficients of their laws (in p's order after the
    parameters) with their defaults, and each input's law."""

    names: tuple[str, ...]
    coefficients: tuple[sympy.Symbol, ...]
    defaults: tuple[float, ...]
    laws: tuple[sympy.Expr, ...]

    @property
    def stride(self) -> int:
        """Coefficients per input: COEFFICIENTS, then one gain per entry of the state."""
        return len(self.coefficients) // len(self.names) if self.names else 0

    @property
    def substitutions(self) -> dict[sympy.Symbol, sympy.Expr]:
        return {m.symbol(name): law for name, law in zip(self.names, self.laws)}

    def values(self) -> tuple[sympy.Symbol, ...]:
        """Each input's constant term `a`: the derivative by it is the derivative by the input."""
        return self.coefficients[1::self.stride] if self.names else ()


def coefficient(name: str, part: str) -> sympy.Symbol:
    """A coefficient of input NAME's law: a symbol no name from the file can equal (it holds
    spaces), the same in every derivation of the mechanism; printed as P(k)."""
    return sympy.Symbol(f"input {name} {part}", real=True)


def input_law(mech: m.Mechanism, runtime) -> InputLaw:
    """The laws of MECH's inputs, their YAML expressions (the scene's value, else the default)
    in runtime symbols through RUNTIME (constants folded, derived parameters written out)."""
    if not mech.inputs:
        return InputLaw((), (), (), ())
    state = [symbol for q in mech.coordinates
             for symbol in (m.symbol(q), m.rate_symbol(q))]
    coefficients: list[sympy.Symbol] = []
    defaults: list[float] = []
    laws = []
    for item in mech.inputs:
        own = [coefficient(item.name, part) for part in COEFFICIENTS]
        gains = [coefficient(item.name, f"gain {y}") for y in state]
        scale, value, slope, start = own
        written = runtime(mech.simulation.inputs.get(item.name, item.expr))
        laws.append(scale * written + value + slope * (m.TIME - start)
                    + sum((g * y for g, y in zip(gains, state)), sympy.S.Zero))
        coefficients += own + gains
        defaults += [1.0, 0.0, 0.0, 0.0] + [0.0] * len(state)
    return InputLaw(tuple(item.name for item in mech.inputs), tuple(coefficients),
                    tuple(defaults), tuple(laws))
