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


def compile(path: str | Path) -> Model:  # noqa: A001 (the interface's name)
    """Build the mechanism in PATH, or load its cached build, and return the Model."""
    from .pipeline import compile_mechanism

    return compile_mechanism(path).model


__all__ = ["compile", "__version__"]
