"""Method "auto"'s look at the start in C (templates/spectrum.c.tmpl), compiled alone: its
eigenvalues against LAPACK's (numpy.linalg.eigvals) on seeded random matrices, mechanical
Jacobians with gains of 1e4 and the matrices that stall unshifted QR; the stiff rate of given
eigenvalues; and the whole look (trace shortcut, eigenvalues, forward differences of an RHS,
non-finite Jacobians) against the same rules computed here with numpy."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from c_harness import compiled_harness
from scipy.optimize import linear_sum_assignment

from nemc.emit.resources import read_template

# The model's Jacobian and RHS, stand-ins: p holds the n x n matrix A; jacobian writes A,
# rhs writes A y (its forward differences are A up to rounding).
HARNESS = """
#include <math.h>
#include <string.h>
"""
CALLERS = """
static int n_of_test;
int eigenvalues(int n, double *a, double *re, double *im)
{
    return spectrum_eigenvalues(n, a, re, im);
}

double stiff_rate(int n, const double *re, const double *im)
{
    return spectrum_stiff_rate(n, re, im);
}

static int matrix_jacobian(double t, const double *y, const double *p, double *jac)
{
    (void)t; (void)y;
    memcpy(jac, p, sizeof(double) * (size_t)(n_of_test * n_of_test));
    return 0;
}

static int linear_rhs(double t, const double *y, const double *p, double *dy)
{
    (void)t;
    for (int i = 0; i < n_of_test; ++i) {
        dy[i] = 0.0;
        for (int j = 0; j < n_of_test; ++j)
            dy[i] += p[i * n_of_test + j] * y[j];
    }
    return 0;
}

int start_steps(int n, int differences, const double *y, const double *a, double per_step,
                double enough, double *work, double *steps)
{
    n_of_test = n;
    return spectrum_start_steps(linear_rhs, differences ? NULL : matrix_jacobian, n, 0.0, y,
                                a, per_step, enough, work, steps);
}
"""
CDEF = """
int eigenvalues(int n, double *a, double *re, double *im);
double stiff_rate(int n, const double *re, const double *im);
int start_steps(int n, int differences, const double *y, const double *a, double per_step,
                double enough, double *work, double *steps);
"""


@pytest.fixture(scope="module")
def spectrum(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    """The template's functions in a cffi module, compiled warning-free (-Wall -Wextra)."""
    folder = tmp_path_factory.mktemp("spectrum")
    source = HARNESS + read_template("spectrum.c.tmpl") + CALLERS
    module = compiled_harness("_nemc_spectrum_test", CDEF, source, folder)
    buffer = module.ffi.from_buffer

    def eigenvalues(matrix: np.ndarray) -> np.ndarray:
        a = np.array(matrix, dtype=float, order="C")
        n = len(a)
        re, im = np.empty(n), np.empty(n)
        status = module.lib.eigenvalues(n, buffer("double[]", a), buffer("double[]", re),
                                        buffer("double[]", im))
        assert status == 0, "the QR iterations did not converge"
        return re + 1j * im

    def stiff_rate(values: list[complex]) -> float:
        re = np.array([v.real for v in values] or [0.0])
        im = np.array([v.imag for v in values] or [0.0])
        return module.lib.stiff_rate(len(values), buffer("double[]", re), buffer("double[]", im))

    def start_steps(matrix: np.ndarray, per_step: float, enough: float,
                    differences: bool = False) -> tuple[int, float]:
        a = np.array(matrix, dtype=float, order="C")
        n = len(a)
        y, work, steps = np.zeros(n), np.empty(n * (n + 3)), module.ffi.new("double *")
        status = module.lib.start_steps(n, differences, buffer("double[]", y),
                                        buffer("double[]", a), per_step, enough,
                                        buffer("double[]", work), steps)
        return status, steps[0]

    return SimpleNamespace(eigenvalues=eigenvalues, stiff_rate=stiff_rate,
                           start_steps=start_steps)


def assert_same_spectrum(found: np.ndarray, expected: np.ndarray, tolerance: float) -> None:
    """Each eigenvalue matched to one of LAPACK's (the closest assignment) within tolerance."""
    assert len(found) == len(expected)
    distance = np.abs(found[:, None] - expected[None, :])
    rows, columns = linear_sum_assignment(distance)
    assert distance[rows, columns].max() <= tolerance, (found, expected)


def mechanical_jacobian(rng: np.random.Generator, coordinates: int, gain: float) -> np.ndarray:
    """[[0, I], [-M^-1 K, -M^-1 B]]: a controlled chain's Jacobian, gains up to `gain` on
    inertias of order 1 (the book's stiff arm is of this kind)."""
    root = rng.normal(size=(coordinates, coordinates))
    mass = root @ root.T + coordinates * np.eye(coordinates)
    stiffness, damping = (gain * np.diag(rng.uniform(0.1, 1.0, coordinates)) for _ in range(2))
    inverse = np.linalg.inv(mass)
    zero, one = np.zeros((coordinates, coordinates)), np.eye(coordinates)
    return np.block([[zero, one], [-inverse @ stiffness, -inverse @ damping]])


def test_eigenvalues_match_lapack_on_random_matrices(spectrum: SimpleNamespace) -> None:
    rng = np.random.default_rng(1919)
    for n in [*range(1, 13), 16, 20, 27, 33, 40]:
        for _ in range(8):
            matrix = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-3, 3)
            expected = np.linalg.eigvals(matrix)
            assert_same_spectrum(spectrum.eigenvalues(matrix), expected,
                                 1e-9 * np.abs(matrix).sum(axis=1).max())


def test_eigenvalues_of_badly_scaled_mechanical_jacobians(spectrum: SimpleNamespace) -> None:
    """Balancing keeps the slow and the fast modes accurate together: gains of 1e4 beside
    unit inertias, each eigenvalue within 1e-9 of its own size."""
    rng = np.random.default_rng(54)
    for coordinates in (1, 2, 3, 5, 8, 20):
        for gain in (1.0, 1e2, 1e4):
            matrix = mechanical_jacobian(rng, coordinates, gain)
            expected = np.linalg.eigvals(matrix)
            found = spectrum.eigenvalues(matrix)
            assert_same_spectrum(found, expected, 1e-9 * np.abs(expected).max())
            assert np.sort(np.abs(found)) == pytest.approx(np.sort(np.abs(expected)), rel=1e-8)


def test_balancing_keeps_the_small_eigenvalues_of_a_badly_scaled_matrix(
        spectrum: SimpleNamespace) -> None:
    """D A D^-1 has A's eigenvalues: with D over twelve decades, unbalanced QR would lose the
    small ones in the large entries' rounding."""
    rng = np.random.default_rng(7)
    for n in (4, 6, 10):
        vectors = rng.normal(size=(n, n))
        values = -(10.0 ** rng.uniform(-3, 3, n))
        matrix = vectors @ np.diag(values) @ np.linalg.inv(vectors)
        scale = 10.0 ** np.linspace(-6, 6, n)
        scaled = scale[:, None] * matrix / scale[None, :]
        found = np.sort_complex(spectrum.eigenvalues(scaled))
        assert found.real == pytest.approx(np.sort(np.linalg.eigvals(matrix).real), rel=1e-6)


def test_eigenvalues_where_plain_qr_stalls(spectrum: SimpleNamespace) -> None:
    """The cyclic shift (roots of unity: the exceptional shifts must break the cycle), the
    zero matrix, a triangular one, a real pair of equal values and a companion matrix whose
    roots are known."""
    for n in (2, 3, 4, 7, 12):
        cyclic = np.roll(np.eye(n), 1, axis=0)
        assert_same_spectrum(spectrum.eigenvalues(cyclic), np.exp(2j * np.pi * np.arange(n) / n),
                             1e-12)
    assert_same_spectrum(spectrum.eigenvalues(np.zeros((5, 5))), np.zeros(5), 0.0)
    triangular = np.triu(np.arange(1.0, 17.0).reshape(4, 4))
    assert_same_spectrum(spectrum.eigenvalues(triangular), np.diag(triangular), 1e-12)
    assert_same_spectrum(spectrum.eigenvalues([[3.0, 1.0], [0.0, 3.0]]), np.array([3.0, 3.0]),
                         1e-12)
    roots = np.array([-1.0, -2.0, -30.0, -1 + 4j, -1 - 4j, 0.5])
    companion = np.zeros((6, 6))
    companion[0] = -np.poly(roots)[1:].real
    companion[1:, :-1] = np.eye(5)
    assert_same_spectrum(spectrum.eigenvalues(companion), roots, 1e-9)


def test_the_stiff_rate_is_the_fastest_damped_decay_less_the_fastest_growth(
        spectrum: SimpleNamespace) -> None:
    assert spectrum.stiff_rate([-100.0, -1 + 5j, -1 - 5j]) == 100.0
    assert spectrum.stiff_rate([-100.0, 3.0]) == 97.0  # the growth must be resolved anyway
    assert spectrum.stiff_rate([-1 + 50j, -1 - 50j]) == 0.0  # an oscillation, not damped
    assert spectrum.stiff_rate([-50 + 1j, -50 - 1j, -3.0]) == 50.0  # damped beyond its frequency
    assert spectrum.stiff_rate([2.0, -1.0]) == 0.0
    assert spectrum.stiff_rate([]) == 0.0


def expected_steps(matrix: np.ndarray, per_step: float, enough: float) -> float:
    """The look's rules, here with numpy: the trace's estimate up to `enough`, else the stiff
    rate of LAPACK's eigenvalues."""
    dissipation = -np.trace(matrix) * per_step
    if dissipation <= enough:
        return max(dissipation, 0.0)
    values = np.linalg.eigvals(matrix)
    decay = -values.real
    damped = decay[decay > np.abs(values.imag)]
    if damped.size == 0:
        return 0.0
    return max(damped.max() - max(values.real.max(), 0.0), 0.0) * per_step


def test_the_start_look_follows_its_rules(spectrum: SimpleNamespace) -> None:
    rng = np.random.default_rng(2026)
    for coordinates in (1, 2, 4, 10):
        for gain in (0.1, 10.0, 1e4):
            matrix = mechanical_jacobian(rng, coordinates, gain)
            for per_step in (0.01, 1.0, 100.0):
                expected = expected_steps(matrix, per_step, 200.0)
                status, steps = spectrum.start_steps(matrix, per_step, 200.0)
                assert status == 0 and steps == pytest.approx(expected, rel=1e-9, abs=1e-12)
                status, steps = spectrum.start_steps(matrix, per_step, 200.0, differences=True)
                assert status == 0 and steps == pytest.approx(expected, rel=1e-4, abs=1e-9)
    # a growing mode beside a decaying one: the trace says little, the eigenvalues decide
    assert spectrum.start_steps(np.diag([-1e4, 50.0]), 1.0, 200.0) == (0, 1e4 - 50.0)
    assert spectrum.start_steps(np.diag([-10.0, 3.0]), 1.0, 200.0) == (0, 7.0)  # the trace's


def test_a_jacobian_that_is_not_finite_says_nothing(spectrum: SimpleNamespace) -> None:
    for bad in (np.nan, np.inf):
        matrix = np.diag([-1e6, -1.0])
        matrix[0, 1] = bad
        assert spectrum.start_steps(matrix, 1.0, 200.0) == (0, 0.0)
    assert spectrum.start_steps(np.diag([-np.inf, -1.0]), 1.0, 200.0) == (0, 0.0)
