"""What method "auto" starts a run with (vocabulary.auto_method's rules): from the size, the
tolerance, whether nemc.Taylor's code (or its SIMD lanes) is at hand and cheap enough, and the
stiff modes at the start, which one C call measures (start_stiffness)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..vocabulary import (
    AUTO_LANES_MIN_RUNS,
    AUTO_LANES_TAYLOR_MAX_COORDINATES,
    AUTO_SPECTRUM_MAX_STATES,
    AUTO_STIFF_STEPS,
    AUTO_TAYLOR_BUILD_RUNS,
    AUTO_TAYLOR_MAX_COORDINATES,
    EXPLICIT_STABILITY,
    auto_method,
    auto_takes_taylor,
)
from .built import BuiltModel
from .checks import checked_state


def checked_auto_choice(model: BuiltModel, span: Sequence[float], y0: Any, rtol: float,
                        params: Any = None, runs: int = 1) -> str:
    """Model.auto_method: auto_choice for a caller's span, state and parameters (a vector as
    it is, else overrides, checked)."""
    p = params if isinstance(params, np.ndarray) else model.parameter_vector(params)
    return auto_choice(model, tuple(span), checked_state(y0, model.n_state), rtol, p, runs)


def auto_choice(model: BuiltModel, span: tuple[float, ...], y0: np.ndarray, rtol: float,
                p: np.ndarray, runs: int = 1) -> str:
    """Model.auto_method with its arguments checked already (simulate's own call)."""
    lanes = lanes_at_hand(model) if runs >= AUTO_LANES_MIN_RUNS else 0
    taylor_max = max(AUTO_TAYLOR_MAX_COORDINATES,
                     AUTO_LANES_TAYLOR_MAX_COORDINATES.get(lanes, 0))
    return auto_method(len(model.coordinate_names), rtol,
                       bool(lanes) or (taylor_at_hand(model, runs) and taylor_cheap(model, rtol)),
                       start_stiffness(model, span, y0, p), taylor_max)


def taylor_cheap(model: BuiltModel, rtol: float) -> bool:
    """Whether the build's nemc.Taylor program is cheap enough against its right-hand side
    for "auto" to give it a run at rtol (vocabulary.auto_takes_taylor; a build without
    Taylor's code, built later for an ensemble, counts as cheap, as before)."""
    return auto_takes_taylor(model.metadata.get("taylor_cost_ratio", 0.0), rtol)


def lanes_at_hand(model: BuiltModel) -> int:
    """The lanes per batch of a build at hand with nemc.Taylor's lanes (this one, or the
    variant compiled_with("lanes") already gave), else 0: nothing is built to find out."""
    for build in model._builds_at_hand():
        if build.has_part("lanes") and build.compiled.taylor_ready():
            return int(build.metadata.get("lane_count", 0))
    return 0


def taylor_at_hand(model: BuiltModel, runs: int) -> bool:
    """nemc.Taylor's code is in the build, or worth building for this many runs."""
    if model.has_loops or "taylor_unavailable" in model.metadata:
        return False
    if model.has_part("taylor"):
        return model.compiled.taylor_ready()
    return runs >= AUTO_TAYLOR_BUILD_RUNS and model.part_compiler is not None


def start_stiffness(model: BuiltModel, span: tuple[float, ...], y0: np.ndarray,
                    p: np.ndarray) -> float:
    """The steps an explicit method would need over the span for stability alone: the stiff
    rate of the Jacobian's eigenvalues at y0 x the span / EXPLICIT_STABILITY, in one C call
    (<model>_start_stiffness, templates/spectrum.c.tmpl), with the exact Jacobian of a build
    at hand that has it, else forward differences of the RHS (nothing is built to look).
    The eigenvalues are computed only when the dissipation (minus the trace: the decay
    rates' sum) is large enough to make AUTO_STIFF_STEPS; else it is returned, an estimate
    that a stiffness it misses is still caught by the run's test.
    0 when not computed (loops, large systems, a start the RHS cannot evaluate)."""
    if model.has_loops or model.n_state > AUTO_SPECTRUM_MAX_STATES:
        return 0.0
    compiled = stiffness_build(model).compiled
    steps = compiled.ffi.new(compiled.double_pointer)
    if compiled.functions["start_stiffness"](float(span[0]), compiled.buffer(y0),
                                             compiled.parameter_buffer(p),
                                             abs(span[1] - span[0]) / EXPLICIT_STABILITY,
                                             AUTO_STIFF_STEPS, steps):
        return 0.0  # the run itself will say why
    return steps[0]


def stiffness_build(model: BuiltModel) -> BuiltModel:
    """The build start_stiffness looks with: the first at hand with the exact Jacobian (the
    model or a variant), else the model; found again only when a variant was added."""
    count, build = model._stiffness_build
    if count != len(model._variants) or build is None:
        build = next((build for build in model._builds_at_hand() if build.has_part("jacobian")),
                     model)
        model._stiffness_build = (len(model._variants), build)
    return build
