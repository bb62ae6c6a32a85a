"""How far to trust a simulation: measurements of a compiled mechanism's numerical behaviour.

Each function measures one thing and returns a plain value (`nemc.stress_report` writes them
up): accuracy against a tight reference per method and tolerance, energy drift over a long
horizon, sensitivity to the initial state (largest Lyapunov exponent), stiffness (the Jacobian's
eigenvalues along the trajectory), conditioning of the mass matrix, and the error estimate of
one run that `nemc simulate --error-estimate` prints. Every run goes through `Model.simulate`.
With Coulomb friction or contacts the methods are nemc.Vern9 and nemc.DOP853, the reference
nemc.Vern9, and the energy is a balance against the friction's work and the impacts' losses
(`energy_balance`, from the run's outputs NAME.friction_work and NAME.impact_loss).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..runtime import model as runtime
from ..runtime import runs
from ..runtime.friction import FRICTION_METHODS
from ..runtime.model import Model, SimulationResult

Params = Mapping[str, float] | None

BOOK_RTOL, BOOK_ATOL = 1e-3, 1e-6  # MATLAB's ode45 defaults, which the book's programs use
TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)  # atol = rtol / 1000
DRIFT_TOLERANCES = (1e-3, 1e-6, 1e-9)
REFERENCE_RTOL = 1e-12
TRUST_ERROR = 1e-3  # "reproduces the curve": max |y - y_true| at most this
CONSERVED = 1e-7  # |dE/dt| / |dT/dt| below this along the trajectory: energy is conserved
ILL_CONDITIONED, NEAR_SINGULAR = 1e6, 1e10  # cond(M): digits lost in the accelerations
STIFF_RATIO, STIFF_STEP = 100.0, 1.0  # eigenvalue spread and h * max(-Re lambda) of RK45
EXPONENTIAL_SHARE = 0.35  # of the log growth of a tangent vector, in the second half of the run


def tolerance_pair(rtol: float) -> tuple[float, float]:
    """(rtol, atol) as used in every table: the book's ode45 pair at 1e-3, else atol = rtol/1000."""
    return (BOOK_RTOL, BOOK_ATOL) if rtol == BOOK_RTOL else (rtol, rtol * 1e-3)


def methods(explicit_only: bool = False, model: Model | None = None) -> tuple[str, ...]:
    """The methods compared: scipy's RK45, DOP853 and Radau, and nemc's native ones if present
    (without nemc.Taylor where MODEL cannot have it: a closed loop, a load with no recurrence;
    asking builds its coefficients, which its runs need anyway). With Coulomb friction or
    contacts, the methods that can run them: nemc.Vern9 and nemc.DOP853."""
    if model is not None and model.friction.present:
        return FRICTION_METHODS
    native = tuple(getattr(runtime, "NATIVE_METHODS", ()))
    chosen = ("RK45", "DOP853") if explicit_only else ("RK45", "DOP853", "Radau")
    extra = tuple(m for m in native if not (explicit_only and "radau" in m.lower()))
    if model is not None and (model.has_loops  # refused at once, no build needed
                              or not model.compiled_with("taylor").has_part("taylor")):
        extra = tuple(m for m in extra if m not in runtime.TAYLOR_METHODS)
    return chosen + extra


# -- references and errors -------------------------------------------------------------------


@dataclass(frozen=True)
class Reference:
    """A tight run (DOP853; nemc.Vern9 with friction or contacts), and a bound on its own
    error (its distance to a 100x looser run); ended: why it ends before the span asked (an
    event's stop, impacts that accumulate), or ""."""

    result: SimulationResult
    own_error: float
    ended: str = ""


ENDS_BY_EVENTS = (runs.STOPPED_BY_EVENT, runs.CHATTERING)  # a scene's own end, not a failure


def reference_method(model: Model) -> str:
    """The reference's method: scipy's DOP853, or nemc.Vern9 where friction or contacts
    switch modes (scipy's methods cannot run them)."""
    return FRICTION_METHODS[0] if model.friction.present else "DOP853"


def reference(model: Model, t_span: Sequence[float], times: np.ndarray, params: Params = None,
              y0: np.ndarray | None = None, rtol: float = REFERENCE_RTOL) -> Reference:
    """The reference over T_SPAN at TIMES; where the scene's events end it early (a stopping
    event, a ball coming to rest), over the times before that end, which `ended` names."""
    method = reference_method(model)
    tight = model.simulate(t_span, y0, method=method, t_eval=times, rtol=rtol,
                           atol=rtol * 1e-2, params=params)
    ended = ""
    if tight.status in ENDS_BY_EVENTS and np.sum(times < tight.t[-1]) >= 2:
        ended = tight.message.split(" End t_span")[0].rstrip(".")
        times = times[times < tight.t[-1]]  # both runs over the part before the end
        t_span = (t_span[0], float(times[-1]))
        tight = model.simulate(t_span, y0, method=method, t_eval=times, rtol=rtol,
                               atol=rtol * 1e-2, params=params)
    check = model.simulate(t_span, y0, method=method, t_eval=times, rtol=rtol * 100,
                           atol=rtol, params=params)
    if not (tight.success and check.success):
        raise runtime.ModelError(f"the reference run failed: {tight.message} {check.message}")
    return Reference(tight, float(np.max(np.abs(tight.y - check.y))), ended)


def state_errors(result: SimulationResult, truth: SimulationResult) -> np.ndarray:
    """max over t of |y - y_true| for each state (inf where the run stopped early)."""
    if not result.success or result.y.shape != truth.y.shape:
        return np.full(truth.y.shape[0], np.inf)
    return np.max(np.abs(result.y - truth.y), axis=1)


@dataclass(frozen=True)
class Run:
    """One run of the scene against the reference."""

    method: str
    rtol: float
    atol: float
    nfev: int
    errors: tuple[float, ...]  # per state, max over t
    events: int = 0  # the events the run located (friction's and contacts' switches)

    @property
    def max_error(self) -> float:
        return max(self.errors)


def measure_run(model: Model, ref: Reference, method: str, rtol: float, params: Params = None,
                y0: np.ndarray | None = None) -> Run:
    truth = ref.result
    rtol, atol = tolerance_pair(rtol)
    result = model.simulate((truth.t[0], truth.t[-1]), y0, method=method, t_eval=truth.t,
                            rtol=rtol, atol=atol, params=params)
    return Run(method, rtol, atol, result.nfev, tuple(state_errors(result, truth).tolist()),
               sum(len(times) for times, _ in result.events.values()))


def accuracy_table(model: Model, ref: Reference, method_names: Sequence[str],
                   tolerances: Sequence[float] = TOLERANCES, params: Params = None,
                   done: Callable[[Run], None] | None = None) -> list[Run]:
    """Every method at every tolerance; done(run) after each (progress, partial reports)."""
    runs = []
    for m in method_names:
        for tol in tolerances:
            runs.append(measure_run(model, ref, m, tol, params))
            if done:
                done(runs[-1])
    return runs


def loosest_tolerance(runs: Sequence[Run], method: str, target: float = TRUST_ERROR
                      ) -> float | None:
    """The largest rtol of METHOD whose run, and every tighter one, is within TARGET."""
    passing = None
    for run in sorted((r for r in runs if r.method == method), key=lambda r: r.rtol):
        if run.max_error > target:
            return passing
        passing = run.rtol
    return passing


def impacts_once(result: SimulationResult) -> tuple[np.ndarray, np.ndarray]:
    """The run's times and states with an impact's time once (its steps hold the states
    before and after it at one time, which no t_eval may repeat): the state after it."""
    after = np.append(np.diff(result.t) != 0, True)
    return result.t[after], result.y[:, after]


def error_estimate(model: Model, result: SimulationResult, params: Params = None
                   ) -> tuple[dict[str, float], float, float]:
    """max |y - y_ref| per state over the run's times, y_ref from DOP853 (nemc.Vern9 with
    friction or contacts) at rtol/1000, atol/1000 (rtol at least 1e-13): (errors, reference
    rtol, reference atol). At an impact's time (the state before and after it) the state after
    it is compared."""
    rtol, atol = max(result.rtol / 1000, 1e-13), result.atol / 1000
    t, y = impacts_once(result)
    truth = model.simulate((t[0], t[-1]), y[:, 0], method=reference_method(model), t_eval=t,
                           rtol=rtol, atol=atol, params=params)
    errors = np.full(y.shape[0], np.inf) if not result.success or truth.y.shape != y.shape \
        else np.max(np.abs(y - truth.y), axis=1)
    return dict(zip(model.state_names, errors.tolist())), rtol, atol


# -- energy ----------------------------------------------------------------------------------


def energy_power_ratio(model: Model, result: SimulationResult, params: Params = None) -> float:
    """max |dE/dt| / max |dT/dt| along the run, both by central differences along the flow.

    Zero (to rounding) when the loads outside the energy output do no work: no damping, no
    torques or forces, nothing time-dependent. This is how a scene is judged conservative."""
    h = 1e-5
    power, kinetic_power = [], []
    for t, y in zip(result.t, result.y.T):
        step = model.rhs(t, y, params) * h
        up, down = model.outputs(t + h, y + step, params), model.outputs(t - h, y - step, params)
        power.append(abs(up["energy.total"] - down["energy.total"]) / (2 * h))
        kinetic_power.append(abs(up["energy.kinetic"] - down["energy.kinetic"]) / (2 * h))
    return max(power) / max(max(kinetic_power), 1e-300)


@dataclass(frozen=True)
class Drift:
    """Energy drift of one method and tolerance over the long horizon."""

    method: str
    rtol: float
    atol: float
    nfev: int
    t: np.ndarray
    relative: np.ndarray  # |E(t) - E(0)| / energy scale
    rate: float  # secular growth rate of `relative`, 1/s (least-squares slope)
    trusted_until: float  # the first time the state is off the reference by > TRUST_ERROR
    stopped: str | None = None  # the failure message when the run did not reach the end

    @property
    def max_relative(self) -> float:
        return float(np.max(self.relative))


def energy_scale(result: SimulationResult) -> float:
    """|E(0)|, or the largest kinetic energy if larger (E's zero is arbitrary)."""
    total, kinetic = result.outputs["energy.total"], result.outputs["energy.kinetic"]
    return float(max(abs(total[0]), np.max(np.abs(kinetic)), 1e-300))


def secular_rate(t: np.ndarray, relative: np.ndarray) -> float:
    """The slope of a least-squares line through |dE/E| against t."""
    return float(np.polyfit(t, relative, 1)[0])


def first_exceedance(t: np.ndarray, error: np.ndarray, limit: float) -> float:
    above = np.nonzero(error > limit)[0]
    return float(t[above[0]]) if above.size else math.inf


def energy_drift(model: Model, ref: Reference, method: str, rtol: float, params: Params = None
                 ) -> Drift:
    """Energy drift and trust horizon of one run over the reference's times. A run that fails
    (a numerical blow-up) is measured up to where it stopped and says so in `stopped`."""
    truth = ref.result
    rtol, atol = tolerance_pair(rtol)
    run = model.simulate((truth.t[0], truth.t[-1]), method=method, t_eval=truth.t, rtol=rtol,
                         atol=atol, params=params)
    reached = run.t.size if run.outputs else 0
    if reached < 2:
        raise runtime.ModelError(f"{method} at rtol {rtol:g} failed at once: {run.message}")
    total = run.outputs["energy.total"]
    relative = np.abs(total - total[0]) / energy_scale(truth)
    deviation = np.max(np.abs(run.y - truth.y[:, :reached]), axis=0)
    stopped = None if run.success else run.message
    trusted = first_exceedance(run.t, deviation, TRUST_ERROR)
    if stopped:
        trusted = min(trusted, float(run.t[-1]))
    return Drift(method, rtol, atol, run.nfev, run.t, relative, secular_rate(run.t, relative),
                 trusted, stopped)


def drift_exponent(drifts: Sequence[Drift], method: str) -> float:
    """p in rate ~ rtol^p, fitted over METHOD's tolerances (log-log least squares)."""
    chosen = [d for d in drifts if d.method == method and d.rate > 0]
    if len(chosen) < 2:
        return math.nan
    x = np.log10([d.rtol for d in chosen])
    return float(np.polyfit(x, np.log10([d.rate for d in chosen]), 1)[0])


@dataclass(frozen=True)
class Balance:
    """The energy balance of a run with friction or contacts: the change of energy.total over
    it, the friction's work (every NAME.friction_work: the joints', the guides' and the
    contacts', <= 0)
    and what the impacts took (every NAME.impact_loss, >= 0); the rest is the other loads'
    work (driven, time-dependent or damping loads, not in the energy)."""

    change: float
    friction_work: float
    impact_loss: float = 0.0

    @property
    def rest(self) -> float:
        return self.change - self.friction_work + self.impact_loss


def energy_balance(model: Model, span: Sequence[float], params: Params = None) -> Balance:
    """The balance over SPAN of a run of the reference's method at REFERENCE_RTOL, from the
    run's work account (its outputs NAME.friction_work and NAME.impact_loss at the end)."""
    run = model.simulate(tuple(span), method=reference_method(model),
                         t_eval=np.array([span[0], span[1]], dtype=float),
                         rtol=REFERENCE_RTOL, atol=REFERENCE_RTOL * 1e-2, params=params)
    outputs = run.outputs
    total = outputs["energy.total"]

    def summed(suffix: str) -> float:
        return float(sum(values[-1] for name, values in outputs.items()
                         if name.endswith(suffix)))

    return Balance(float(total[-1] - total[0]), summed(".friction_work"),
                   summed(".impact_loss"))


# -- constraint drift (closed loops) ----------------------------------------------------------


@dataclass(frozen=True)
class ConstraintDrift:
    """How well one method's run keeps a closed loop's constraints: the largest |Phi| and
    |Phi_q q' + Phi_t| of its returned states, over the first and the second half of the run
    (growth shows as a second half larger than the first)."""

    method: str
    rtol: float
    nfev: int
    t_end: float
    position: tuple[float, float]  # max |Phi| over the first half, the second half
    rate: tuple[float, float]  # max |Phi_q q' + Phi_t| over the same halves
    stopped: str | None = None  # the failure message when the run did not reach the end

    @property
    def growing(self) -> bool:
        """The second half's residual above 10x the first's and above rounding (1e-13)."""
        return any(late > max(10 * early, 1e-13) for early, late in (self.position, self.rate))


def constraint_drift(model: Model, span: Sequence[float], method: str, rtol: float,
                     params: Params = None, samples: int = 2001) -> ConstraintDrift:
    """The constraint residuals of one run over SPAN (a closed loop's scene)."""
    rtol, atol = tolerance_pair(rtol)
    times = np.linspace(span[0], span[1], samples)
    run = model.simulate(tuple(span), method=method, t_eval=times, rtol=rtol, atol=atol,
                         params=params)
    position, rate = model.constraint_residual(run.y, run.t, params) if run.t.size else (
        np.zeros(1), np.zeros(1))
    half = max(1, run.t.size // 2)

    def halves(values: np.ndarray) -> tuple[float, float]:
        return float(values[:half].max(initial=0.0)), float(values[half:].max(initial=0.0))

    return ConstraintDrift(method, rtol, run.nfev, float(run.t[-1]) if run.t.size else span[0],
                           halves(position), halves(rate), None if run.success else run.message)


# -- sensitivity -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Lyapunov:
    """Running estimate of the largest Lyapunov exponent (Benettin, variational equations)."""

    t: np.ndarray
    estimate: np.ndarray  # (1/t) sum of log growth up to t

    @property
    def value(self) -> float:
        return float(self.estimate[-1])

    @property
    def exponential(self) -> bool:
        """Does the separation grow exponentially? Then the second half of the run adds about
        half of the total log growth; a power law t^p adds only p ln 2 of p ln t (for regular
        motion the estimate falls like ln t / t towards 0)."""
        total = self.estimate[-1] * self.t[-1]
        half = len(self.t) // 2
        if total <= 0 or half == 0:
            return False
        return (total - self.estimate[half - 1] * self.t[half - 1]) / total >= EXPONENTIAL_SHARE


def lyapunov(model: Model, y0: np.ndarray, duration: float, params: Params = None,
             interval: float = 1.0, rtol: float = 1e-9) -> Lyapunov:
    """Integrate y' = f(y) with one tangent vector v' = J(y) v, renormalizing v every INTERVAL
    seconds; the mean log growth rate tends to the largest Lyapunov exponent."""
    from scipy.integrate import solve_ivp

    n = model.n_state

    def augmented(t: float, z: np.ndarray) -> np.ndarray:
        y = z[:n]
        return np.concatenate([model.rhs(t, y, params), model.jacobian(t, y, params) @ z[n:]])

    z = np.concatenate([np.asarray(y0, dtype=float), np.ones(n) / math.sqrt(n)])
    count = max(1, int(round(duration / interval)))
    log_growth, times = np.empty(count), interval * np.arange(1, count + 1)
    for k in range(count):
        sol = solve_ivp(augmented, (times[k] - interval, times[k]), z, method="DOP853",
                        rtol=rtol, atol=rtol * 1e-3)
        z = sol.y[:, -1]
        growth = np.linalg.norm(z[n:])
        log_growth[k], z[n:] = math.log(growth), z[n:] / growth
    return Lyapunov(times, np.cumsum(log_growth) / times)


def divergence(model: Model, ref: Reference, delta: float = 1e-6, params: Params = None,
               rtol: float = 1e-10) -> np.ndarray:
    """|y(t) - y~(t)| for y~ started DELTA away in the first coordinate (DOP853 at RTOL, far
    tighter than DELTA: the separation measured is the dynamics', not the integrator's). With
    closed loops the rest of the moved start is assembled from the constraints."""
    truth = ref.result
    if truth.method == "kinematic":  # no degree of freedom: no initial value to move
        return np.zeros(truth.t.size)
    start: Any = truth.y[:, 0].copy()
    start[0] += delta
    if model.has_loops:  # the other coordinates and rates follow from the constraints
        first, rate = model.state_names[:2]
        start = {first: start[0], rate: start[1]}
    moved = model.simulate((truth.t[0], truth.t[-1]), start, method="DOP853", t_eval=truth.t,
                           rtol=rtol, atol=rtol * 1e-2, params=params)
    return np.linalg.norm(moved.y - truth.y, axis=0)


def growth_exponent(t: np.ndarray, separation: np.ndarray) -> float:
    """p in |dy| ~ t^p, fitted (log-log least squares) over the second half of the run."""
    half = slice(len(t) // 2, None)
    keep = (t[half] > 0) & (separation[half] > 0)
    if keep.sum() < 2:
        return math.nan
    return float(np.polyfit(np.log(t[half][keep]), np.log(separation[half][keep]), 1)[0])


def lyapunov_horizon(exponent: float, tolerance: float, target: float = TRUST_ERROR) -> float:
    """ln(target / tolerance) / lambda: when an error of size TOLERANCE has grown to TARGET
    (inf when the exponent is not positive: errors then grow slower than exponentially)."""
    return math.log(target / tolerance) / exponent if exponent > 0 else math.inf


# -- stiffness and conditioning --------------------------------------------------------------


@dataclass(frozen=True)
class Stiffness:
    t: np.ndarray
    eigenvalues: np.ndarray  # (n_t, n_state), complex
    explicit_step: float  # mean step of RK45 at the scene's tolerances (6 RHS calls a step)
    explicit_nfev: int  # over the whole span (extrapolated when its stiffness test stopped it)
    implicit_nfev: int
    explicit_stopped_at: float = math.nan  # where RK45's stiffness test stopped it, if it did

    @property
    def fastest_decay(self) -> float:
        """max over the trajectory of -Re(lambda) (0 when nothing decays)."""
        return float(max(0.0, np.max(-self.eigenvalues.real)))

    @property
    def ratio(self) -> float:
        """max |lambda| / min nonzero |lambda| at each point, largest along the trajectory."""
        size = np.abs(self.eigenvalues)
        floor = 1e-9 * max(float(np.max(size)), 1e-300)
        smallest = np.where(size > floor, size, np.inf).min(axis=1)
        return float(np.max(size.max(axis=1) / smallest))

    @property
    def step_times_decay(self) -> float:
        return self.explicit_step * self.fastest_decay

    @property
    def stiff(self) -> bool:
        return self.ratio >= STIFF_RATIO and self.step_times_decay >= STIFF_STEP


def stiffness(model: Model, ref: Reference, params: Params = None, samples: int = 200
              ) -> Stiffness:
    truth = ref.result
    pick = np.unique(np.linspace(0, truth.t.size - 1, min(samples, truth.t.size)).astype(int))
    eigen = np.array([np.linalg.eigvals(model.jacobian(truth.t[k], truth.y[:, k], params))
                      for k in pick])
    span = (truth.t[0], truth.t[-1])
    rtol = model.scene["rtol"] or runtime.DEFAULT_RTOL
    atol = model.scene["atol"] or runtime.DEFAULT_ATOL
    explicit = model.simulate(span, method="RK45", rtol=rtol, atol=atol, params=params,
                              t_eval=runtime.SOLVER_STEPS)  # its last step: where it stopped
    implicit = model.simulate(span, method="Radau", rtol=rtol, atol=atol, params=params)
    whole, stopped_at = abs(span[1] - span[0]), math.nan
    covered = whole
    if explicit.status == runs.STIFF and explicit.t.size:  # RK45 stopped: its pace so far
        stopped_at = float(explicit.t[-1])
        covered = abs(stopped_at - span[0]) or whole
    step = covered / max(1.0, explicit.nfev / 6)
    nfev = round(explicit.nfev * whole / covered)
    return Stiffness(truth.t[pick], eigen, step, nfev, implicit.nfev, stopped_at)


@dataclass(frozen=True)
class Conditioning:
    t: np.ndarray
    condition: np.ndarray  # cond_2(M(q)) along the trajectory
    smallest: np.ndarray  # smallest eigenvalue of M
    largest: np.ndarray
    worst_state: np.ndarray

    @property
    def worst(self) -> float:
        return float(np.max(self.condition))

    @property
    def digits_lost(self) -> float:
        return math.log10(self.worst)

    @property
    def verdict(self) -> str:
        if self.worst >= NEAR_SINGULAR:
            return "near-singular"
        return "ill-conditioned" if self.worst >= ILL_CONDITIONED else "well-conditioned"


def conditioning(model: Model, result: SimulationResult, params: Params = None
                 ) -> Conditioning:
    eigen = np.array([np.linalg.eigvalsh(model.mass_matrix(y, params)) for y in result.y.T])
    smallest, largest = eigen.min(axis=1), eigen.max(axis=1)
    condition = largest / np.maximum(smallest, 1e-300)
    worst = int(np.argmax(condition))
    return Conditioning(result.t, condition, smallest, largest, result.y[:, worst].copy())


def agreement(model: Model, params: Params = None) -> tuple[str, str, float]:
    """The scene run by its own method and by one of the other family (explicit vs implicit),
    same tolerances; with friction or contacts the other of nemc.Vern9 and nemc.DOP853:
    (method, other method, max |difference| over the scene's times)."""
    own = model.simulate(params=params)
    other = "DOP853" if own.method in runtime.IMPLICIT_METHODS else "Radau"
    if model.friction.present:
        other = next(m for m in FRICTION_METHODS if m != own.method)
    t, y = impacts_once(own)
    second = model.simulate(method=other, t_eval=t, params=params)
    difference = float(np.max(np.abs(y - second.y))) if second.success else math.inf
    return own.method, other, difference
