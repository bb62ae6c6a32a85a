"""A sweep's Dask client for the command line (`nemc sweep --dask`): a running scheduler's
address, or a local cluster of worker processes that ignore the terminal's Ctrl-C (the sweep
handles it, with one line) and whose failure to start is one line naming its cause.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import threading
from collections.abc import Iterator
from typing import Any

from .sweep_store import require


@contextlib.contextmanager
def ctrl_c_ignored() -> Iterator[None]:
    """SIGINT ignored in the block (the main thread only; elsewhere the block just runs):
    processes started in it ignore a Ctrl-C too, so that a Ctrl-C in the terminal, which
    goes to every process of its group, stops the sweep alone, with its one line, and not
    also each local worker with its traceback. A Ctrl-C while the block runs is lost."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class WorkersFailed(RuntimeError):
    """The worker processes of `--dask local:N` could not start (one line, the cause's)."""


def local_cluster(distributed: Any, workers: int, address: str) -> Any:
    """A LocalCluster of WORKERS processes, one thread each; its workers' start failing (an
    import, a preload, memory: "Nanny failed to start" and a traceback per worker) is a
    WorkersFailed naming the first cause. Their logs below CRITICAL are silenced (not their
    cancelled tasks, nor each failed start's traceback)."""
    try:
        with ctrl_c_ignored():  # inherited by the worker processes: the sweep handles it
            return distributed.LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True,
                dashboard_address=":0", silence_logs=logging.CRITICAL)
    except (RuntimeError, OSError, TimeoutError, ImportError) as error:
        cause: BaseException = error
        while cause.__cause__ is not None or cause.__context__ is not None:
            cause = cause.__cause__ or cause.__context__  # type: ignore[assignment]
        why = f"{type(cause).__name__}: {cause}" if str(cause) else type(cause).__name__
        raise WorkersFailed(f"--dask {address}: the worker processes could not start ({why})"
                            ) from error


@contextlib.contextmanager
def dask_client(address: str | None) -> Iterator[Any]:
    """None: no client; 'local' or 'local:N': a LocalCluster of N worker processes (one
    thread each; N default: the cores); else the address of a running scheduler."""
    if address is None:
        yield None
        return
    distributed = require("distributed")
    name, _, count = address.partition(":")
    if name == "local":
        workers = int(count) if count else os.cpu_count() or 1
        cluster = local_cluster(distributed, workers, address)
        with cluster, distributed.Client(cluster) as client:
            yield client
    else:
        with distributed.Client(address, timeout="30s") as client:
            yield client

