"""A small model's compile in a fresh process, as a user meets it (issue 19): cold (an empty
cache), with the native integrators' object kept (the cache holds another model of the same
size: nemc_drivers.c names no model, so its object is reused), and cached (the whole build
kept), for the book's double pendulum (no Jacobian) and its 5.3 robot arm (with its Jacobian:
Radau in the drivers). Wall time of `nemc.compile` inside the process, and its build stage
(the C compiler's jobs and the links), which is what the kept object saves. Optionally the
same cold compile with another nemc checkout (--against PATH, e.g. a git worktree of an older
commit), in the same rounds. Fresh processes, interleaved, repeated; a fresh cache for every
cold sample.

Run: `python benchmarks/compile_time.py [--rounds 5] [--against PATH]` (about 30 s a round).
Prints a Markdown table (median (min-max)) and the load average; writes nothing. The README
quotes one run.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, spread_of  # noqa: E402

MODELS = {"double pendulum": ROOT / "examples" / "double_pendulum.yaml",
          "robot arm (Jacobian)": ROOT / "examples" / "robot_arm.yaml"}
# Another model of each one's size, built first into the cache whose drivers are kept
SAME_SIZE = {"double pendulum": ROOT / "examples" / "two_link_robot_arm.yaml",
             "robot arm (Jacobian)": ROOT / "examples" / "compound_pendulum.yaml"}
COMPILE = ("import json, sys, time; t = time.perf_counter(); import nemc.pipeline as p; "
           "c = p.compile_mechanism(sys.argv[1], jacobian=sys.argv[2] == 'jacobian'); "
           "print(json.dumps({'total': time.perf_counter() - t, 'cached': c.cached, "
           "'build': c.timings.get('build', 0.0)}))")


def compile_in_process(path: Path, cache: Path, code_path: Path, jacobian: bool) -> dict:
    """nemc.compile(path) in a fresh process with NEMC_CACHE=cache and nemc from code_path."""
    env = {**os.environ, "NEMC_CACHE": str(cache), "PYTHONPATH": str(code_path)}
    # cwd=code_path: `python -c` puts the working folder first on sys.path, ahead of
    # PYTHONPATH, so a run from ROOT imported ROOT's nemc whatever --against named.
    done = subprocess.run([sys.executable, "-c", COMPILE, str(path),
                           "jacobian" if jacobian else "rhs"], env=env, capture_output=True,
                          text=True, timeout=600, cwd=code_path)
    if done.returncode != 0:
        raise RuntimeError(f"compiling {path} failed: {done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def builds_without_entries(cache: Path) -> None:
    """Remove the cache's builds and keep its drivers' objects."""
    for entry in cache.iterdir():
        if entry.is_dir() and entry.name != "drivers":
            shutil.rmtree(entry)


def one_round(name: str, against: Path | None, scratch: Path) -> dict[str, dict]:
    """Each way of compiling model NAME once, in a fresh cache of its own."""
    path, jacobian = MODELS[name], "Jacobian" in name
    results = {}
    cold = scratch / "cold"
    results["cold (empty cache)"] = compile_in_process(path, cold, ROOT, jacobian)
    results["cached (the whole build kept)"] = compile_in_process(path, cold, ROOT, jacobian)
    kept = scratch / "kept"
    compile_in_process(SAME_SIZE[name], kept, ROOT, jacobian)
    builds_without_entries(kept)
    results["drivers kept (another model of its size built before)"] = compile_in_process(
        path, kept, ROOT, jacobian)
    if against is not None:
        results[f"cold, nemc at {against}"] = compile_in_process(path, scratch / "against",
                                                                 against, jacobian)
    for folder in ("cold", "kept", "against"):
        shutil.rmtree(scratch / folder, ignore_errors=True)
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--against", type=Path, help="another nemc checkout, compiled cold too")
    args = parser.parse_args()
    print(f"load average at start: {os.getloadavg()}")
    samples: dict[tuple[str, str], list[dict]] = {}
    with tempfile.TemporaryDirectory(prefix="nemc-compile-time-") as scratch:
        for _ in range(args.rounds):
            for name in MODELS:
                for way, result in one_round(name, args.against, Path(scratch)).items():
                    samples.setdefault((name, way), []).append(result)
    print(f"\n{args.rounds} rounds\n")
    print("| model | compile | nemc.compile, wall | its build stage |\n| --- | --- | --- | --- |")
    for (name, way), results in samples.items():
        print(f"| {name} | {way} | {spread_of([r['total'] for r in results])} | "
              f"{spread_of([r['build'] for r in results])} |")
    print(f"load average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
