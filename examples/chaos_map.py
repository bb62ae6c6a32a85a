"""The double pendulum's chaos map: where each link points at t = 10 s, over a grid of initial
angles (q1, q2), both links released at rest. Angles are absolute, from the x axis, so the
pendulum hangs at rest at q1 = q2 = -pi/2 (marked +): near it the map is smooth (small,
regular swings); towards the upright corner at (pi/2, pi/2) it breaks into fractal structure.

    python examples/chaos_map.py                          # 300 x 300 runs on this machine
    python examples/chaos_map.py --n 1000 --dask tcp://scheduler:8786
    python examples/chaos_map.py --from runs.zarr         # plot a `nemc sweep` output

`--from` takes any output of `nemc sweep` with two --grid axes (q1 first, then q2), e.g. the
10^6 runs of docs/cluster.md; the runs are written to (and resumed from) --data.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MECHANISM = ROOT / "examples" / "double_pendulum.yaml"


def run_grid(n: int, data: Path, address: str | None) -> object:
    """n x n runs (q1 slowest) over [-pi, pi]^2, final states at t = 10, as `nemc sweep
    --grid q1=-pi:pi:n --grid q2=-pi:pi:n --t-end 10 --times 1 --method nemc.Taylor`."""
    import nemc
    from nemc.tools.sweeps import dask_client, sweep

    model = nemc.compile(MECHANISM, taylor=True)
    axis = np.linspace(-math.pi, math.pi, n)
    q1, q2 = np.meshgrid(axis, axis, indexing="ij")
    grid = [{"name": name, "low": -math.pi, "high": math.pi, "count": n} for name in ("q1", "q2")]
    with dask_client(address) as client:
        result = sweep(model, {"q1": q1.ravel(), "q2": q2.ravel()}, t_span=(0.0, 10.0),
                       t_eval=[10.0], method="nemc.Taylor", rtol=1e-8, client=client, out=data,
                       attrs={"grid": json.dumps(grid)})
    print(f"{result.runs} runs ({result.resumed} done before) in {result.seconds:.1f} s; "
          f"{result.failed} failed -> {data}")
    return result.dataset


def wrapped(angle: np.ndarray) -> np.ndarray:
    """An angle in (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, 2 * np.pi)


def final_angles(dataset) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """(final q1, final q2) on the grid, as (n_q1, n_q2) arrays, and the grid's axes."""
    grid = json.loads(dataset.attrs["grid"])
    if [axis["name"] for axis in grid] != ["q1", "q2"]:
        sys.exit(f"expected a sweep with --grid q1=... --grid q2=..., got {grid}")
    shape = (grid[0]["count"], grid[1]["count"])
    final = dataset["y"].isel(time=-1)
    q1 = final.sel(state="q1").values.reshape(shape)
    q2 = final.sel(state="q2").values.reshape(shape)
    return wrapped(q1), wrapped(q2), grid


def plot(dataset, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    q1, q2, grid = final_angles(dataset)
    extent = [grid[0]["low"], grid[0]["high"], grid[1]["low"], grid[1]["high"]]
    t_end = float(dataset["time"].values[-1])
    figure, axes = plt.subplots(1, 2, figsize=(11, 5.2), constrained_layout=True)
    for ax, values, name in zip(axes, (q1, q2), ("q1", "q2")):
        image = ax.imshow(values.T, origin="lower", extent=extent, cmap="twilight",
                          vmin=-np.pi, vmax=np.pi, interpolation="antialiased")
        ax.plot([-np.pi / 2], [-np.pi / 2], "k+", markersize=12)
        ax.set_xlabel("initial q1 (rad, from the x axis)")
        ax.set_ylabel("initial q2 (rad)")
        ax.set_title(f"{name} at t = {t_end:g} s")
    figure.colorbar(image, ax=axes, label="final angle (rad), wrapped to (-π, π]",
                    shrink=0.8)
    runs = dataset.sizes["run"]
    figure.suptitle(f"Double pendulum chaos map: {grid[0]['count']} x {grid[1]['count']} = "
                    f"{runs:,} runs from rest ({dataset.attrs['method']}, rtol "
                    f"{dataset.attrs['rtol']:g}); + hanging at rest")
    figure.savefig(out, dpi=110)
    print(f"figure written to {out}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=300, help="grid points per angle (300)")
    parser.add_argument("--dask", help="a Dask scheduler address, or local[:N]")
    parser.add_argument("--data", type=Path, default=ROOT / "generated" / "chaos_map.zarr",
                        help="where the runs go (resumed if there)")
    parser.add_argument("--from", dest="source", type=Path,
                        help="plot this `nemc sweep` output instead of running")
    parser.add_argument("--out", type=Path, default=ROOT / "generated" / "chaos_map.png")
    args = parser.parse_args()
    if args.source is not None:
        from nemc.tools.sweep_store import read_output

        dataset = read_output(args.source)
    else:
        dataset = run_grid(args.n, args.data, args.dask)
    plot(dataset, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
