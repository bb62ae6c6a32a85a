"""How runs end, the runtime's side: run settings (max_step, tstops, the step budget), what a
run that stopped early says, events through scipy's solve_ivp, Ctrl-C (progress lines: progress.py).

The native methods do the same in C (templates/run_control.c.tmpl); this module gives scipy's
methods the same rules and every method the same messages. Like runtime.py it needs only numpy
and scipy (no nemc, no sympy): `nemc compile` copies it into every standalone package.
Rules and why: docs/decisions.md, "Runs that end".
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .failures import IntegrationFailure
from .progress import Progress  # noqa: F401 - runs.Progress, as callers name it

DEFAULT_MAX_STEPS = 1_000_000  # accepted steps; 0: no budget
DEFAULT_MAX_EVENTS = 32  # simulate_many: the event times kept per run
PACE_WINDOW = 1000  # as run_control.c.tmpl: steps between two looks at the pace,
PACE_FACTOR = 100.0  # and how many budgets the rest may take at that pace
STIFF_TESTS, NONSTIFF_TESTS = 15, 6  # Hairer's counters (dop853.f)
STIFF_FRACTION = 0.01  # a stiff run stops when the rest would take over this x max_steps steps
NSTIFF = 1000  # scipy's methods: test every NSTIFF steps, and every step once one is positive
CHATTER_FRACTION = 1e-9  # the chattering window, x |t_end - t0|: after an impact its event
# is not looked at for one window; impacts of one event closer than two windows chatter
SWITCH_WINDOW = 1e-8  # a mode switch's window at most this x (1 + |t|) (run_control.c.tmpl)
DIRECTIONS = {"rising": 1, "falling": -1, "both": 0}
# The statuses of a run: the C enum nemc_status (templates/model.h.tmpl), the same for scipy's
# methods. scipy's own: 1 a terminal event, 0 the end, -1 it gave up.
STOPPED_BY_EVENT, REACHED_END, STEP_TOO_SMALL, EQUATIONS_FAILED = 1, 0, -1, -2
STEP_BUDGET, TOO_SLOW, STIFF, CHATTERING, INTERRUPTED = -7, -8, -9, -10, -11
EVENT_STOP_MESSAGE = "A termination event occurred."  # scipy's


# ---- settings ---------------------------------------------------------------------------------


class SettingsError(ValueError):
    """A run setting that cannot be honoured (the runtime raises it as a ModelError)."""


@dataclass(frozen=True)
class RunSettings:
    """max_step (inf: none), the tstops inside the interval in the direction of integration,
    and the step budget (0: none)."""

    max_step: float = math.inf
    tstops: np.ndarray = field(default_factory=lambda: np.empty(0))
    max_steps: int = DEFAULT_MAX_STEPS
    stiff_switch: int = 0  # native explicit methods: stop once stiff with this many steps left


def run_settings(scene: Mapping[str, Any], span: Sequence[float], max_step: Any = None,
                 tstops: Any = None, max_steps: Any = None) -> RunSettings:
    """The call's values, else the scene's (model.json), else the defaults, checked."""
    if max_step is None and tstops is None and max_steps is None and scene.get(
            "max_step") is None and not scene.get("tstops") and scene.get("max_steps") is None:
        return DEFAULT_SETTINGS  # the usual case, shared (frozen, its tstops read-only)
    max_step = scene.get("max_step") if max_step is None else max_step
    tstops = scene.get("tstops") or () if tstops is None else tstops
    max_steps = scene.get("max_steps") if max_steps is None else max_steps
    return RunSettings(checked_max_step(max_step), checked_tstops(tstops, span),
                       checked_max_steps(max_steps))


def checked_max_step(value: Any) -> float:
    if value is None:
        return math.inf
    number = _real(value, "max_step")
    if not number > 0:
        raise SettingsError(f"max_step must be > 0 (inf: no limit), got {value!r}")
    return number


def checked_max_steps(value: Any) -> int:
    if value is None:
        return DEFAULT_MAX_STEPS
    if isinstance(value, (bool, np.bool_)) or not float(_real(value, "max_steps")).is_integer():
        raise SettingsError(f"max_steps must be a whole number >= 0 (0: no budget), got {value!r}")
    steps = int(value)
    if not 0 <= steps <= 2**62:
        raise SettingsError(f"max_steps must be a whole number >= 0 (0: no budget), got {value!r}")
    return steps


NO_TSTOPS = np.empty(0)
NO_TSTOPS.flags.writeable = False  # shared by every run without tstops
DEFAULT_SETTINGS = RunSettings(tstops=NO_TSTOPS)


def checked_tstops(value: Any, span: Sequence[float]) -> np.ndarray:
    """The finite times strictly inside the interval, in the direction of integration."""
    if isinstance(value, (tuple, list)) and not value:  # the usual case: none, at no cost
        return NO_TSTOPS
    try:
        times = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SettingsError(f"tstops must be a list of times, got {value!r}") from None
    if times.ndim != 1 or not np.all(np.isfinite(times)):
        raise SettingsError(f"tstops must be a list of finite times, got {value!r}")
    t0, t1 = span
    inside = np.unique(times[(times > min(t0, t1)) & (times < max(t0, t1))])
    return np.ascontiguousarray(inside if t1 >= t0 else inside[::-1])


def _real(value: Any, what: str) -> float:
    if isinstance(value, (str, bytes)) or np.iscomplexobj(value):
        raise SettingsError(f"{what} must be a real number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise SettingsError(f"{what} must be a number, got {value!r}") from None
    if math.isnan(number):
        raise SettingsError(f"{what} must be a number, got nan")
    return number


# ---- what a run that ended early says ----------------------------------------------------------


@dataclass(frozen=True)
class Ending:
    """Where and how a run ended, for its message."""

    status: int
    t: float
    span: tuple[float, float]
    steps: int
    method: str
    max_steps: int
    y: np.ndarray
    h_recent: float = math.nan  # the mean step of the last steps
    stiff_from: float = math.nan
    stiffness: float = math.nan  # the last h |lambda|
    event: str | None = None  # the event that stopped or chattered the run
    interval: float = math.nan  # chattering: the time between its last two impacts


def steps_to_go(remaining: float, h: float) -> float:
    """The steps of length H that REMAINING takes: inf when the steps shrank to nothing (a
    blow-up under LSODA: its last steps had length 0, and the message divided by it)."""
    return remaining / h if h > 0 else math.inf


def ending_message(end: Ending) -> str:
    """What happened and what to do, for every status but the equations failing."""
    at = f"at t = {end.t:.9g}"
    size = float(np.max(np.abs(end.y))) if end.y.size else math.nan
    remaining = abs(end.span[1] - end.t)
    if end.status == STOPPED_BY_EVENT:
        return f"event {end.event!r} stopped the run {at}" if end.event else EVENT_STOP_MESSAGE
    if end.status == INTERRUPTED:
        return f"interrupted (Ctrl-C) {at} after {end.steps:,} steps; the states so far are kept"
    if end.status == STIFF:
        return (f"stiff from t = {end.stiff_from:.6g}: stopped {at} after {end.steps:,} steps, "
                f"the step held near {end.h_recent:.2g} by {end.method}'s stability (h|lambda| "
                f"~ {end.stiffness:.2g}), not by accuracy; the rest would take "
                f"~{steps_to_go(remaining, end.h_recent):.1e} steps: try nemc.Radau (or scipy's "
                "Radau, BDF)")
    if end.status == TOO_SLOW:
        return (f"stopped {at} after {end.steps:,} steps: at the pace of the last ones (steps of "
                f"~{end.h_recent:.2g}) reaching t = {end.span[1]:g} would take "
                f"~{steps_to_go(remaining, end.h_recent):.1e} steps, over {PACE_FACTOR:g} x "
                "max_steps "
                f"({end.max_steps:,}). The motion is too fast to follow over this interval (a "
                f"very stiff spring, a tiny mass or inertia, or a blow-up: |y| = {size:.3g}): "
                "check the parameters; if the problem is stiff (fast motion that decays), try "
                "nemc.Radau; max_steps=0 lifts the budget")
    if end.status == STEP_BUDGET:
        return (f"stopped {at} after {end.steps:,} steps (max_steps): the last steps were "
                f"~{end.h_recent:.2g} long and |y| reached {size:.3g}. The solution may grow "
                "without bound (negative damping, an unstable load) or move too fast to "
                "follow; raise max_steps (0: no budget) to go on")
    if end.status == CHATTERING:
        window = 2 * CHATTER_FRACTION * abs(end.span[1] - end.span[0])
        rule = f"{2 * CHATTER_FRACTION:g} of the run's interval"
        capped = 2 * SWITCH_WINDOW * (1 + abs(end.t))
        if end.event and end.event.endswith((".contact", ".stick_slip")) and capped < window:
            window, rule = capped, f"a mode switch's: {2 * SWITCH_WINDOW:g} (1 + |t|)"
        return (f"event {end.event!r} chatters {at}: two impacts {end.interval:.2g} apart (within "
                f"{window:.2g}, {rule}): they accumulate there (a body "
                "coming to rest on a surface, or a law that does not separate, e.g. restitution "
                f"0); the run stops. End t_span before t = {end.t:.6g}, or model the contact")
    raise ValueError(f"no message for status {end.status}")


def stiffness_note(stiff_from: float) -> str:
    """Appended to a successful run's message when the stiffness test held."""
    return (f" The problem is stiff from t = {stiff_from:.6g} (the steps were held by "
            "stability): nemc.Radau would need fewer.")


# ---- Ctrl-C ----------------------------------------------------------------------------------

try:  # the C functions under signal.signal: 0.4 us a pair against 5.7 (enum conversions)
    import _signal as _signals
except ImportError:  # pragma: no cover (CPython has it)
    import signal as _signals


class _InterruptWatch:
    """Ctrl-C while a run is in C: Python's SIGINT handler runs only between bytecodes, after the
    call. During a guarded run the signal wakeup fd, which Python's C-level handler writes at
    once, is this pipe; a daemon thread reading it sets the active guards' flags, which the C
    loops read between steps. Bytes of other signals go on to the wakeup fd set before."""

    def __init__(self) -> None:
        self.guards: set[interrupt_flag] = set()  # add and discard are atomic: no lock
        self.forward = -1
        self.write_fd = -1

    def start(self) -> int:
        """The pipe's write end, its reading thread started on first use (again in a child
        after a fork: the thread does not cross it)."""
        if self.write_fd < 0:
            read_fd, self.write_fd = os.pipe()
            os.set_blocking(self.write_fd, False)
            threading.Thread(target=self._watch, args=(read_fd,), daemon=True,
                             name="nemc-interrupts").start()
        return self.write_fd

    def forget_after_fork(self) -> None:
        self.write_fd, self.forward, self.guards = -1, -1, set()

    def _watch(self, read_fd: int) -> None:
        while True:
            data = os.read(read_fd, 512)
            if not data:
                return
            if 2 in data:  # SIGINT
                self.set_flags()
            if self.forward >= 0:
                try:
                    os.write(self.forward, data)
                except OSError:
                    pass

    def set_flags(self) -> None:
        for guard in tuple(self.guards):  # a copy: a run may end meanwhile
            guard.flag[0] = 1


WATCH = _InterruptWatch()  # the process's one watch (public: tests look at its guards)
os.register_at_fork(after_in_child=WATCH.forget_after_fork)
_RAISING = threading.local()  # interrupts_raise() is active in this thread


@contextmanager
def interrupts_raise() -> Iterator[None]:
    """Within: a run stopped by Ctrl-C raises KeyboardInterrupt when it returns, instead of
    returning its partial result: for loops of runs (nemc stress, the benchmarks), whose next
    run would otherwise start as if nothing had happened."""
    before = getattr(_RAISING, "on", False)
    _RAISING.on = True
    try:
        yield
    finally:
        _RAISING.on = before


def swallow_sigint(signum: int, frame: Any) -> None:
    """SIGINT's Python handler during a guarded run: the runs' flags say it (set already by
    the watch thread; set here too for a signal the pipe missed), nothing is raised."""
    WATCH.set_flags()


class interrupt_flag:  # a class, not @contextmanager: 2 us less a run (issue 19)
    """`with interrupt_flag() as flag`: a C int that Ctrl-C sets to 1 while the block runs; the
    KeyboardInterrupt is not raised. flag: np.intc array of one by default, or the caller's
    (a cffi int *, which a nemc_run points to as is). Only in the main thread with Python's
    default SIGINT handler: elsewhere (threads, SIG_IGN, a handler of the caller's) the flag
    stays 0 and Ctrl-C behaves as it would without nemc. A single run in C arms its guard
    itself once it lasts (arm_interrupts)."""

    __slots__ = ("flag", "guarded")

    def __init__(self, flag: Any = None) -> None:
        self.flag = np.zeros(1, dtype=np.intc) if flag is None else flag
        self.guarded = False

    def __enter__(self) -> Any:
        if (threading.current_thread() is not threading.main_thread()
                or _signals.getsignal(2) is not _signals.default_int_handler):
            return self.flag
        WATCH.guards.add(self)  # listed before the swap: a SIGINT from then on is seen
        _signals.signal(2, swallow_sigint)
        self.guarded = True
        WATCH.forward = _signals.set_wakeup_fd(WATCH.start(), warn_on_full_buffer=False)
        return self.flag

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: Any) -> None:
        self.release()
        if kind is None:
            raise_if_interrupted(self.flag)

    def release(self) -> None:
        """The handlers and the wakeup fd as they were before; the flag no longer set."""
        if self.guarded:
            self.guarded = False
            _signals.set_wakeup_fd(WATCH.forward)
            WATCH.forward = -1
            _signals.signal(2, _signals.default_int_handler)
        WATCH.guards.discard(self)


def raise_if_interrupted(flag: Any) -> None:
    """Under interrupts_raise: KeyboardInterrupt if Ctrl-C stopped the run of this flag."""
    if flag[0] and getattr(_RAISING, "on", False):
        raise KeyboardInterrupt


# ---- a single run in C arms its guard itself, once it lasts ------------------------------
# Swapping the handlers costs 1.5 us, a sixth of a short simulate() (issue 19). A native run
# calls nemc_run.arm_interrupt (a cffi callback of arm_interrupts) once it has done enough work
# for Ctrl-C to matter (templates/run_control.c.tmpl, NEMC_ARM_WORK); after the call, after_run
# restores the handlers. A Ctrl-C before arming raises KeyboardInterrupt when a short run
# returns, as after any short call, or in the callback of a long one, which ends the run.

ARMED: list[interrupt_flag] = []  # guards armed by a run in C of the main thread


def arm_interrupts(flag: Any) -> int:
    """nemc_run.arm_interrupt: watch for Ctrl-C on the run's flag from now on. 0: go on."""
    if threading.current_thread() is threading.main_thread():
        guard = interrupt_flag(flag)
        ARMED.append(guard)
        guard.__enter__()
    return 0


def interrupted_while_arming(kind: type[BaseException], error: BaseException,
                             trace: Any) -> int:
    """arm_interrupts' onerror: a Ctrl-C that came before it raises in the callback, which
    cannot pass it through C; 1 ends the run as an interrupted one."""
    if issubclass(kind, KeyboardInterrupt):
        return 1
    import traceback

    traceback.print_exception(kind, error, trace)
    return 0


def after_run(flag: Any) -> None:
    """After a run in C given arm_interrupts: the guard it armed, if any, released (handlers
    restored); under interrupts_raise, KeyboardInterrupt if Ctrl-C stopped it."""
    if ARMED and threading.current_thread() is threading.main_thread():
        while ARMED:
            guard = ARMED.pop()
            guard.flag = flag  # the owner of the int: the watch thread may still hold guard
            guard.release()
    if flag[0]:  # (raise_if_interrupted, its call saved in the usual case)
        raise_if_interrupted(flag)


# ---- scipy's methods: the same rules through solve_ivp -----------------------------------------

# Hairer's stiffness test on scipy's explicit pairs: two stages at the same time (the stage
# index, the index of f at the new point) and 0.95 of the stability boundary on the negative
# real axis (dopri5.f's 3.25 for RK45, dop853.f's 6.1; RK23's stage 2 is at 3/4 h: an
# estimate of the same kind).
STIFFNESS_STAGES = {"RK45": (5, 6, 3.25), "DOP853": (11, 12, 6.1), "RK23": (2, 3, 2.4)}


@dataclass
class ScipyControl:
    """The step budget, the pace, Hairer's test and Ctrl-C for one run of scipy's methods,
    across its solve_ivp segments (tstops, impacts)."""

    settings: RunSettings
    span: tuple[float, float]
    flag: np.ndarray
    stiffness_stages: tuple[int, int, float] | None
    steps: int = 0
    steps_at_mark: int = 0
    t_at_mark: float = 0.0
    h_recent: float = math.nan
    stiffness: float = math.nan
    stiff_count: int = 0
    nonstiff_count: int = 0
    stiff_start: float = math.nan
    stiff_from: float = math.nan
    stop: int = 0  # the status that ends the run before the next step
    t: float = math.nan  # where it ended, and the state there
    y: np.ndarray = field(default_factory=lambda: np.empty(0))
    failure: IntegrationFailure | None = None  # what ended the run, if the equations failed
    inside: Callable | None = None  # (solver, t_old) -> a shorter step to take again, or None

    def fail(self, failure: IntegrationFailure) -> None:
        """The equations (an event's function, an impact law) failed: the run ends before the
        next step, its states so far kept (status EQUATIONS_FAILED)."""
        if self.failure is None:
            self.failure = failure
        self.stop = EQUATIONS_FAILED

    def before_step(self, solver: Any) -> str | None:
        """A reason to stop now (the last accepted step is then the run's last), or None."""
        if self.flag[0]:
            self.stop = INTERRUPTED
        if self.stop:
            self.t, self.y = solver.t, np.array(solver.y)
            return f"stopped (status {self.stop})"
        return None

    def after_step(self, solver: Any) -> None:
        """Count the step; decide whether the run must stop before the next one."""
        self.steps += 1
        t, budget = solver.t, self.settings.max_steps
        if self.direction * (t - self.span[1]) >= 0:
            return
        if budget and self.steps >= budget:
            self.end(STEP_BUDGET, t)
        if self.steps - self.steps_at_mark >= PACE_WINDOW:
            self.h_recent = abs(t - self.t_at_mark) / (self.steps - self.steps_at_mark)
            self.steps_at_mark, self.t_at_mark = self.steps, t
            if budget and abs(self.span[1] - t) > PACE_FACTOR * budget * self.h_recent:
                self.end(TOO_SLOW, t)
        if self.stiffness_stages and (self.steps % NSTIFF == 0 or self.stiff_count):
            self.stiffness_test(solver)

    @property
    def direction(self) -> float:
        return 1.0 if self.span[1] >= self.span[0] else -1.0

    def end(self, status: int, t: float) -> None:
        if not self.stop:
            self.stop, self.t = status, t
            if math.isnan(self.h_recent) and self.steps > self.steps_at_mark:
                self.h_recent = abs(t - self.t_at_mark) / (self.steps - self.steps_at_mark)

    def stiffness_test(self, solver: Any) -> None:
        """dop853.f's test on the step just taken: |h| |f_b - f_a| / |y_b - y_a| for the two
        evaluations at one time (the stage's argument formed again from solver.K)."""
        stage, final, threshold = self.stiffness_stages  # type: ignore[misc]
        h = solver.h_previous  # the step just taken (solver.t_old is set after it)
        argument = solver.y_old + h * (solver.K[:stage].T @ solver.A[stage, :stage])
        denominator = np.linalg.norm(solver.y - argument)
        if not denominator > 0:
            return
        self.stiffness = abs(h) * np.linalg.norm(solver.K[final] - solver.K[stage]) / denominator
        if self.stiffness <= threshold:
            self.nonstiff_count += 1
            if self.nonstiff_count == NONSTIFF_TESTS:
                self.stiff_count = 0
            return
        self.nonstiff_count = 0
        if self.stiff_count == 0:
            self.stiff_start = solver.t - h
        self.stiff_count += 1
        if self.stiff_count < STIFF_TESTS:
            return
        if math.isnan(self.stiff_from):
            self.stiff_from = self.stiff_start
        budget = self.settings.max_steps
        if budget and abs(self.span[1] - solver.t) > STIFF_FRACTION * budget * abs(h):
            self.h_recent = abs(h)
            self.end(STIFF, solver.t)


_CONTROLLED: dict[type, type] = {}


def controlled_solver(base: type) -> type:
    """scipy's solver class BASE, checked by a ScipyControl before and after each step (passed
    to solve_ivp as the option `control`)."""
    if base not in _CONTROLLED:
        class Controlled(base):  # type: ignore[misc, valid-type]
            def __init__(self, *args: Any, control: ScipyControl, **kwargs: Any):
                super().__init__(*args, **kwargs)
                self.control = control

            def _step_impl(self) -> tuple[bool, str | None]:
                reason = self.control.before_step(self)
                if reason:
                    return False, reason
                try:
                    inside = self.control.inside  # explicit RK only (scipy_switches.py)
                    before = (self.t, self.y, self.f) if inside else ()
                    success, message = super()._step_impl()
                    cut = success and inside and inside(self, before[0])
                    if cut:  # a mode switch crossed inside the step: the step taken to there
                        self.t, self.y, self.f, self.h_abs = (*before, cut)
                        success, message = super()._step_impl()
                except IntegrationFailure as failure:  # the steps so far are kept
                    self.control.fail(failure)
                    return False, "the equations failed"
                if success:
                    self.control.after_step(self)
                return success, message

        Controlled.__name__ = f"Controlled{base.__name__}"
        _CONTROLLED[base] = Controlled
    return _CONTROLLED[base]


@dataclass(frozen=True)
class ModelEvents:
    """The YAML's events as scipy sees them: the compiled functions and their table."""

    names: tuple[str, ...]
    directions: tuple[int, ...]
    actions: tuple[str, ...]
    values: Callable[[float, np.ndarray], np.ndarray]  # every event's function at (t, y)
    impact: Callable[[int, float, np.ndarray], np.ndarray]  # event k's law: the new state


@dataclass
class ScipyOutcome:
    """A scipy run assembled from its segments."""

    t: np.ndarray
    y: np.ndarray
    nfev: int
    njev: int
    nlu: int
    status: int
    message: str
    events: dict[str, tuple[np.ndarray, np.ndarray]]
    ending: dict[str, Any] = field(default_factory=dict)  # Ending's fields, when it ended early
    work: np.ndarray | None = None  # the work account at each time (friction, contacts)


class _Segments:
    """solve_ivp over the pieces of one run: between tstops, and restarted after impacts (scipy
    has no impacts: each impact event is terminal there, its law applied, the run restarted)."""

    def __init__(self, solve_ivp: Callable, rhs: Callable, method: type, span: tuple,
                 times: np.ndarray | None, options: dict, model_events: ModelEvents | None,
                 user_events: Sequence[Callable], control: ScipyControl):
        self.solve_ivp, self.rhs, self.method, self.span = solve_ivp, rhs, method, span
        self.times, self.options, self.control = times, options, control
        self.model_events, self.user_events = model_events, list(user_events)
        self.direction = 1.0 if span[1] >= span[0] else -1.0
        count = len(model_events.names) if model_events else 0
        self.cooldown: dict[int, tuple[float, int]] = {}  # event -> (until, side)
        self.last_values: dict[int, float] = {}  # event -> its latest finite value
        self.last_impact: dict[int, float] = {}
        self.user_counts = [0] * len(self.user_events)
        self.names = (list(model_events.names) if model_events else []) + [
            _event_name(fn, i, set(model_events.names if model_events else ()))
            for i, fn in enumerate(self.user_events)]
        self.n_model = count
        self.t_events: list[list[float]] = [[] for _ in self.names]
        self.y_events: list[list[np.ndarray]] = [[] for _ in self.names]
        self.ts: list[np.ndarray] = []
        self.ys: list[np.ndarray] = []
        self.counts = np.zeros(3, dtype=int)

    def chatter_window(self, k: int, t: float) -> float:
        """Event k's chattering window at t: CHATTER_FRACTION of the run's length."""
        return CHATTER_FRACTION * abs(self.span[1] - self.span[0])

    # -- the event functions of one segment --

    def model_event(self, k: int) -> Callable:
        events = self.model_events
        assert events is not None
        until_side = self.cooldown.get(k)

        def event(t: float, y: np.ndarray) -> float:
            try:
                value = float(events.values(t, y)[k])
            except IntegrationFailure as failure:  # the run ends before the next step
                self.control.fail(failure)
                return self.last_values.get(k, 1.0)  # no crossing here
            self.last_values[k] = value
            if until_side and self.direction * (until_side[0] - t) >= 0:
                # just after its impact: on the side it leaves to (never 0: brentq would
                # take the segment's start for the root)
                return until_side[1] * max(abs(value), np.finfo(float).tiny)
            return value

        event.direction = events.directions[k]  # type: ignore[attr-defined]
        event.terminal = events.actions[k] != "record"  # type: ignore[attr-defined]
        return event

    def user_event(self, i: int) -> Callable:
        fn = self.user_events[i]
        terminal = getattr(fn, "terminal", False)

        def event(t: float, y: np.ndarray) -> float:
            return fn(t, y)

        event.direction = getattr(fn, "direction", 0)  # type: ignore[attr-defined]
        left = (terminal if terminal is not True else 1) - self.user_counts[i] if terminal else 0
        event.terminal = max(int(left), 1) if terminal else False  # type: ignore[attr-defined]
        return event

    def segment_events(self) -> list[Callable] | None:
        events = [self.model_event(k) for k in range(self.n_model)]
        events += [self.user_event(i) for i in range(len(self.user_events))]
        return events or None

    # -- the run --

    def run(self, y0: np.ndarray) -> ScipyOutcome:
        """The run from y0; where the equations fail, the states before (control.failure)."""
        self.n_state = len(y0)
        try:
            return self.segments(y0)
        except IntegrationFailure as failure:  # at a segment's start, or an impact law
            self.control.fail(failure)
            return self.outcome(EQUATIONS_FAILED, str(failure))

    def segments(self, y0: np.ndarray) -> ScipyOutcome:
        """run's segments, one after the other."""
        stops = list(self.control.settings.tstops) + [self.span[1]]
        t, y, first = self.span[0], y0, True
        while True:
            bound = next(s for s in stops if self.direction * (s - t) > 0) \
                if self.direction * (self.span[1] - t) > 0 else self.span[1]
            sol = self.segment(t, bound, y, first)
            if sol.status == -1:
                return self.outcome(sol.status, sol.message)
            if sol.status == 1:
                next_state = self.after_termination(sol)
                if isinstance(next_state, ScipyOutcome):
                    return next_state
                t, y = next_state
            else:
                t, y = bound, sol.y[:, -1] if sol.y.size else y
                if bound == self.span[1]:
                    return self.outcome(REACHED_END, str(sol.message))
            first = False

    def segment(self, t0: float, t1: float, y0: np.ndarray, first: bool) -> Any:
        """One solve_ivp from (t0, y0) to t1; its states and events are kept."""
        wanted = None
        if self.times is not None:  # this segment's points, and its end (the next one's start)
            after_start = self.direction * (self.times - t0)
            inside = self.times[(after_start >= 0 if first else after_start > 0)
                                & (self.direction * (self.times - t1) <= 0)]
            wanted = inside if inside.size and inside[-1] == t1 else np.append(inside, t1)
        sol = self.solve_ivp(self.rhs, (t0, t1), y0, method=self.method, t_eval=wanted,
                             events=self.segment_events(), control=self.control,
                             **self.options)
        self.counts += (sol.nfev, sol.njev, sol.nlu)
        keep_t = np.asarray(sol.t, dtype=float)
        keep_y = np.asarray(sol.y, dtype=float).reshape(len(y0), keep_t.size)
        if self.times is not None and keep_t.size and keep_t[-1] == t1 and (
                t1 not in self.times):
            keep_t, keep_y = keep_t[:-1], keep_y[:, :-1]  # the state at the bound, not asked
        if self.times is None and not first and keep_t.size and self.continued_from_bound:
            keep_t, keep_y = keep_t[1:], keep_y[:, 1:]  # the bound's state is already kept
        self.ts.append(keep_t)
        self.ys.append(keep_y)
        if sol.t_events is not None:
            for i, (te, ye) in enumerate(zip(sol.t_events, sol.y_events)):
                self.t_events[i] += list(te)
                self.y_events[i] += list(ye)
                if i >= self.n_model:
                    self.user_counts[i - self.n_model] += len(te)
        self.continued_from_bound = sol.status == 0
        return sol

    continued_from_bound = False

    def action(self, i: int) -> str:
        """What event i (the model's, then the user's) does: record, stop or impact."""
        if i < self.n_model:
            return self.model_events.actions[i]  # type: ignore[union-attr]
        return "stop" if getattr(self.user_events[i - self.n_model], "terminal", False) \
            else "record"

    def after_termination(self, sol: Any) -> tuple[float, np.ndarray] | ScipyOutcome:
        """The event that ended the segment: a stop (or a user's terminal event) ends the
        run; an impact applies its law and the run goes on from the new state."""
        t_end = max((te[-1] for te in sol.t_events if len(te)), key=lambda t: self.direction * t)
        enders = [i for i, te in enumerate(sol.t_events)
                  if len(te) and te[-1] == t_end and self.action(i) != "record"]
        stopper = next((i for i in enders if self.action(i) == "stop"), None)
        if stopper is not None:
            name = self.names[stopper] if stopper < self.n_model else None
            outcome = self.outcome(STOPPED_BY_EVENT, ending_message(Ending(
                STOPPED_BY_EVENT, t_end, self.span, self.control.steps, "", 0, np.empty(0),
                event=name)) if name else EVENT_STOP_MESSAGE)
            outcome.ending = {"event": name}
            return outcome
        y = np.array(sol.y_events[enders[0]][-1], dtype=float)
        for k in enders:
            y = self.model_events.impact(k, t_end, y)  # type: ignore[union-attr]
            last = self.last_impact.get(k)
            if last is not None and abs(t_end - last) <= 2 * self.chatter_window(k, t_end):
                outcome = self.outcome(CHATTERING, ending_message(Ending(
                    CHATTERING, t_end, self.span, self.control.steps, "", 0, y,
                    event=self.names[k], interval=abs(t_end - last))))
                outcome.ending = {"event": self.names[k], "interval": abs(t_end - last)}
                return outcome
            self.last_impact[k] = t_end
        before = np.array(sol.y_events[enders[0]][-1], dtype=float)
        refire = self.set_cooldowns(enders, t_end, before, y)
        if refire is not None:  # the law did not separate: it fires again at once
            self.t_events[refire].append(t_end)
            self.y_events[refire].append(y)
            outcome = self.outcome(CHATTERING, ending_message(Ending(
                CHATTERING, t_end, self.span, self.control.steps, "", 0, y,
                event=self.names[refire], interval=0.0)))
            outcome.ending = {"event": self.names[refire], "interval": 0.0}
            return outcome
        return t_end, y

    def set_cooldowns(self, impacted: list[int], t: float, before: np.ndarray,
                      y: np.ndarray) -> int | None:
        """After an impact at t (state before, y after): each impacted event's side along the
        new motion, with a short cooldown when a rounding leaves its value on the other side
        (as run_control.c.tmpl). A law that does not separate (the value stays or goes on the
        way it crossed) gets no cooldown: if a rounding left its value on the crossed side it
        fires again at once (returned: the run chatters), else scipy sees it cross again."""
        self.cooldown = {}
        events = self.model_events
        assert events is not None
        h = 1e-7 * (abs(t) + abs(self.span[1] - self.span[0])) * self.direction
        now, later = self.event_values_ahead(t, y, h)
        window = CHATTER_FRACTION * abs(self.span[1] - self.span[0])
        crossed: np.ndarray | None = None
        for k in impacted:
            moving = int(np.sign(later[k] - now[k]))
            crossed_to = events.directions[k]
            if crossed_to == 0:  # either way: the way it went before the impact
                if crossed is None:
                    crossed = np.sign(np.subtract(*self.event_values_ahead(t, before, h)[::-1]))
                crossed_to = int(crossed[k])
            if crossed_to and moving in (0, crossed_to):  # no separation
                if now[k] == 0 or np.sign(now[k]) == crossed_to:
                    return k
                continue
            if moving:
                leave = 2 * abs(now[k] / (later[k] - now[k]) * h)  # back across zero
                until = t + self.direction * (max(leave, window)
                                              + 64 * np.finfo(float).eps * abs(t))
                self.cooldown[k] = (until, moving)
        return None

    def event_values_ahead(self, t: float, y: np.ndarray, h: float
                           ) -> tuple[np.ndarray, np.ndarray]:
        """The events' values at (t, y) and a short Euler step h along the motion."""
        events = self.model_events
        assert events is not None
        f = self.rhs(t, y)
        self.counts[0] += 1
        return events.values(t, y), events.values(t + h, y + h * f)

    def outcome(self, status: int, message: str) -> ScipyOutcome:
        t = np.concatenate(self.ts) if self.ts else np.empty(0)
        y = np.concatenate(self.ys, axis=1) if self.ys else np.empty((0, 0))
        n = y.shape[0] if y.size else self.n_state
        events = {name: (np.array(self.t_events[i], dtype=float),
                         np.array(self.y_events[i], dtype=float).reshape(len(self.t_events[i]),
                                                                        n))
                  for i, name in enumerate(self.names)}
        nfev, njev, nlu = (int(v) for v in self.counts)
        return ScipyOutcome(t, y, nfev, njev, nlu, status, message, events)


def _event_name(fn: Callable, index: int, taken: set[str]) -> str:
    """A user's event callable's name in res.events: its __name__, made unique."""
    name = getattr(fn, "__name__", "") or f"event{index}"
    if name == "<lambda>":
        name = f"event{index}"
    while name in taken:
        name += "_"
    taken.add(name)
    return name


def simulate_scipy(solve_ivp: Callable, rhs: Callable, method: str, span: tuple[float, float],
                   y0: np.ndarray, times: np.ndarray | None, options: dict,
                   model_events: ModelEvents | None, user_events: Sequence[Callable],
                   settings: RunSettings, flag: np.ndarray, segments_class: type | None = None
                   ) -> tuple[ScipyOutcome, ScipyControl]:
    """A run of scipy's METHOD under the run settings and events (see _Segments; with
    friction's mode switches, SEGMENTS_CLASS: scipy_switches.SwitchingSegments)."""
    from scipy.integrate._ivp.ivp import METHODS as SCIPY_CLASSES

    control = ScipyControl(settings, span, flag, STIFFNESS_STAGES.get(method),
                           t_at_mark=span[0])
    options = dict(options)
    if math.isfinite(settings.max_step):
        options["max_step"] = settings.max_step
    segments = (segments_class or _Segments)(
        solve_ivp, rhs, controlled_solver(SCIPY_CLASSES[method]), span, times, options,
        model_events, user_events, control)
    return segments.run(y0), control
