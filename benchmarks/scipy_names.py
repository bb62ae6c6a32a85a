"""scipy's DOP853 against its native port nemc.DOP853 (the same steps in C) and the default,
auto, on the examples whose scenes named DOP853 until issue 52, at each scene's tolerances:
each time the best of 5 runs in this process (cached builds), and the largest difference of the
port's states from scipy's. Decision 0037 quotes its table.

    python benchmarks/scipy_names.py [EXAMPLE ...]
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import nemc

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
NAMED_DOP853 = ("fourbar", "fourbar_driven", "slider_crank", "kapitza", "andrews",
                "weld_t_pendulum", "body_frame_thruster", "prismatic_cart_pendulum",
                "joint_spring_telescope", "damped_spring_pendulum", "free_body_on_spring")


def best(run: Callable[[], Any], repeats: int = 5) -> tuple[float, Any]:
    """The shortest wall time of `repeats` calls, and the last call's result."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return min(times), result


def row(name: str) -> str:
    """One example's times (ms), the two ratios, auto's choice and the port's difference."""
    model = nemc.compile(EXAMPLES / f"{name}.yaml")
    scipy, by_scipy = best(lambda: model.simulate(method="DOP853"))
    port, by_port = best(lambda: model.simulate(method="nemc.DOP853"))
    auto, by_auto = best(lambda: model.simulate(method="auto"))
    difference = float(np.max(np.abs(by_scipy.y - by_port.y)))
    return (f"{name:26s} {scipy * 1e3:9.2f} {port * 1e3:11.2f} {auto * 1e3:9.2f} "
            f"{scipy / port:6.0f}x {scipy / auto:6.0f}x {by_auto.method:>12s} {difference:10.1e}")


def main(names: list[str]) -> None:
    print(f"{'example':26s} {'DOP853 ms':>9s} {'nemc.DOP853':>11s} {'auto ms':>9s} "
          f"{'port':>7s} {'auto':>7s} {'auto ran':>12s} {'|port-scipy|':>10s}")
    for name in names or NAMED_DOP853:
        print(row(name), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
