"""The runtime: a compiled mechanism as a Model (thin, checked wrappers over its C functions),
its runs and their results. It knows a model only through its package's model.json and compiled
extension, imports nothing of nemc but the vocabulary and never sympy: an exported package holds
a copy of this folder (nemc/build/builder.py, runtime_files)."""

from .model import EnsembleResult, Model, ModelError, SimulationResult, read_metadata

__all__ = ["EnsembleResult", "Model", "ModelError", "SimulationResult", "read_metadata"]
