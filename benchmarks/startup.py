"""What a fresh process pays before its first run (issue 19, lazy imports): `import nemc` and a
cached `nemc.compile` of the book's double pendulum timed inside the process (and the same
call once more, the cache's check alone), against
`import numpy` alone (the floor: the model's arrays are numpy's), and `nemc simulate` from the
command line (wall time: the interpreter's start too), with the scene's method (RK45, so scipy
is imported) and with nemc.DOP853 (no scipy). Fresh processes, interleaved, repeated; the
cache warmed first.

Run: `python benchmarks/startup.py [--rounds 7] [--pycache DIR]` (about 30 s). Prints a Markdown
table (median (min-max)) of wall times and of CPU times (user + system: what a busy machine
disturbs less), and the load average; writes nothing. Python writes no bytecode
when PYTHONDONTWRITEBYTECODE is set, and then compiles nemc's modules from source in every
process (~20 ms more); --pycache DIR unsets it and keeps the bytecode in DIR, as an installed
nemc has it. The README quotes one run.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, spread_of  # noqa: E402

EXAMPLE = ROOT / "examples" / "double_pendulum.yaml"
# Each prints pairs (wall, CPU) of seconds.
IMPORT_NUMPY = ("import time; t, c = time.perf_counter(), time.process_time(); import numpy; "
                "print(time.perf_counter() - t, time.process_time() - c)")
CACHED_COMPILE = ("import sys, time; t, c = time.perf_counter(), time.process_time(); "
                  "import nemc; i, j = time.perf_counter(), time.process_time(); "
                  "nemc.compile(sys.argv[1]); e, f = time.perf_counter(), time.process_time(); "
                  "nemc.compile(sys.argv[1]); g, h = time.perf_counter(), time.process_time(); "
                  "print(i - t, j - c, e - i, f - j, e - t, f - c, g - e, h - f)")


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(command: Sequence[str], env: dict[str, str]) -> tuple[list[float], float, float]:
    """Run COMMAND; the numbers on its last output line (if any), its wall and CPU times."""
    start, cpu = time.perf_counter(), children_cpu()
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=120,
                          cwd=ROOT)
    wall, cpu = time.perf_counter() - start, children_cpu() - cpu
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}): {done.stderr}")
    last = done.stdout.strip().splitlines()[-1] if done.stdout.strip() else ""
    try:
        return [float(v) for v in last.split()], wall, cpu
    except ValueError:  # a table, not numbers
        return [], wall, cpu


def contenders() -> dict[str, tuple[list[str], list[str]]]:
    """name -> (command, the names of the (wall, CPU) pairs it prints; [] for the process's
    own)."""
    python = sys.executable
    simulate = [python, "-m", "nemc.tools.cli", "simulate", str(EXAMPLE)]
    return {
        "python -c pass (process)": ([python, "-c", "pass"], []),
        "import numpy (in process)": ([python, "-c", IMPORT_NUMPY], ["import numpy"]),
        "nemc.compile, cached (in process)": (
            [python, "-c", CACHED_COMPILE, str(EXAMPLE)],
            ["import nemc", "nemc.compile(path)", "import nemc + nemc.compile(path)",
             "nemc.compile(path) again, same process"]),
        "nemc simulate (process; scene's RK45: scipy)": (simulate, []),
        "nemc simulate --method nemc.DOP853 (process)": (
            [*simulate, "--method", "nemc.DOP853"], []),
    }


def environment(pycache: str | None) -> dict[str, str]:
    env = dict(os.environ)
    if pycache:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = pycache
    return env


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--pycache", help="keep bytecode in this folder (see above)")
    args = parser.parse_args()
    env = environment(args.pycache)
    calls = contenders()
    for command, _ in calls.values():  # warm: the build cached, bytecode written, files read
        run(command, env)
    samples: dict[str, list[tuple[float, float]]] = {}
    names = list(calls)
    print(f"load average at start: {os.getloadavg()}")
    for r in range(args.rounds):
        for name in names[r % len(names):] + names[:r % len(names)]:
            command, labels = calls[name]
            values, wall, cpu = run(command, env)
            pairs = zip(values[::2], values[1::2]) if labels else [(wall, cpu)]
            for label, pair in zip(labels or [name], pairs):
                samples.setdefault(label, []).append(pair)
    bytecode = "kept in " + args.pycache if args.pycache else (
        "not written (PYTHONDONTWRITEBYTECODE)" if os.environ.get("PYTHONDONTWRITEBYTECODE")
        else "Python's default")
    print(f"bytecode: {bytecode}; {args.rounds} rounds\n")
    print("| what | wall, median (min-max) | CPU, median (min-max) |\n| --- | --- | --- |")
    for label, pairs in samples.items():
        print(f"| {label} | {spread_of([w for w, _ in pairs])} | "
              f"{spread_of([c for _, c in pairs])} |")
    print(f"load average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
