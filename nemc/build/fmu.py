"""A built package as an FMU (Model.export_fmu, `nemc export MECH.yaml --fmu OUT.fmu`): the
same generated C plus an FMI wrapper, compiled with gcc and the flags of builder.py, no Python.

The wrapper is one C file, <name>_fmi2.c or <name>_fmi3.c: the FMU's core
(templates/fmi/fmu_core.c.tmpl: variables by value reference, modes, events, projections, the
co-simulation step through <prefix>integrate) with the version's functions
(templates/fmi/fmi2.c.tmpl, fmi3.c.tmpl), printed with the model's sizes, names, start values
and value references (fmu_variables.py). The archive holds modelDescription.xml
(fmu_description.py), binaries/<platform>/<name>.so, the C sources under sources/ (FMI 3.0's
sources/buildDescription.xml with them) and the FMI headers' license; fmu_archive.py writes it.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from string import Template

from ..emit.resources import templates
from ..errors import BuildError
from ..vocabulary import DRIVERS, NEMC_VERSION, RUN_HEADER
from . import fmu_variables as fv
from .builder import (
    CFLAGS,
    DRIVERS_CFLAGS,
    MAX_COMPILER_JOBS,
    UNIT_CFLAGS,
    compiler,
    drivers_key,
    drivers_object,
    run_jobs,
    start,
    usable_cores,
)
from .fmu_archive import write_archive
from .fmu_description import Dependencies, Description, build_description, model_description

HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
           3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
DIRECTIONS = {"falling": -1, "both": 0, "rising": 1}  # enum nemc_event_direction
ACTIONS = {"record": 0, "stop": 1, "impact": 2}  # enum nemc_event_action
FMU_KIND = {"me": 0, "cs": 1}  # fmu_core.c.tmpl's FMU_MODEL_EXCHANGE, FMU_COSIMULATION
LICENSE = "documentation/licenses/fmi-standard-headers.txt"


def fmi_template(name: str) -> str:
    return templates().joinpath("fmi").joinpath(name).read_text(encoding="utf-8")


def platform_folder(fmi: int) -> str:
    """The binaries/ folder of this machine's platform (Linux on x86-64; FMI 3 also AArch64)."""
    machine = os.uname().machine if hasattr(os, "uname") else ""
    if sys.platform.startswith("linux") and machine in ("x86_64", "AMD64"):
        return "linux64" if fmi == 2 else "x86_64-linux"
    if sys.platform.startswith("linux") and machine in ("aarch64", "arm64") and fmi == 3:
        return "aarch64-linux"
    raise BuildError(f"an FMU's binary is built for Linux on x86-64 (FMI 3: also AArch64); "
                     f"this machine is {sys.platform} on {machine}")


def write_fmu(package: Path, target: Path, fmi: int, kind: str, facts: Mapping) -> Path:
    """The built PACKAGE (with the parts "jacobian" and "linearization") as the FMU TARGET:
    FMI FMI (2 or 3), KIND "me" or "cs", FACTS the runtime's (nemc/runtime/fmu.py)."""
    meta = json.loads((package / "model.json").read_text())
    defaults = fv.FmuDefaults(**facts)
    layout = fv.layout(meta, defaults, kind)
    token = fmu_token(package.name, fmi, kind, defaults)
    name = meta["name"]
    wrapper = f"{name}_fmi{fmi}.c"
    sources = model_sources(package, name)
    sources[wrapper] = wrapper_source(meta, layout, defaults, fmi, kind, token).encode()
    for header in HEADERS[fmi]:
        sources[header] = fmi_template(header).encode()
    source_sets = compile_sets(name, sources, wrapper)
    binary = compiled_library(name, sources, source_sets, fmi)
    description = Description(
        meta, layout, defaults, dependencies(meta, defaults), fmi, kind, token,
        tuple(name for files, _ in source_sets for name in files), has_linearization(meta),
        any(event["action"] == "stop" for event in meta.get("events", ())))
    library = f"binaries/{platform_folder(fmi)}/{name}.so"
    files = {"modelDescription.xml": model_description(description).encode(),
             library: binary, LICENSE: fmi_template("LICENSE.txt").encode()}
    files.update({f"sources/{file}": data for file, data in sources.items()})
    if fmi == 3:
        files["sources/buildDescription.xml"] = build_description(name, source_sets).encode()
    try:
        return write_archive(target, files, executable={library})
    except OSError as error:
        raise BuildError(f"cannot write the FMU {target}: {error.strerror or error}") from None


def has_linearization(meta: Mapping) -> bool:
    """Whether the build's C gives a tree's [A | B], [C | D] (exact directional derivatives)."""
    return "linearization" in meta["generated"] and not meta.get("constraint_equations")


def dependencies(meta: Mapping, defaults: fv.FmuDefaults) -> Dependencies:
    pattern = defaults.dependencies
    if not pattern:
        return Dependencies()
    return Dependencies(tuple(pattern["derivatives"]), tuple(pattern["outputs"]))


def fmu_token(key: str, fmi: int, kind: str, defaults: fv.FmuDefaults) -> str:
    """The GUID (FMI 2) or instantiation token (FMI 3): from the build key, the version, the
    kind, the wrapper's templates and the defaults, as a GUID's text."""
    digest = hashlib.sha256()
    for part in (key, str(fmi), kind, NEMC_VERSION, repr(defaults),
                 fmi_template("fmu_core.c.tmpl"), fmi_template(f"fmi{fmi}.c.tmpl")):
        digest.update(part.encode() + b"\0")
    text = digest.hexdigest()[:32]
    return "{" + "-".join((text[:8], text[8:12], text[12:16], text[16:20], text[20:])) + "}"


def model_sources(package: Path, name: str) -> dict[str, bytes]:
    """The model's C and headers as nemc built them: <name>.c, its unit and spectrum files,
    the native integrators, and the headers they include."""
    names = [f"{name}.c", *sorted(p.name for p in package.glob(f"{name}_unit*.c")),
             f"{name}_spectrum.c", f"{DRIVERS}.c", f"{name}.h", f"{RUN_HEADER}.h",
             f"{DRIVERS}.h"]
    return {file: (package / file).read_bytes() for file in names if (package / file).exists()}


def compile_sets(name: str, sources: Mapping[str, bytes], wrapper: str
                 ) -> list[tuple[tuple[str, ...], str]]:
    """The C files by the compiler options builder.py gives them: the model and the wrapper
    (CFLAGS), the unit and spectrum files (UNIT_CFLAGS), the integrators (DRIVERS_CFLAGS)."""
    units = tuple(file for file in sources if file.startswith(f"{name}_unit")
                  or file == f"{name}_spectrum.c")
    return [((f"{name}.c", wrapper), " ".join(CFLAGS)), (units, " ".join(UNIT_CFLAGS)),
            ((f"{DRIVERS}.c",), " ".join(DRIVERS_CFLAGS))]


def compiled_library(name: str, sources: Mapping[str, bytes],
                     source_sets: Sequence[tuple[tuple[str, ...], str]], fmi: int) -> bytes:
    """The FMU's shared library, compiled in a temporary folder: every C file with its set's
    flags (the integrators' object from nemc's cache where it has one: builder.drivers_object),
    linked with only the fmi<N> functions exported (a version script), so that two FMUs in one
    process share no symbol."""
    cc = compiler()
    with tempfile.TemporaryDirectory(prefix="nemc-fmu-") as scratch:
        folder = Path(scratch)
        for file, data in sources.items():
            (folder / file).write_bytes(data)
        drivers = folder / f"{DRIVERS}.c"
        key = drivers_key(drivers)
        cached = drivers_object(drivers, key)  # nemc's build compiled the same text already
        jobs = [[*cc, *options.split(), "-I", str(folder), "-c", str(folder / file), "-o",
                 str((folder / file).with_suffix(".o"))]
                for files, options in source_sets for file in files
                if not (cached and folder / file == drivers)]
        run_jobs(jobs, min(max(usable_cores(), 2), MAX_COMPILER_JOBS))
        exports = folder / "exports.map"
        exports.write_text(f"{{ global: fmi{fmi}*; local: *; }};\n")
        library = folder / f"{name}.so"
        command = [*cc, "-shared", *(str((folder / file).with_suffix(".o"))
                                     for files, _ in source_sets for file in files),
                   "-o", str(library), "-lm", f"-Wl,--version-script={exports}"]
        process = start(command)
        output = process.communicate()[0].decode(errors="replace")
        if process.returncode:
            raise BuildError(f"linking the FMU failed:\n$ {' '.join(command)}\n{output}")
        return library.read_bytes()


# ---- the wrapper's C ------------------------------------------------------------------------

def c_number(value: float | int) -> str:
    return repr(float(value)) if isinstance(value, float) else str(int(value))


def c_list(values: Sequence[float | int]) -> str:
    """A C initializer's entries (one 0 for an empty array: its size is N + 1)."""
    return ", ".join(c_number(v) for v in values) if values else "0"


def c_strings(names: Sequence[str]) -> str:
    return ", ".join(json.dumps(name) for name in names) if names else "0"


def parameter_start(meta: Mapping, defaults: fv.FmuDefaults) -> list[float]:
    """p at instantiation: the parameters' defaults, then each input's law with scale 0 and
    its value the input's start value (decision 0031: a constant input)."""
    inputs = meta["inputs"]
    p = [float(v) for v in meta["parameter_defaults"]]
    if len(p) != inputs["offset"]:
        raise BuildError("model.json's inputs do not follow its parameters")
    for value in defaults.input_start:
        law = [float(v) for v in inputs["defaults"]]
        law[0], law[1] = 0.0, float(value)  # scale, value (runtime/inputs.py's SCALE, VALUE)
        p += law
    return p


def wrapper_source(meta: Mapping, layout: fv.Layout, defaults: fv.FmuDefaults, fmi: int,
                   kind: str, token: str) -> str:
    """The FMU's C wrapper: the core printed with the model's tables, inside the version's
    functions."""
    name, first = meta["name"], layout.first
    settings = layout.of("setting")
    events = meta.get("events", ())
    given = set(meta.get("initial_given", ()))
    has_loops = bool(meta.get("constraint_equations"))
    starts = [tuple(pair) for pair in meta.get("constraint_starts", ())]  # "as at the start"
    core = Template(fmi_template("fmu_core.c.tmpl")).substitute(
        name=name, prefix=meta["c_prefix"], fmi=fmi, fmi_version=f"{fmi}.0",
        vr_state=first["state"], vr_derivative=first["derivative"],
        vr_parameter=first["parameter"], vr_input=first["input"], vr_output=first["output"],
        vr_indicator=first["indicator"], vr_setting=first["setting"], n_setting=len(settings),
        n_runtime_parameter=len(meta["parameter_names"]),
        input_offset=meta["inputs"]["offset"], input_stride=meta["inputs"]["stride"],
        n_check=len(meta["check_names"]), fmu_kind=FMU_KIND[kind],
        has_linearization=int(has_linearization(meta)),
        has_taylor=int("taylor" in meta["generated"] and not has_loops),
        kinematic=int(defaults.kinematic), max_step=c_number(float(defaults.max_step)),
        max_steps=int(defaults.max_steps), n_tstop=len(defaults.tstops),
        variable_names=c_strings([v.name for v in layout.variables]),
        parameter_start=c_list(parameter_start(meta, defaults)),
        state_start=c_list([float(v) for v in defaults.initial_state]),
        scene_given=c_list([int(s in given) for s in meta["state_names"]]),
        setting_start=c_list([s.start for s in settings]),
        setting_min=c_list([float(s.minimum) for s in settings]),
        setting_max=c_list([float(s.maximum) for s in settings]),
        event_directions=c_list([DIRECTIONS[e["direction"]] for e in events]),
        event_actions=c_list([ACTIONS[e["action"]] for e in events]),
        check_names=c_strings(meta["check_names"]),
        constraint_names=c_strings(meta.get("constraint_equations", ())),
        tstops=c_list(list(defaults.tstops)),
        n_start=len(starts), start_equation=c_list([k for k, _ in starts]),
        start_parameter=c_list([index for _, index in starts]),
        state_magic=int(token[1:9], 16))
    return Template(fmi_template(f"fmi{fmi}.c.tmpl")).substitute(
        name=name, version=NEMC_VERSION, source=meta.get("source", ""),
        source_hash=meta.get("source_hash", ""), guid=token, core=core,
        kind_text="model exchange" if kind == "me" else "co-simulation")
