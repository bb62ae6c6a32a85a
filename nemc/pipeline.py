"""The compiler, read top to bottom: read, (cache hit? load) parse + validate, derive,
optimize, emit, build, load. Each stage is a module returning a plain value.

Only a cache miss imports the symbolic stages (and so sympy): a cached build loads in
milliseconds.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .build.builder import Source, build_key, cached_package, fma_available, is_intact, lane_count
from .runtime.load import load_package
from .runtime.model import Model
from .runtime.runs import Progress

if TYPE_CHECKING:  # a cache hit imports no sympy
    from .front.mechanism import Mechanism


@dataclass(frozen=True)
class Recipe:
    """What builds a model again in another process (a Dask worker, `nemc.sweep`): the
    mechanism's bytes and the options it was compiled with, and the C parts that gave."""

    source: Source
    jacobian: bool | None = None
    taylor: bool | None = None
    energy: bool = False
    chunk_steps: int | None = None
    parts: tuple[str, ...] = ()
    mass_matrix: bool = False
    linearization: bool = False
    sensitivities: bool = False


@dataclass
class Compiled:
    """A compiled model, where its package lives, and the time each stage took (seconds)."""

    model: Model
    package: Path
    cached: bool
    timings: dict[str, float] = field(default_factory=dict)


@contextmanager
def timed(timings: dict[str, float], stage: str, progress: Progress | None = None
          ) -> Iterator[None]:
    if progress is not None:  # a long build shows its stage on a terminal
        progress.update(note=stage)
    start = time.perf_counter()
    yield
    timings[stage] = time.perf_counter() - start


def read_source(path: str | Path) -> Source:
    from .errors import InputError, Problem
    from .front.reading import read_file

    try:
        return Source(str(path), read_file(path))
    except OSError as error:
        problem = Problem(str(path), 0, "", f"cannot read the file: {error.strerror}")
        raise InputError([problem]) from None


def compile_mechanism(
    path: str | Path, jacobian: bool | None = None, *, energy: bool = False,
    taylor: bool | None = None, chunk_steps: int | None = None, mass_matrix: bool = False,
    linearization: bool = False, sensitivities: bool = False,
) -> Compiled:
    """Build the mechanism in PATH (or load its cached build) and load it.

    jacobian: True generates the analytic Jacobian; None (default) generates it only when the
    scene's method is implicit, and later on the model's first need of it.
    taylor: the same for nemc.Taylor's coefficient code (scene method nemc.Taylor).
    mass_matrix: True generates M^-1 (Model.mass_matrix) now; False, on its first call.
    linearization: True generates A, B, C, D's code (Model.linearize) now; False, on its first
    call.
    sensitivities: True generates the variational equations' code (simulate(...,
    sensitivities=[...])) now; False, on their first run.
    energy: True adds the energy outputs when the YAML does not request them (`nemc stress`).
    chunk_steps: the most steps of a program emitted as one C function (None:
    nemc.emit.parts.CHUNK_STEPS); part of the build key."""
    return compile_source(read_source(path), jacobian, energy=energy, taylor=taylor,
                          chunk_steps=chunk_steps, mass_matrix=mass_matrix,
                          linearization=linearization, sensitivities=sensitivities)


def compile_source(
    source: Source, jacobian: bool | None, *, energy: bool = False,
    taylor: bool | None = None, chunk_steps: int | None = None, lanes: int = 0,
    mass_matrix: bool = False, linearization: bool = False, sensitivities: bool = False,
) -> Compiled:
    """lanes: also nemc.Taylor's ensembles in SIMD lanes, this many per batch (with taylor: the
    part "lanes"; build.lane_count() gives this machine's); 0: none."""
    timings: dict[str, float] = {}
    options: dict = {"jacobian": "auto" if jacobian is None else bool(jacobian)}
    if energy:
        options["energy"] = True
    if taylor is not None:
        options["taylor"] = bool(taylor)
    if lanes:
        options["lanes"] = lanes
    if mass_matrix:
        options["mass_matrix"] = True
    if linearization:
        options["linearization"] = True
    if sensitivities:
        options["sensitivities"] = True
    if chunk_steps is not None:
        options["chunk_steps"] = chunk_steps
    key = build_key(source, options)
    for attempt in range(2):  # a second look if a concurrent process moved the entry meanwhile
        with timed(timings, "lookup"):
            package = cached_package(key)
        cached = package is not None
        if package is None:
            package = generate_and_build(source, key, jacobian, timings, energy, taylor,
                                         chunk_steps, lanes, mass_matrix, linearization,
                                         sensitivities)
        try:
            with timed(timings, "load"):
                model = load_package(package)
            break
        except ImportError:
            if attempt or is_intact(package, key):
                raise

    def compile_parts(parts: frozenset[str]) -> Model:
        """This mechanism built with these optional parts (Model.compiled_with)."""
        return compile_source(source, "jacobian" in parts, energy=energy,
                              taylor=bool(parts & {"taylor", "lanes"}), chunk_steps=chunk_steps,
                              lanes=lane_count() if "lanes" in parts else 0,
                              mass_matrix="mass_matrix" in parts,
                              linearization="linearization" in parts,
                              sensitivities="sensitivities" in parts).model

    def export_fmu(target: Path, fmi: int, kind: str) -> Path:
        """This mechanism as an FMU (Model.export_fmu): its build with the Jacobian (nemc.Radau
        in co-simulation) and the linearization (directional derivatives), what the runtime
        knows of it (runtime/fmu.py), then the wrapper, gcc and the archive (build/fmu.py)."""
        from .build.fmu import write_fmu
        from .runtime.fmu import fmu_facts

        built = compile_source(source, True, energy=energy, taylor=taylor,
                               chunk_steps=chunk_steps, linearization=True)
        return write_fmu(built.package, target, fmi, kind, fmu_facts(built.model))

    def make_regressor(linear: tuple[str, ...]) -> Any:
        """The regressor's code (Model.regressor): validated, derived (derive/regressor.py)
        and made numpy functions (emit/regressor_code.py)."""
        from .derive.regressor import regressor_equations
        from .emit.regressor_code import regressor_code
        from .front.validate import validate_text

        return regressor_code(regressor_equations(validate_text(source.data, source.path),
                                                  linear))

    model.fresh_build_seconds = None if cached else sum(timings.values())
    model.regressor_maker = make_regressor
    model.part_compiler = compile_parts
    model.fmu_exporter = export_fmu
    model.system_drivers = system_drivers
    model.recipe = Recipe(source, jacobian, taylor, energy, chunk_steps,
                          tuple(model.metadata["generated"]), mass_matrix, linearization,
                          sensitivities)
    return Compiled(model, package, cached, timings)


def system_drivers(n_state: int) -> Any:
    """The native integrators for systems of N_STATE states (a model's sensitivity system):
    built once per size into the cache (nemc/build/systems.py), then loaded."""
    from .build.systems import system_extension
    from .runtime.load import load_system

    return load_system(system_extension(n_state))


def generate_and_build(
    source: Source, key: str, jacobian: bool | None, timings: dict[str, float],
    energy: bool = False, taylor: bool | None = None, chunk_steps: int | None = None,
    lanes: int = 0, mass_matrix: bool = False, linearization: bool = False,
    sensitivities: bool = False,
) -> Path:
    from .build.builder import build
    from .derive.assembly import check_assembly
    from .derive.equations import (
        derive,
        taylor_cost_ratio,
        with_jacobian,
        with_linearization,
        with_mass_matrix,
        with_sensitivities,
        with_taylor,
    )
    from .emit.emitted import emit
    from .emit.optimize import optimize_equations
    from .front.validate import validate_text
    from .vocabulary import IMPLICIT_METHODS, auto_builds_taylor, auto_keeps_taylor

    progress = Progress(f"nemc: building {source.path}", delay=0.0)
    try:
        with timed(timings, "validate", progress):
            mechanism = validate_text(source.data, source.path)
            check_assembly(mechanism)  # closed loops: refused here if they cannot close
            if energy:
                mechanism = with_energy_output(mechanism)
        method = mechanism.simulation.method
        with timed(timings, "derive", progress):
            equations = derive(mechanism)
            if jacobian or (jacobian is None and method in IMPLICIT_METHODS):
                equations = with_jacobian(equations)
            if mass_matrix:
                equations = with_mass_matrix(equations)
            if linearization:
                equations = with_linearization(equations)
            if sensitivities:
                equations = with_sensitivities(equations)
            if taylor or (taylor is None and method == "nemc.Taylor"):
                equations = with_taylor(equations)
            elif taylor is None and auto_builds_taylor(method, equations.n):
                for_auto = with_taylor(equations)  # kept where auto would take it (or refused)
                if for_auto.taylor is None or auto_keeps_taylor(taylor_cost_ratio(for_auto)):
                    equations = for_auto
        with timed(timings, "optimize", progress):
            block = optimize_equations(equations)
        with timed(timings, "emit", progress), number_range(source):
            code = emit(equations, block, chunk_steps, lanes=lanes, fma=fma_available())
        with timed(timings, "build", progress):
            return build(code, key)
    finally:
        progress.close()


@contextmanager
def number_range(source: Source) -> Iterator[None]:
    """A number no double holds, made by folding the file's constants, is bad input (exit 2)."""
    from .emit.c_text import NumberOutOfRange
    from .errors import InputError, Problem

    try:
        yield
    except NumberOutOfRange as error:
        raise InputError([Problem(source.path, 1, "", str(error))]) from None


def with_energy_output(mechanism: Mechanism) -> Mechanism:
    """The mechanism with the energy outputs requested, whatever its YAML asks for."""
    outputs = dataclasses.replace(mechanism.outputs, energy=True)
    return dataclasses.replace(mechanism, outputs=outputs)
