"""nemc, the Newton-Euler Mechanism Compiler: planar mechanisms in YAML -> C -> integration.

    import nemc
    model = nemc.compile("examples/double_pendulum.yaml")
    result = model.simulate()

`compile` imports the symbolic machinery (sympy) only when it must build: a cached build
loads in milliseconds.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from .vocabulary import NEMC_VERSION as __version__

if TYPE_CHECKING:
    from .runtime.model import Model
    from .tools.sweeps import SweepResult


def compile(  # noqa: A001
    path: str | Path | None = None, *, text: str | None = None, name: str = "<text>",
    jacobian: bool | None = None, taylor: bool | None = None,
) -> Model:
    """Build the mechanism in PATH, or given as YAML `text` (messages then name `name`), or
    load its cached build, and return the Model.

    The analytic Jacobian is generated when `jacobian` is True, or (None) when the scene's
    method is implicit; otherwise it is built on the model's first call that needs it.
    nemc.Taylor's code likewise: `taylor` True, or the scene's method nemc.Taylor, or the first
    simulate(method="nemc.Taylor")."""
    from .build.builder import Source
    from .pipeline import compile_mechanism, compile_source

    if (path is None) == (text is None):
        raise TypeError("nemc.compile: give a file path or text=, not both")
    if text is not None:
        if not isinstance(text, str):
            raise TypeError(f"nemc.compile: text= is the YAML as a str, got {type(text).__name__}")
        source = Source(name, text.encode("utf-8", "surrogatepass"))
        return compile_source(source, jacobian, taylor=taylor).model
    return compile_mechanism(path, jacobian, taylor=taylor).model


def feedback(K: Any, y_ref: Any = None, u_ref: Any = None, states: Any = None) -> Any:
    """A linear state feedback u = u_ref - K (y - y_ref) for simulate's inputs, evaluated in C
    by every method: inputs={"F": nemc.feedback(K)} (K a row, a column per entry of the state,
    or of STATES), or inputs=nemc.feedback(K) for every input (K a row per input)."""
    from .runtime.inputs import feedback as make

    return make(K, y_ref, u_ref, states)


def fit(model: Model, t: Any = None, data: Any = None, fit: Any = (), observed: Any = (),
        y0: Any = None, weights: Any = None, **options: Any) -> Any:
    """MODEL fitted to measured DATA at times T: the values of FIT (parameters, constant inputs,
    initial values or "y0") that minimize the weighted squared differences of the OBSERVED
    state entries or outputs from the data (n_t x len(observed), or a mapping by name), by
    scipy's least_squares with the exact Jacobian from the run's sensitivities. WEIGHTS: 1 /
    sigma (a number, one per observed, or the data's shape). Options: experiments= (a list of
    nemc.Experiment sharing the parameters, instead of t and data), bounds= (name -> (low,
    high)), start=, params= (the others' values), inputs=, method= ("auto": nemc.Vern9 or
    nemc.DOP853 in C; scipy's methods too), rtol= (1e-10), atol= (1e-12), absolute_sigma=
    (False: the errors scaled by the residuals' variance), max_nfev= (100), shots= (1: one
    run per experiment; K: multiple shooting, each experiment's time cut into K shots whose
    starts are fitted too, tied by continuity defects: a chaotic mechanism). Returns a
    FitResult (values, stderr, covariance, correlation, residual, success, runs); a fit that
    cannot identify a name, or does not converge, raises
    nemc.FitError saying which."""
    from .runtime.fitting import fit as run_fit

    return run_fit(model, t, data, fit, observed, y0, weights, **options)


def identify(model: Model, t: Any, q: Any, qd: Any, qdd: Any, tau: Any, *,
             params: Any = None, linear: Any = (), sigma: float | None = None) -> Any:
    """MODEL's base parameters (the combinations of its bodies' mass, first moments and
    inertias, and of the load coefficients named in LINEAR, that the data identify) from
    measured coordinates, rates, accelerations (every joint's, shape (coordinates, n_t)) and
    generalized forces TAU (Model.regressor's rows, shape (rows, n_t)) at times T, by linear
    least squares on tau = Y phi - Q. SIGMA: the noise's standard deviation on tau (default:
    from the residual). Returns an Identification (names, values, stderr, covariance,
    expected: the model's own values); nemc.runtime.regressor says how."""
    from .runtime.regressor import identify as estimate

    return estimate(model.regressor_at(params, tuple(linear)), t, q, qd, qdd, tau, sigma)


def sweep(model: Model, y0s: Any = None, **options: Any) -> SweepResult:
    """Run MODEL over many initial states and parameter sets, on this machine's cores or a Dask
    cluster (client=...), into one xarray dataset (out=None, or a .zarr, .nc or .npz file).
    The options and the result: nemc.sweeps.sweep. Needs the extra nemc[sweep]."""
    from .tools.sweeps import sweep as run_sweep

    return run_sweep(model, y0s, **options)


def open_sweep(source: Any, grid: Any = None) -> Any:
    """A sweep's results (a .zarr, .nc or .npz path, or a SweepResult) as an xarray Dataset,
    the runs of a grid unstacked into its dimensions. Details: nemc.tools.sweep_view.
    Needs the extra nemc[sweep]."""
    from .tools.sweep_view import open_sweep as open_view

    return open_view(source, grid)


def __getattr__(name: str) -> Any:
    """nemc.Experiment, nemc.FitError and nemc.FitResult, and nemc.BuildNotice (the warning of
    a call that compiled a build of its own), imported when first named."""
    if name in ("Experiment", "FitError", "FitResult"):
        from .runtime import fitting

        return getattr(fitting, name)
    if name == "BuildNotice":
        from .runtime.failures import BuildNotice

        return BuildNotice
    raise AttributeError(f"module 'nemc' has no attribute {name!r}")


__all__ = ["BuildNotice", "Experiment", "FitError", "FitResult", "compile", "feedback", "fit",
           "identify", "open_sweep", "sweep", "__version__"]
