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


def sweep(model: Model, y0s: Any = None, **options: Any) -> SweepResult:
    """Run MODEL over many initial states and parameter sets, on this machine's cores or a Dask
    cluster (client=...), into one xarray dataset (out=None, or a .zarr, .nc or .npz file).
    The options and the result: nemc.sweeps.sweep. Needs the extra nemc[sweep]."""
    from .tools.sweeps import sweep as run_sweep

    return run_sweep(model, y0s, **options)


__all__ = ["compile", "feedback", "sweep", "__version__"]
