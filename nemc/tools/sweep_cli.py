"""`nemc sweep MECH.yaml --grid ... --random ...`: the command's options, its run (the plan
from sweep_plan.py, the runs by sweeps.py), what a Ctrl-C kept and the summary."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path


def sweep_axis(grid: bool):
    """argparse type of --grid / --random (a bad value: argparse's message, exit status 2)."""
    def parse(text: str):
        from .sweep_plan import parse_axis

        try:
            return parse_axis(text, grid)
        except ValueError as error:
            raise argparse.ArgumentTypeError(str(error)) from None
    return parse


def whole_number_from(least: int, what: str) -> Callable[[str], int]:
    """argparse type of a whole number >= LEAST (WHAT it counts, for its help)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < least:
            raise argparse.ArgumentTypeError(f"expected {what} >= {least}, got {text!r}")
        return value
    return parse


positive_int = whole_number_from(1, "a number")
whole_number = whole_number_from(0, "a whole number")  # a seed


def add_sweep_parser(commands: argparse._SubParsersAction,
                     parse_assignment: Callable[[str], tuple[str, float]],
                     finite_number: Callable[[str], float],
                     positive_number: Callable[[str], float]) -> None:
    """`nemc sweep`'s options (the shared argument types handed over by cli.py)."""
    sweep = commands.add_parser(
        "sweep", help="many runs over parameter and initial-value sets (this machine or Dask)")
    sweep.add_argument("mechanism")
    sweep.add_argument("--grid", action="append", default=[], type=sweep_axis(True),
                       metavar="NAME=START:STOP:N", help="N values from START to STOP of a "
                       "parameter or initial state (q1, dot(q1)); grids multiply (repeatable)")
    sweep.add_argument("--random", action="append", default=[], type=sweep_axis(False),
                       metavar="NAME=LOW:HIGH", help="uniform random values (repeatable)")
    sweep.add_argument("--runs", type=positive_int,
                       help="random draws (per grid point, with --grid); default 1")
    sweep.add_argument("--seed", type=whole_number, default=0,
                       help="of the random draws, a whole number >= 0 (0)")
    sweep.add_argument("--set", dest="params", type=parse_assignment, action="append",
                       default=[], metavar="NAME=VALUE", help="the same value for every run")
    sweep.add_argument("--t-end", type=finite_number, help="end time (the scene's by default)")
    sweep.add_argument("--times", type=positive_int, metavar="N", help="N output times equally"
                       " spaced from the start to the end, both included (1: the end only; "
                       "default: the scene's)")
    sweep.add_argument("--method", help="nemc.DOP853 nemc.Vern9 nemc.Taylor nemc.Radau or auto "
                       "(default: the scene's if native, else auto's choice)")
    sweep.add_argument("--rtol", type=positive_number)
    sweep.add_argument("--atol", type=positive_number)
    sweep.add_argument("--dask", type=dask_address, metavar="ADDRESS",
                       help="a Dask scheduler (tcp://host:8786), or local[:N] for N local "
                       "worker processes (N <= 4 x cores); default: this machine's threads")
    sweep.add_argument("--out", help="FILE.zarr, FILE.nc or FILE.npz (default "
                       "<name>-sweep.zarr); the same command again resumes it")
    sweep.add_argument("--resume", action="store_true",
                       help="require an interrupted sweep in --out to continue")
    sweep.add_argument("--chunk", type=positive_int, metavar="RUNS", help="runs per task")
    sweep.add_argument("--threads", type=positive_int, help="threads without --dask (cores)")
    sweep.add_argument("--no-outputs", dest="outputs", action="store_false",
                       help="store the states only, not the scene's outputs (energy, "
                       "reactions, expressions) beside them")


MAX_LOCAL_WORKERS_PER_CORE = 4  # --dask local:N: at most this many worker processes a core


def dask_address(text: str) -> str:
    """--dask: local, local:N (1 <= N <= 4 x the cores: each worker is a process), or a
    scheduler's address (distributed checks it)."""
    name, colon, count = text.partition(":")
    if name != "local" or not colon:
        return text
    most = MAX_LOCAL_WORKERS_PER_CORE * (os.cpu_count() or 1)
    try:
        workers = int(count)
    except ValueError:
        workers = 0
    if not 1 <= workers <= most:
        raise argparse.ArgumentTypeError(f"local:N: expected N, the worker processes, a whole "
                                         f"number from 1 to {most}, got {text!r}")
    return text


def cmd_sweep(args: argparse.Namespace) -> int:
    from ..pipeline import compile_mechanism
    from ..runtime.model import ModelError
    from . import sweep_cluster, sweep_plan, sweeps

    model = compile_mechanism(args.mechanism).model
    span = list(model.scene["t_span"] or [0.0, 10.0])
    if args.t_end is not None:
        span[1] = args.t_end
    out = args.out or f"{model.name}-sweep.zarr"
    try:
        if not span[1] > span[0]:
            raise ModelError(f"--t-end: must be after the start time {span[0]:g}")
        y0, params, attrs = sweep_plan.plan_runs(model, args.grid, args.random, args.runs,
                                             args.seed, dict(args.params))
        times = None if args.times is None else sweep_plan.output_times(span, args.times)
        with sweep_cluster.dask_client(args.dask) as client:
            result = sweeps.sweep(model, y0, params=params, t_span=span, t_eval=times,
                                  method=args.method, rtol=args.rtol, atol=args.atol,
                                  client=client, out=out, resume=args.resume,
                                  chunk_runs=args.chunk, threads=args.threads, attrs=attrs,
                                  outputs=args.outputs)
    except (ModelError, sweeps.SweepStoreError) as error:
        print(f"{args.mechanism}: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as stop:  # SweepInterrupted, or Ctrl-C while setting up
        print(f"\n{interrupted_sweep(stop, out)}", file=sys.stderr)
        return 130
    except (ImportError, sweep_cluster.WorkersFailed) as error:
        print(f"nemc: {error}", file=sys.stderr)
        return 1
    return report_sweep(result)


def interrupted_sweep(stop: KeyboardInterrupt, out: str) -> str:
    """What a Ctrl-C kept: the runs done, the finished runs of a store that exists, or
    nothing (before the store was made: it said runs were kept there)."""
    from .sweep_store import partial_path
    from .sweeps import SweepInterrupted

    if isinstance(stop, SweepInterrupted):
        return (f"interrupted: {stop.done} of {stop.runs} runs kept in {out}; run the same "
                "command again to continue")
    if os.path.lexists(out) or os.path.lexists(partial_path(Path(out))):
        return (f"interrupted: the finished runs kept in {out}; run the same command again to "
                "continue")
    return f"interrupted before the sweep began: nothing kept, no {out} written"


def report_sweep(result) -> int:
    """The summary: runs, time, rate, failures counted by status and listed (the first 20);
    1 if any run failed or did not run."""
    import numpy as np

    rate = f"{result.ran / result.seconds:.0f} runs/s" if result.ran else "nothing left to run"
    print(f"{result.runs} runs ({result.resumed} done before) in {result.seconds:.1f} s, "
          f"{rate}; {result.failed} failed, {result.not_run} not run -> {result.path}")
    if result.failed:
        from .sweep_store import STATUS_MEANINGS

        codes, counts = np.unique(result.status[result.status != 0], return_counts=True)
        print("failed runs: " + ", ".join(f"{n} {STATUS_MEANINGS.get(int(c), c)} ({c})"
                                          for c, n in zip(codes, counts)))
    for run, status, message in result.failures(20):
        print(f"  run {run}: status {status}: {message}")
    if result.failed > 20:
        print(f"  ... and {result.failed - 20} more (status != 0 in the file)")
    for error in result.chunk_errors:
        print(f"  chunk failed: {error}", file=sys.stderr)
    return 1 if result.failed or result.not_run else 0
