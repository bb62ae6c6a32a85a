"""nemc.Taylor from a model's default build at a ladder of tolerances (issue 19), in a fresh
process per round, on one CPU (`common.one_cpu`: this machine's two CPUs can run at different
speeds), and optionally the same with another nemc checkout (--against PATH, e.g. a git
worktree of an older commit), the processes of the two alternated. Systems: the book's double
pendulum over [0, 20] and a 3-link chain over [0, 5] (`common.chain_yaml(3)`), rtol 1e-3 ...
1e-13, atol = rtol x 1e-3. Per rtol, the best of `--repeats` runs in a process, then the best
over the rounds; the final states of the two checkouts are
compared bit for bit.

Run: `python benchmarks/taylor_orders.py [--rounds 6] [--repeats 41] [--against PATH]` (a few
seconds a round once the builds are cached). Prints a Markdown table and the load average;
writes nothing. docs/decisions.md quotes it ("nemc.Taylor's Cauchy sums inlined", "nemc.Taylor's
values of one order as locals").
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402 (the benchmarks folder is not a package)
from common import ROOT  # noqa: E402

RTOLS = [10.0 ** -k for k in range(3, 14)]
SPANS = {"double pendulum": 20.0, "3-link chain": 5.0}
# One process: the model's default build with nemc.Taylor's part, each rtol timed (best of N).
RUN = """
import json, sys, time
import nemc
path, t_end, repeats = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
rtols = json.loads(sys.argv[4])
model = nemc.compile(path, taylor=True)
y0, out = model.initial_state(), {}
for rtol in rtols:
    def run():
        return model.simulate((0.0, t_end), y0, method="nemc.Taylor", rtol=rtol,
                              atol=rtol * 1e-3, t_eval=[0.0, t_end])
    result, times = run(), []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    out[repr(rtol)] = [min(times), result.y[:, -1].tolist()]
print(json.dumps({"nemc_file": nemc.__file__, "runs": out}))
"""


def one_process(path: Path, t_end: float, code: Path, cache: Path, repeats: int) -> dict:
    """The RUN script in a fresh process with nemc from CODE and NEMC_CACHE=cache."""
    env = {**os.environ, "NEMC_CACHE": str(cache), "PYTHONPATH": str(code)}
    # cwd=code: `python -c` puts the working folder ahead of PYTHONPATH on sys.path.
    done = subprocess.run([sys.executable, "-c", RUN, str(path), str(t_end), str(repeats),
                           json.dumps(RTOLS)], env=env, capture_output=True, text=True,
                          timeout=900, cwd=code)
    if f'"nemc_file": "{code.resolve()}/' not in done.stdout and done.returncode == 0:
        raise RuntimeError(f"the process did not import nemc from {code}: {done.stdout[-300:]}")
    if done.returncode != 0:
        raise RuntimeError(f"nemc.Taylor on {path} failed: {done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])["runs"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--repeats", type=int, default=41)
    parser.add_argument("--against", type=Path, help="another nemc checkout, in the same rounds")
    args = parser.parse_args()
    checkouts = {"this": ROOT} | ({"against": args.against} if args.against else {})
    env: dict = {}
    print(f"load average at start: {os.getloadavg()}")
    with tempfile.TemporaryDirectory(prefix="nemc-taylor-orders-") as scratch, \
            common.one_cpu(env):  # the processes inherit it
        chain = Path(scratch) / "chain3.yaml"
        chain.write_text(common.chain_yaml(3))
        paths = {"double pendulum": ROOT / "examples" / "double_pendulum.yaml",
                 "3-link chain": chain}
        best: dict[tuple[str, str], dict] = {}
        for _ in range(args.rounds):
            for system, path in paths.items():
                for who, code in checkouts.items():
                    run = one_process(path, SPANS[system], code, Path(scratch) / who,
                                      args.repeats)
                    kept = best.setdefault((system, who), run)
                    for rtol, (seconds, _) in run.items():
                        kept[rtol][0] = min(kept[rtol][0], seconds)
    print(f"\n{args.rounds} rounds, each in a fresh process, on CPU {env.get('pinned_cpu')}; "
          f"best of {args.repeats} runs per rtol, then over the rounds\n")
    header = "| system | rtol | this checkout |" + (
        f" {args.against} | speed-up | same bits |" if args.against else "")
    print(header)
    print("|" + " --- |" * (header.count("|") - 1))
    for system in paths:
        for rtol, (seconds, y) in best[(system, "this")].items():
            row = f"| {system} | {float(rtol):.0e} | {seconds * 1e6:.1f} µs |"
            if args.against:
                other, other_y = best[(system, "against")][rtol]
                row += f" {other * 1e6:.1f} µs | {other / seconds:.2f}x | {other_y == y} |"
            print(row)
    print(f"load average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
