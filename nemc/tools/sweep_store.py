"""Where a sweep's results go: one xarray dataset, in memory or streamed chunk by chunk into a
zarr store, then (for .nc and .npz) converted to the file asked for when the sweep completes.

The dataset (dimensions run, state, time):
    y (run, state, time)   the states at the output times (NaN after a run stopped)
    y0 (run, state)        the initial states (a variable: selections of y combine freely)
    outputs (run, output, time)  the scene's outputs (energy, reactions, expressions), unless
                           the sweep leaves them out (NaN where y is)
    status (run,)          0 success, < 0 failure, NOT_RUN not yet run (CF flag attributes)
    message (run,)         why a run failed ('' when it succeeded)
    nfev (run,)            right-hand-side evaluations
    coordinates: run, state (names), time, output (names) and one per varying input (run,)

A zarr store is created whole in a temporary folder and published by one rename; status is
created as NOT_RUN and each chunk's status is written after its other variables, so a chunk
counts as done only once all of it is on disk (zarr writes each chunk file atomically). A
missing chunk file means "not run": status's zarr fill value is NOT_RUN (a lost status chunk
reads so), every chunk's files are written even when they hold only the fill value, and a done
chunk missing one of its files (a lost `y` chunk) reads as NOT_RUN (issue 51). An
interrupted sweep keeps its finished chunks; the same sweep (same fingerprint) resumes them.
nemc never overwrites a file it did not write: an existing output that is not this sweep is
refused.

This module imports xarray, zarr and dask only inside the functions that need them.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import threading
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

NOT_RUN = -9
STATUS_MEANINGS = {
    0: "success", -1: "step_size_too_small", -2: "equations_failed", -3: "inputs_refused",
    NOT_RUN: "not_run",
}
# Names the dataset uses itself; an input with one of these names is stored as "input_<name>".
RESERVED = ("run", "state", "time", "y", "y0", "status", "message", "nfev", "output",
            "outputs")
FORMATS = (".zarr", ".nc", ".npz")
CHUNK_VARIABLES = ("y", "y0", "nfev", "message")  # what a chunk fills; status after them
# Stored without compression: zstd saved 3% on double-pendulum states at 5x the write time.
UNCOMPRESSED = ("y", "y0", "nfev", "outputs")
EXTRAS_HINT = "pip install 'nemc[sweep]' (dask[distributed], xarray, zarr, h5netcdf, tqdm)"


class SweepStoreError(ValueError):
    """An output that cannot be used: another sweep's, not nemc's, or of an unknown format."""


@contextlib.contextmanager
def damaged_store(path: Path) -> Iterator[None]:
    """Reading the store at PATH back: metadata nemc cannot read (edited, cut, deleted) is a
    SweepStoreError naming the store, not a traceback (issue 51)."""
    try:
        yield
    except SweepStoreError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError, OSError) as error:
        raise SweepStoreError(f"{path}: the sweep store is damaged ({type(error).__name__}: "
                              f"{error}); remove it to run the sweep afresh") from None


def require(module: str) -> Any:
    """Import an optional package of the sweep extra, or say how to install it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as error:
        raise ImportError(f"nemc sweep needs {module!r} ({error}): {EXTRAS_HINT}") from None


@dataclass
class ChunkOutput:
    """One chunk's results, as a worker returns them: runs start .. stop-1."""

    start: int
    stop: int
    y: np.ndarray  # (n, n_state, n_t)
    y0: np.ndarray  # (n, n_state)
    status: np.ndarray  # (n,) int32
    nfev: np.ndarray  # (n,) int64
    messages: list[str]
    build_key: str = ""
    seconds: float = 0.0
    outputs: np.ndarray | None = None  # (n, n_outputs, n_t): the scene's outputs, if stored


@dataclass
class Layout:
    """The shape of a sweep's dataset and what identifies the sweep."""

    runs: int
    chunk_runs: int
    state_names: tuple[str, ...]
    times: np.ndarray
    inputs: dict[str, np.ndarray]  # varying inputs: name -> (runs,) values
    attrs: dict[str, Any] = field(default_factory=dict)  # includes "nemc_sweep", the fingerprint
    output_names: tuple[str, ...] = ()  # the scene's outputs stored beside the states

    def chunks(self) -> list[tuple[int, int]]:
        starts = range(0, self.runs, self.chunk_runs)
        return [(a, min(a + self.chunk_runs, self.runs)) for a in starts]

    @property
    def fingerprint(self) -> str:
        return str(self.attrs["nemc_sweep"])

    def chunk_variables(self) -> tuple[str, ...]:
        """What a chunk fills (its status is written after them)."""
        return (*CHUNK_VARIABLES, *(("outputs",) if self.output_names else ()))


def input_name(name: str) -> str:
    return f"input_{name}" if name in RESERVED else name


def string_array(values: Any) -> np.ndarray:
    """Variable-length strings (numpy's StringDType): zarr 3 and netCDF-4 store them as such."""
    return np.array(values, dtype=np.dtypes.StringDType())


def template(layout: Layout, lazy: bool) -> Any:
    """The whole dataset before any run: y and y0 NaN, status NOT_RUN. lazy: the variables
    that chunks fill are dask arrays (to_zarr(compute=False) writes only their metadata)."""
    xr = require("xarray")
    k, c = layout.runs, layout.chunk_runs
    n_s, n_t = len(layout.state_names), len(layout.times)

    def empty(shape: tuple[int, ...], value: Any, dtype: Any) -> Any:
        if not lazy:
            return np.full(shape, value, dtype=dtype)
        return require("dask.array").full(shape, value, dtype=dtype, chunks=(c, *shape[1:]))

    status_attrs = {"flag_values": np.array(list(STATUS_MEANINGS), dtype=np.int32),
                    "flag_meanings": " ".join(STATUS_MEANINGS.values())}
    data = {
        "y": (("run", "state", "time"), empty((k, n_s, n_t), np.nan, np.float64),
              {"long_name": "state at the output times (NaN after a run stopped)"}),
        "status": (("run",), np.full(k, NOT_RUN, dtype=np.int32), status_attrs),
        "message": (("run",), empty((k,), "", np.dtypes.StringDType()),
                    {"long_name": "why the run failed ('' when it succeeded)"}),
        "nfev": (("run",), empty((k,), 0, np.int64),
                 {"long_name": "right-hand-side evaluations"}),
        "y0": (("run", "state"), empty((k, n_s), np.nan, np.float64),
               {"long_name": "initial state"}),
    }
    if layout.output_names:
        data["outputs"] = (("run", "output", "time"),
                           empty((k, len(layout.output_names), n_t), np.nan, np.float64),
                           {"long_name": "the scene's outputs at the output times (NaN where "
                                         "y is)"})
    coords = {
        "run": np.arange(k), "state": string_array(layout.state_names), "time": layout.times,
        **({"output": string_array(layout.output_names)} if layout.output_names else {}),
        **{input_name(name): (("run",), values) for name, values in layout.inputs.items()},
    }
    return xr.Dataset(data, coords=coords, attrs=dict(layout.attrs))


def chunk_values(out: ChunkOutput, name: str) -> np.ndarray:
    """One of CHUNK_VARIABLES of a chunk, in the dataset's dtype."""
    if name == "message":
        return string_array(out.messages)
    if name == "nfev":
        return out.nfev.astype(np.int64)
    return np.asarray(getattr(out, name), dtype=np.float64)


@contextlib.contextmanager
def interrupt_deferred() -> Iterator[None]:
    """Hold a Ctrl-C (SIGINT) until the block is done, then raise it: a write is never cut
    in half by the user. Only the main thread can do this; elsewhere the block just runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if received and callable(previous):
            previous(signal.SIGINT, None)  # the default handler raises KeyboardInterrupt


class MemoryStore:
    """Results kept in memory (no output file)."""

    def __init__(self, layout: Layout):
        self.layout = layout
        self.data = template(layout, lazy=False)

    def done_chunks(self) -> set[int]:
        return set()

    def write(self, out: ChunkOutput) -> None:
        rows = slice(out.start, out.stop)
        for name in self.layout.chunk_variables():
            self.data[name].values[rows] = chunk_values(out, name)
        self.data["status"].values[rows] = out.status

    def status(self) -> np.ndarray:
        return self.data["status"].values

    def finish(self) -> Any:
        return self.data

    @property
    def path(self) -> Path | None:
        return None


class ZarrStore:
    """The sweep's zarr store at PATH, created for LAYOUT or reopened to resume it."""

    def __init__(self, path: Path, layout: Layout, *, resume: bool = False):
        self.path_ = Path(path)
        self.arrays: dict[str, Any] | None = None
        if self.path_.exists():
            layout.chunk_runs = self._check_same(layout)
        elif resume:
            raise SweepStoreError(f"{self.path_}: --resume: no sweep to resume here")
        else:
            self._create(layout)
        self.layout = layout

    @property
    def path(self) -> Path:
        return self.path_

    def _check_same(self, layout: Layout) -> int:
        """The existing store's chunk size, if it is this sweep; refuse anything else."""
        attrs = read_zarr_attrs(self.path_)
        if attrs is None or "nemc_sweep" not in attrs:
            raise SweepStoreError(f"{self.path_} exists and is not a nemc sweep: nemc will not "
                                  "overwrite it; choose another output")
        if attrs["nemc_sweep"] != layout.fingerprint:
            raise SweepStoreError(
                f"{self.path_} holds a different sweep (other model, inputs or settings): "
                "choose another output, or remove it to start this sweep afresh")
        with damaged_store(self.path_):
            chunk_runs = int(attrs["chunk_runs"])
        self._check_arrays(layout)
        return chunk_runs

    def _check_arrays(self, layout: Layout) -> None:
        """Each array's own metadata file is there and readable: the group's consolidated
        copy would otherwise hide an array's edited, cut or deleted metadata from this run
        (its chunks then written under metadata no other reader finds)."""
        present = {meta.parent.name for meta in self.path_.glob("*/zarr.json")}
        for name in sorted({*layout.chunk_variables(), "status"} | present):
            meta = self.path_ / name / "zarr.json"
            try:
                array = json.loads(meta.read_text())
            except (OSError, ValueError) as error:
                raise SweepStoreError(f"{self.path_}: the sweep store is damaged ({name}: "
                                      f"{type(error).__name__}); remove it to run the sweep "
                                      "afresh") from None
            if not isinstance(array, dict) or array.get("node_type") != "array":
                raise SweepStoreError(f"{self.path_}: the sweep store is damaged ({name}: "
                                      "not an array's metadata); remove it to run the sweep "
                                      "afresh")

    def _create(self, layout: Layout) -> None:
        """Write the whole empty store in a temporary folder, then publish it by a rename."""
        scratch = self.path_.with_name(f".{self.path_.name}.tmp-{os.getpid()}")
        shutil.rmtree(scratch, ignore_errors=True)  # ours: this process's name
        dataset = template(layout, lazy=True)
        encoding = {name: {"chunks": (layout.chunk_runs, *dataset[name].shape[1:]),
                           **({"compressors": None} if name in UNCOMPRESSED else {})}
                    for name in dataset.variables if dataset[name].dims[:1] == ("run",)}
        encoding["status"]["fill_value"] = NOT_RUN  # a missing status chunk: not run
        try:
            with interrupt_deferred(), warnings.catch_warnings():
                # zarr 3 notes that consolidated metadata is not yet in its format's spec;
                # xarray and zarr read it, and without it every open_zarr warns
                warnings.filterwarnings("ignore", "Consolidated metadata", UserWarning)
                dataset.to_zarr(scratch, mode="w-", compute=False, encoding=encoding,
                                consolidated=True)
                publish(scratch, self.path_)
        finally:
            shutil.rmtree(scratch, ignore_errors=True)

    def status(self) -> np.ndarray:
        """Each run's status, NOT_RUN for the runs of a chunk whose files are not all there."""
        with damaged_store(self.path_):
            group = require("zarr").open_group(str(self.path_), mode="r")
            status = group["status"][:]
            for a, b in self.layout.chunks():
                if np.any(status[a:b] != NOT_RUN) and not self._chunk_whole(group, a):
                    status[a:b] = NOT_RUN
        return status

    def _chunk_whole(self, group: Any, start: int) -> bool:
        """Whether the files of the chunk starting at run START are all in the store."""
        for name in (*self.layout.chunk_variables(), "status"):
            array = group[name]
            index = (start // array.chunks[0],) + (0,) * (array.ndim - 1)
            if not (self.path_ / name / array.metadata.encode_chunk_key(index)).is_file():
                return False
        return True

    def done_chunks(self) -> set[int]:
        status = self.status()
        return {i for i, (a, b) in enumerate(self.layout.chunks())
                if not np.any(status[a:b] == NOT_RUN)}

    def write(self, out: ChunkOutput) -> None:
        """The chunk's variables into their zarr arrays, status last. The arrays stay open:
        an xarray region write reopens and re-checks the whole store each time (40 ms a
        chunk against 4 ms here, measured); the layout and encoding are xarray's own, from
        the template."""
        if self.arrays is None:
            with damaged_store(self.path_):
                group = require("zarr").open_group(str(self.path_), mode="r+")
                self.arrays = {name: group[name].with_config({"write_empty_chunks": True})
                               for name in (*self.layout.chunk_variables(), "status")}
        rows = slice(out.start, out.stop)
        with interrupt_deferred():
            for name in self.layout.chunk_variables():
                self.arrays[name][rows] = chunk_values(out, name)
            self.arrays["status"][rows] = out.status.astype(np.int32)

    def finish(self) -> Any:
        return with_status(open_zarr(self.path_), self.status())


def publish(scratch: Path, path: Path) -> None:
    """SCRATCH renamed PATH; when another process published PATH first (two sweeps started at
    once), a SweepStoreError naming PATH, not this process's scratch folder."""
    try:
        os.rename(scratch, path)
    except OSError as error:
        if not os.path.lexists(path):
            raise
        raise SweepStoreError(f"{path}: another sweep created it at the same time ({error.strerror}"
                              "); run the command again to continue that sweep") from None


def open_zarr(path: Path) -> Any:
    """The store's dataset, read through its consolidated metadata (written when nemc
    created it; a store of an older nemc has none and is read without)."""
    with damaged_store(path):
        consolidated = "consolidated_metadata" in (read_zarr_json(path) or {})
        return require("xarray").open_zarr(path, consolidated=consolidated)


def with_status(dataset: Any, status: np.ndarray) -> Any:
    """DATASET with STATUS (the store's, chunks whose files are lost not run)."""
    if np.array_equal(np.asarray(dataset["status"].values), status):
        return dataset
    return dataset.assign(status=(("run",), status, dataset["status"].attrs))


def read_zarr_json(path: Path) -> dict | None:
    """The zarr.json of the group at PATH, or None when it is not one."""
    try:
        group = json.loads((Path(path) / "zarr.json").read_text())
    except (OSError, ValueError):
        return None
    return group if isinstance(group, dict) else None


def read_zarr_attrs(path: Path) -> dict | None:
    """The attributes of the zarr group at PATH, or None when it is not one."""
    group = read_zarr_json(path)
    return None if group is None else group.get("attributes", {})


class ConvertedStore(ZarrStore):
    """A .nc or .npz output: the sweep streams into a zarr store beside it (FILE.partial.zarr),
    converted to FILE when every run is done, then removed."""

    def __init__(self, final: Path, layout: Layout, *, resume: bool = False):
        self.final = Path(final)
        self.complete = None
        self.arrays = None
        if self.final.exists():
            self.complete = self._finished_output(layout)
            self.layout = layout
            self.path_ = self.final
            return
        super().__init__(partial_path(self.final), layout, resume=resume)

    def _finished_output(self, layout: Layout) -> Any:
        """The dataset in FILE when FILE is this sweep, complete; refuse anything else."""
        try:
            dataset = read_output(self.final)
        except Exception:  # noqa: BLE001 - any unreadable file is simply not ours
            dataset = None
        if dataset is None or dataset.attrs.get("nemc_sweep") is None:
            raise SweepStoreError(f"{self.final} exists and is not a nemc sweep: nemc will not "
                                  "overwrite it; choose another output")
        if dataset.attrs["nemc_sweep"] != layout.fingerprint:
            raise SweepStoreError(f"{self.final} holds a different sweep: choose another output,"
                                  " or remove it to run this sweep")
        return dataset

    def status(self) -> np.ndarray:
        if self.complete is not None:
            return np.asarray(self.complete["status"].values)
        return super().status()

    def done_chunks(self) -> set[int]:
        if self.complete is not None:
            return set(range(len(self.layout.chunks())))
        return super().done_chunks()

    def finish(self) -> Any:
        if self.complete is not None:
            return self.complete
        if np.any(self.status() == NOT_RUN):  # chunks failed: keep the partial store
            return with_status(open_zarr(self.path_), self.status())
        scratch = self.final.with_name(f".{self.final.name}.tmp-{os.getpid()}")
        try:
            with interrupt_deferred():
                convert(open_zarr(self.path_), scratch, self.final.suffix)
                os.replace(scratch, self.final)
        finally:
            with contextlib.suppress(OSError):
                scratch.unlink()
        shutil.rmtree(self.path_)  # our own partial store, now converted
        self.complete = read_output(self.final)
        self.path_ = self.final
        return self.complete


def partial_path(final: Path) -> Path:
    return final.with_name(final.name + ".partial.zarr")


def convert(dataset: Any, target: Path, suffix: str) -> None:
    if suffix == ".nc":
        write_netcdf(dataset, target)
    else:
        write_npz(dataset.load(), target)


def write_netcdf(dataset: Any, target: Path) -> None:
    """netCDF-4 through h5netcdf, streamed chunk by chunk (dask), compressed."""
    require("h5netcdf")
    for variable in dataset.variables.values():
        variable.encoding = {}
    encoding = {name: {"zlib": True, "complevel": 1} for name in ("y", "y0", "outputs")
                if name in dataset.variables}
    dataset.to_netcdf(target, engine="h5netcdf", encoding=encoding)


def write_npz(dataset: Any, target: Path) -> None:
    """Every variable as a numpy array, attributes as JSON (small sweeps: loads them whole)."""
    arrays = {f"var.{name}": np.array(v.values.tolist(), dtype=str) if v.dtype.kind == "T"
              else np.asarray(v.values) for name, v in dataset.variables.items()}
    dims = {name: list(v.dims) for name, v in dataset.variables.items()}
    roles = {name: "coord" if name in dataset.coords else "data" for name in dataset.variables}
    meta = {"attrs": jsonable(dataset.attrs), "dims": dims, "roles": roles}
    with open(target, "wb") as handle:
        np.savez_compressed(handle, __meta__=np.array(json.dumps(meta)), **arrays)


def jsonable(attrs: dict) -> dict:
    return {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in attrs.items()}


def read_output(path: Path) -> Any:
    """The dataset in a finished output file (.zarr, .nc lazily; .npz into memory)."""
    xr = require("xarray")
    path = Path(path)
    if path.suffix == ".zarr":
        return open_zarr(path)
    if path.suffix == ".nc":
        require("h5netcdf")
        return xr.open_dataset(path, engine="h5netcdf", chunks={})
    with np.load(path, allow_pickle=False) as npz:
        meta = json.loads(str(npz["__meta__"]))
        variables = {name: (meta["dims"][name], npz[f"var.{name}"]) for name in meta["dims"]}
    data = {n: v for n, v in variables.items() if meta["roles"][n] == "data"}
    coords = {n: v for n, v in variables.items() if meta["roles"][n] == "coord"}
    return xr.Dataset(data, coords=coords, attrs=meta["attrs"])


def open_store(out: str | Path | None, layout: Layout, *, resume: bool = False) -> Any:
    """The store for OUT (None: in memory), created or reopened for this sweep."""
    if out is None:
        if resume:
            raise SweepStoreError("resume needs an output file")
        return MemoryStore(layout)
    path = Path(out)
    if path.suffix not in FORMATS:
        raise SweepStoreError(f"{path}: unknown output format {path.suffix!r}: use "
                              f"{', '.join(FORMATS)}")
    if path.suffix == ".zarr":
        return ZarrStore(path, layout, resume=resume)
    return ConvertedStore(path, layout, resume=resume)
