"""The smallest step a native method takes (templates/drivers.h.tmpl's min_step: 10 ulps of
t in the direction of integration, scipy's rule), written with the neighbouring bit pattern
instead of libm's nextafter: compiled alone and compared, bit for bit, with Python's
math.nextafter on doubles of every exponent, signs, zeros, subnormals, the largest double and
infinities."""

from __future__ import annotations

import math
import re
import struct
from pathlib import Path

import numpy as np
from c_harness import compiled_harness

from nemc.emit.resources import read_template


def min_step_source() -> str:
    text = read_template("drivers.h.tmpl")
    found = re.search(r"static inline double min_step\(.*?\n}\n", text, re.S)
    assert found, "min_step not found in drivers.h.tmpl"
    return found.group(0)


def expected(t: float, direction: float) -> float:
    return 10 * abs(math.nextafter(t, direction * math.inf) - t)


def bits(x: float) -> bytes:
    return struct.pack("<d", x)


def test_min_step_is_ten_ulps_towards_the_direction(tmp_path: Path) -> None:
    source = ("#include <math.h>\n#include <stdint.h>\n#include <string.h>\n" + min_step_source()
              + "double nemc_min_step(double t, double d) { return min_step(t, d); }\n")
    harness = compiled_harness("min_step_harness", "double nemc_min_step(double, double);",
                               source, tmp_path)
    rng = np.random.default_rng(19)
    patterns = rng.integers(0, 2**63, 20_000, dtype=np.int64).view(np.float64)
    times = [t for t in patterns.tolist() if not math.isnan(t)] + [
        0.0, -0.0, 1.0, -1.0, 2.0, -2.0, 0.5, 1024.0, 5e-324, -5e-324, 2.2250738585072014e-308,
        1e-310, 1.7976931348623157e308, -1.7976931348623157e308, math.inf, -math.inf,
        *rng.uniform(-1e3, 1e3, 2_000).tolist()]
    times += [-t for t in times]
    for t in times:
        for direction in (1.0, -1.0):
            assert bits(harness.lib.nemc_min_step(t, direction)) == bits(expected(t, direction)), \
                (t, direction)
