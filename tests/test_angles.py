"""The right-hand side's sines and cosines of its angles, computed together (nemc/angles.py,
templates/angles.c.tmpl): which calls become names, that the rewritten program keeps its
values, and a compiled right-hand side that runs the vectorized kernel against the
articulated-body program (a different derivation) at 30 digits, at ordinary, large and huge
angles (the last beyond the kernel's range: libm's) and an odd number of angles."""

from __future__ import annotations

import numpy as np
import pytest
import sympy
from reference import program_results, relative_chain_yaml

import nemc
from nemc.derive.equations import ARTICULATED, derive
from nemc.derive.program import Guard, Program
from nemc.emit.angles import angle_calls
from nemc.emit.emitted import emit
from nemc.emit.optimize import optimize_equations
from nemc.front.validate import validate_text

q1, q2, p, w0, w1, w2 = sympy.symbols("q1 q2 p w0 w1 w2", real=True)


def test_the_sines_and_cosines_of_inputs_become_names_and_keep_their_values() -> None:
    """Angles of inputs, directly or through a step that only adds and multiplies them (w2),
    become names; the sine of another intermediate (w0) keeps libm."""
    program = Program(
        steps=((w2, q1 - q2),
               (w0, sympy.cos(w2) * p + sympy.sin(q1)),
               Guard(sympy.cos(q2) + 2, 1),
               (w1, sympy.sin(w0) + sympy.cos(q1) * sympy.sin(p * q2) + sympy.sin(q1 - q2))),
        results=(w1 * sympy.sin(q1), w0))
    calls = angle_calls(program, frozenset({q1, q2, p}))
    assert calls.angles == (w2, q1, q2, p * q2, q1 - q2)  # in the order of first use
    assert calls.ahead == ((w2, q1 - q2),)  # computed ahead for the angles
    left = {node for step in calls.program.assignments() for node in
            sympy.preorder_traversal(step[1]) if isinstance(node, (sympy.sin, sympy.cos))}
    assert left == {sympy.sin(w0)}  # an intermediate's sine keeps libm
    rng = np.random.default_rng(3)
    for _ in range(5):
        values = {q1: rng.uniform(-9, 9), q2: rng.uniform(-9, 9), p: rng.uniform(-2, 2)}
        ahead = dict(values)
        for name, expr in calls.ahead:
            ahead[name] = expr.xreplace(ahead)
        names = {s: sympy.sin(a.xreplace(ahead)).evalf(30) for s, a in
                 zip(calls.sines, calls.angles)}
        names.update({c: sympy.cos(a.xreplace(ahead)).evalf(30) for c, a in
                      zip(calls.cosines, calls.angles)})
        before, after = dict(values), {**values, **names}
        for (name, expr), (_, renamed) in zip(program.assignments(),
                                              calls.program.assignments()):
            before[name] = expr.xreplace(before).evalf(30)
            after[name] = renamed.xreplace(after).evalf(30)
        for result, renamed in zip(program.results, calls.program.results):
            assert float(result.xreplace(before).evalf(30)) == pytest.approx(
                float(renamed.xreplace(after).evalf(30)), rel=1e-14, abs=1e-14)


def test_a_program_without_input_angles_is_left_as_it_is() -> None:
    program = Program(((w0, sympy.exp(q1) * p), (w1, sympy.sin(w0))), (w1,))
    calls = angle_calls(program, frozenset({q1, p}))
    assert calls.angles == () and calls.program is program


CHAIN3 = relative_chain_yaml(3, "chain3_angles", mass=1.3, length=0.7)


@pytest.mark.parametrize("scale", [2.0, 1e3, 3e6])
def test_the_compiled_rhs_at_ordinary_large_and_huge_angles(tmp_path, scale: float) -> None:
    """Three angles (a pair and one alone) through the kernel; at 3e6 rad, beyond its range
    (2^20 pi/2), libm's. The accelerations match the articulated-body program's at 30
    digits, evaluated at the same doubles."""
    path = tmp_path / "chain3.yaml"
    path.write_text(CHAIN3)
    model = nemc.compile(path)
    eqs = derive(validate_text(CHAIN3.encode(), "chain3.yaml"))
    assert "angles_sincos(3, angle, sine, cosine);" in emit(eqs, optimize_equations(eqs)).c_source
    program = eqs.forms[ARTICULATED]
    rng = np.random.default_rng(int(scale) % 1000 + 5)
    for _ in range(8):
        y = np.empty(6)
        y[0::2] = rng.uniform(-scale, scale, 3)
        y[1::2] = rng.uniform(-2.0, 2.0, 3)
        env = {eqs.parameters[k]: v for k, v in enumerate(eqs.parameter_defaults)}
        env.update(zip((*eqs.coordinates, *eqs.speeds), (*y[0::2], *y[1::2])))
        expected = program_results(program, env)
        np.testing.assert_allclose(model.rhs(0.0, y)[1::2], expected, rtol=1e-12, atol=1e-11)


def test_a_reader_of_the_program_reads_its_sines_and_cosines_too() -> None:
    """The Jacobian's tangent reads its primal's steps: its sines and cosines of the primal's
    angles (here the step w2) become the primal's names; others keep libm."""
    primal = Program(((w2, q1 - q2), (w0, sympy.sin(w2) * p)), (w0,))
    calls = angle_calls(primal, frozenset({q1, q2, p}))
    reader = Program(((w1, sympy.cos(w2) * sympy.sin(q1 + 1) + sympy.sin(w2)),), (w1,))
    renamed = calls.names_in(reader)
    (_, value), = renamed.assignments()
    assert value == calls.cosines[0] * sympy.sin(q1 + 1) + calls.sines[0]


def test_a_chains_absolute_angles_cost_one_addition_a_joint_ahead() -> None:
    """On a 6-link chain (the articulated-body program) the angles are the links' absolute
    angles, each its parent's plus its joint's: computed ahead one addition each, not as sums
    from the first joint (quadratic in the links)."""
    eqs = derive(validate_text(relative_chain_yaml(6, "chain6", 1.0, 1.0).encode(), "c6.yaml"))
    inputs = frozenset((*eqs.coordinates, *eqs.speeds, *eqs.parameters))
    calls = angle_calls(eqs.dynamics, inputs)
    assert len(calls.angles) == 6 and len(calls.ahead) == 5
    assert all(expr.is_Add and len(expr.args) == 2 for _, expr in calls.ahead)
