"""nemc.Taylor's own sin, cos, log2 and exp2 (templates/taylor_math.c.tmpl), compiled alone over
one-element vectors (the scalar runs') and four lanes (the SIMD lanes'): sin and cos below 1 ulp
of mpmath's values at 200 bits (1e-16 absolute near multiples of pi/2), the step size's log2
within 4e-6 and exp2 within 3e-7, and the same bits in both instantiations, lane by lane,
whatever the other lanes hold."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import mpmath
import numpy as np
import pytest
from c_harness import compiled_harness

from nemc.emit.math_kernels import taylor_math

HARNESS = """
#include <math.h>
typedef double taylor_double1 __attribute__((vector_size(8)));
typedef unsigned long long taylor_bits1 __attribute__((vector_size(8)));
typedef double lanes __attribute__((vector_size(32)));
typedef unsigned long long lane_bits __attribute__((vector_size(32)));
#pragma GCC diagnostic ignored "-Wpsabi"
"""

# Each function over n values (n a multiple of 4), into out (and out2: cos).
CALLERS = """
void one_sincos(int n, const double *x, double *out, double *out2)
{
    for (int i = 0; i < n; ++i) {
        const taylor_double1 v = {x[i]};
        taylor_double1 s, c;
        math1_sincos(&v, &s, &c);
        out[i] = s[0];
        out2[i] = c[0];
    }
}

void four_sincos(int n, const double *x, double *out, double *out2)
{
    for (int i = 0; i + 4 <= n; i += 4) {
        const lanes v = {x[i], x[i + 1], x[i + 2], x[i + 3]};
        lanes s, c;
        lanes_math_sincos(&v, &s, &c);
        for (int l = 0; l < 4; ++l) {
            out[i + l] = s[l];
            out2[i + l] = c[l];
        }
    }
}
#define ONE_AND_FOUR(f)                                                      \\
    void one_##f(int n, const double *x, double *out, double *out2)          \\
    {                                                                        \\
        (void)out2;                                                          \\
        for (int i = 0; i < n; ++i) {                                        \\
            const taylor_double1 v = {x[i]};                                 \\
            taylor_double1 r;                                                \\
            math1_##f(&v, &r);                                               \\
            out[i] = r[0];                                                   \\
        }                                                                    \\
    }                                                                        \\
    void four_##f(int n, const double *x, double *out, double *out2)         \\
    {                                                                        \\
        (void)out2;                                                          \\
        for (int i = 0; i + 4 <= n; i += 4) {                                \\
            const lanes v = {x[i], x[i + 1], x[i + 2], x[i + 3]};            \\
            lanes r;                                                         \\
            lanes_math_##f(&v, &r);                                          \\
            for (int l = 0; l < 4; ++l)                                      \\
                out[i + l] = r[l];                                           \\
        }                                                                    \\
    }
ONE_AND_FOUR(log2)
ONE_AND_FOUR(exp2)
"""

Run = Callable[[str, np.ndarray], tuple[np.ndarray, np.ndarray]]


@pytest.fixture(scope="module")
def kernels(tmp_path_factory: pytest.TempPathFactory) -> Run:
    """The functions as the builds instantiate them (nemc.emit.math_kernels.taylor_math), in a cffi
    module:
    run("one_sincos" | "four_log2" | ..., x) -> (out, out2)."""
    folder = tmp_path_factory.mktemp("taylor_math")
    cdef = "".join(f"void {width}_{f}(int, const double *, double *, double *);"
                   for width in ("one", "four") for f in ("sincos", "log2", "exp2"))
    source = (HARNESS + taylor_math("math1_", "taylor_double1", "taylor_bits1", "one value")
              + taylor_math("lanes_math_", "lanes", "lane_bits", "four lanes") + CALLERS)
    module = compiled_harness("_nemc_taylor_math_test", cdef, source, folder)

    def run(which: str, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.ascontiguousarray(x, dtype=float)
        assert len(x) % 4 == 0
        out, out2 = np.empty_like(x), np.empty_like(x)
        buffer = module.ffi.from_buffer
        getattr(module.lib, which)(len(x), buffer("double[]", x), buffer("double[]", out),
                                   buffer("double[]", out2))
        return out, out2

    return run


def four_of(values: np.ndarray) -> np.ndarray:
    return values[: len(values) // 4 * 4]


def angles(seed: int) -> np.ndarray:
    """Angles a mechanism meets, whole turns, near multiples of pi/2 (where the reduction
    cancels) and up to the end of the reduction's range, seeded."""
    rng = np.random.default_rng(seed)
    near = np.arange(-400, 400) * (math.pi / 2)
    return four_of(np.concatenate([
        rng.uniform(-4, 4, 2000), rng.uniform(-1e3, 1e3, 1000), rng.uniform(-1.6e6, 1.6e6, 400),
        near, np.nextafter(near, np.inf), near + rng.uniform(-1e-6, 1e-6, near.size),
        rng.uniform(-1e-8, 1e-8, 200), [0.0, -0.0, 5e-324, 1e-300, math.pi / 4, 3 * math.pi / 4],
    ]))


def positives(seed: int) -> np.ndarray:
    """log2's arguments: ratios of a state's size to a coefficient's, over the normal range."""
    rng = np.random.default_rng(seed)
    return four_of(np.concatenate([
        10.0 ** rng.uniform(-300, 300, 1500), rng.uniform(0.5, 2.0, 1000),
        np.nextafter(math.sqrt(2), [0, 4]), [1.0, 2.0, 0.5, 2.2250738585072014e-308, 1.7e308],
    ]))


def exponents(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return four_of(np.concatenate([rng.uniform(-999, 999, 1500), rng.uniform(-1, 1, 1000),
                                   [0.0, -0.0, 1e-20, 999.9, -999.9, 0.5, -0.5, 3.0]]))


def ulp_errors(x: np.ndarray, values: np.ndarray, exact: Callable) -> np.ndarray:
    mpmath.mp.prec = 200
    errors = np.empty(len(x))
    for i, (xi, vi) in enumerate(zip(x, values)):
        reference = exact(mpmath.mpf(float(xi)))
        ulp = math.ulp(float(reference)) if reference != 0 else 5e-324
        errors[i] = abs(float((mpmath.mpf(float(vi)) - reference) / ulp))
    return errors


def test_sin_and_cos_within_one_ulp_and_1e16_of_mpmath(kernels: Run) -> None:
    """Below 1 ulp where the value exceeds 1e-6; near the multiples of pi/2 (one round of the
    reduction) below 1e-16 absolute."""
    x = angles(7)
    s, c = kernels("one_sincos", x)
    mpmath.mp.prec = 200
    for values, exact in ((s, mpmath.sin), (c, mpmath.cos)):
        ulps = ulp_errors(x, values, exact)
        large = np.abs(values) > 1e-6
        assert ulps[large].max() < 1.0, x[large][np.argmax(ulps[large])]
        assert np.mean(ulps[large]) < 0.3  # mostly correctly rounded
        absolute = [abs(float(mpmath.mpf(float(v)) - exact(mpmath.mpf(float(xi)))))
                    for xi, v in zip(x, values)]
        assert max(absolute) < 1e-16, x[int(np.argmax(absolute))]
        assert (~large).sum() > 500  # the arguments near multiples of pi/2 are tested


def test_log2_within_4e6(kernels: Run) -> None:
    x = positives(11)
    values, _ = kernels("one_log2", x)
    mpmath.mp.prec = 200
    errors = [abs(float(mpmath.mpf(float(v)) - mpmath.log(mpmath.mpf(float(xi)), 2)))
              for xi, v in zip(x, values)]
    assert max(errors) < 4e-6, x[int(np.argmax(errors))]
    assert values[list(x).index(1.0)] == 0.0 and values[list(x).index(2.0)] == 1.0


def test_exp2_within_3e7(kernels: Run) -> None:
    x = exponents(12)
    values, _ = kernels("one_exp2", x)
    mpmath.mp.prec = 200
    relative = [abs(float(mpmath.mpf(float(v)) / mpmath.power(2, mpmath.mpf(float(xi))) - 1))
                for xi, v in zip(x, values)]
    assert max(relative) < 3e-7, x[int(np.argmax(relative))]
    assert values[list(x).index(3.0)] == 8.0  # whole powers of two are exact


@pytest.mark.parametrize("name, arguments, odd", [
    ("sincos", angles, [np.nan, np.inf, -np.inf, 2e6, -1e300, 1e20]),
    ("log2", positives, [np.nan, np.inf, 0.0, -1.0, 5e-324, 1e-310]),
    ("exp2", exponents, [np.nan, np.inf, -np.inf, 1000.0, -1075.5, 1e10]),
])
def test_lanes_give_the_scalar_bits(kernels: Run, name: str, arguments: Callable,
                                    odd: list[float]) -> None:
    x = arguments(8)
    rng = np.random.default_rng(9)
    x[rng.choice(len(x), 200, replace=False)] = rng.choice(odd, 200)  # libm's among the others
    with np.errstate(invalid="ignore"):
        one, four = kernels(f"one_{name}", x), kernels(f"four_{name}", x)
    for a, b in zip(one, four) if name == "sincos" else [(one[0], four[0])]:
        assert np.array_equal(a.view(np.int64), b.view(np.int64))


def test_sin_odd_and_cos_even(kernels: Run) -> None:
    x = angles(10)
    s, c = kernels("one_sincos", x)
    s_neg, c_neg = kernels("one_sincos", -x)
    assert np.array_equal(s_neg, -s) and np.array_equal(c_neg, c)


@pytest.mark.parametrize("name, x, functions", [
    ("sincos", [2e6, -3.5e7, 1e300, np.inf, -np.inf, np.nan, 1647100.0, -1e22],
     (math.sin, math.cos)),
    ("log2", [0.0, -1.0, 5e-324, 1e-310, np.inf, np.nan, -np.inf, 2e-308], (math.log2,)),
    ("exp2", [1000.0, -1000.0, 1023.9, -1074.0, 1e5, np.inf, -np.inf, np.nan], (math.exp2,)),
])
def test_outside_their_range_libm_decides(kernels: Run, name: str, x: list[float],
                                          functions: tuple[Callable, ...]) -> None:
    """Python's math is libm's; NaN where libm raises (math.log2(0): -inf in C)."""
    outputs = kernels(f"four_{name}", np.array(x))
    c_values = {0.0: -math.inf}

    def libm(function: Callable, v: float) -> float:
        if math.isnan(v) or (math.isinf(v) and function in (math.sin, math.cos)):
            return math.nan
        try:
            return function(v)
        except ValueError:
            return c_values.get(v, math.nan)
        except OverflowError:
            return math.inf

    for function, values in zip(functions, outputs):
        assert np.array_equal(values, [libm(function, v) for v in x], equal_nan=True), function


def test_the_functions_are_what_the_builds_use() -> None:
    templates = Path(__file__).resolve().parents[1] / "templates"
    taylor, lanes = ((templates / name).read_text() for name in ("taylor.c.tmpl", "batch.c.tmpl"))
    assert "math1_sincos(&a0, &sin_a, &cos_a)" in taylor
    assert "math1_log2(&ratio, &log2_ratio)" in taylor
    assert "math1_exp2(&log2_rho, &rho)" in taylor
    assert "lanes_math_sincos(&a[0], &s[0], &c[0])" in lanes
