"""Emission: a model's generated code (`emit` -> `Emitted`): <name>.c (model_c.py's model
functions, native.py's entry points, taylor_c.py's nemc.Taylor, positions_c.py's drawing), its
unit files (parts.py), <name>_spectrum.c and nemc_drivers.c (native.py), the headers and the
cffi cdef (interface.py), the package's __init__.py and model.json's metadata (metadata.py).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..derive.equations import Equations, taylor_cost_ratio
from ..vocabulary import NEMC_VERSION as __version__
from .c_text import SymbolTablePrinter
from .interface import cdef, header, shared_headers
from .metadata import metadata
from .model_c import c_source
from .native import drivers_source, native_section, spectrum_source
from .optimize import Block
from .parts import CHUNK_STEPS, Units, needs_units
from .positions_c import positions_part
from .printing import symbol_table, template
from .taylor_c import lanes_section, taylor_section
from .units import unit_metadata


@dataclass(frozen=True)
class Emitted:
    """The generated code of one model: C source and header, cffi declarations, metadata."""

    name: str
    c_source: str
    header: str
    cdef: str
    package_init: str
    metadata: dict
    spectrum: str  # the C of <name>_spectrum.c (method auto's look at the start)
    units: tuple[str, ...] = ()  # the C of <name>_unit<k>.c, k = 1, 2, ... (long programs' parts)
    rhs_call: str = ""  # the C of _rhs_call.c: Model.rhs's extension (templates/rhs_call.c.tmpl)
    drivers: str = ""  # the C of nemc_drivers.c: the native integrators (the same at one size)
    # the headers every model shares, by file name: nemc_run.h (in the cdef), nemc_drivers.h
    shared_headers: tuple[tuple[str, str], ...] = ()


def emit(eqs: Equations, block: Block, chunk_steps: int | None = None,
         lanes: int = 0, fma: bool = False) -> Emitted:
    """chunk_steps: the most steps of a program printed as one function (CHUNK_STEPS);
    lanes: also nemc.Taylor's ensembles in SIMD lanes, this many per batch (when Taylor's code
    is built); 0: none. fma: nemc.Taylor's multiply-adds fused (a CPU with FMA builds it:
    build.fma_available)."""
    prefix = f"{eqs.mechanism.name}_"
    printer = SymbolTablePrinter(symbol_table(eqs, block))
    taylor_c = taylor_section(eqs, printer, fma)
    taylor, taylor_unavailable = taylor_c.source, taylor_c.unavailable
    lanes_c = lanes_section(eqs, printer, prefix, lanes) if lanes and taylor else ""
    info = metadata(eqs, prefix)
    info.update(unit_metadata(eqs.mechanism, info["output_names"]))
    chunk_steps = chunk_steps or CHUNK_STEPS
    units = Units(prefix) if needs_units(block, chunk_steps) else None
    positions_c, info["drawing"] = positions_part(eqs, block, prefix, chunk_steps, units)
    if taylor:
        info["generated"].append("taylor")
        info["taylor_program"] = eqs.taylor_form
        info["taylor_cost_ratio"] = round(taylor_cost_ratio(eqs), 3)
        info["fma"] = fma
    if lanes_c:
        info["generated"].append("lanes")
        info["lane_count"] = lanes
    if taylor_unavailable:
        info["taylor_unavailable"] = info["lanes_unavailable"] = taylor_unavailable
    if eqs.sensitivities_unavailable:
        info["sensitivities_unavailable"] = eqs.sensitivities_unavailable
    interface = header(eqs, prefix)
    headers = shared_headers()
    return Emitted(
        name=eqs.mechanism.name,
        c_source=c_source(eqs, block, prefix, chunk_steps, units)
        + native_section(eqs, prefix, taylor, lanes_c) + positions_c,
        units=units.files(eqs.mechanism.name) if units is not None else (),
        spectrum=spectrum_source(eqs, prefix),
        header=interface,
        cdef=cdef(dict(headers)["nemc_run.h"], interface),
        package_init=template("package_init.py.tmpl").substitute(
            name=eqs.mechanism.name, version=__version__
        ),
        metadata=info,
        rhs_call=template("rhs_call.c.tmpl").substitute(
            name=eqs.mechanism.name, prefix=prefix, version=__version__
        ),
        drivers=drivers_source(eqs),
        shared_headers=headers,
    )
