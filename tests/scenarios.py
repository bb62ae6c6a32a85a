"""The scenario table: models x their independent references x options, for the properties the
suite states once (tests/test_scenarios.py) instead of once per file.

A scenario is a mechanism (an example, a file under tests/models/, or a seeded random one from
tests/reference.py) with

- its reference: "lagrange" (tests/reference.py's Lagrange derivation, which shares nothing
  with nemc's but the validated model) or "loops" (tests/loop_reference.py's multipliers), and
  the tight solution of that reference at the scenario's times (scipy's DOP853 at rtol 1e-13);
- the times of its runs (the book's output times for the book's systems);
- the methods that apply (nemc.Taylor: not on closed loops; the explicit methods on the stiff
  arm too, their steps held by stability, as the run's message says);
- how an ensemble varies: per-run initial states, and a parameter per run.

The compiled models, references and tight solutions are made once per test process (a worker
of `make test -n 2`), on first use, and shared by every test that asks: `model`, `reference`,
`truth`. Options (methods, their tolerances, the parts a run needs: the Jacobian for Radau,
Taylor's code, its SIMD lanes) are in METHODS and PARTS.
"""

from __future__ import annotations

import functools
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from loop_reference import LoopReference
from reference import ReferenceModel, random_mechanism_yaml
from scipy.integrate import solve_ivp

import nemc
from nemc.front.validate import load_mechanism

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
MODELS = Path(__file__).resolve().parent / "models"

NATIVE = ("nemc.DOP853", "nemc.Vern9", "nemc.Radau", "nemc.Taylor")
SCIPY = ("RK45", "DOP853", "Radau", "BDF", "LSODA")


@dataclass(frozen=True)
class Tolerance:
    """A method's run against the reference: its rtol (atol = rtol / 100), and the largest
    difference to the tight solution allowed, in units of that rtol, per state scaled by 1 + |y|.
    Measured: up to 400 rtol for the explicit pairs and 2900 for BDF (the four-bar's fast crank),
    a tenth to a fifth of what is allowed."""

    rtol: float
    factor: float = 1e3

    @property
    def error(self) -> float:
        return self.factor * self.rtol


METHODS: dict[str, Tolerance] = {
    "nemc.DOP853": Tolerance(1e-10), "nemc.Vern9": Tolerance(1e-10),
    "nemc.Taylor": Tolerance(1e-10), "nemc.Radau": Tolerance(1e-9),
    "RK45": Tolerance(1e-9, 1e4), "DOP853": Tolerance(1e-10), "Radau": Tolerance(1e-8),
    "BDF": Tolerance(1e-8, 2e4), "LSODA": Tolerance(1e-8, 2e4),
}
MULTISTEP = ("BDF", "LSODA")  # their error is checked to fall with rtol too
# the build's parts a method needs (compiled_with): built once per process, on first need
PARTS: dict[str, tuple[str, ...]] = {"nemc.Radau": ("jacobian",), "Radau": ("jacobian",),
                                     "BDF": ("jacobian",), "LSODA": ("jacobian",),
                                     "nemc.Taylor": ("taylor",)}


@dataclass(frozen=True)
class Scenario:
    name: str
    source: Callable[[], Path]  # the YAML file (written on first use for generated ones)
    reference: str  # "lagrange" or "loops"
    times: tuple[float, ...]  # t_eval; the run's span is their first to last
    methods: tuple[str, ...]
    parameter: str | None = None  # an ensemble's parameter, varied per run (x 0.6 .. 1.4)
    spread: float = 0.5  # an ensemble's initial states: the scene's + uniform(-spread, spread)
    events: bool = False  # the scene has events: ensembles compare their times too
    stops: bool = False  # some runs of its ensembles end early (their states NaN after)

    @property
    def span(self) -> tuple[float, float]:
        return self.times[0], self.times[-1]

    def __str__(self) -> str:
        return self.name


def example(name: str) -> Callable[[], Path]:
    return lambda: EXAMPLES / f"{name}.yaml"


def model_file(name: str) -> Callable[[], Path]:
    return lambda: MODELS / f"{name}.yaml"


@functools.cache
def _generated_folder() -> Path:
    """Beside this test process's nemc cache (tests/conftest.py: in pytest's temporary folder,
    which pytest clears), else a new temporary folder."""
    cache = os.environ.get("NEMC_CACHE")
    if cache is None:
        return Path(tempfile.mkdtemp(prefix="nemc-scenarios-"))
    folder = Path(cache).parent / "scenario-models"
    folder.mkdir(exist_ok=True)
    return folder


def random_mechanism(seed: int, bodies: int, tree: bool, name: str) -> Callable[[], Path]:
    """tests/reference.py's seeded random mechanism (prismatic and free joints, springs, loads
    in t and dot(q)), written once per process."""
    def write() -> Path:
        path = _generated_folder() / f"{name}.yaml"
        if not path.exists():
            path.write_text(random_mechanism_yaml(np.random.default_rng(seed), bodies, tree,
                                                  name))
        return path

    return write


def linspace(start: float, stop: float, count: int) -> tuple[float, ...]:
    return tuple(float(t) for t in np.linspace(start, stop, count))


ALL = NATIVE + SCIPY
NO_TAYLOR = tuple(m for m in ALL if m != "nemc.Taylor")

SCENARIOS: dict[str, Scenario] = {s.name: s for s in (
    # the book's four systems at the book's output times
    Scenario("compound_pendulum", example("compound_pendulum"), "lagrange",
             linspace(0, 10, 21), ALL, "W"),
    Scenario("double_pendulum", example("double_pendulum"), "lagrange",
             linspace(0, 5, 11), ALL, "L2"),
    Scenario("robot_arm", example("robot_arm"), "lagrange",
             linspace(0, 10, 11), ALL, "beta"),
    Scenario("two_link_robot_arm", example("two_link_robot_arm"), "lagrange",
             linspace(0, 5, 6), ALL, "m2"),
    # seeded random mechanisms: a chain and a tree of mixed joints and loads
    Scenario("chain", random_mechanism(7, 4, False, "chain"), "lagrange",
             linspace(0, 2, 9), ALL, spread=0.3),
    Scenario("tree", random_mechanism(11, 5, True, "tree"), "lagrange",
             linspace(0, 2, 9), ALL, spread=0.3),
    # every function with a Taylor recurrence, of the state and of time
    Scenario("functions", model_file("functions"), "lagrange", linspace(0, 5, 11), ALL, "m"),
    # a closed loop: nemc.Taylor is refused on it (test_loop_runtime.py)
    Scenario("fourbar", example("fourbar"), "loops", linspace(0, 2, 41), NO_TAYLOR,
             spread=0.0),
    # events, and impacts
    Scenario("double_pendulum_events", example("double_pendulum_events"), "lagrange",
             linspace(0, 5, 11), NATIVE, events=True, spread=0.2),
    # (restitutions 0.48 to 0.61 chatter before t = 2: those runs end early, the others not)
    Scenario("bouncing_ball", example("bouncing_ball"), "lagrange", linspace(0, 2, 5),
             NATIVE, "e", spread=0.0, events=True, stops=True),
)}


def the(name: str) -> Scenario:
    return SCENARIOS[name]


def where(condition: Callable[[Scenario], bool]) -> list[Scenario]:
    return [s for s in SCENARIOS.values() if condition(s)]


def cases(condition: Callable[[Scenario], bool], methods: Callable[[Scenario], Any]
          ) -> list[tuple[Scenario, str]]:
    """(scenario, method) pairs, for parametrize: every scenario that meets CONDITION with each
    of methods(scenario)."""
    return [(s, m) for s in where(condition) for m in methods(s)]


# ---- made once per process ---------------------------------------------------------------------


@functools.cache
def model(name: str, *parts: str) -> nemc.Model:
    """The scenario's compiled model, with PARTS built (compiled_with)."""
    built = nemc.compile(SCENARIOS[name].source())
    for part in parts:
        built = built.compiled_with(part)
    return built


def model_for(name: str, method: str) -> nemc.Model:
    """The scenario's model with the parts METHOD needs already built."""
    return model(name, *PARTS.get(method, ()))


@functools.cache
def reference(name: str, params: tuple[tuple[str, float], ...] = ()) -> Any:
    """The independent reference at PARAMS (the file's values but these): its rhs(t, y) and
    initial_state() (ReferenceModel or LoopReference)."""
    mechanism = load_mechanism(SCENARIOS[name].source())
    if SCENARIOS[name].reference == "loops":
        return LoopReference(mechanism, dict(params))
    model = ReferenceModel(mechanism)
    if params:
        return _At(model, dict(params))
    return model


@dataclass(frozen=True)
class _At:
    """A ReferenceModel at parameters of its own."""

    model: ReferenceModel
    params: dict[str, float]

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        return self.model.rhs(t, y, self.params)

    def initial_state(self) -> np.ndarray:
        return self.model.initial_state(self.params)


@functools.cache
def truth(name: str, params: tuple[tuple[str, float], ...] = ()) -> np.ndarray:
    """The reference's tight solution from the scene's initial state, at the scenario's times
    (at PARAMS: the file's values but these)."""
    scenario, ref = SCENARIOS[name], reference(name, params)
    solution = solve_ivp(ref.rhs, scenario.span, ref.initial_state(), method="DOP853",
                         t_eval=scenario.times, rtol=1e-13, atol=1e-14)
    assert solution.success, solution.message
    return solution.y


def starts(name: str, runs: int, seed: int) -> np.ndarray:
    """An ensemble's initial states: the scene's moved at random by the scenario's spread (a
    closed loop's: its crank angle and rate, the rest assembled by the model)."""
    scenario, base = SCENARIOS[name], model(name)
    rng = np.random.default_rng(seed)
    if scenario.reference == "loops":
        return np.array([base.simulate((0, 0), y0={"q1": q1, "dot(q1)": rate}, t_eval=[0.0]).y[:, 0]
                         for q1, rate in zip(rng.uniform(0.5, 2.5, runs),
                                             rng.uniform(-2, 2, runs))])
    y0 = base.initial_state()
    return y0 + rng.uniform(-scenario.spread, scenario.spread, (runs, len(y0)))


def varied(name: str, runs: int) -> dict[str, np.ndarray] | None:
    """An ensemble's parameter per run: the scenario's parameter x 0.6 .. 1.4, or None."""
    scenario = SCENARIOS[name]
    if scenario.parameter is None:
        return None
    value = model(name).parameters[scenario.parameter]
    return {scenario.parameter: value * np.linspace(0.6, 1.4, runs)}


def row(params: dict[str, np.ndarray] | None, r: int) -> dict[str, float] | None:
    """Run R's parameters of an ensemble's PARAMS (None: the scene's)."""
    return None if params is None else {name: float(values[r]) for name, values in params.items()}
