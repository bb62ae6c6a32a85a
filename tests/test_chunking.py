"""Long programs emitted in parts (emit.parts.CHUNK_STEPS): forced on small models, the parts
must give bit-for-bit the numbers and statuses of the one-body code, and compile warning-free."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from reference import random_mechanism_yaml

from nemc.build.builder import package_c_flags
from nemc.pipeline import Compiled, compile_mechanism

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
PARTS = ("accelerations_part", "jacobian_primal_part", "jacobian_tangent_part",
         "inverse_mass_times_part")


def build(path: Path, cache: Path, chunk_steps: int | None) -> Compiled:
    """The model with the Jacobian and the mass matrix, in parts of chunk_steps steps (None:
    the default)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("NEMC_CACHE", str(cache))
        return compile_mechanism(path, True, chunk_steps=chunk_steps, mass_matrix=True)


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
    return (compiled.package / f"{compiled.model.name}.c").read_text()


def evaluate(compiled: Compiled, y: np.ndarray, p: np.ndarray) -> dict[str, tuple[int, list]]:
    """Status and values of the C rhs, jacobian and inverse mass matrix, called directly (the
    Model refuses parameters that make the mass matrix singular before C sees them)."""
    model = compiled.model
    n, n_coord, buffer = model.n_state, len(model.coordinate_names), model.compiled.buffer
    c = model.compiled.functions  # the build's C entry points
    y, p = np.ascontiguousarray(y, dtype=float), np.ascontiguousarray(p, dtype=float)
    dy, jac, minv = np.zeros(n), np.zeros((n, n)), np.zeros((n_coord, n_coord))
    return {
        "rhs": (c["rhs"](0.7, buffer(y), buffer(p), buffer(dy)), dy.tolist()),
        "jacobian": (c["jacobian"](0.7, buffer(y), buffer(p), buffer(jac)), jac.tolist()),
        "inverse_mass_matrix": (
            c["inverse_mass_matrix"](0.0, buffer(y), buffer(p), buffer(minv)),
            minv.tolist()),
    }


def test_parts_are_emitted_only_when_forced(pair: tuple[Compiled, Compiled]) -> None:
    whole, parts = pair
    assert not any(name in c_source(whole) for name in PARTS)
    text = c_source(parts)
    assert all(f"{name}2(" in text for name in PARTS if name != "accelerations_part")
    assert "intermediates passed between the parts" in text
    # with the Jacobian, the accelerations run its primal's parts (emit.jacobian_c.shares_primal)
    assert "accelerations_part" not in text
    accelerations = text[text.index("static int accelerations("):]
    assert "jacobian_primal_part1(" in accelerations[: accelerations.index("\n}")]


def test_without_the_jacobian_the_accelerations_have_parts_of_their_own(tmp_path: Path) -> None:
    path = EXAMPLES / "double_pendulum.yaml"
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("NEMC_CACHE", str(tmp_path))
        whole = compile_mechanism(path, False)
        parts = compile_mechanism(path, False, chunk_steps=7)
    text = c_source(parts)
    assert "accelerations_part2(" in text and "jacobian_primal_part" not in text
    rng = np.random.default_rng(5)
    for _ in range(4):
        y = rng.uniform(-1.5, 1.5, whole.model.n_state)
        assert parts.model.rhs(0.3, y).tolist() == whole.model.rhs(0.3, y).tolist()


def assert_same_numbers(whole: Compiled, other: Compiled, rng: np.random.Generator) -> None:
    """Every compiled function of OTHER gives WHOLE's numbers, bit for bit (the same
    operations), at 4 random states."""
    p = whole.model.parameter_vector()
    for _ in range(4):
        y = rng.uniform(-1.5, 1.5, whole.model.n_state)
        expected = evaluate(whole, y, p)
        assert all(status == 0 for status, _ in expected.values())
        assert evaluate(other, y, p) == expected


def test_parts_give_the_same_numbers(pair: tuple[Compiled, Compiled]) -> None:
    assert_same_numbers(*pair, np.random.default_rng(11))


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
    c_file = pair[1].package / f"{pair[1].model.name}.c"
    done = subprocess.run(
        ["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-c", str(c_file),
         "-o", str(tmp_path / "parts.o")],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr


# ---- very long programs in unit files (nemc/emit/parts.py, issue 19): forced on small models -


def model_path(name: str, folder: Path) -> Path:
    if name == "tree6":
        path = folder / "tree6.yaml"
        path.write_text(random_mechanism_yaml(np.random.default_rng(7), 6, True, "tree6"))
        return path
    return EXAMPLES / f"{name}.yaml"


@pytest.fixture(scope="module", params=["double_pendulum", "tree6"])
def units(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
          ) -> tuple[Compiled, Compiled]:
    """The model in one file, and in parts of 7 steps spread over unit files of about 30 steps
    (its own cache: the build key does not see the patched sizes)."""
    folder = tmp_path_factory.mktemp("units")
    path = model_path(request.param, folder)
    whole = build(path, folder / "whole", None)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("nemc.emit.parts.UNIT_STEPS", 20)
        patch.setattr("nemc.emit.parts.UNIT_FILE_STEPS", 30)
        split = build(path, folder / "split", 7)
    return whole, split


def test_unit_files_hold_the_parts(units: tuple[Compiled, Compiled]) -> None:
    whole, split = units
    name = split.model.name
    files = sorted(split.package.glob(f"{name}_unit*.c"))
    assert len(files) >= 2 and not list(whole.package.glob(f"{name}_unit*.c"))
    main = (split.package / f"{name}.c").read_text()
    assert "in a unit file of its own" in main and "static void accelerations_part" not in main
    defined = "".join(path.read_text() for path in files)
    # the accelerations run the Jacobian's primal parts (emit.jacobian_c.shares_primal)
    assert f"\nvoid {name}_jacobian_primal_part1(" in defined or \
        f"\nint {name}_jacobian_primal_part1(" in defined


def test_unit_files_give_the_same_numbers(units: tuple[Compiled, Compiled]) -> None:
    whole, split = units
    rng = np.random.default_rng(12)
    assert_same_numbers(whole, split, rng)
    y = rng.uniform(-1.5, 1.5, (whole.model.n_state, 3))
    expected = whole.model.positions(0.2, y)
    found = split.model.positions(0.2, y)
    assert found.keys() == expected.keys()
    assert all(np.array_equal(found[name], expected[name]) for name in expected)


def test_unit_files_compile_warning_free(units: tuple[Compiled, Compiled], tmp_path: Path
                                         ) -> None:
    for c_file in sorted(units[1].package.glob("*.c")):
        for level in ("-O1", "-O2"):  # unit files are built at -O1 (build.UNIT_CFLAGS)
            done = subprocess.run(
                ["gcc", "-std=c99", level, "-Wall", "-Wextra", "-Werror",
                 *package_c_flags(c_file), "-c", str(c_file), "-o", str(tmp_path / "unit.o")],
                capture_output=True, text=True,
            )
            assert done.returncode == 0, (c_file.name, level, done.stderr)
