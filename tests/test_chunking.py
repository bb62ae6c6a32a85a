"""Long programs emitted in parts (nemc/emit.py, CHUNK_STEPS): forced on small models, the parts
must give bit-for-bit the numbers and statuses of the one-body code, and compile warning-free."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from reference import random_mechanism_yaml

from nemc.pipeline import Compiled, compile_mechanism

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
PARTS = ("accelerations_part", "jacobian_primal_part", "jacobian_tangent_part",
         "inverse_mass_times_part")


def build(path: Path, cache: Path, chunk_steps: int | None) -> Compiled:
    """The model with the Jacobian, in parts of chunk_steps steps (None: the default)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("NEMC_CACHE", str(cache))
        return compile_mechanism(path, True, chunk_steps=chunk_steps)


@pytest.fixture(scope="module", params=["double_pendulum", "tree6"])
def pair(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
         ) -> tuple[Compiled, Compiled]:
    """The same model built as one body per function and in parts of at most 7 steps."""
    folder = tmp_path_factory.mktemp("chunking")
    if request.param == "tree6":
        path = folder / "tree6.yaml"
        path.write_text(random_mechanism_yaml(np.random.default_rng(7), 6, True, "tree6"))
    else:
        path = EXAMPLES / f"{request.param}.yaml"
    whole, parts = build(path, folder, None), build(path, folder, 7)
    assert whole.package != parts.package  # two builds, two extensions loaded
    return whole, parts


def c_source(compiled: Compiled) -> str:
    return next(compiled.package.glob("*.c")).read_text()


def evaluate(compiled: Compiled, y: np.ndarray, p: np.ndarray) -> dict[str, tuple[int, list]]:
    """Status and values of the C rhs, jacobian and inverse mass matrix, called directly (the
    Model refuses parameters that make the mass matrix singular before C sees them)."""
    model = compiled.model
    n, n_coord, buffer = model.n_state, len(model.coordinate_names), model._buffer
    y, p = np.ascontiguousarray(y, dtype=float), np.ascontiguousarray(p, dtype=float)
    dy, jac, minv = np.zeros(n), np.zeros((n, n)), np.zeros((n_coord, n_coord))
    return {
        "rhs": (model._c["rhs"](0.7, buffer(y), buffer(p), buffer(dy)), dy.tolist()),
        "jacobian": (model._c["jacobian"](0.7, buffer(y), buffer(p), buffer(jac)), jac.tolist()),
        "inverse_mass_matrix": (
            model._c["inverse_mass_matrix"](0.0, buffer(y), buffer(p), buffer(minv)),
            minv.tolist()),
    }


def test_parts_are_emitted_only_when_forced(pair: tuple[Compiled, Compiled]) -> None:
    whole, parts = pair
    assert not any(name in c_source(whole) for name in PARTS)
    text = c_source(parts)
    assert all(f"{name}2(" in text for name in PARTS)
    assert "intermediates passed between the parts" in text


def test_parts_give_the_same_numbers(pair: tuple[Compiled, Compiled]) -> None:
    whole, parts = pair
    rng = np.random.default_rng(11)
    p = whole.model.parameter_vector()
    for _ in range(4):
        y = rng.uniform(-1.5, 1.5, whole.model.n_state)
        expected = evaluate(whole, y, p)
        assert all(status == 0 for status, _ in expected.values())
        assert evaluate(parts, y, p) == expected  # bit for bit: the same operations


def test_parts_return_the_same_status_at_singular_states(pair: tuple[Compiled, Compiled]) -> None:
    whole, parts = pair
    p = whole.model.parameter_vector()
    y = np.full(whole.model.n_state, 0.3)
    y[0::2] = np.nan  # coordinates: no finite articulated inertia
    singular = [(y, p)]
    if whole.model.name == "double_pendulum":  # its tip link without mass (and inertia)
        massless = p.copy()
        massless[whole.model.parameter_names.index("m2")] = 0.0
        singular.append((np.full(whole.model.n_state, 0.3), massless))
    for state, parameters in singular:
        statuses = {key: status for key, (status, _) in evaluate(whole, state, parameters).items()}
        assert all(status > 0 for status in statuses.values())
        assert {key: status for key, (status, _) in evaluate(parts, state, parameters).items()
                } == statuses


def test_parts_compile_warning_free(pair: tuple[Compiled, Compiled], tmp_path: Path) -> None:
    c_file = next(pair[1].package.glob("*.c"))
    done = subprocess.run(
        ["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-c", str(c_file),
         "-o", str(tmp_path / "parts.o")],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
