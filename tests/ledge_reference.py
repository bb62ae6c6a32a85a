"""An independent reference for a disc on a surface with ends (issue 50; decision 0042): a
uniform disc dropped on a ledge bounces to rest, rolls to the ledge's end, pivots on its
corner, slips, leaves it and falls to a floor (examples/ball_off_ledge.yaml).

Nothing here imports nemc or shares its code path: the equations are derived by hand below,
written in closed form where one exists and otherwise integrated by scipy's ``solve_ivp`` at a
tight tolerance with a located event.

The disc: mass m, radius r, inertia k m r² (k = 1/2), its center (x, y), its spin w
(counterclockwise), on the ledge y = h for -L <= x <= 0, with the corner C = (0, h); a floor
at y = 0 below.

- The drop from (x0, y0) at speed xd0 without spin: the first impact at t1 = sqrt(2 (y0 - h -
  r) / g). Its friction sticks where that takes |P_t| <= mu P_n (P_n = (1 + e) m sqrt(2 g (y0
  - h - r))): the slip s = x' + r w brought to 0 by P_t = -m k s / (1 + k), so the disc rolls
  on at v = xd0 / (1 + k). The next impacts find no slip: they are normal only, so it bounces
  to rest rolling at v, and its center is over the corner (x = 0) at t_edge = t1 - x1 / v.
- Over the corner the center moves on the circle of radius r about C: at the angle θ from the
  vertical, its speed v = r θ' along t = (cos θ, -sin θ), the outward normal n = (sin θ,
  cos θ). Radially m g cos θ - N = m v² / r; along t, m v' = m g sin θ + F (F the friction
  force along t); the spin I w' = r F.
  Rolling (w = -v / r): F = -k m v', so v' = g sin θ / (1 + k), v² = v0² + 2 g r (1 - cos θ)
  / (1 + k), N = m g ((3 + k) cos θ - 2) / (1 + k) - m v0² / r and |F| = k m g sin θ /
  (1 + k). It slips where |F| = mu N: k sin θ = mu ((3 + k) cos θ - 2 - (1 + k) v0² / (g r))
  (a closed form, solved by bisection to rounding). Without slipping it would leave (N = 0)
  at cos θ = (2 + (1 + k) v0² / (g r)) / (3 + k); frictionless (F = 0, any spin), at cos θ =
  (2 + v0² / (g r)) / 3.
  Slipping forward (the center ahead of the spin): F = -mu N, integrated to N = 0.
- A point (radius 0) sliding on the ledge from x0 at speed v0, friction mu: x = x0 + v0 t -
  mu g t² / 2 until x = 0 (t_e); a corner cannot turn a point, so it flies from there:
  x = v_e (t - t_e), y = -g (t - t_e)² / 2 (v_e = v0 - mu g t_e).
- Then it flies: from the center (r sin θ, h + r cos θ) at velocity v t, it lands on the floor
  (y = r) after the root τ of h + r cos θ - r - v sin θ τ - g τ² / 2 = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

RTOL = 1e-13
ATOL = 1e-15


@dataclass(frozen=True)
class Ledge:
    """The parameters and start of examples/ball_off_ledge.yaml."""

    m: float = 0.2
    r: float = 0.05
    e: float = 0.5
    mu: float = 0.3
    g: float = 9.81
    h: float = 0.5
    L: float = 1.0
    k: float = 0.5  # I / (m r²): a uniform disc
    x0: float = -0.4
    y0: float = 0.85
    xd0: float = 0.4


@dataclass(frozen=True)
class Timeline:
    """The reference's instants and states: the first impact, the roll's speed, the corner
    reached, the slip's start, the leaving, the landing."""

    t1: float
    x1: float
    v_roll: float
    t_inf: float
    t_edge: float
    theta_slip: float
    t_slip: float
    theta_leave: float
    t_leave: float
    speed_leave: float
    t_land: float


def first_impact(p: Ledge) -> tuple[float, float, float]:
    """(t1, x1, v): the first impact's time and place, and the rolling speed after it (the
    friction impulse sticks; asserted)."""
    drop = p.y0 - p.h - p.r
    t1 = math.sqrt(2 * drop / p.g)
    vn = math.sqrt(2 * p.g * drop)
    pt = p.m * p.k * p.xd0 / (1 + p.k)
    assert pt <= p.mu * (1 + p.e) * p.m * vn, "the first impact's friction would slide"
    return t1, p.x0 + p.xd0 * t1, p.xd0 / (1 + p.k)


def slip_angle(p: Ledge, v0: float) -> float:
    """The angle over the corner where rolling from speed V0 at θ = 0 needs more friction
    than mu N: k sin θ = mu ((3 + k) cos θ - 2 - (1 + k) v0² / (g r))."""
    c = (1 + p.k) * v0 ** 2 / (p.g * p.r)

    def excess(theta: float) -> float:
        return p.k * math.sin(theta) - p.mu * ((3 + p.k) * math.cos(theta) - 2 - c)

    assert excess(0.0) < 0, "it would slip at once"
    return brentq(excess, 0.0, math.acos(min(1.0, (2 + c) / (3 + p.k))), xtol=1e-16,
                  rtol=4 * np.finfo(float).eps)


def rolling_leave_angle(p: Ledge, v0: float) -> float:
    """Where a disc rolling without slip from speed V0 at θ = 0 would leave the corner."""
    return math.acos((2 + (1 + p.k) * v0 ** 2 / (p.g * p.r)) / (3 + p.k))


def frictionless_leave_angle(p: Ledge, v0: float) -> float:
    """Where a disc sliding without friction from speed V0 at θ = 0 leaves the corner."""
    return math.acos((2 + v0 ** 2 / (p.g * p.r)) / 3)


def rolling_speed(p: Ledge, v0: float, theta: float) -> float:
    """The center's speed rolling over the corner at θ, from energy with the disc's inertia."""
    return math.sqrt(v0 ** 2 + 2 * p.g * p.r * (1 - math.cos(theta)) / (1 + p.k))


def rolling_time(p: Ledge, v0: float, theta: float) -> float:
    """The time rolling from θ = 0 at speed V0 to θ: the quadrature of r dθ / v."""
    return quad(lambda a: p.r / rolling_speed(p, v0, a), 0.0, theta, epsabs=0.0,
                epsrel=1e-13, limit=200)[0]


def slipping_leave(p: Ledge, theta: float, speed: float) -> tuple[float, float, float]:
    """(time, θ, speed) at which the disc slipping forward over the corner from (THETA,
    SPEED) leaves it: θ'' = (g sin θ - mu N / m) / r, N / m = g cos θ - r θ'², to N = 0."""
    def normal(_: float, y: np.ndarray) -> float:
        return p.g * math.cos(y[0]) - p.r * y[1] ** 2

    def rhs(t: float, y: np.ndarray) -> list[float]:
        return [y[1], (p.g * math.sin(y[0]) - p.mu * normal(t, y)) / p.r]

    normal.terminal, normal.direction = True, -1  # type: ignore[attr-defined]
    sol = solve_ivp(rhs, (0.0, 10.0), [theta, speed / p.r], method="DOP853", rtol=RTOL,
                    atol=ATOL, events=normal)
    (t,), (y,) = sol.t_events[0], sol.y_events[0]
    return t, y[0], p.r * y[1]


def flight_time(p: Ledge, theta: float, speed: float) -> float:
    """The time from leaving the corner at (THETA, SPEED) to the floor (center at y = r)."""
    height = p.h + p.r * math.cos(theta) - p.r
    down = speed * math.sin(theta)
    return (-down + math.sqrt(down ** 2 + 2 * p.g * height)) / p.g


def timeline(p: Ledge = Ledge()) -> Timeline:
    """The whole run's instants, from the drop to the landing on the floor."""
    t1, x1, v = first_impact(p)
    t_edge = t1 - x1 / v
    theta_slip = slip_angle(p, v)
    t_slip = t_edge + rolling_time(p, v, theta_slip)
    dt, theta_leave, speed = slipping_leave(p, theta_slip, rolling_speed(p, v, theta_slip))
    t_leave = t_slip + dt
    return Timeline(t1=t1, x1=x1, v_roll=v, t_inf=t1 * (1 + p.e) / (1 - p.e), t_edge=t_edge,
                    theta_slip=theta_slip, t_slip=t_slip, theta_leave=theta_leave,
                    t_leave=t_leave, speed_leave=speed,
                    t_land=t_leave + flight_time(p, theta_leave, speed))


def point_off_edge(x0: float, v0: float, mu: float, g: float, t: np.ndarray
                   ) -> tuple[float, np.ndarray, np.ndarray]:
    """(t_e, x, y) of a point sliding from X0 at V0 with friction MU to the ledge's end at
    x = 0 (reached at t_e, asserted), then flying: its place at the times T."""
    a = mu * g
    t_e = -x0 / v0 if a == 0 else (v0 - math.sqrt(v0 ** 2 + 2 * a * x0)) / a
    v_e = v0 - a * t_e
    assert v_e > 0, "it stops before the end"
    flying = t > t_e
    x = np.where(flying, v_e * (t - t_e), x0 + v0 * t - a * t ** 2 / 2)
    y = np.where(flying, -g * (t - t_e) ** 2 / 2, 0.0)
    return t_e, x, y
