"""The checks of a call's arguments: each converts what it can (a list to an array, an int to a
float) and refuses the rest with a ModelError that says what was expected. The usual case
(a float, a float64 array of the right shape) is tested first and returned as it is: these run
on every call (issue 19's fixed cost)."""

from __future__ import annotations

import math
import sys
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .failures import ModelError

EPS = float(np.finfo(float).eps)
MIN_RTOL = 100 * EPS  # as scipy's solve_ivp: a smaller rtol is raised to this
FLOAT64 = np.dtype(np.float64)  # native float64's dtype, one object: checked with `is`
MAX_STEP_TIMES = 1_000_000  # times a scene's t_eval {step} may give (memory: n_state doubles each)
MAX_RESULT_VALUES = 2**27  # the numbers one call's results may hold (1 GiB of doubles): checked
#                            before anything is allocated (issue 51: raw MemoryErrors)


def within_budget(what: str, values: int) -> None:
    """Refuse a call whose results would hold more than MAX_RESULT_VALUES numbers, before
    allocating them: WHAT says what would be that large."""
    if values > MAX_RESULT_VALUES:
        raise ModelError(f"{what} would hold {values:.3g} numbers ({values * 8 / 2**30:.3g} "
                         f"GiB), over nemc's budget of {MAX_RESULT_VALUES:.3g} "
                         f"({MAX_RESULT_VALUES * 8 / 2**30:g} GiB) for one call: fewer runs "
                         "or output times")


def real_array(value: Any, what: str) -> np.ndarray:
    """VALUE as a numpy array of real numbers (bool, int, float); anything else is refused."""
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as error:  # e.g. ragged nested lists
        raise ModelError(f"{what} must be an array of real numbers ({error})") from None
    if array.dtype.kind not in "biuf":
        raise ModelError(f"{what} must be real numbers, got dtype {array.dtype}")
    return array


def all_finite(array: np.ndarray) -> bool:
    """Whether every entry is finite. A small array's sum as Python floats (no warning on an
    overflow) says so in 0.2 us where numpy's isfinite().all() takes 1 us: a nan or inf makes
    the sum nan or inf; only then (or after an overflow) each entry is looked at."""
    if array.size <= 64 and math.isfinite(sum(
            array.tolist() if array.ndim == 1 else array.ravel().tolist())):
        return True
    return bool(np.isfinite(array).all())


def finite_number(name: str, value: Any, what: str = "parameter") -> float:
    """One named value (a parameter, a state's entry) as a finite float."""
    if isinstance(value, (str, bytes)) or np.iscomplexobj(value):
        raise ModelError(f"{what} {name!r}: expected a real number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f"{what} {name!r}: expected a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ModelError(f"{what} {name!r}: must be finite, got {number}")
    return number


def checked_state(y: Any, n_state: int) -> np.ndarray:
    """One state as a new-or-checked contiguous float64 array of shape (n_state,)."""
    if (type(y) is np.ndarray and y.dtype is FLOAT64 and y.shape == (n_state,)
            and y.flags.c_contiguous):  # already what C takes
        return y
    array = real_array(y, "state")
    if array.shape != (n_state,):
        raise ModelError(f"state must have shape ({n_state},), got {array.shape}")
    return np.ascontiguousarray(array, dtype=np.float64)


def checked_states(y: Any, n_state: int) -> np.ndarray:
    """(n_state, n) -> contiguous (n, n_state) rows for the C loops."""
    array = real_array(y, "states")
    if array.ndim != 2 or array.shape[0] != n_state:
        expected = f"({n_state}, n)"
        raise ModelError(f"states must be real with shape {expected}, got {array.shape}")
    return np.ascontiguousarray(array.T, dtype=np.float64)


def checked_time(t: Any) -> float:
    """One time: a real scalar."""
    if type(t) is float and math.isfinite(t):
        return t
    array = real_array(t, "time t")
    if array.ndim != 0:
        raise ModelError(f"time t must be a scalar, got shape {array.shape}")
    if not np.isfinite(array):
        raise ModelError(f"time t must be finite, got {float(array)}")
    return float(array)


def times_for(t: Any, count: int) -> np.ndarray:
    """Times for COUNT states: a real scalar or an array of shape (COUNT,)."""
    array = real_array(t, "times t")
    if array.ndim != 0 and array.shape != (count,):
        raise ModelError(f"times t must be a scalar or have shape ({count},), "
                         f"got {array.shape}")
    if not np.isfinite(array).all():
        raise ModelError("times t must be finite")
    return np.ascontiguousarray(np.broadcast_to(array.astype(np.float64), (count,)))


def checked_span(t_span: Any) -> tuple[float, float]:
    """t_span as two finite times. t1 < t0 integrates backwards (every method can); t1 == t0
    returns the initial state."""
    if type(t_span) in (tuple, list) and len(t_span) == 2 and type(t_span[0]) is float \
            and type(t_span[1]) is float:  # the usual case: no array needed
        t0, t1 = t_span
    else:
        array = real_array(t_span, "t_span")
        if array.shape != (2,):
            got = f"{array.size} value(s)" if array.ndim == 1 else f"shape {array.shape}"
            raise ModelError(f"t_span must be two times [t0, t1], got {got}")
        t0, t1 = (float(v) for v in array)
    if not (math.isfinite(t0) and math.isfinite(t1) and math.isfinite(t1 - t0)):
        raise ModelError(f"t_span must be two finite times [t0, t1] (and t1 - t0 finite), "
                         f"got [{t0}, {t1}]")
    return t0, t1


def checked_times(times: np.ndarray, span: tuple[float, ...]) -> np.ndarray:
    """t_eval checked, as a contiguous float array: 1-d, not empty, finite, within t_span, in
    the span's direction. (solve_ivp silently drops NaN times and fails on an empty t_eval.)"""
    times = np.asarray(times, dtype=float)
    t0, tf = span
    if times.ndim != 1 or not times.size:
        raise ModelError(f"t_eval must be a 1-d list of at least one time (or None: the "
                         f"solver's own steps), got shape {times.shape}")
    if times.size == 1:  # the usual short case: no numpy reduction (0.15 us less)
        low = high = times.item()
    else:
        low, high = times.min(), times.max()  # a nan or inf shows in min or max
    first, last = (t0, tf) if t0 <= tf else (tf, t0)
    if not (first <= low and high <= last):  # the span is finite: so are the times, if within
        if not (math.isfinite(low) and math.isfinite(high)):
            raise ModelError("Values in `t_eval` are not within `t_span`: "
                             f"{times[~np.isfinite(times)][0]} is not finite")
        raise ModelError(f"Values in `t_eval` are not within `t_span` {list(span)}")
    if times.size > 1:
        d = np.diff(times)
        if not ((tf > t0 and d.min() > 0) or (tf < t0 and d.max() < 0)):
            direction = "increasing" if tf > t0 else "decreasing"
            raise ModelError(f"Values in `t_eval` are not properly sorted: they must be strictly "
                             f"{direction}, as t_span {list(span)}")
    return np.ascontiguousarray(times)


def step_times(span: tuple[float, ...], step: float) -> np.ndarray:
    """t0, t0 + step, ... up to t1 (down to t1 when t1 < t0), at most MAX_STEP_TIMES of them."""
    ratio = abs(span[1] - span[0]) / step
    if not ratio < MAX_STEP_TIMES:
        raise ModelError(f"t_eval {{step: {step:g}}} over t_span {list(span)} gives more than "
                         f"{MAX_STEP_TIMES} times: use a larger step or a shorter span")
    count = int(math.floor(ratio * (1 + 1e-12))) + 1
    return span[0] + math.copysign(step, span[1] - span[0]) * np.arange(count)


def checked_method(method: Any, methods: Sequence[str]) -> str:
    if not isinstance(method, str) or method not in methods:
        raise ModelError(f"unknown method {method!r}; choose one of {', '.join(methods)}")
    return method


def checked_tolerances(rtol: Any, atol: Any) -> tuple[float, float]:
    """rtol in (0, 1) and atol >= 0, each one finite number (scipy would take rtol 1e10, and a
    native method then returned 1e54 with success). rtol below 100 eps is raised to it with a
    warning, by scipy and native_tolerances alike."""
    if type(rtol) is float and type(atol) is float and 0 < rtol < 1 and 0 <= atol < math.inf:
        return rtol, atol  # the usual case (a nan fails every comparison)
    rtol, atol = _tolerance(rtol, "rtol"), _tolerance(atol, "atol")
    if not 0 < rtol < 1:
        raise ModelError(f"rtol must be > 0 and < 1 (a relative error), got {rtol:g}")
    if not atol >= 0:
        raise ModelError(f"atol must be >= 0, got {atol:g}")
    return rtol, atol


def _tolerance(value: Any, name: str) -> float:
    if type(value) is float:  # the usual case (checked finite below)
        return _finite_tolerance(value, name)
    if isinstance(value, (bool, np.bool_)):
        raise ModelError(f"{name} must be a number, got {value!r}")
    array = real_array(value, name)
    if array.ndim != 0:
        raise ModelError(f"{name} must be one number (tolerances per state entry are not "
                         f"supported), got an array of shape {array.shape}")
    return _finite_tolerance(float(array), name)


def _finite_tolerance(number: float, name: str) -> float:
    if not math.isfinite(number):
        raise ModelError(f"{name} must be finite, got {number}")
    return number


def native_tolerances(rtol: float, atol: float) -> tuple[float, float]:
    """rtol and atol checked as scipy's validate_tol (rtol raised to 100 eps, with a warning
    that names the user's line)."""
    if rtol < MIN_RTOL:
        warnings.warn(f"At least one element of `rtol` is too small. Setting"
                      f" `rtol = np.maximum(rtol, {MIN_RTOL})`.", stacklevel=_user_stacklevel())
        rtol = MIN_RTOL
    if not (atol >= 0 and math.isfinite(atol) and math.isfinite(rtol)):
        raise ModelError(f"atol must be finite and >= 0, rtol finite; got {atol}, {rtol}")
    return rtol, atol


def _user_stacklevel() -> int:
    """warnings.warn's stacklevel, called here, that names the first frame outside nemc: the
    user's line, however deep in nemc the warning is made."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").partition(".")[0] == "nemc":
        frame, level = frame.f_back, level + 1
    return level


def checked_threads(threads: Any) -> int | None:
    if threads is None:
        return None
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)) \
            or threads < 1:
        raise ModelError(f"threads must be a whole number >= 1 (or None: every core), "
                         f"got {threads!r}")
    return int(threads)


def checked_max_events(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ModelError(f"max_events must be a whole number >= 0, got {value!r}")
    return int(value)


def ensemble_columns(params: Any, what: str = "parameter", argument: str = "params"
                     ) -> dict[str, np.ndarray]:
    """simulate_many's params (or a dict y0s: WHAT "state value"): name -> 1-d float array
    (one value, or one per run)."""
    if params is None:
        return {}
    if not isinstance(params, Mapping):
        raise ModelError(f"{argument} must be a mapping name -> value(s), got "
                         f"{type(params).__name__}")
    columns = {}
    for name, value in params.items():
        array = real_array(value, f"{what} {name!r}")
        if array.ndim > 1:
            raise ModelError(f"{what} {name!r}: expected a number or a 1-d array of one value"
                             f" per run, got shape {array.shape}")
        within_budget(f"{what} {name!r} of {array.size} values", array.size)
        columns[name] = np.atleast_1d(array.astype(float))
    return columns
