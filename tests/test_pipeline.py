"""The compiler's plumbing: cache, standalone packages, generated C, CLI, runtime checks."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import nemc
from nemc.build import builder as build
from nemc.build.builder import package_c_flags
from nemc.pipeline import compile_mechanism
from nemc.runtime.model import ModelError
from nemc.tools.cli import main

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
DOUBLE = EXAMPLES / "double_pendulum.yaml"
COMPOUND = EXAMPLES / "compound_pendulum.yaml"


@pytest.fixture(autouse=True)
def cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path_factory.getbasetemp() / "pipeline-cache"
    monkeypatch.setenv("NEMC_CACHE", str(folder))
    return folder


def run_python(code: str, env_cache: Path, cwd: Path = ROOT) -> str:
    env = {**os.environ, "NEMC_CACHE": str(env_cache)}
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_second_compile_is_cached_and_needs_no_sympy(cache: Path) -> None:
    first = compile_mechanism(DOUBLE)
    again = compile_mechanism(DOUBLE)
    assert again.cached and again.package == first.package
    out = run_python(
        f"""
        import sys
        from nemc.pipeline import compile_mechanism
        compiled = compile_mechanism({str(DOUBLE)!r})
        print(compiled.cached, "sympy" in sys.modules, compiled.model.state_names)
        """,
        cache,
    )
    cached, sympy_loaded, _ = out.split(" ", 2)
    assert (cached, sympy_loaded) == ("True", "False")


def test_exported_package_imports_alone_and_matches(tmp_path: Path, cache: Path) -> None:
    assert main(["compile", str(DOUBLE), "-o", str(tmp_path)]) == 0
    package = tmp_path / "double_pendulum"
    c_text = (package / "double_pendulum.c").read_text()
    assert str(DOUBLE) in c_text and nemc.compile(DOUBLE).metadata["source_hash"] in c_text
    y = [0.3, -0.2, 1.1, 0.4]
    out = run_python(
        f"""
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        import double_pendulum as dp
        print(repr(list(dp.rhs(0.0, {y}))), "sympy" in sys.modules, "nemc" in sys.modules)
        """,
        cache,
        cwd=tmp_path,
    )
    values, sympy_loaded, nemc_loaded = out.rsplit(" ", 2)
    assert (sympy_loaded, nemc_loaded.strip()) == ("False", "False")
    np.testing.assert_array_equal(eval(values), nemc.compile(DOUBLE).rhs(0.0, y))  # noqa: S307


@pytest.mark.parametrize("example", sorted(EXAMPLES.glob("*.yaml")), ids=lambda p: p.stem)
def test_generated_c_is_warning_free(example: Path, tmp_path: Path) -> None:
    compiled = compile_mechanism(example)
    package, name = compiled.package, compiled.model.name
    c_files = sorted(package.glob("*.c"))
    assert {c.name for c in c_files} >= {f"{name}.c", f"{name}_spectrum.c", "nemc_drivers.c"}
    for c_file in c_files:  # the drivers at the level the build compiles them (-O3)
        level = build.DRIVERS_CFLAGS[0] if c_file.name == "nemc_drivers.c" else "-O2"
        done = subprocess.run(
            ["gcc", "-std=c99", level, "-Wall", "-Wextra", "-Werror", *package_c_flags(c_file),
             "-c", str(c_file), "-o", str(tmp_path / "x.o")],
            capture_output=True, text=True,
        )
        assert done.returncode == 0, (c_file.name, done.stderr)
    text = (package / f"{name}.c").read_text()
    assert "exit(" not in text
    # small integer powers are products (pow remains only for the integrators' real exponents)
    assert not re.search(r"pow\([^()]*(\([^()]*\))?[^()]*,\s*[234](\.0)?\)", text)


def test_parameter_override_never_recompiles_and_derived_follow(cache: Path) -> None:
    model = nemc.compile(COMPOUND)
    builds = sorted(p.name for p in cache.iterdir())
    y = np.array([0.4, 0.0])
    base = model.outputs(0.0, y)["energy.potential"]
    heavier = model.outputs(0.0, y, params={"W": 24})["energy.potential"]
    assert heavier == pytest.approx(2 * base, rel=1e-14)  # m = W/g follows W
    assert sorted(p.name for p in cache.iterdir()) == builds
    with pytest.raises(ModelError, match="derived"):
        model.rhs(0.0, y, params={"m": 1.0})


@pytest.mark.parametrize(
    ("params", "y", "message"),
    [
        ({"W": float("nan")}, [0.1, 0.0], "finite"),
        ({"W": -1.0}, [0.1, 0.0], "bodies.rod.mass must be >= 0"),
        ({"Wx": 1.0}, [0.1, 0.0], "did you mean 'W'"),
        (None, [0.1, 0.0, 0.0], r"shape \(2,\)"),
        (None, [[0.1, 0.0]], r"shape \(2,\)"),
        (None, ["a", "b"], "real"),
    ],
)
def test_runtime_refuses_bad_arguments(params, y, message: str) -> None:
    model = nemc.compile(COMPOUND)
    with pytest.raises(ModelError, match=message):
        model.rhs(0.0, y, params=params)


def test_blow_up_is_reported_not_returned(tmp_path: Path) -> None:
    text = DOUBLE.read_text().replace(
        "outputs:", "loads:\n  - {torque: 1/(q1 + pi/4 - t), body: link1}\noutputs:"
    )
    path = tmp_path / "blowup.yaml"
    path.write_text(text)
    res = nemc.compile(path).simulate(t_span=(0, 1), t_eval=None)
    assert not res.success and res.status == -2  # equations failed (issue 51)
    assert "not finite" in res.message and "t=" in res.message


def test_cli_bad_input_exits_2_and_writes_nothing(tmp_path: Path, cache: Path, capsys) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(DOUBLE.read_text().replace("mass: m2", "mass: m2^2"))
    before = set(cache.iterdir()) if cache.exists() else set()
    out_dir = tmp_path / "out"
    assert main(["compile", str(bad), "-o", str(out_dir)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{bad}:") and "bodies.link2.mass" in err and "**" in err
    assert not out_dir.exists()
    assert (set(cache.iterdir()) if cache.exists() else set()) == before


def test_cli_simulate_prints_the_book_table(tmp_path: Path, capsys) -> None:
    csv_file = tmp_path / "table.csv"
    assert main(["simulate", str(COMPOUND), "--csv", str(csv_file)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].split()[:3] == ["[s]", "[rad]", "[rad/s]"]  # the header's units
    rows = [line.split() for line in lines[2:] if not line.startswith("#")]
    assert [float(r[0]) for r in rows] == [0.5 * k for k in range(21)]  # the book's 0:0.5:10
    assert float(rows[0][1]) == pytest.approx(np.pi / 4, rel=1e-5)
    assert len(csv_file.read_text().splitlines()) == 22


def test_concurrent_compiles_of_one_model_both_succeed(tmp_path: Path) -> None:
    cache = tmp_path / "fresh-cache"
    code = f"import nemc; print(nemc.compile({str(DOUBLE)!r}).rhs(0, [0.1, 0, 0.2, 0])[1])"
    env = {**os.environ, "NEMC_CACHE": str(cache)}
    procs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=env) for _ in range(3)]
    results = [p.communicate(timeout=180) for p in procs]
    assert all(p.returncode == 0 for p in procs), [r[1] for r in results]
    assert len({r[0] for r in results}) == 1
    builds = [p for p in cache.iterdir()
              if not p.name.startswith(".") and p.name != build.DRIVERS_FOLDER]
    assert len(builds) == 1 and not [p for p in cache.iterdir() if p.name.startswith(".tmp")]
    # the three compiled the same drivers' object, and one of them is kept
    assert len(list((cache / build.DRIVERS_FOLDER).iterdir())) == 1
