"""Model.rhs's C call (the build's _rhs_call extension, templates/rhs_call.c.tmpl): the bits of
the cffi call, None for everything it does not take as it is (Model.rhs then converts, refuses
or raises the failure the checked way), and no reference kept or lost. What it computes is
checked against the independent Lagrangian reference by tests/test_dynamics.py, whose
model.rhs calls go through it. Its speed is measured by benchmarks/overhead.py, never asserted
here."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from reference import relative_chain_yaml

import nemc
from nemc.build.builder import CFLAGS, call_suffix, compiler, package_c_flags
from nemc.runtime.compiled import no_fast_call
from nemc.runtime.model import IntegrationFailure, Model

ROOT = Path(__file__).resolve().parent.parent
DOUBLE = ROOT / "examples" / "double_pendulum.yaml"  # state [q1, dot(q1), q2, dot(q2)]


@pytest.fixture(scope="module")
def model() -> Model:
    return nemc.compile(DOUBLE)


def fast_call(model: Model):
    """Model.rhs's C call at the default parameters, through the build's _rhs_call."""
    return model.compiled.fast_rhs(model.parameter_vector())


def cffi_call(model: Model):
    """Model.rhs's other way at the default parameters: cffi's, its arguments checked."""
    return model.compiled.checked_rhs(model.parameter_vector())


def test_the_c_call_gives_the_bits_of_the_cffi_call(model: Model) -> None:
    fast = fast_call(model)
    assert type(fast).__name__ == "RhsCall"
    rng = np.random.default_rng(19)
    for _ in range(50):
        t, y = float(rng.uniform(-10, 10)), rng.uniform(-4, 4, model.n_state)
        dy = fast(t, y)
        np.testing.assert_array_equal(dy, cffi_call(model)(t, y))  # cffi's
        np.testing.assert_array_equal(model.rhs(t, y), dy)
        assert dy.dtype == np.float64 and dy.shape == (model.n_state,) and dy.flags.writeable
    y = np.array([0.3, -0.2, 1.1, 0.5])
    assert fast(0.0, y) is not fast(0.0, y)  # a new array each call


def test_a_long_model_without_the_gil_gives_the_same_bits() -> None:
    """From 32 states on the call releases the GIL around the C (RHS_CALL_RELEASES_GIL)."""
    chain = nemc.compile(text=relative_chain_yaml(16, "chain16_call", mass=1.3, length=0.7))
    assert chain.n_state == 32
    fast = fast_call(chain)
    rng = np.random.default_rng(32)
    for _ in range(5):
        y = rng.uniform(-2, 2, chain.n_state)
        np.testing.assert_array_equal(fast(0.3, y), cffi_call(chain)(0.3, y))


def test_what_it_does_not_take_is_left_to_the_checked_way(model: Model) -> None:
    fast = fast_call(model)
    y = np.array([0.3, -0.2, 1.1, 0.5])
    assert fast(0.0, y) is not None
    np.testing.assert_array_equal(fast(np.float64(0.5), y), fast(0.5, y))  # a float subclass
    others = [(0, y), (np.float32(0.0), y), (math.nan, y), (math.inf, y), (0.0, list(y)),
              (0.0, y.astype(np.float32)), (0.0, y.astype(">f8")), (0.0, np.repeat(y, 2)[::2]),
              (0.0, y[:3]), (0.0, y.reshape(2, 2)), (0.0, np.zeros(4, dtype=complex)),
              (0.0, y.view(np.recarray))]
    for t, state in others:
        assert fast(t, state) is None, (t, state)
    assert fast(0.0) is None and fast(0.0, y, y) is None and fast(t=0.0, y=y) is None
    # the model's status is not NEMC_OK: None, and Model.rhs raises the failure it names
    assert fast(0.0, np.array([math.nan, 0.0, 0.1, 0.0])) is None
    with pytest.raises(IntegrationFailure, match="the state is not finite"):
        model.rhs(0.0, np.array([math.nan, 0.0, 0.1, 0.0]))
    for t, state in [(np.float64(0.5), y), (0.5, list(y)), (0.5, y.astype(">f8")),
                     (0.5, np.repeat(y, 2)[::2])]:
        np.testing.assert_array_equal(model.rhs(t, state), fast(0.5, y))


def test_it_keeps_no_reference_and_loses_none(model: Model) -> None:
    fast = fast_call(model)
    y, bad, strided = np.array([0.3, -0.2, 1.1, 0.5]), np.full(4, math.nan), np.zeros(8)[::2]
    t, p = 0.25, model.parameter_vector()
    before = [sys.getrefcount(x) for x in (y, bad, strided, t, p)]
    for _ in range(1000):
        fast(t, y)
        fast(t, bad)
        fast(t, strided)
    assert [sys.getrefcount(x) for x in (y, bad, strided, t, p)] == before


def test_the_parameters_must_be_the_models(model: Model) -> None:
    c = model.compiled
    make, defaults = c.rhs_call.make, model.parameter_vector()
    address = int(c.ffi.cast("uintptr_t", c.ffi.addressof(c.lib, c.prefix + "rhs")))
    with pytest.raises(ValueError, match="N_PARAM"):
        make(address, np.zeros(len(defaults) + 1), np.ndarray, np.empty)
    with pytest.raises(ValueError, match="N_PARAM"):
        make(address, defaults.astype(np.float32), np.ndarray, np.empty)


def test_without_it_rhs_goes_through_cffi_with_the_same_bits(model: Model) -> None:
    """A package whose _rhs_call cannot be imported (its stable-ABI build in CPython 3.10)."""
    plain = Model(model.metadata, model.compiled.ffi, model.compiled.lib, rhs_call=None)
    y = np.array([0.3, -0.2, 1.1, 0.5])
    np.testing.assert_array_equal(plain.rhs(0.7, y), model.rhs(0.7, y))
    assert fast_call(plain) is no_fast_call
    with pytest.raises(IntegrationFailure, match="the state is not finite"):
        plain.rhs(0.0, np.array([math.nan, 0.0, 0.1, 0.0]))


def test_the_build_has_it_for_this_python(model: Model) -> None:
    folder = Path(model.compiled.rhs_call.__file__).parent
    assert Path(model.compiled.rhs_call.__file__).name == "_rhs_call" + call_suffix()
    assert (folder / "_rhs_call.c").is_file()  # its readable source, beside it
    if sys.version_info >= (3, 11):
        assert call_suffix() == ".abi3.so"


def test_its_c_compiles_warning_free(model: Model, tmp_path: Path) -> None:
    source = Path(model.compiled.rhs_call.__file__).with_name("_rhs_call.c")
    done = subprocess.run(
        [*compiler(), *CFLAGS, *package_c_flags(source), "-Werror", "-c", str(source), "-o",
         str(tmp_path / "call.o")],
        capture_output=True, text=True)
    assert done.returncode == 0 and "warning" not in done.stderr, done.stderr
