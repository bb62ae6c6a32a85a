"""The standalone package: the model's whole API at module level, and a native extension for
CPython's stable ABI that loads in another Python version."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.build.builder import export
from nemc.pipeline import compile_mechanism
from nemc.runtime.model import Model

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
OTHER_PYTHON = ROOT / ".venv-abi3" / "bin" / "python"  # set up by `make test`


@pytest.fixture(scope="module")
def package(tmp_path_factory: pytest.TempPathFactory) -> Path:
    compiled = compile_mechanism(EXAMPLES / "double_pendulum.yaml")
    return export(compiled.package, tmp_path_factory.mktemp("exported"), "double_pendulum")


def run_python(python: str | Path, folder: Path, code: str) -> dict:
    """Run CODE in a fresh interpreter with the package's folder on sys.path; its JSON out."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    out = subprocess.run([str(python), "-c", f"import sys; sys.path.insert(0, {str(folder)!r})\n"
                          + code], capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_the_whole_api_is_at_module_level(package: Path) -> None:
    # set by nemc's pipeline, absent in a package
    hooks = ("part_compiler", "recipe", "fmu_exporter", "system_drivers", "fresh_build_seconds",
             "regressor_maker")
    public = sorted(name for name in dir(nemc.compile(EXAMPLES / "double_pendulum.yaml"))
                    if not name.startswith("_") and name not in hooks)
    code = ("import json, double_pendulum as m\n"
            f"print(json.dumps([n for n in {public!r} if not hasattr(m, n)]))")
    assert run_python(sys.executable, package.parent, code) == []
    code = ("import json, double_pendulum as m\n"
            "runs = m.simulate_many([[0.1, 0, 0.2, 0], [0.3, 0, -0.1, 0]], threads=1)\n"
            "print(json.dumps({'y': runs.y[:, :, -1].tolist(), 'all': m.__all__}))")
    found = run_python(sys.executable, package.parent, code)
    model = nemc.compile(EXAMPLES / "double_pendulum.yaml")
    expected = model.simulate_many(np.array([[0.1, 0, 0.2, 0], [0.3, 0, -0.1, 0]]), threads=1)
    np.testing.assert_allclose(found["y"], expected.y[:, :, -1], rtol=1e-15)
    assert {"simulate_many", "positions", "rhs_many", "mass_matrix"} <= set(found["all"])


def test_plotting_in_a_package_without_nemc_says_what_it_needs(package: Path) -> None:
    code = ("import json, sys\n"
            "sys.modules['nemc'] = None  # as where nemc is not installed\n"
            "import double_pendulum as m\n"
            "res = m.simulate(t_span=(0, 0.1))\n"
            "try:\n    res.plot()\nexcept ImportError as e:\n    print(json.dumps(str(e)))")
    message = run_python(sys.executable, package.parent, code)
    assert message.startswith("plot() needs nemc and matplotlib installed")


def test_the_extension_is_built_for_the_stable_abi(package: Path) -> None:
    """Named for the stable ABI, and compiled with Py_LIMITED_API for 3.10 (the wrapper cffi
    writes uses only the limited API; loading it elsewhere is the test below)."""
    from nemc.build.builder import limited_api_flags

    assert [p.name for p in package.glob("_native*")] == ["_native.abi3.so"]
    assert limited_api_flags() == ["-DPy_LIMITED_API=0x030A0000"]


@pytest.mark.skipif(not OTHER_PYTHON.exists(), reason="no other CPython set up (make test "
                    "does it when one is installed)")
def test_the_package_loads_in_another_python_version(package: Path) -> None:
    code = ("import json, sys, double_pendulum as m\n"
            "res = m.simulate(method='nemc.DOP853', t_eval=[0, 2.5, 5])\n"
            "rhs = m.rhs(0.0, [0.1, 0.2, 0.3, 0.4]).tolist()\n"
            "fast = m.model.compiled.fast_rhs(m.parameter_vector())\n"
            "print(json.dumps({'version': list(sys.version_info[:2]), 'so': m._native.__file__,"
            " 'rhs': rhs, 'y': res.y.tolist(), 'fast': type(fast).__name__,"
            " 'fast_rhs': m.rhs(0.0, m.model.state_vector([0.1, 0.2, 0.3, 0.4])).tolist()}))")
    found = run_python(OTHER_PYTHON, package.parent, code)
    assert tuple(found["version"]) != sys.version_info[:2]
    assert found["so"].endswith("_native.abi3.so")
    # Model.rhs's extension too, built for the stable ABI of 3.11 on (in 3.10: cffi alone)
    assert found["fast"] == ("RhsCall" if tuple(found["version"]) >= (3, 11) else "function")
    assert found["fast_rhs"] == found["rhs"]
    model: Model = nemc.compile(EXAMPLES / "double_pendulum.yaml")
    np.testing.assert_allclose(found["rhs"], model.rhs(0.0, [0.1, 0.2, 0.3, 0.4]), rtol=1e-15)
    mine = model.simulate(method="nemc.DOP853", t_eval=[0, 2.5, 5]).y
    np.testing.assert_allclose(found["y"], mine, rtol=1e-13, atol=1e-13)
