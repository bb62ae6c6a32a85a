"""Long chains: the derivation and the generated code grow linearly, and a 32-body chain of
mixed revolute and prismatic joints with joint springs conserves energy.

Sizes are counted, never timed (speed belongs to benchmarks/scaling.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.derive.equations import derive
from nemc.front.validate import validate_text


def mixed_chain(n: int) -> str:
    """n uniform rods; every fourth joint prismatic, each of those on an undamped joint spring."""
    lines = ["name: mixed", "parameters: {m: 1, L: 1, k: 40, g: 9.81}", "gravity: [0, -g]",
             "bodies:"]
    lines += [f"  b{i}: {{mass: m, inertia: m*L**2/12, com: [L/2, 0]}}" for i in range(n)]
    lines.append("joints:")
    springs = []
    for i in range(n):
        parent, at = ("ground", "[0, 0]") if i == 0 else (f"b{i - 1}", "[L, 0]")
        head = f"  j{i}: {{parent: {parent}, child: b{i}, at: {at}, "
        if i % 4 == 3:
            lines.append(head + f"type: prismatic, axis: [1, 0], coordinate: s{i}}}")
            springs.append(f"  - joint_spring: {{joint: j{i}, k: k, rest: 0}}")
        else:
            lines.append(head + f"type: revolute, coordinate: q{i}}}")
    lines += ["loads:", *springs] if springs else []
    initial = ", ".join(f"q{i}: 0.1" for i in range(n) if i % 4 != 3)
    lines += ["outputs: {energy: true}", "simulation:", f"  initial: {{{initial}}}"]
    return "\n".join(lines) + "\n"


def program_size(n: int) -> int:
    return derive(validate_text(mixed_chain(n).encode(), f"mixed{n}.yaml")).dynamics.size


def test_program_grows_linearly_with_the_bodies() -> None:
    sizes = {n: program_size(n) for n in (8, 16, 32)}
    per_body = {n: size / n for n, size in sizes.items()}
    assert per_body[32] <= 1.1 * per_body[16] <= 1.21 * per_body[8], sizes


def test_32_body_chain_conserves_energy(tmp_path: Path) -> None:
    path = tmp_path / "mixed32.yaml"
    path.write_text(mixed_chain(32))
    model = nemc.compile(path)
    assert len(model.coordinate_names) == 32
    res = model.simulate((0.0, 1.0), method="DOP853", rtol=1e-10, atol=1e-10)
    assert res.success, res.message
    total = res.outputs["energy.total"]
    scale = max(abs(total[0]), float(np.max(res.outputs["energy.kinetic"])))
    drift = float(np.max(np.abs(total - total[0]))) / scale
    assert drift < 1e-8, drift
    assert float(np.max(res.outputs["energy.kinetic"])) > 1.0  # it moved


@pytest.mark.parametrize("n", [1, 2, 5])
def test_mixed_chain_matches_reference(n: int, tmp_path: Path) -> None:
    """The test's own chain against the independent Lagrangian reference."""
    from reference import ReferenceModel

    from nemc.front.validate import load_mechanism

    path = tmp_path / f"mixed{n}.yaml"
    path.write_text(mixed_chain(n))
    model, ref = nemc.compile(path), ReferenceModel(load_mechanism(str(path)))
    rng = np.random.default_rng(n)
    for _ in range(3):
        y = rng.uniform(-1, 1, model.n_state)
        expected = ref.rhs(0.0, y)
        assert np.linalg.norm(model.rhs(0.0, y) - expected) <= 1e-10 * np.linalg.norm(expected)
