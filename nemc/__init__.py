"""nemc, the Newton-Euler Mechanism Compiler: planar mechanisms in YAML -> C -> integration.

    import nemc
    model = nemc.compile("examples/double_pendulum.yaml")
    result = model.simulate()

`compile` imports the symbolic machinery (sympy) only when it must build: a cached build
loads in milliseconds.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

__version__ = "0.1.0"

if TYPE_CHECKING:
    from .runtime import Model


def compile(  # noqa: A001
    path: str | Path, *, jacobian: bool | None = None, taylor: bool | None = None
) -> Model:
    """Build the mechanism in PATH, or load its cached build, and return the Model.

    The analytic Jacobian is generated when `jacobian` is True, or (None) when the scene's
    method is implicit; otherwise it is built on the model's first call that needs it.
    nemc.Taylor's code likewise: `taylor` True, or the scene's method nemc.Taylor, or the first
    simulate(method="nemc.Taylor")."""
    from .pipeline import compile_mechanism

    return compile_mechanism(path, jacobian, taylor=taylor).model


__all__ = ["compile", "__version__"]
