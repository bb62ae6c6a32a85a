"""What an FMU export needs from the runtime (Model.export_fmu): the model's experiment as
the runtime would run it (the scene's span, tolerances, run settings, the native method for
co-simulation), its initial state (assembled), its inputs' start values, whether a closed loop
has no degree of freedom left, and which states and inputs each derivative and output depends
on (the nonzero pattern of the exact linearization). The FMU itself is written by the
pipeline's exporter, Model.fmu_exporter (it builds the model with the parts an FMU needs, asks
fmu_facts of that build, and calls nemc/build/fmu.py): a standalone package has none.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..vocabulary import AUTO, DEFAULT_ATOL, DEFAULT_RTOL, IMPLICIT_METHODS, NATIVE_METHODS
from . import runs
from .built import DEFAULT_T_SPAN
from .failures import IntegrationFailure, ModelError

Model = Any  # runtime.model.Model, which imports this module

FMI_VERSIONS = (2, 3)
FMU_KINDS = ("me", "cs")
PATTERN_POINTS = 2  # random states (and parameters, inputs, times) the dependencies are seen at
PATTERN_SEED = 48


def export_fmu(model: Model, path: str | Path, fmi: int, kind: str) -> Path:
    """MODEL as an FMU at PATH (Model.export_fmu checks the arguments here)."""
    model.friction.refuse("an FMU export")
    if fmi not in FMI_VERSIONS or isinstance(fmi, bool):
        raise ModelError(f"export_fmu: fmi must be 2 or 3, got {fmi!r}")
    if kind not in FMU_KINDS:
        raise ModelError(f"export_fmu: kind must be 'me' (model exchange) or 'cs' "
                         f"(co-simulation), got {kind!r}")
    if not isinstance(path, (str, Path)) or not str(path).endswith(".fmu"):
        raise ModelError(f"export_fmu: the path must name a .fmu file, got {path!r}")
    if model.fmu_exporter is None:
        raise ModelError("export_fmu: a standalone package holds no compiler to build an FMU"
                         " with: run `nemc export MECH.yaml --fmu OUT.fmu` where nemc is "
                         "installed")
    return model.fmu_exporter(Path(path), fmi, kind)


def cosimulation_method(model: Model, span: tuple[float, float], y0: np.ndarray,
                        rtol: float) -> str:
    """The native method of a co-simulation step: the scene's if native; nemc.Radau for an
    implicit scene; "auto"'s start for the scene's initial state otherwise."""
    method = model.scene.get("method") or AUTO
    if method in NATIVE_METHODS:
        return method
    if method in IMPLICIT_METHODS:
        return "nemc.Radau"
    if method != AUTO:
        return "nemc.DOP853"  # scipy's explicit methods: RK45, RK23, DOP853
    chosen = model.auto_method(span, y0, rtol)
    return chosen if chosen in NATIVE_METHODS else "nemc.Radau"


def fmu_facts(model: Model) -> dict[str, Any]:
    """The export's defaults (nemc/build/fmu_variables.py's FmuDefaults, as a dict)."""
    scene = model.scene
    span = tuple(float(t) for t in scene["t_span"] or DEFAULT_T_SPAN)
    rtol = float(scene["rtol"] or DEFAULT_RTOL)
    atol = float(scene["atol"] or DEFAULT_ATOL)
    settings = runs.run_settings(scene, span)
    y0 = model.initial_state()
    p = model.parameter_vector()
    kinematic = False
    if model.has_loops:  # a gear pair's offset as at the start, as a run sets it
        started = model.loops.started(span[0], y0, p)
        kinematic = model.loops.assembled(span[0], y0, model.loops.given_mask(None),
                                          started)[1] == 0
    from .plant import input_vector

    return {
        "method": cosimulation_method(model, span, y0, rtol),
        "rtol": rtol, "atol": atol, "start_time": span[0], "stop_time": span[1],
        "output_step": float(scene["t_eval_step"]) if scene.get("t_eval_step") else None,
        "initial_state": tuple(float(v) for v in y0),
        "input_start": tuple(float(u) for u in input_vector(model, p, span[0], y0)),
        "kinematic": bool(kinematic),
        "max_step": settings.max_step if math.isfinite(settings.max_step) else 0.0,
        "max_steps": int(settings.max_steps),
        "tstops": tuple(float(t) for t in np.unique(np.asarray(scene.get("tstops") or (),
                                                               dtype=float))),
        "dependencies": dependency_pattern(model, span, y0),
    }


def dependency_pattern(model: Model, span: tuple[float, float], y0: np.ndarray
                       ) -> dict[str, tuple] | None:
    """Which states and inputs each derivative and output depends on: the entries of the
    exact A, B, C, D that are nonzero at random states, times, inputs and parameters (a
    structural zero is exactly 0 in the derivation's C). None (all) for a closed loop, whose
    linearization is in independent coordinates, or where the model cannot be linearized."""
    if model.has_loops:
        return None
    rng = np.random.default_rng(PATTERN_SEED)
    n, m = model.n_state, len(model.input_names)
    seen = [np.zeros((n, n + m), dtype=bool), np.zeros((len(model.output_names), n + m),
                                                       dtype=bool)]
    for _ in range(PATTERN_POINTS):
        params = {name: value * (1 + 0.25 * rng.uniform(-1, 1)) if value else
                  0.5 * rng.uniform(-1, 1) for name, value in model.parameters.items()}
        y = y0 + 0.3 * rng.standard_normal(n)
        u = rng.standard_normal(m) if m else None
        t = span[0] + rng.uniform(0, 1) * (span[1] - span[0])
        try:
            lin = model.linearize(y, u, t=t, params=params)
        except (ModelError, IntegrationFailure, ValueError):
            return None
        n_out = len(model.output_names)
        seen[0] |= np.hstack([lin.A, lin.B.reshape(n, m)]) != 0
        seen[1] |= np.hstack([lin.C.reshape(n_out, n), lin.D.reshape(n_out, m)]) != 0

    def rows(mask: np.ndarray) -> tuple:
        return tuple((tuple(int(j) for j in np.flatnonzero(row[:n])),
                      tuple(int(k) for k in np.flatnonzero(row[n:]))) for row in mask)

    return {"derivatives": rows(seen[0]), "outputs": rows(seen[1])}
