"""The compiler, read top to bottom: read, (cache hit? load) parse + validate, derive,
optimize, emit, build, load. Each stage is a module returning a plain value.

Only a cache miss imports the symbolic stages (and so sympy): a cached build loads in
milliseconds.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from .build import Source, build_key, cached_package
from .load import load_package
from .runtime import Model


@dataclass
class Compiled:
    """A compiled model, where its package lives, and the time each stage took (seconds)."""

    model: Model
    package: Path
    cached: bool
    timings: dict[str, float] = field(default_factory=dict)
    generated: list[str] = field(default_factory=list)


@contextmanager
def timed(timings: dict[str, float], stage: str) -> Iterator[None]:
    start = time.perf_counter()
    yield
    timings[stage] = time.perf_counter() - start


def read_source(path: str | Path) -> Source:
    from .errors import InputError, Problem

    try:
        return Source(str(path), Path(path).read_bytes())
    except OSError as error:
        problem = Problem(str(path), 0, "", f"cannot read the file: {error.strerror}")
        raise InputError([problem]) from None


def compile_mechanism(path: str | Path) -> Compiled:
    """Build the mechanism in PATH (or load its cached build) and load it."""
    timings: dict[str, float] = {}
    source = read_source(path)
    key = build_key(source)
    with timed(timings, "lookup"):
        package = cached_package(key)
    cached, generated = package is not None, []
    if package is None:
        package, generated = generate_and_build(source, key, timings)
    with timed(timings, "load"):
        model = load_package(package)
    return Compiled(model, package, cached, timings, generated)


def generate_and_build(source: Source, key: str, timings: dict[str, float]) -> tuple[Path, list]:
    from .build import build
    from .derive import derive
    from .emit import emit
    from .optimize import optimize_equations
    from .validate import validate_text

    with timed(timings, "validate"):
        mechanism = validate_text(source.data, source.path)
    with timed(timings, "derive"):
        equations = derive(mechanism)
    with timed(timings, "optimize"):
        block = optimize_equations(equations)
    with timed(timings, "emit"):
        code = emit(equations, block)
    with timed(timings, "build"):
        package = build(code, key)
    return package, code.metadata["generated"]

