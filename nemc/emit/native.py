"""The native integrators (issue 9): the model's entry points appended to <name>.c, the
model-independent nemc_drivers.c, and <name>_spectrum.c, method auto's look at the start.
What a sensitivity system's drivers need (system_code) imports no sympy: a cached model's first
run with sensitivities finds them in the cache through it (the printer, jacobian_c, is imported
by the functions that print a model).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..vocabulary import AUTO_SPECTRUM_MAX_STATES
from ..vocabulary import NEMC_VERSION as __version__
from .interface import cdef, shared_headers
from .resources import read_template, template

if TYPE_CHECKING:
    from ..derive.equations import Equations


def native_section(eqs: Equations, prefix: str, taylor: str, lanes: str = "") -> str:
    """The model's side of the native integrators in <name>.c: nemc.Taylor's code (the model's
    own coefficients) only in builds that ask for it, its ensembles in SIMD lanes (lanes:
    templates/batch.c.tmpl, else batch_absent.c.tmpl) only when asked, and the model's entry
    points, which hand its functions to the drivers (drivers_source)."""
    from .jacobian_c import jacobian_function

    entry = template("integrators_entry.c.tmpl").substitute(
        name=eqs.mechanism.name, prefix=prefix, jacobian=jacobian_function(eqs, prefix)
    )
    batch = lanes or template("batch_absent.c.tmpl").substitute(prefix=prefix)
    return "\n" + taylor + entry + batch


def drivers_source(eqs: Equations) -> str:
    """nemc_drivers.c: the model-independent integrators, run control and ensembles' loop for
    a model of N_STATE states (templates/drivers.c.tmpl). Radau only in builds with the
    Jacobian: it halves the compile time the integrators add elsewhere. The text names no
    model, so models of one size (and Jacobian or not) share one compiled object
    (build.builder.drivers_object)."""
    from .jacobian_c import has_jacobian

    return drivers_text(2 * eqs.n, has_jacobian(eqs))


def drivers_text(n_state: int, radau: bool) -> str:
    """nemc_drivers.c for N_STATE states, with nemc.Radau or without."""
    return template("drivers.c.tmpl").substitute(
        version=__version__, n_state=n_state,
        radau_note=" (with the Jacobian)" if radau else "", radau_name=", Radau" if radau else "",
        run_control=read_template("run_control.c.tmpl"),
        integrators=read_template("integrators.c.tmpl"),
        radau=read_template("radau.c.tmpl") if radau else "")


@dataclass(frozen=True)
class SystemCode:
    """The C of the native integrators for a system of N_STATE states given by a function
    pointer (a model's sensitivity system): nemc_drivers.c (with Radau, which takes the
    model's Jacobian as a pointer too, the block of the system's), nemc_system.c's entry
    points, the shared headers and the cffi cdef. It names no model."""

    n_state: int
    drivers: str
    entry: str
    headers: tuple[tuple[str, str], ...]
    cdef: str


def system_code(n_state: int) -> SystemCode:
    entry = template("system.c.tmpl").substitute(version=__version__, n_state=n_state)
    headers = shared_headers()
    return SystemCode(n_state, drivers_text(n_state, radau=True), entry, headers,
                      cdef(dict(headers)["nemc_run.h"], entry))


def spectrum_source(eqs: Equations, prefix: str) -> str:
    """<name>_spectrum.c: method auto's look at the start (templates/spectrum.c.tmpl), in a
    file of its own that the build compiles in parallel with <name>.c."""
    from .jacobian_c import jacobian_function

    return template("spectrum_unit.c.tmpl").substitute(
        name=eqs.mechanism.name, version=__version__, prefix=prefix,
        spectrum=read_template("spectrum.c.tmpl"), jacobian=jacobian_function(eqs, prefix),
        spectrum_max_states=AUTO_SPECTRUM_MAX_STATES)
