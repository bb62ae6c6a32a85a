"""The words every stage shares: nemc's version, the integration methods it accepts (read by
the validator: a scene's `method`; the compiler: which parts a build needs; the runtime: what
`simulate` runs, and method "auto"'s rules), and the files of a built package.

Plain constants and small functions, no imports: the lowest module of nemc. The runtime of a
standalone package imports it too (nemc/build/builder.py copies it with nemc/runtime/).
"""

NEMC_VERSION = "0.1.0"

SCIPY_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
# Integrators in the model's own C (templates/integrators.c.tmpl), no Python in the loop.
NATIVE_METHODS = ("nemc.DOP853", "nemc.Radau", "nemc.Vern9", "nemc.Taylor")
AUTO = "auto"  # nemc chooses, by the rules below (Model.simulate's default)
METHODS = SCIPY_METHODS + NATIVE_METHODS + (AUTO,)
IMPLICIT_METHODS = ("Radau", "BDF", "LSODA", "nemc.Radau")  # these get the analytic Jacobian
TAYLOR_METHODS = ("nemc.Taylor",)  # these need the build's Taylor coefficients
# Contacts (format v3 `contacts`, decision 0041): explicit methods whose switch events are
# located inside the steps too (in C; scipy's by nemc/runtime/scipy_switches.py), as Coulomb
# friction's (nemc/runtime/friction.py)
CONTACT_METHODS = ("nemc.Vern9", "nemc.DOP853", "RK45", "RK23", "DOP853")
DEFAULT_METHOD = AUTO
DEFAULT_RTOL = 1e-6  # a run's tolerances when neither the call nor the scene sets them
DEFAULT_ATOL = 1e-9

# -- method "auto" ------------------------------------------------------------------------------
# Measured with benchmarks/auto.py (docs/decisions.md, "method auto"): each native method's time
# to the same final error on the double pendulum, 4- and 8-link chains and the book's stiff arm.
AUTO_TAYLOR_MAX_COORDINATES = 3  # nemc.Taylor up to this many coordinates (2: 2-3x Vern9's
#                                  speed; 4: even; 8: 3-4x slower), when the build has its code
AUTO_TAYLOR_MAX_COST_RATIO = 0.85  # and when its Cauchy sums per order over the RHS's estimated
#   ns (derive.taylor_cost_ratio, model.json's "taylor_cost_ratio") are at most this: measured
#   (benchmarks/auto.py), nemc.Taylor is the fastest at 0.54 (a free body on a spring, 3
#   coordinates), 0.62 (the double pendulum) and 0.74 (a 2-link chain), and 1.2-1.5x slower
#   than nemc.DOP853 or nemc.Vern9 at 0.99 (a 3-link chain: at 1e-6 and 1e-9; since its loop
#   over the orders inlines the Cauchy sums, 1.45x and 1.16x, and 1.06x faster at 1e-12, fb6d53a;
#   since its sums in blocks, 1.32x slower at 1e-6, even at 1e-9 and 1.21x faster at 1e-12,
#   1944b1a: not taken, 1e-6 being the default rtol) and 1.10 (4 links)
AUTO_TAYLOR_TIGHT_RTOL = 1e-8  # from this rtol down, nemc.Taylor up to a cost ratio of
AUTO_TAYLOR_TIGHT_MAX_COST_RATIO = 1.0  # this: its order grows as the tolerance shrinks where
#   a Runge-Kutta method's steps shrink instead. Measured (benchmarks/auto.py --quick, Intel
#   Xeon, 0fb3eb0): on the 3-link chain (0.99) nemc.Taylor is 1.7x slower than the fastest at
#   the final error 1e-6, 1.07x faster at 1e-9 and 1.5x faster at 1e-12 (nemc.Vern9's rtol for
#   an error of 1e-8, their break-even, is about 5e-9); on the 4-link chain (1.10) even at 1e-12
AUTO_VERN9_BELOW_RTOL = 1e-4  # nemc.Vern9 below (the same error as nemc.DOP853 in as much or
#                               less time: 1.3x on the double pendulum), nemc.DOP853 above
AUTO_STIFF_STEPS = 200  # nemc.Radau from the start when the decaying modes at y0 alone would
#                        hold an explicit method to more steps than this; an explicit start goes
#                        on with nemc.Radau once Hairer's stiffness test holds and the rest of the
#                        interval would take more steps than this
AUTO_SWITCHES_FROM = ("nemc.DOP853", "nemc.Vern9", "nemc.Taylor")  # the explicit starts, whose
#   runs take Hairer's stiffness test (templates/run_control.c.tmpl; nemc.Taylor's estimate in
#   templates/taylor.c.tmpl): auto goes on from them with nemc.Radau
AUTO_TAYLOR_BUILD_RUNS = 1_000  # an ensemble this large builds nemc.Taylor's code when the
#                                build lacks it (1-2 s once; 2,000 double pendulums: 1.1 s with
#                                nemc.DOP853, 0.3 s with nemc.Taylor in lanes)
AUTO_LANES_MIN_RUNS = 100  # simulate_many: nemc.Taylor in SIMD lanes (a build of seconds) from
#                            this many runs, or when the build has them
# simulate_many's default for AUTO_LANES_MIN_RUNS runs or more, when a build with nemc.Taylor's
# lanes is at hand: nemc.Taylor up to this many coordinates, by lanes per batch. At equal error
# 1e-3, 1e-5 and 1e-7 (benchmarks/ensemble_default.py, 400-run ensembles of chains, Intel Xeon,
# since nemc.Taylor's sums in blocks) 8 lanes are 1.5-2.4x the fastest other method at 8, 12,
# 16, 24 and 32 links (0.97-1.2x at 8 before), 4 lanes 1.2-2.2x at 4, 8 and 16 links (0.67-0.78x
# at 8 before; measured on the same AVX-512 machine: the AVX2 code): the largest measured. Never
# a reason to build the lanes (an 8-link chain's: 8 s): the gain is a fraction of a second per
# ensemble.
AUTO_LANES_TAYLOR_MAX_COORDINATES = {4: 16, 8: 32}
AUTO_SPECTRUM_MAX_STATES = 40  # the start's eigenvalues are computed up to this many states (in
#                                C, on the stack: templates/spectrum.c.tmpl)
EXPLICIT_STABILITY = 6.0  # h |lambda| nemc.DOP853 stays stable to on a decaying mode (-6.1)


def auto_builds_taylor(method: str | None, coordinates: int) -> bool:
    """Whether a build whose scene names METHOD (None: none) derives nemc.Taylor's program for
    "auto" to choose: small mechanisms, where it may be the fastest and costs little to build
    (it is kept only where auto_keeps_taylor)."""
    return method in (None, AUTO) and coordinates <= AUTO_TAYLOR_MAX_COORDINATES


def auto_takes_taylor(cost_ratio: float, rtol: float) -> bool:
    """Whether "auto" gives a single run at rtol to nemc.Taylor, by its program's cost ratio
    (derive.taylor_cost_ratio)."""
    tight = rtol <= AUTO_TAYLOR_TIGHT_RTOL
    return cost_ratio <= (AUTO_TAYLOR_TIGHT_MAX_COST_RATIO if tight else AUTO_TAYLOR_MAX_COST_RATIO)


def auto_keeps_taylor(cost_ratio: float) -> bool:
    """Whether a build for "auto" keeps nemc.Taylor's code: auto takes it at some rtol."""
    return auto_takes_taylor(cost_ratio, 0.0)


def auto_method(coordinates: int, rtol: float, has_taylor: bool, stiff_steps: float,
                taylor_max: int = AUTO_TAYLOR_MAX_COORDINATES) -> str:
    """The native method "auto" starts with. stiff_steps: the steps an explicit method would
    need over the interval for stability alone, from the decaying modes at the start (0: none
    or not computed). taylor_max: nemc.Taylor up to this many coordinates (more for an
    ensemble in lanes: AUTO_LANES_TAYLOR_MAX_COORDINATES)."""
    if stiff_steps > AUTO_STIFF_STEPS:
        return "nemc.Radau"
    if has_taylor and coordinates <= taylor_max:
        return "nemc.Taylor"
    return "nemc.Vern9" if rtol < AUTO_VERN9_BELOW_RTOL else "nemc.DOP853"


# -- the files of a built package ------------------------------------------------------------
# (nemc/build/ writes them; the front end refuses a model named like one: a model named _native
# could not import its own extension)
COMPLETE = "BUILD_OK"  # the cache's manifest: the build finished
PACKAGE_MARKER = ".nemc-package.json"  # an exported package's list of the files nemc wrote
RHS_CALL = "_rhs_call"  # Model.rhs's own extension (templates/rhs_call.c.tmpl)
DRIVERS = "nemc_drivers"  # the native integrators' C (templates/drivers.c.tmpl)
RUN_HEADER = "nemc_run"  # the header every model shares
# An exported package's copy of nemc's runtime: _nemc/vocabulary.py and _nemc/runtime/ (the
# package's __init__ imports ._nemc.runtime)
RUNTIME_PACKAGE = "_nemc"
PACKAGE_FILE_STEMS = ("__init__", "_native", RHS_CALL, "model", COMPLETE, DRIVERS, RUN_HEADER,
                      RUNTIME_PACKAGE)
