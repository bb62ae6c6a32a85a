"""The runtime: a compiled mechanism as a Model (thin, checked wrappers over its C functions),
its runs and their results. It knows a model only through its package's model.json and compiled
extension, imports nothing of nemc but the vocabulary and never sympy: an exported package holds
a copy of this folder (nemc/build/builder.py, runtime_files).

Its modules, lowest first: failures (what it raises), checks (a call's arguments), results,
compiled (one build's C through cffi), inputs (a run's inputs as their laws' coefficients),
parameters, loops (closed loops), built (a build's names and evaluation), outcome (a run's
RunSpec and result pieces), native, scipy_run and auto (the ways of running and the choice
among them), simulation (one run), ensemble (many), linear and plant (the model as a plant:
linearization, modes, trim, Floquet), model (the Model), load (a built package's Model); runs
holds how runs end (settings, messages, Ctrl-C, progress), for native and scipy runs alike.
"""

from .failures import ModelError
from .inputs import feedback
from .linear import Linearization, Modes
from .model import Model, read_metadata
from .plant import Floquet, OperatingPoint
from .results import EnsembleResult, SimulationResult

__all__ = ["EnsembleResult", "Floquet", "Linearization", "Model", "ModelError", "Modes",
           "OperatingPoint", "SimulationResult", "feedback", "read_metadata"]
