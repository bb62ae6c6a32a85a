"""Parameter studies: many runs of one model over parameter and initial-value sets, on this
machine's cores or on a Dask cluster, into one xarray dataset (in memory, .zarr, .nc or .npz).

    runs = nemc.sweep(model, {"q1": q1s, "q2": q2s}, t_eval=[10.0])             # this machine
    runs = nemc.sweep(model, y0s, params={"m2": m2s}, client=client, out="s.zarr")  # a cluster

The runs are cut into chunks (1,000 to 10,000 runs, fewer when their results would be large);
each chunk is one `simulate_many` call on one thread: in a thread pool of this process, or as
one Dask task (Client.submit + as_completed, retried when it raises or its worker is lost).
Workers receive the mechanism's source and build options (`pipeline.Recipe`), never cffi
objects, build or load it from their own nemc cache, and keep it loaded per process
(`worker_model`). Each run is deterministic, so the results are those of the same runs done
serially, whatever the chunking, whichever worker ran a chunk and however often.

Dask, xarray, zarr and tqdm are the optional extra `nemc[sweep]`, imported only here, inside
the functions that need them.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..runtime.inputs import RunInputs
from ..runtime.model import (
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    DEFAULT_T_SPAN,
    Model,
    ModelError,
)
from ..runtime.outcome import outputs_along
from ..runtime.simulation import run_times
from ..vocabulary import NEMC_VERSION as __version__
from .start import kept_over_scene
from .sweep_store import NOT_RUN, ChunkOutput, Layout, SweepStoreError, open_store, require

MAX_CHUNK_RUNS = 10_000
MIN_CHUNK_RUNS = 1_000
CHUNK_BYTES = 64 * 2**20  # at most this much of y per chunk (bounded memory on both ends)
INPUTS_REFUSED = -3
FAILURE_CAUSES = {  # simulate_many's failing statuses (EnsembleResult.status), as simulate says
    -1: "Required step size is less than spacing between numbers.",
    -2: "the equations could not be evaluated (non-finite values or a singular mass matrix)",
}

__all__ = ["sweep", "SweepResult", "SweepInterrupted", "SweepStoreError", "Settings",
           "default_chunk_runs"]


@dataclass(frozen=True)
class Settings:
    """How every run integrates: resolved once, as simulate_many resolves its defaults."""

    t_span: tuple[float, float]
    t_eval: tuple[float, ...]
    method: str
    rtol: float
    atol: float
    outputs: tuple[str, ...] = ()  # the scene's outputs stored beside the states

    @classmethod
    def resolve(cls, model: Model, t_span: Any, t_eval: Any, method: str | None,
                rtol: float | None, atol: float | None, runs: int = 1,
                outputs: bool = True) -> Settings:
        scene = model.scene
        span = tuple(float(v) for v in (t_span if t_span is not None else
                                        scene["t_span"] or DEFAULT_T_SPAN))
        times = run_times(scene, span, t_eval)  # the scene's t_eval rules, as simulate_many's
        times = np.array(span if times is None else times, dtype=float).reshape(-1)
        return cls(
            t_span=(span[0], span[1]), t_eval=tuple(times.tolist()),
            method=model.ensemble_method(span, rtol=rtol, runs=runs) if method in (None, "auto")
            else method,
            rtol=float(rtol if rtol is not None else scene["rtol"] or DEFAULT_RTOL),
            atol=float(atol if atol is not None else scene["atol"] or DEFAULT_ATOL),
            outputs=tuple(model.output_names) if outputs else (),
        )

    def identity(self) -> dict[str, Any]:
        """What the runs' results depend on (the sweep's fingerprint): a sweep without
        outputs keeps the fingerprint it had before outputs were stored."""
        fields = {k: v for k, v in self.__dict__.items() if k != "outputs"}
        return {**fields, **({"outputs": list(self.outputs)} if self.outputs else {})}

    def run(self, model: Model, y0s: np.ndarray, params: Mapping[str, Any],
            controls: Mapping[str, Any] | None = None) -> Any:
        return model.simulate_many(y0s, params=params, t_span=self.t_span,
                                   t_eval=np.array(self.t_eval), method=self.method,
                                   rtol=self.rtol, atol=self.atol, threads=1,
                                   inputs=dict(controls) if controls else None,
                                   progress=False)  # the sweep's bar is the one display


# -- the runs' inputs -------------------------------------------------------------------------

@dataclass
class ChunkInputs:
    """What one task needs to know of its runs start .. stop-1 (small: pickled to workers)."""

    start: int
    stop: int
    y0s: np.ndarray | None  # (n, n_state), or None: from the scene and y0_columns
    y0_columns: dict[str, Any]  # state name -> number or (n,) values
    params: dict[str, Any]  # parameter -> number or (n,) values
    controls: dict[str, Any] = field(default_factory=dict)  # the model's inputs: per run
    #                                       (n,) values, or shared (a number, a table, a feedback)


@dataclass
class Inputs:
    """The runs' initial states and parameters: full arrays, shared numbers, or columns."""

    runs: int
    y0s: Any  # (runs, n_state) array-like (sliced per chunk), or None
    y0_columns: dict[str, Any]
    params: dict[str, Any]
    controls: dict[str, Any] = field(default_factory=dict)  # the model's inputs (ChunkInputs')

    @classmethod
    def of(cls, model: Model, y0s: Any, params: Mapping[str, Any] | None,
           controls: Mapping[str, Any] | None = None) -> Inputs:
        columns: dict[str, Any] = {}
        full = None
        if isinstance(y0s, Mapping):
            columns = {check_state(model, name): column(name, v) for name, v in y0s.items()}
        elif y0s is not None:
            full = y0s if hasattr(y0s, "shape") and hasattr(y0s, "__getitem__") else \
                np.asarray(y0s, dtype=float)
            if len(full.shape) != 2 or full.shape[1] != model.n_state:
                raise ModelError(f"y0s must have shape (k, {model.n_state}), got {full.shape}")
        shared = {n: column(n, v) for n, v in (params or {}).items()}
        for name in shared:
            model.parameter_table.index(name)  # unknown or derived: a clear ModelError now
        controls = dict(controls or {})
        for name in controls:
            if name not in model.input_names:
                raise ModelError(f"sweep: unknown input {name!r}; the model's inputs: "
                                 f"{list(model.input_names)}")
        controls = {n: column(n, v) if np.isscalar(v) or isinstance(v, np.ndarray | list)
                    and np.ndim(v) == 1 and all(np.isscalar(x) for x in v) else v
                    for n, v in controls.items()}
        per_run = [v for v in controls.values() if isinstance(v, np.ndarray) and v.ndim == 1]
        sizes = {len(v) for v in [*columns.values(), *shared.values(), *per_run] if np.ndim(v)}
        sizes |= {full.shape[0]} if full is not None else set()
        if len(sizes) > 1:
            raise ModelError(f"sweep: the inputs disagree on the number of runs: {sorted(sizes)}")
        runs = sizes.pop() if sizes else 1
        if runs < 1:
            raise ModelError("sweep: no runs (the inputs are empty)")
        return cls(runs, full, columns, shared, controls)

    def chunk(self, start: int, stop: int) -> ChunkInputs:
        def part(values: dict[str, Any]) -> dict[str, Any]:
            return {n: v[start:stop] if np.ndim(v) else v for n, v in values.items()}

        y0s = None if self.y0s is None else np.asarray(self.y0s[start:stop], dtype=float)
        controls = {n: v[start:stop] if isinstance(v, np.ndarray) else v
                    for n, v in self.controls.items()}
        return ChunkInputs(start, stop, y0s, part(self.y0_columns), part(self.params),
                           controls)

    def varying(self) -> dict[str, np.ndarray]:
        """The inputs that differ between runs (the dataset's coordinates along run)."""
        numbers = {**self.params, **self.y0_columns, **self.numeric_controls()}
        return {n: v for n, v in numbers.items() if np.ndim(v)}

    def shared(self) -> dict[str, float]:
        numbers = {**self.params, **self.y0_columns, **self.numeric_controls()}
        return {n: float(v) for n, v in numbers.items() if not np.ndim(v)}

    def numeric_controls(self) -> dict[str, Any]:
        """The model's inputs given as numbers (shared or per run), not tables or feedbacks."""
        return {n: v for n, v in self.controls.items() if isinstance(v, float | np.ndarray)}

    def digest(self) -> str:
        """A hash of every input value (part of the sweep's fingerprint)."""
        digest = hashlib.sha256()
        for tag, values in (("p", self.params), ("c", self.y0_columns),
                            ("u", self.numeric_controls())):
            for name in sorted(values):
                digest.update(f"{tag}:{name}:".encode())
                digest.update(np.ascontiguousarray(values[name], dtype=float).tobytes())
        for name in sorted(set(self.controls) - set(self.numeric_controls())):
            digest.update(f"u:{name}:{self.controls[name]!r}".encode())  # tables, feedbacks
        if self.y0s is not None:
            for a in range(0, self.runs, 100_000):  # array-likes (zarr, memmap) a part at a time
                part = np.asarray(self.y0s[a:a + 100_000], dtype=float)
                digest.update(np.ascontiguousarray(part).tobytes())
        return digest.hexdigest()


def column(name: str, values: Any) -> Any:
    """A number (shared by every run) or a 1-d float array (one value per run)."""
    array = np.asarray(values, dtype=float)
    if array.ndim > 1:
        raise ModelError(f"sweep: {name!r} must be a number or a 1-d array, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ModelError(f"sweep: {name!r} must be finite")
    return float(array) if array.ndim == 0 else array


def check_state(model: Model, name: str) -> str:
    if name not in model.state_names:
        raise ModelError(f"unknown state name {name!r} (states: {list(model.state_names)})")
    return name


# -- one chunk: runs on a worker or in a thread -----------------------------------------------

def run_chunk(model_or_ref: Model | ModelRef, settings: Settings,
              chunk: ChunkInputs) -> ChunkOutput:
    """Integrate one chunk (one simulate_many on one thread); runs whose parameters the model
    refuses, or whose initial values a closed loop cannot meet, get status INPUTS_REFUSED and
    the reason, the others run as usual."""
    started = time.perf_counter()
    model, key = (model_or_ref, "") if isinstance(model_or_ref, Model) else \
        worker_model(model_or_ref)
    n = chunk.stop - chunk.start
    try:
        y0s, reasons = initial_states(model, settings, chunk, n)
        if not reasons:
            result = settings.run(model, y0s, chunk.params, chunk.controls)
            status, y, nfev = result.status.astype(np.int32), result.y, result.nfev
    except ModelError:
        reasons = refused_runs(model, chunk, n)
        if not reasons:  # not the parameters of some runs: an error of the whole sweep
            raise
    if reasons:  # some runs' parameters or (a closed loop's) initial values refused
        y0s, status, y, nfev = run_valid(model, settings, chunk, n, reasons)
    messages = failure_messages(status, y, settings.t_eval)
    for i, reason in reasons.items():
        messages[i] = reason
    outputs = run_outputs(model, settings, chunk, y0s, y) if settings.outputs else None
    return ChunkOutput(chunk.start, chunk.stop, y, y0s, status, nfev.astype(np.int64),
                       messages, key, time.perf_counter() - started, outputs)


def run_outputs(model: Model, settings: Settings, chunk: ChunkInputs, y0s: np.ndarray,
                y: np.ndarray) -> np.ndarray:
    """The scene's outputs (n, n_outputs, n_t) at each run's states, its parameters and
    inputs, as its result's outputs would give them (equations that hold "as at the start"
    taken at its initial state); NaN where the state is (after a stop, inputs refused).
    Runs that share their parameters and inputs take one C call together, else one each."""
    times = np.array(settings.t_eval)
    out = np.full((y.shape[0], len(settings.outputs), len(times)), np.nan)
    finite = np.all(np.isfinite(y), axis=1) & np.all(np.isfinite(y0s), axis=1)[:, None]
    shared = not model.loops.starts and not any(
        np.ndim(v) for v in chunk.params.values()) and not any(
        isinstance(v, np.ndarray) for v in chunk.controls.values())
    if shared:  # every finite (run, time) at once: (points, n_state)
        runs, columns = np.nonzero(finite)
        if len(runs):
            inputs = run_inputs(model, settings, chunk, y0s, int(runs[0]))
            if inputs is not None:
                values = outputs_of(model, inputs, times[columns], y[runs, :, columns].T)
                for k, name in enumerate(settings.outputs):
                    out[runs, k, columns] = values[name]
        return out
    for i in np.flatnonzero(finite.any(axis=1)):
        inputs = run_inputs(model, settings, chunk, y0s, int(i))
        if inputs is None:
            continue
        columns = finite[i]
        values = outputs_of(model, inputs, times[columns], y[i][:, columns])
        out[i][:, columns] = [values[name] for name in settings.outputs]
    return out


def outputs_of(model: Model, inputs: Any, t: np.ndarray, y: np.ndarray) -> dict[str, Any]:
    """The outputs at times T and states Y (n_state, n_t) under a run's inputs."""
    if inputs.tables:  # a table's segment at each time
        return outputs_along(model, t, y, inputs)
    return model.compiled.outputs_at(t, y, inputs.p)


def run_inputs(model: Model, settings: Settings, chunk: ChunkInputs, y0s: np.ndarray,
               i: int) -> Any:
    """Run I's parameter vector and inputs (inputs.RunInputs), or None when the model refuses
    its parameters."""
    try:
        p = model.parameter_vector(run_params(chunk.params, i))
    except ModelError:
        return None
    given = {n: v[i] if isinstance(v, np.ndarray) else v for n, v in chunk.controls.items()}
    inputs = model.input_layout.resolve(p, given) if given else RunInputs(p)
    if model.loops.starts:
        inputs.p = model.loops.started(settings.t_span[0], y0s[i], inputs.p)
    return inputs


def initial_states(model: Model, settings: Settings, chunk: ChunkInputs, n: int
                   ) -> tuple[np.ndarray, dict[int, str]]:
    """The chunk's initial states (given, or the scene's at each run's parameters with the
    given coordinates and rates put in), and the runs (in the chunk) whose initial values a
    closed loop refuses, with why: a closed loop's states are each assembled from its given
    values (assembled_states)."""
    y0s = chunk.y0s if chunk.y0s is not None else scene_states(model, chunk, n)
    if not model.has_loops:
        return y0s, {}
    return assembled_states(model, settings, chunk, y0s)


def scene_states(model: Model, chunk: ChunkInputs, n: int) -> np.ndarray:
    """The scene's initial state at each run's parameters with the chunk's initial-value
    columns put in (a closed loop's: model.guess_state, assembled_states' start)."""
    scene = model.guess_state if model.has_loops else model.initial_state
    if any(np.ndim(v) for v in chunk.params.values()):
        y0s = np.array([scene(run_params(chunk.params, i)) for i in range(n)])
    else:
        y0s = np.tile(scene(chunk.params), (n, 1))
    for name, values in chunk.y0_columns.items():
        y0s[:, model.state_names.index(name)] = values
    return y0s.reshape(n, model.n_state)


def assembled_states(model: Model, settings: Settings, chunk: ChunkInputs, y0s: np.ndarray
                     ) -> tuple[np.ndarray, dict[int, str]]:
    """A closed loop's runs' initial states, each assembled at the start as `nemc simulate
    --initial` (and simulate's y0=dict) assembles one: the values given kept (the scene's
    `initial` and the sweep's columns; every entry of a full state), the others solved from
    the constraints from the scene's state. A run whose values the constraints cannot meet
    is refused (NaN, and why), not the sweep; runs whose parameters are refused are left."""
    names = set(model.state_names) if chunk.y0s is not None else \
        kept_over_scene(model, chunk.y0_columns)
    given = np.array([name in names for name in model.state_names])
    states = np.array(y0s, dtype=float)
    refused: dict[int, str] = {}
    for i in range(len(states)):
        inputs = run_inputs(model, settings, chunk, states, i)
        if inputs is None:  # its parameters refused: run_chunk says so
            continue
        try:
            states[i] = model.loops.assembled(settings.t_span[0], states[i], given, inputs.p)[0]
        except ModelError as error:
            refused[i] = f"initial values refused: {error}"
            states[i] = np.nan
    return states, refused


def run_params(params: Mapping[str, Any], i: int) -> dict[str, float]:
    return {n: float(v[i]) if np.ndim(v) else v for n, v in params.items()}


def refused_runs(model: Model, chunk: ChunkInputs, n: int) -> dict[int, str]:
    """Run (in the chunk) -> why the model refuses its parameters (a mass <= 0, ...)."""
    reasons: dict[int, str] = {}
    for i in range(n):
        try:
            model.parameter_vector(run_params(chunk.params, i))
        except ModelError as error:
            reasons[i] = f"inputs refused: {error}"
    return reasons


def subset(values: Mapping[str, Any], rows: np.ndarray) -> dict[str, Any]:
    return {n: v[rows] if np.ndim(v) else v for n, v in values.items()}


def run_valid(model: Model, settings: Settings, chunk: ChunkInputs, n: int,
              refused: dict[int, str]) -> tuple[np.ndarray, ...]:
    """The chunk's runs but the REFUSED ones (run -> why; those whose initial values a closed
    loop refuses are added), which get status INPUTS_REFUSED and NaN."""
    valid = np.array([i for i in range(n) if i not in refused], dtype=int)
    y0s = np.full((n, model.n_state), np.nan) if chunk.y0s is None else chunk.y0s.copy()
    y = np.full((n, model.n_state, len(settings.t_eval)), np.nan)
    status = np.full(n, INPUTS_REFUSED, dtype=np.int32)
    nfev = np.zeros(n, dtype=np.int64)
    rows = valid
    if len(valid):
        y0s[valid], more = initial_states(model, settings, rows_of(chunk, valid), len(valid))
        refused.update({int(valid[j]): why for j, why in more.items()})
        rows = np.array([i for i in valid if i not in refused], dtype=int)
    if len(rows):
        sub = rows_of(chunk, rows)
        result = settings.run(model, y0s[rows], sub.params, sub.controls)
        y[rows], status[rows], nfev[rows] = result.y, result.status, result.nfev
    return y0s, status, y, nfev


def rows_of(chunk: ChunkInputs, rows: np.ndarray) -> ChunkInputs:
    """The chunk's runs ROWS (indices in the chunk) as a chunk of their own."""
    controls = {n: v[rows] if isinstance(v, np.ndarray) else v
                for n, v in chunk.controls.items()}
    return ChunkInputs(0, len(rows), None if chunk.y0s is None else chunk.y0s[rows],
                       subset(chunk.y0_columns, rows), subset(chunk.params, rows), controls)


def failure_messages(status: np.ndarray, y: np.ndarray, times: Sequence[float]) -> list[str]:
    """'' for each run that succeeded; for the others, what happened and after which time."""
    messages = [""] * len(status)
    for i in np.flatnonzero(status != 0):
        if status[i] == INPUTS_REFUSED:
            continue
        finite = np.flatnonzero(np.all(np.isfinite(y[i]), axis=0))
        after = f"after t={times[finite[-1]]:.9g}" if len(finite) else "before the first output"
        messages[i] = f"stopped {after}: {FAILURE_CAUSES.get(int(status[i]), status[i])}"
    return messages


# -- models on workers ------------------------------------------------------------------------

@dataclass(frozen=True)
class ModelRef:
    """A model as shipped to workers: the recipe to build it, the C parts it needs, and the
    build key on the submitting machine (the per-process memo's key)."""

    recipe: Any  # pipeline.Recipe
    jacobian: bool | None
    taylor: bool | None
    key: str
    mass_matrix: bool = False


_MODELS: dict[str, tuple[Model, str]] = {}
_MODELS_LOCK = threading.Lock()


def worker_model(ref: ModelRef) -> tuple[Model, str]:
    """The model of REF in this process and the key it was built under here: built or loaded
    from this machine's nemc cache on first use, then kept (one per build key and process)."""
    with _MODELS_LOCK:
        if ref.key not in _MODELS:
            _MODELS[ref.key] = build_ref(ref)
        return _MODELS[ref.key]


def build_ref(ref: ModelRef) -> tuple[Model, str]:
    from ..pipeline import compile_source

    recipe = ref.recipe
    compiled = compile_source(recipe.source, ref.jacobian, taylor=ref.taylor,
                              energy=recipe.energy, chunk_steps=recipe.chunk_steps,
                              mass_matrix=ref.mass_matrix)
    return compiled.model, compiled.package.name  # the package folder is named by its key


def model_ref(model: Model) -> ModelRef:
    """What a worker needs to build MODEL as it is now (with the parts it has gained since),
    and the key of that build here (a worker with another key has another nemc, compiler or
    Python: the sweep warns)."""
    recipe = getattr(model, "recipe", None)
    if recipe is None:
        raise ModelError("sweep on a Dask cluster needs a model from nemc.compile (workers "
                         "build it from its source); this one has no recipe")
    parts = tuple(model.metadata["generated"])
    if parts == recipe.parts:
        jacobian, taylor, mass_matrix = recipe.jacobian, recipe.taylor, recipe.mass_matrix
    else:
        jacobian, taylor, mass_matrix = ("jacobian" in parts, "taylor" in parts,
                                         "mass_matrix" in parts)
    ref = ModelRef(recipe, jacobian, taylor, "", mass_matrix)
    return dataclasses.replace(ref, key=build_ref(ref)[1])  # a cache hit, as a rule


# -- the sweep --------------------------------------------------------------------------------

class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during a sweep: the finished chunks are kept (in the output file, if any)."""

    def __init__(self, done: int, runs: int, path: Path | None):
        self.done, self.runs, self.path = done, runs, path
        super().__init__(f"sweep interrupted: {done} of {runs} runs done"
                         + (f", kept in {path}" if path else ""))


@dataclass
class ChunkReport:
    """Passed to on_chunk after each chunk is stored."""

    start: int
    stop: int
    failed: int
    seconds: float
    done: int  # runs done so far, including resumed ones
    runs: int


@dataclass
class SweepResult:
    """The sweep's dataset (xarray; lazy when read from a file) and what happened."""

    dataset: Any
    path: Path | None
    runs: int
    ran: int  # runs integrated by this call
    resumed: int  # runs found done in the output
    seconds: float
    chunk_errors: list[str] = field(default_factory=list)

    @property
    def t(self) -> np.ndarray:
        return np.asarray(self.dataset["time"].values)

    @property
    def y(self) -> Any:
        """(run, state, time): a numpy array in memory, a dask array when read from a file."""
        return self.dataset["y"].data

    @property
    def status(self) -> np.ndarray:
        return np.asarray(self.dataset["status"].values)

    @property
    def success(self) -> np.ndarray:
        return self.status == 0

    @property
    def nfev(self) -> np.ndarray:
        return np.asarray(self.dataset["nfev"].values)

    @property
    def not_run(self) -> int:
        return int(np.sum(self.status == NOT_RUN))

    @property
    def failed(self) -> int:
        status = self.status
        return int(np.sum((status != 0) & (status != NOT_RUN)))

    def failures(self, limit: int | None = None) -> list[tuple[int, int, str]]:
        """(run, status, message) of the runs that failed, the first LIMIT of them."""
        status = self.status
        runs = np.flatnonzero((status != 0) & (status != NOT_RUN))[:limit]
        messages = self.dataset["message"][runs].values if len(runs) else []
        return [(int(r), int(status[r]), str(m)) for r, m in zip(runs, messages)]


def default_chunk_runs(runs: int, n_state: int, n_times: int) -> int:
    """Runs per chunk: about 1/64 of the sweep, within 1,000 .. 10,000, and no more than
    CHUNK_BYTES of results. It depends on the sweep only (not the cluster), so a sweep
    resumed on another cluster keeps its chunks."""
    by_memory = max(1, CHUNK_BYTES // (8 * n_state * max(n_times, 1)))
    target = min(MAX_CHUNK_RUNS, max(MIN_CHUNK_RUNS, -(-runs // 64)))
    return max(1, min(runs, target, by_memory))


def sweep(
    model: Model,
    y0s: Any = None,
    *,
    params: Mapping[str, Any] | None = None,
    t_span: Sequence[float] | None = None,
    t_eval: Sequence[float] | None = None,
    method: str | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    client: Any = None,
    out: str | Path | None = None,
    resume: bool = False,
    chunk_runs: int | None = None,
    threads: int | None = None,
    retries: int = 2,
    progress: bool | None = None,
    attrs: Mapping[str, Any] | None = None,
    on_chunk: Callable[[ChunkReport], None] | None = None,
    inputs: Mapping[str, Any] | None = None,
    outputs: bool = True,
) -> SweepResult:
    """Run MODEL over many initial states and parameter sets; the results as one dataset.

    y0s: (k, n_state) initial states (any array-like that slices, e.g. a zarr array), or a
    dict state name -> number or (k,) values (other states: the scene's initial state at each
    run's parameters; a closed loop's each assembled keeping the scene's `initial` values and
    the dict's, as `nemc simulate --initial`; a run the constraints cannot meet fails alone,
    status INPUTS_REFUSED), or None (the scene's). params: name -> number (shared) or (k,)
    values.
    t_span, t_eval, method, rtol, atol: as simulate_many (method: a native one).
    client: a dask.distributed Client, or None for this machine's cores (threads, default all).
    out: None (in memory), or a .zarr, .nc or .npz file, written chunk by chunk (.nc, .npz:
    through FILE.partial.zarr). An existing output of the same sweep is resumed; resume=True
    requires one. chunk_runs: runs per task (default_chunk_runs). retries: re-runs of a task
    that raised (a lost worker's tasks are re-run by Dask itself). progress: a bar on stderr
    (None: when stderr is a terminal). attrs: extra dataset attributes. on_chunk: called with
    a ChunkReport after each chunk is stored. inputs: the model's inputs, each a number or
    (k,) values (a coordinate of the dataset, as a parameter's), or shared by every run: a
    table (times, values) or nemc.feedback(...) (simulate_many's). outputs: store the
    scene's outputs (energy, reactions, expressions) beside the states, as `outputs` (run,
    output, time) (False: the states only).
    """
    started = time.perf_counter()
    controls = inputs
    inputs = Inputs.of(model, y0s, params, controls)
    settings = Settings.resolve(model, t_span, t_eval, method, rtol, atol, inputs.runs,
                                outputs)
    run_chunk(model, settings, inputs.chunk(0, 1))  # settings errors here, before any output
    ref = model_ref(model) if client is not None else None
    layout = sweep_layout(model, settings, inputs, chunk_runs, attrs)
    store = open_store(out, layout, resume=resume)
    chunks = layout.chunks()
    done = store.done_chunks()
    resumed = sum(b - a for i, (a, b) in enumerate(chunks) if i in done)
    todo = [(a, b) for i, (a, b) in enumerate(chunks) if i not in done]
    tracker = Tracker(store, layout.runs, resumed, progress, on_chunk, ref)
    try:
        if client is None:
            errors = run_local(model, settings, inputs, todo, tracker, threads)
        else:
            errors = run_dask(client, ref, settings, inputs, todo, tracker, retries)
    except KeyboardInterrupt:
        raise SweepInterrupted(resumed + tracker.ran, layout.runs, store.path) from None
    finally:
        tracker.close()
    dataset = store.finish()
    return SweepResult(dataset, store.path, layout.runs, tracker.ran, resumed,
                       time.perf_counter() - started, errors)


def sweep_layout(model: Model, settings: Settings, inputs: Inputs, chunk_runs: int | None,
                 attrs: Mapping[str, Any] | None) -> Layout:
    identity = {  # what the results depend on (not the C parts a build happens to have)
        "model": model.metadata.get("source_hash", model.name), "name": model.name,
        "nemc": __version__, "settings": settings.identity(), "inputs": inputs.digest(),
        "runs": inputs.runs,
    }
    fingerprint = hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()
    rows = model.n_state + len(settings.outputs)  # values per run and output time
    chunk = chunk_runs or default_chunk_runs(inputs.runs, rows, len(settings.t_eval))
    described = {
        "nemc_sweep": fingerprint, "mechanism": model.name,
        "source": str(model.metadata.get("source", "")),
        "source_sha256": str(model.metadata.get("source_hash", "")), "nemc_version": __version__,
        "method": settings.method, "rtol": settings.rtol, "atol": settings.atol,
        "t_span": list(settings.t_span), "chunk_runs": int(min(chunk, inputs.runs)),
        "shared_inputs": json.dumps(inputs.shared()),
        **dict(attrs or {}),
    }
    return Layout(inputs.runs, int(min(chunk, inputs.runs)), model.state_names,
                  np.array(settings.t_eval), inputs.varying(), described, settings.outputs)


class Tracker:
    """Stores each finished chunk, counts runs and failures, shows progress."""

    def __init__(self, store: Any, runs: int, resumed: int, progress: bool | None,
                 on_chunk: Callable[[ChunkReport], None] | None, ref: ModelRef | None):
        self.store, self.runs, self.resumed, self.on_chunk = store, runs, resumed, on_chunk
        self.ran = self.failed = 0
        self.keys = {ref.key} if ref is not None else set()
        self.bar = progress_bar(runs, resumed, progress)

    def accept(self, out: ChunkOutput) -> None:
        self.store.write(out)
        failed = int(np.sum(out.status != 0))
        self.ran += out.stop - out.start
        self.failed += failed
        self.check_build(out.build_key)
        if self.bar is not None:
            self.bar.update(out.stop - out.start)
            if self.failed:
                self.bar.set_postfix(failed=self.failed, refresh=False)
        if self.on_chunk is not None:
            self.on_chunk(ChunkReport(out.start, out.stop, failed, out.seconds,
                                      self.resumed + self.ran, self.runs))

    def check_build(self, key: str) -> None:
        """Warn once per key when a worker's build differs from this machine's."""
        if key and key not in self.keys:
            import warnings

            self.keys.add(key)
            warnings.warn(f"a worker built the model under another key ({key}): its nemc, "
                          "compiler or Python differ from this machine's, and its results "
                          "may differ in the last bits", stacklevel=2)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def progress_bar(runs: int, done: int, progress: bool | None) -> Any:
    """A tqdm bar on stderr (runs done, rate, time left), or None."""
    if progress is False:
        return None
    tqdm = require("tqdm").tqdm
    return tqdm(total=runs, initial=done, unit="run", unit_scale=True, smoothing=0.05,
                disable=None if progress is None else False, desc="sweep", dynamic_ncols=True)


def run_local(model: Model, settings: Settings, inputs: Inputs, todo: list[tuple[int, int]],
              tracker: Tracker, threads: int | None) -> list[str]:
    """The chunks on this machine: THREADS of them at once (each in C, without the GIL),
    stored in this thread as they finish; at most 2 x THREADS chunks in memory."""
    workers = max(1, threads or os.cpu_count() or 1)
    pending_chunks = iter(todo)
    with ThreadPoolExecutor(workers) as pool:
        running: set[Future] = set()
        try:
            while True:
                for a, b in take(pending_chunks, 2 * workers - len(running)):
                    running.add(pool.submit(run_chunk, model, settings, inputs.chunk(a, b)))
                if not running:
                    return []
                finished, running = wait(running, return_when=FIRST_COMPLETED)
                for future in finished:
                    tracker.accept(future.result())
        finally:
            for future in running:
                future.cancel()


def take(items: Iterator, count: int) -> Iterable:
    for _ in range(max(0, count)):
        item = next(items, None)
        if item is None:
            return
        yield item


def run_dask(client: Any, ref: ModelRef, settings: Settings, inputs: Inputs,
             todo: list[tuple[int, int]], tracker: Tracker, retries: int) -> list[str]:
    """The chunks as Dask tasks, two per worker thread in flight (bounded memory on the
    workers and here), stored as they complete. A task that still fails after its retries
    (or whose workers keep dying: KilledWorker) leaves its runs NOT_RUN and is reported, and
    no further chunk is submitted (the same sweep run again continues)."""
    distributed = require("distributed")
    pending_chunks = iter(todo)
    completed = distributed.as_completed()
    errors: list[str] = []
    in_flight: dict[Any, tuple[int, int]] = {}

    def fill() -> None:
        for a, b in take(pending_chunks, 2 * cluster_threads(client) - len(in_flight)):
            future = client.submit(run_chunk, ref, settings, inputs.chunk(a, b), pure=False,
                                   retries=retries, key=f"nemc-sweep-{a}-{os.urandom(6).hex()}")
            in_flight[future] = (a, b)
            completed.add(future)

    try:
        fill()
        for future in completed:
            if future.status not in ("finished", "error", "cancelled"):
                # done, then lost with its worker's memory: Dask computes it again
                completed.add(future)
                continue
            a, b = in_flight.pop(future)
            if future.status == "finished":
                tracker.accept(future.result())
            else:  # failed after its retries: likely every chunk would; submit no more
                errors.append(f"runs {a}..{b - 1}: {future.exception()!r}")
                pending_chunks = iter(())
            future.release()
            fill()
    finally:
        if in_flight:
            client.cancel(list(in_flight))
    return errors


def cluster_threads(client: Any) -> int:
    """The cluster's worker threads now (workers may come and go: adaptive clusters)."""
    try:
        info = client.scheduler_info(n_workers=0)  # the totals only
    except TypeError:  # an older distributed: no n_workers
        info = client.scheduler_info()
    total = info.get("total_threads") or sum(
        w.get("nthreads", 1) for w in info.get("workers", {}).values())
    return max(1, int(total))
