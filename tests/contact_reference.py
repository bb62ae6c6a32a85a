"""Independent references for Coulomb friction that sticks and slips, and contacts that last
(issue 50; the spec's "Friction that sticks and slips" and "Contacts that last").

Nothing here imports nemc: each system's equations of motion are derived by hand below (in
the docstrings), and integrated by scipy's ``solve_ivp`` at a tight tolerance with located
events for every switch (stick/slip, impact), or written in closed form where one exists. The
tests of nemc's implementation compare against these; tests/test_contact_reference.py checks
these against their own closed forms and against energy balances.

Systems (each a frozen dataclass of parameters with the defaults of its example file in
tests/data/friction/):

- ``Incline``: a block on an incline whose angle is driven, alpha(t) = alpha0 + w t, about a
  pivot on the block's path (block_incline.yaml). Stick time and slip distance in closed form.
- ``StickSlip``: a mass on a moving belt held by a spring to a wall (stick_slip.yaml). Limit
  cycle (period, stick time) in closed form; an event-driven solver from any state.
- ``SliderCrank``: a flywheel crank, rod and slider with dry friction on the slider's guide,
  driven by an oscillating motor torque (slider_crank_friction.yaml). The coupled normal force
  and friction solved together in maximal coordinates with Lagrange multipliers.
- ``Ball``: a ball bouncing with restitution e and Coulomb friction in the impacts on a floor,
  coming to rest (lasting contact), sliding, then rolling (ball_to_rest.yaml). Closed form.
- ``RockingBlock``: Housner's rigid block rocking on its corners on a rigid floor
  (rocking_block.yaml). Amplitude decay and impact times exact (the times by quadrature).
  On a table shaken by a half-sine pulse of acceleration (``BasePulse``,
  rocking_block_pulse.yaml): it rests, lifts and rocks, or slides, then rests again; the
  onsets and the slide in closed form.
- ``CartPendulumWall``: a cart with dry friction on a rough floor carrying a rod whose tip
  strikes a wall (tests/data/contacts/cart_pendulum_wall.yaml): joint friction and a contact
  together, Coulomb's law in the impacts' impulses too. Lagrange's equations by hand.
- ``CartBall``: a sliding cart with dry friction carrying a ball on a vertical slider that
  bounces to rest on a rough floor (tests/data/contacts/cart_ball_floor.yaml): the cart's
  speed through the impacts' friction impulses and the lasting contact in closed form.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import quad, solve_ivp

RTOL = 1e-12
ATOL = 1e-14


def _event(fun: Callable[..., float], direction: float = 0.0) -> Callable[..., float]:
    """A solve_ivp event that stops the integration (each switch restarts it)."""
    fun.terminal = True  # type: ignore[attr-defined]
    fun.direction = direction  # type: ignore[attr-defined]
    return fun


@dataclass(frozen=True)
class Segment:
    """One mode's stretch of a run: [t0, t1], its mode name, and its state at t as a callable."""

    t0: float
    t1: float
    mode: str
    state: Callable[[float], np.ndarray]


@dataclass
class Run:
    """An event-driven run: its segments in time order, the switches (time, name) between them,
    the friction work (the friction's power on the relative sliding, integrated: <= 0) and the
    work of the motors (where a system has one)."""

    segments: list[Segment] = field(default_factory=list)
    switches: list[tuple[float, str]] = field(default_factory=list)
    friction_work: float = 0.0
    input_work: float = 0.0  # the work of the drives or motors on the system

    def state(self, t: float) -> np.ndarray:
        """The state at time t (the segment holding t; at a switch, the later one)."""
        for seg in reversed(self.segments):
            if seg.t0 <= t:
                return seg.state(t)
        raise ValueError(f"t = {t} is before the run's start {self.segments[0].t0}")

    def switch_times(self, name: str) -> list[float]:
        return [t for t, n in self.switches if n == name]


# =============================================================================================
# a. A block on a driven incline


@dataclass(frozen=True)
class Incline:
    """A block (mass m, its mass center on the incline's line) on an incline turning about a
    ground pivot O at alpha(t) = alpha0 + w t (counterclockwise, driven), s its position along
    the incline from O (up the slope positive), Coulomb friction mu_k, mu_s between them.

    Derivation (polar coordinates about O, e_t = (cos a, sin a), e_n = (-sin a, cos a)): the
    block at s e_t has acceleration (s'' - s w^2) e_t + (2 s' w) e_n (alpha'' = 0). With the
    incline's normal push N e_n and friction F e_t on it, and gravity -m g j:

        m (s'' - s w^2) = -m g sin a + F,        m 2 s' w = N - m g cos a.

    Stuck (s' = 0, s fixed): F = m g sin a - m s w^2 holds it while |F| <= mu_s N,
    N = m g cos a. Sliding: F = -sign(s') mu_k |N|. From s0 = 0 (the block at the pivot) the
    holding force is m g sin a and the block slips when tan a = mu_s:
    t_slip = (atan(mu_s) - alpha0) / w. Sliding down (s' < 0, F = mu_k N):

        s'' - 2 mu_k w s' - w^2 s = -g (sin a - mu_k cos a),

    linear with constant coefficients: s = A sin a + B cos a + C1 exp(l1 tau) + C2 exp(l2 tau),
    tau = t - t_slip, l = w (mu_k +- sqrt(1 + mu_k^2)), A = c (1 - mu_k^2) / (1 + mu_k^2),
    B = -2 mu_k c / (1 + mu_k^2), c = g / (2 w^2); C1, C2 from s = s' = 0 at t_slip.
    """

    m: float = 1.0
    g: float = 9.81
    mu_s: float = 0.5
    mu_k: float = 0.4
    alpha0: float = 0.2
    w: float = 0.1

    def alpha(self, t: float) -> float:
        return self.alpha0 + self.w * t

    def normal(self, t: float, s_dot: float) -> float:
        return self.m * (self.g * math.cos(self.alpha(t)) + 2.0 * s_dot * self.w)

    def holding(self, t: float, s: float) -> float:
        """Friction force (along e_t) that keeps the block stuck at s."""
        return self.m * (self.g * math.sin(self.alpha(t)) - s * self.w**2)


def incline_slip_time(p: Incline) -> float:
    """Closed form, block stuck at the pivot (s0 = 0): tan(alpha) reaches mu_s."""
    return (math.atan(p.mu_s) - p.alpha0) / p.w


def incline_slide(p: Incline, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Closed form (s, s') while sliding down from rest at the pivot at incline_slip_time."""
    ts = incline_slip_time(p)
    c = p.g / (2.0 * p.w**2)
    mu = p.mu_k
    a_coef = c * (1.0 - mu**2) / (1.0 + mu**2)
    b_coef = -2.0 * mu * c / (1.0 + mu**2)
    root = math.sqrt(1.0 + mu**2)
    l1, l2 = p.w * (mu + root), p.w * (mu - root)
    a_s = p.alpha(ts)
    # particular solution and its rate at t_slip; C1 + C2 and l1 C1 + l2 C2 cancel them
    sp0 = a_coef * math.sin(a_s) + b_coef * math.cos(a_s)
    spd0 = p.w * (a_coef * math.cos(a_s) - b_coef * math.sin(a_s))
    c1 = (-spd0 + l2 * sp0) / (l1 - l2)
    c2 = -sp0 - c1
    tau = np.asarray(t, dtype=float) - ts
    a = p.alpha0 + p.w * np.asarray(t, dtype=float)
    s = a_coef * np.sin(a) + b_coef * np.cos(a) + c1 * np.exp(l1 * tau) + c2 * np.exp(l2 * tau)
    sd = (p.w * (a_coef * np.cos(a) - b_coef * np.sin(a))
          + l1 * c1 * np.exp(l1 * tau) + l2 * c2 * np.exp(l2 * tau))
    return s, sd


def incline_friction_work(p: Incline, t_end: float) -> float:
    """Closed form's friction work up to t_end: the integral of F s' (F = mu_k N, sliding)."""
    ts = incline_slip_time(p)
    if t_end <= ts:
        return 0.0

    def power(t: float) -> float:
        _, sd = incline_slide(p, t)
        return float(p.mu_k * p.normal(t, float(sd)) * sd)

    return quad(power, ts, t_end, epsabs=1e-14, epsrel=1e-13, limit=200)[0]


def _incline_slip_rhs(p: Incline, sigma: float) -> Callable[[float, np.ndarray], np.ndarray]:
    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        s, sd = y[0], y[1]
        friction = -sigma * p.mu_k * abs(p.normal(t, sd))
        sdd = s * p.w**2 - p.g * math.sin(p.alpha(t)) + friction / p.m
        return np.array([sd, sdd, friction * sd])

    return rhs


def incline_run(p: Incline, t_end: float, s0: float = 0.0, sd0: float = 0.0) -> Run:
    """Event-driven run from (s0, s0'): stuck while |holding| <= mu_s N, else sliding; switches
    'slip' (the holding force reaches its limit), 'stick' (s' = 0 with the holding force within
    it) and 'reverse' (s' = 0, not held: it slides back). State: [s, s']."""
    run = Run()
    t, s, sd = 0.0, s0, sd0
    mode = "stick" if sd0 == 0.0 and _incline_holds(p, t, s) else "slip"
    while t < t_end:
        if mode == "stick":
            t1 = _incline_stick_end(p, t, s, t_end)
            run.segments.append(Segment(t, t1, "stick", _at_rest(s)))
            t = t1
            if t1 < t_end:
                run.switches.append((t, "slip"))
            mode = "slip"
            continue
        sigma = math.copysign(1.0, sd) if sd != 0.0 else -math.copysign(1.0, p.holding(t, s))
        stop = _event(lambda _t, y: y[1], sigma * -1.0)
        sol = solve_ivp(_incline_slip_rhs(p, sigma), (t, t_end), [s, sd, 0.0], rtol=RTOL,
                        atol=ATOL, events=stop, dense_output=True)
        run.segments.append(Segment(t, sol.t[-1], "slip", _first_two(sol.sol)))
        run.friction_work += sol.y[2, -1]
        t, s, sd = sol.t[-1], sol.y[0, -1], 0.0 if sol.status == 1 else sol.y[1, -1]
        if sol.status == 1:
            held = _incline_holds(p, t, s)
            run.switches.append((t, "stick" if held else "reverse"))
            mode = "stick" if held else "slip"
    return run


def _incline_holds(p: Incline, t: float, s: float) -> bool:
    return abs(p.holding(t, s)) <= p.mu_s * abs(p.normal(t, 0.0))


def _incline_stick_end(p: Incline, t0: float, s: float, t_end: float) -> float:
    """First time after t0 where the holding force reaches mu_s N (located as an event)."""
    limit = _event(lambda t, _y: abs(p.holding(t, s)) - p.mu_s * abs(p.normal(t, 0.0)), 1.0)
    sol = solve_ivp(lambda _t, _y: np.zeros(1), (t0, t_end), [0.0], events=limit,
                    max_step=0.01 / p.w, rtol=RTOL, atol=ATOL)
    return float(sol.t_events[0][0]) if sol.status == 1 else t_end


def _at_rest(position: float) -> Callable[[float], np.ndarray]:
    """A stuck segment's state [position, 0]."""
    return lambda _t: np.array([position, 0.0])


def _first_two(sol: Callable[[float], np.ndarray]) -> Callable[[float], np.ndarray]:
    """A slip segment's state [position, rate] from its dense output (work integrals left out)."""
    return lambda t: np.asarray(sol(t))[:2]


# =============================================================================================
# b. The belt-driven stick-slip oscillator


@dataclass(frozen=True)
class StickSlip:
    """A mass m on a belt moving at v_belt, a spring k from a wall: x its position (0 where the
    spring is relaxed), Coulomb friction of the belt on it with N = m g:

        m x'' = -k x + F,   F = -mu_k m g sign(x' - v_belt) sliding,
        stuck (x' = v_belt): F = k x while |k x| <= mu_s m g.

    The limit cycle: stuck from x = x_k - D to x_k + D (x_k = mu_k m g / k, the slip arc's
    centre; D = (mu_s - mu_k) m g / k; the stick ends where k x = mu_s m g), then a harmonic arc
    about x_k (omega = sqrt(k/m)) from (x_k + D, v) around to (x_k - D, v), where the relative
    velocity is zero again and the holding force |k x| = |2 mu_k - mu_s| m g is within
    mu_s m g. With theta0 = atan2(v/omega, D): slip time (pi + 2 theta0)/omega, stick time
    2 D / v. Per cycle the friction's work on the mass is 0 and the dissipation (its power on
    the sliding, -F (x' - v)) is mu_k m g (v slip_time + 2 D).
    """

    m: float = 1.0
    k: float = 100.0
    g: float = 9.81
    mu_s: float = 0.4
    mu_k: float = 0.3
    v_belt: float = 0.1

    @property
    def omega(self) -> float:
        return math.sqrt(self.k / self.m)

    @property
    def x_kinetic(self) -> float:
        return self.mu_k * self.m * self.g / self.k

    @property
    def x_static(self) -> float:
        return self.mu_s * self.m * self.g / self.k


@dataclass(frozen=True)
class Cycle:
    """The stick-slip limit cycle (closed form)."""

    period: float
    stick_time: float
    slip_time: float
    x_stick: float  # where sticking starts
    x_slip: float  # where slipping starts (k x = mu_s m g)
    amplitude: float  # the slip arc's amplitude about x_kinetic
    dissipation: float  # per cycle, >= 0


def stick_slip_cycle(p: StickSlip) -> Cycle:
    d = p.x_static - p.x_kinetic
    theta0 = math.atan2(p.v_belt / p.omega, d)
    slip = (math.pi + 2.0 * theta0) / p.omega
    stick = 2.0 * d / p.v_belt
    dissipation = p.mu_k * p.m * p.g * (p.v_belt * slip + 2.0 * d)
    return Cycle(slip + stick, stick, slip, p.x_kinetic - d, p.x_static,
                 math.hypot(d, p.v_belt / p.omega), dissipation)


def stick_slip_closed_form(p: StickSlip, t: float) -> tuple[float, float, bool]:
    """(x, x', stuck) at time t of the run started stuck at x = 0 (x' = v_belt): stuck until
    k x = mu_s m g at t = x_static / v, then on the limit cycle."""
    c = stick_slip_cycle(p)
    t_first = p.x_static / p.v_belt
    if t < t_first:
        return p.v_belt * t, p.v_belt, True
    tau = (t - t_first) % c.period
    if tau < c.slip_time:
        d = p.x_static - p.x_kinetic
        u = d * math.cos(p.omega * tau) + p.v_belt / p.omega * math.sin(p.omega * tau)
        ud = -d * p.omega * math.sin(p.omega * tau) + p.v_belt * math.cos(p.omega * tau)
        return p.x_kinetic + u, ud, False
    return c.x_stick + p.v_belt * (tau - c.slip_time), p.v_belt, True


def stick_slip_switches(p: StickSlip, t_end: float) -> list[tuple[float, str]]:
    """Closed form switch times (time, 'slip' or 'stick') of the run from x = 0, stuck."""
    c = stick_slip_cycle(p)
    out, t = [], p.x_static / p.v_belt
    while t < t_end:
        out.append((t, "slip"))
        if t + c.slip_time < t_end:
            out.append((t + c.slip_time, "stick"))
        t += c.period
    return out


def stick_slip_stick_intervals(p: StickSlip, t_end: float) -> list[tuple[float, float]]:
    """Closed form stick intervals within [0, t_end]."""
    sw = [(0.0, "stick"), *stick_slip_switches(p, t_end), (t_end, "slip")]
    return [(a, b) for (a, na), (b, _nb) in zip(sw, sw[1:]) if na == "stick"]


def stick_slip_run(p: StickSlip, t_end: float, x0: float = 0.0, xd0: float | None = None) -> Run:
    """Event-driven run from (x0, x0') (default: stuck on the belt). State [x, x'];
    friction_work is the dissipation's negative, the integral of F (x' - v_belt)."""
    run = Run()
    t, x, xd = 0.0, x0, p.v_belt if xd0 is None else xd0
    mode = "stick" if xd == p.v_belt and abs(p.k * x) <= p.mu_s * p.m * p.g else "slip"
    while t < t_end:
        if mode == "stick":
            t1 = _stick_slip_stick_end(p, t, x, t_end)
            run.segments.append(Segment(t, t1, "stick", _belt_motion(p, t, x)))
            x, xd, t = x + p.v_belt * (t1 - t), p.v_belt, t1
            if t < t_end:
                run.switches.append((t, "slip"))
            mode = "slip"
            continue
        rel = xd - p.v_belt
        sigma = math.copysign(1.0, rel) if rel != 0.0 else math.copysign(1.0, -p.k * x)
        t, x, xd, stopped = _stick_slip_slide(p, run, t, x, xd, sigma, t_end)
        if stopped:
            if abs(p.k * x) <= p.mu_s * p.m * p.g:
                run.switches.append((t, "stick"))
                mode = "stick"
            else:
                run.switches.append((t, "reverse"))
    return run


def _stick_slip_stick_end(p: StickSlip, t0: float, x0: float, t_end: float) -> float:
    """Stuck from x0 at t0: the holding force k x reaches mu_s m g (closed form, x linear)."""
    limit = p.x_static if p.v_belt > 0 else -p.x_static
    return min(t_end, t0 + (limit - x0) / p.v_belt)


def _belt_motion(p: StickSlip, t0: float, x0: float) -> Callable[[float], np.ndarray]:
    return lambda t: np.array([x0 + p.v_belt * (t - t0), p.v_belt])


def _stick_slip_slide(p: StickSlip, run: Run, t: float, x: float, xd: float, sigma: float,
                      t_end: float) -> tuple[float, float, float, bool]:
    """Slide with friction -sigma mu_k m g until the relative velocity returns to zero."""
    friction = -sigma * p.mu_k * p.m * p.g

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        return np.array([y[1], (-p.k * y[0] + friction) / p.m, friction * (y[1] - p.v_belt)])

    stop = _event(lambda _t, y: y[1] - p.v_belt, -sigma)
    sol = solve_ivp(rhs, (t, t_end), [x, xd, 0.0], method="DOP853", rtol=RTOL, atol=ATOL,
                    events=stop, dense_output=True)
    run.segments.append(Segment(t, sol.t[-1], "slip", _first_two(sol.sol)))
    run.friction_work += sol.y[2, -1]
    stopped = sol.status == 1
    return sol.t[-1], sol.y[0, -1], p.v_belt if stopped else sol.y[1, -1], stopped


# =============================================================================================
# c. A slider-crank with dry friction on the slider


class PainleveError(ValueError):
    """The coupled friction/normal-force problem has no solution or two (Painleve's paradox)."""


@dataclass(frozen=True)
class SliderCrank:
    """Crank (a flywheel: mass center on its ground pivot O, inertia i1) of radius r, rod of
    length l (mass m2, uniform), slider (mass ms) on the ground's x axis; gravity -g j; a motor
    pushing the crank in pulses, torque T0 max(0, sin(W t)) (it coasts to a stop between
    them); Coulomb friction mu_k, mu_s of the guide on the slider, its normal force the
    guide's reaction (it depends on the accelerations).

    Derivation (independent of nemc's tree coordinates): maximal coordinates, three bodies of
    three coordinates each, q = [x1 y1 t1, x2 y2 t2, x3 y3 t3] (mass centers and angles), and
    eight constraint equations: the crank's center at O (2), the rod's end -l/2 at the crank pin
    (r, 0) (2), the rod's end +l/2 at the slider (2), the guide y3 = 0 and t3 = 0 (2). Newton-
    Euler for each body with Lagrange multipliers lambda (G = dC/dq):

        M a = f + G^T lambda + F e_x3,    G a = gamma = -(dG/dt) v,

    where the guide's multiplier lambda_N (row y3) is the normal force N on the slider, and the
    friction while sliding is F = -mu_k sigma |N| (sigma the slider's direction of motion). With
    nu = sign(N) assumed, F = -mu_k sigma nu lambda_N is linear in the unknowns: the augmented
    linear system is solved for nu = +1 and nu = -1 and the solutions whose N has the assumed
    sign are kept; none or two is Painleve's paradox (PainleveError). Stuck, the slider's
    velocity is zero and the mechanism (one degree of freedom) is at rest: F is the multiplier
    of an added row x3 = const, held while |F| <= mu_s |N|.

    The state integrated is the crank's (t1, t1'); the maximal q and v follow from it in closed
    form (rod angle t2 = asin(-r sin t1 / l), the slider to the right of the crank). At a dead
    centre the slider's velocity is zero whatever the crank's rate: the slider reverses there
    (sigma flips, no stick test); a stop exactly at a dead centre (the holding problem
    singular) is not handled.
    """

    r: float = 0.1
    rod: float = 0.35  # the rod's length l
    i1: float = 0.05
    m1: float = 2.0
    m2: float = 0.9
    ms: float = 1.2
    g: float = 9.81
    mu_s: float = 0.4
    mu_k: float = 0.3
    T0: float = 1.0
    W: float = 2.0 * math.pi


def _rot(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def _perp(angle: float, u: np.ndarray) -> np.ndarray:
    """d/dangle of rot(angle) u."""
    return _rot(angle + math.pi / 2.0) @ u


def slider_crank_pose(p: SliderCrank, th: float, thd: float) -> tuple[np.ndarray, np.ndarray]:
    """Maximal coordinates q (9) and velocities v (9) from the crank's angle and rate."""
    sin2 = -p.r * math.sin(th) / p.rod
    t2 = math.asin(sin2)
    t2d = -p.r * math.cos(th) * thd / (p.rod * math.cos(t2))
    pin = p.r * np.array([math.cos(th), math.sin(th)])
    pin_d = p.r * thd * np.array([-math.sin(th), math.cos(th)])
    e2 = np.array([math.cos(t2), math.sin(t2)])
    e2d = t2d * np.array([-math.sin(t2), math.cos(t2)])
    rod = pin + 0.5 * p.rod * e2
    rod_d = pin_d + 0.5 * p.rod * e2d
    slider = pin + p.rod * e2
    slider_d = pin_d + p.rod * e2d
    q = np.array([0.0, 0.0, th, *rod, t2, slider[0], 0.0, 0.0])
    v = np.array([0.0, 0.0, thd, *rod_d, t2d, slider_d[0], 0.0, 0.0])
    return q, v


def _slider_crank_constraints(p: SliderCrank, q: np.ndarray,
                              v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """G = dC/dq (8 x 9) and gamma = -(dG/dt) v of the eight constraint equations."""
    g_mat = np.zeros((8, 9))
    gamma = np.zeros(8)
    g_mat[0, 0] = g_mat[1, 1] = 1.0
    u1, u2, u3 = np.array([p.r, 0.0]), np.array([-0.5 * p.rod, 0.0]), np.array([0.5 * p.rod, 0.0])
    t1, t2 = q[2], q[5]
    # crank pin: p1 + R1 u1 - p2 - R2 u2 = 0
    g_mat[2:4, 0:2] = np.eye(2)
    g_mat[2:4, 2] = _perp(t1, u1)
    g_mat[2:4, 3:5] = -np.eye(2)
    g_mat[2:4, 5] = -_perp(t2, u2)
    gamma[2:4] = _rot(t1) @ u1 * v[2] ** 2 - _rot(t2) @ u2 * v[5] ** 2
    # rod end at the slider: p2 + R2 u3 - p3 = 0
    g_mat[4:6, 3:5] = np.eye(2)
    g_mat[4:6, 5] = _perp(t2, u3)
    g_mat[4:6, 6:8] = -np.eye(2)
    gamma[4:6] = _rot(t2) @ u3 * v[5] ** 2
    # guide: y3 = 0 (its multiplier: N), t3 = 0
    g_mat[6, 7] = g_mat[7, 8] = 1.0
    return g_mat, gamma


def slider_crank_torque(p: SliderCrank, t: float) -> float:
    """The motor's torque on the crank."""
    return p.T0 * max(0.0, math.sin(p.W * t))


def _next_kink(p: SliderCrank, t: float) -> float:
    """The torque's next kink after t (a zero of sin(W t)): segments end there."""
    half = math.pi / p.W
    return (math.floor(t / half * (1.0 + 1e-13) + 1e-13) + 1) * half


def _slider_crank_mass_force(p: SliderCrank, t: float) -> tuple[np.ndarray, np.ndarray]:
    i2 = p.m2 * p.rod**2 / 12.0
    i3 = 1.0  # the slider's rotation is held by the guide; any inertia
    mass = np.diag([p.m1, p.m1, p.i1, p.m2, p.m2, i2, p.ms, p.ms, i3])
    force = np.array([0.0, -p.m1 * p.g, slider_crank_torque(p, t),
                      0.0, -p.m2 * p.g, 0.0, 0.0, -p.ms * p.g, 0.0])
    return mass, force


N_ROW = 6  # the guide's y3 multiplier among the eight


def slider_crank_sliding(p: SliderCrank, t: float, th: float, thd: float,
                         sigma: float) -> tuple[np.ndarray, float, float]:
    """Accelerations (9), N and F while sliding in direction sigma (the coupled problem)."""
    q, v = slider_crank_pose(p, th, thd)
    g_mat, gamma = _slider_crank_constraints(p, q, v)
    mass, force = _slider_crank_mass_force(p, t)
    found = []
    for nu in (1.0, -1.0):
        k = np.zeros((17, 17))
        k[:9, :9] = mass
        k[:9, 9:] = -g_mat.T
        k[6, 9 + N_ROW] += p.mu_k * sigma * nu  # F e_x3 moved to the left: -F = mu sigma nu N
        k[9:, :9] = g_mat
        z = np.linalg.solve(k, np.concatenate([force, gamma]))
        normal = z[9 + N_ROW]
        if normal * nu >= 0.0:
            found.append((z[:9], normal, -p.mu_k * sigma * abs(normal)))
    if len(found) != 1:
        raise PainleveError(f"Painleve's paradox at t = {t}: {len(found)} solutions "
                            f"of the sliding slider's normal force and friction")
    return found[0]


def slider_crank_holding(p: SliderCrank, t: float, th: float) -> tuple[float, float]:
    """Stuck at rest at crank angle th: (F, N), the friction that holds the slider, the normal
    force (a ninth constraint row x3 = const; all bodies at rest)."""
    q, v = slider_crank_pose(p, th, 0.0)
    g_mat, gamma = _slider_crank_constraints(p, q, v)
    g_mat = np.vstack([g_mat, np.eye(9)[6]])
    gamma = np.append(gamma, 0.0)
    mass, force = _slider_crank_mass_force(p, t)
    k = np.zeros((18, 18))
    k[:9, :9], k[:9, 9:], k[9:, :9] = mass, -g_mat.T, g_mat
    z = np.linalg.solve(k, np.concatenate([force, gamma]))
    return z[9 + 8], z[9 + N_ROW]


def slider_crank_energy(p: SliderCrank, th: float, thd: float) -> float:
    """Kinetic plus gravitational potential energy."""
    q, v = slider_crank_pose(p, th, thd)
    mass, _ = _slider_crank_mass_force(p, 0.0)
    return 0.5 * v @ mass @ v + p.g * (p.m1 * q[1] + p.m2 * q[4] + p.ms * q[7])


def _slider_velocity_per_rate(p: SliderCrank, th: float) -> float:
    _, v = slider_crank_pose(p, th, 1.0)
    return v[6]


def _slider_velocity_per_rate_after(p: SliderCrank, th: float, thd: float) -> float:
    """The slider's velocity per crank rate as it is just after now, the crank turning in
    thd's direction (at a dead centre it is zero now: its value a small turn further on)."""
    j_now = _slider_velocity_per_rate(p, th)
    if abs(j_now) < 1e-9 * p.r:
        j_now = _slider_velocity_per_rate(p, th + 1e-6 * math.copysign(1.0, thd))
    return j_now


def slider_crank_run(p: SliderCrank, t_end: float, th0: float, thd0: float = 0.0) -> Run:
    """Event-driven run from crank angle th0 and rate thd0. State [t1, t1']. Switches:
    'stick' (stopped, held), 'slip' (the holding force reaches mu_s |N|), 'dead_centre' (the
    slider reverses while the crank turns: sigma flips), 'reverse' (stopped, not held)."""
    run = Run()
    t, th, thd = 0.0, th0, thd0
    mode = "stick" if thd0 == 0.0 and _crank_held(p, t, th) else "slip"
    while t < t_end:
        if mode == "stick":
            t1 = _crank_stick_end(p, t, th, t_end)
            run.segments.append(Segment(t, t1, "stick", _at_rest(th)))
            t = t1
            if t < t_end:
                run.switches.append((t, "slip"))
            mode = "slip"
            continue
        sigma = _crank_sigma(p, t, th, thd)
        t, th, thd, name = _crank_slide(p, run, t, th, thd, sigma, t_end)
        if name == "stop":
            if _crank_held(p, t, th):
                run.switches.append((t, "stick"))
                mode = "stick"
            else:
                run.switches.append((t, "reverse"))
        elif name == "dead_centre":
            run.switches.append((t, "dead_centre"))
    return run


def _crank_held(p: SliderCrank, t: float, th: float) -> bool:
    f, n = slider_crank_holding(p, t, th)
    return abs(f) <= p.mu_s * abs(n)


def _crank_sigma(p: SliderCrank, t: float, th: float, thd: float) -> float:
    """The slider's direction of sliding: of its velocity, or at rest the consistent one."""
    if thd != 0.0:
        return math.copysign(1.0, _slider_velocity_per_rate_after(p, th, thd) * thd)
    for sigma in (1.0, -1.0):
        acc, _, _ = slider_crank_sliding(p, t, th, 0.0, sigma)
        if acc[6] * sigma > 0.0:
            return sigma
    raise PainleveError(f"no consistent sliding direction at t = {t}")


def _crank_stick_end(p: SliderCrank, t0: float, th: float, t_end: float) -> float:
    def limit(t: float, _y: np.ndarray) -> float:
        f, n = slider_crank_holding(p, t, th)
        return abs(f) - p.mu_s * abs(n)

    sol = solve_ivp(lambda _t, _y: np.zeros(1), (t0, t_end), [0.0], events=_event(limit, 1.0),
                    max_step=0.01 * 2.0 * math.pi / p.W, rtol=RTOL, atol=ATOL)
    return float(sol.t_events[0][0]) if sol.status == 1 else t_end


def _crank_slide(p: SliderCrank, run: Run, t: float, th: float, thd: float, sigma: float,
                 t_end: float) -> tuple[float, float, float, str]:
    """Slide in direction sigma until the crank stops or the slider passes a dead centre.
    The state integrates [t1, t1', friction work, motor work]."""

    def rhs(tt: float, y: np.ndarray) -> np.ndarray:
        acc, _, friction = slider_crank_sliding(p, tt, y[0], y[1], sigma)
        vel = _slider_velocity_per_rate(p, y[0]) * y[1]
        return np.array([y[1], acc[2], friction * vel, slider_crank_torque(p, tt) * y[1]])

    if thd != 0.0:
        turning = math.copysign(1.0, thd)
    else:
        turning = math.copysign(1.0, slider_crank_sliding(p, t, th, 0.0, sigma)[0][2])
    stop = _event(lambda _t, y: y[1], -turning)
    j_after = _slider_velocity_per_rate_after(p, th, turning)
    dead = _event(lambda _t, y: _slider_velocity_per_rate(p, y[0]), -math.copysign(1.0, j_after))
    t_stop = min(t_end, _next_kink(p, t))
    sol = solve_ivp(rhs, (t, t_stop), [th, thd, 0.0, 0.0], method="DOP853", rtol=RTOL,
                    atol=ATOL, events=[stop, dead], dense_output=True)
    run.segments.append(Segment(t, sol.t[-1], "slip", _first_two(sol.sol)))
    run.friction_work += sol.y[2, -1]
    run.input_work += sol.y[3, -1]
    t1, th1, thd1 = sol.t[-1], sol.y[0, -1], sol.y[1, -1]
    if sol.status != 1:
        return t1, th1, thd1, "end" if t_stop == t_end else "kink"
    if len(sol.t_events[0]):
        return t1, th1, 0.0, "stop"
    return t1, th1, thd1, "dead_centre"


# =============================================================================================
# d. A ball bouncing to rest


@dataclass(frozen=True)
class Ball:
    """A ball (disc) of radius r, mass m, inertia i = 2/5 m r^2 (a solid sphere), on a free
    joint (x, y, th) above a floor y = 0, gravity -g j, restitution e, Coulomb friction mu in the
    impacts and in the lasting contact. Dropped with its center at y0 and rates (xd0, thd0).

    Derivation: the contact's normal passes through the center, so normal and tangential
    motions decouple. Bounces: t1 = sqrt(2 (y0 - r) / g), v1 = g t1, impact k has the speed
    e^(k-1) v1 and normal impulse P_k = m (1 + e) e^(k-1) v1; t_(k+1) = t_k + 2 e^k v1 / g,
    accumulating at t_inf = t1 (1 + e) / (1 - e), after which the ball rests (N = m g).
    Tangentially, the contact point's slip c = x' + r th' changes by impulse P_t:
    x' += P_t / m, th' += r P_t / i, so c += P_t (1/m + r^2/i) = P_t / m_eff. An impact sticks
    (P_t = -c m_eff) if that is within mu P_n, else it slides (P_t = -mu P_n sign(c)). In the
    lasting contact the slip decays at mu g (1 + m r^2 / i) until c = 0; then the ball rolls.
    """

    m: float = 0.2
    r: float = 0.05
    g: float = 9.81
    e: float = 0.5
    mu: float = 0.02
    y0: float = 1.05
    xd0: float = 0.5
    thd0: float = 20.0

    @property
    def inertia(self) -> float:
        return 0.4 * self.m * self.r**2

    @property
    def m_eff(self) -> float:
        return 1.0 / (1.0 / self.m + self.r**2 / self.inertia)

    @property
    def t1(self) -> float:
        return math.sqrt(2.0 * (self.y0 - self.r) / self.g)


def ball_accumulation_time(p: Ball) -> float:
    return p.t1 * (1.0 + p.e) / (1.0 - p.e)


def ball_bounce_times(p: Ball, n: int) -> np.ndarray:
    """The first n impact times (closed form)."""
    v1 = p.g * p.t1
    k = np.arange(n)
    return p.t1 + 2.0 * v1 / p.g * p.e * (1.0 - p.e**k) / (1.0 - p.e)


@dataclass(frozen=True)
class BallRest:
    """The ball's closed form after the bounces."""

    t_inf: float
    x_inf: float  # x at t_inf
    xd_inf: float  # x' at t_inf (in the lasting contact, sliding or rolling)
    thd_inf: float
    t_roll: float  # time the slip ends (t_inf if it already rolls; a stuck impact's time)
    x_roll: float
    xd_roll: float  # rolling speed from t_roll on
    friction_work: float  # total, impacts and lasting contact (<= 0)
    impact_loss: float  # the normal impacts' kinetic energy loss (>= 0)


def ball_rest(p: Ball, n_max: int = 10000) -> BallRest:
    """The tangential motion through the bounces (sliding or sticking impacts), then the
    lasting contact's sliding and rolling: closed form, impact by impact."""
    v1 = p.g * p.t1
    times = ball_bounce_times(p, n_max)
    x, xd, thd = 0.0, p.xd0, p.thd0
    t_prev, t_roll, x_roll = 0.0, None, None
    for k, tk in enumerate(times):
        x += xd * (tk - t_prev)
        t_prev = tk
        pn = p.m * (1.0 + p.e) * v1 * p.e**k
        xd, thd, stuck = _ball_impact(p, xd, thd, pn)
        if stuck and t_roll is None:
            t_roll, x_roll = tk, x
        if pn < 1e-300:
            break
    t_inf = ball_accumulation_time(p)
    x += xd * (t_inf - t_prev)
    slip = xd + p.r * thd
    if t_roll is None:
        decel = math.copysign(p.mu * p.g, slip)  # of x' (friction -mu m g sign(c))
        tau = abs(slip) / (p.mu * p.g * (1.0 + p.m * p.r**2 / p.inertia))
        t_roll, x_roll = t_inf + tau, x + xd * tau - 0.5 * decel * tau**2
        xd_roll = xd - decel * tau
    else:
        xd_roll = xd
    energy_t0 = 0.5 * p.m * p.xd0**2 + 0.5 * p.inertia * p.thd0**2
    energy_t1 = 0.5 * p.m * xd_roll**2 + 0.5 * p.inertia * (xd_roll / p.r) ** 2
    loss = 0.5 * p.m * v1**2  # sum of 1/2 m v_k^2 (1 - e^2), v_k = e^(k-1) v1: all of it
    return BallRest(t_inf, x, xd, thd, t_roll, x_roll, xd_roll, energy_t1 - energy_t0, loss)


def _ball_impact(p: Ball, xd: float, thd: float, pn: float) -> tuple[float, float, bool]:
    """Coulomb impulse at the contact: sticking if it can, else sliding."""
    slip = xd + p.r * thd
    pt = -slip * p.m_eff
    stuck = abs(pt) <= p.mu * pn
    if not stuck:
        pt = -math.copysign(p.mu * pn, slip)
    return xd + pt / p.m, thd + p.r * pt / p.inertia, stuck


def ball_run(p: Ball, n_bounces: int) -> tuple[np.ndarray, np.ndarray]:
    """Event-driven flight (solve_ivp, impacts located as events) for n_bounces impacts:
    (impact times, state after each [x, y, th, x', y', th'])."""
    y = np.array([0.0, p.y0, 0.0, p.xd0, 0.0, p.thd0])
    t, times, states = 0.0, [], []

    def rhs(_t: float, s: np.ndarray) -> np.ndarray:
        return np.array([s[3], s[4], s[5], 0.0, -p.g, 0.0])

    # the height, seen only while falling: just after an impact it is zero (to rounding) and
    # would fire again at once
    floor = _event(lambda _t, s: s[1] - p.r if s[4] < 0.0 else 1.0, -1.0)
    for _ in range(n_bounces):
        sol = solve_ivp(rhs, (t, t + 10.0), y, method="DOP853", rtol=RTOL, atol=ATOL,
                        events=floor)
        t, y = sol.t_events[0][0], sol.y_events[0][0].copy()
        pn = -p.m * (1.0 + p.e) * y[4]
        y[3], y[5], _ = _ball_impact(p, y[3], y[5], pn)
        y[4] = -p.e * y[4]
        times.append(t)
        states.append(y.copy())
    return np.array(times), np.array(states)


# =============================================================================================
# e. Housner's rocking block


@dataclass(frozen=True)
class RockingBlock:
    """A rigid rectangular block (half-width b, half-height h, mass m, uniform) on a rigid
    floor, rocking on its corners without sliding or bouncing (Housner 1963). theta its angle
    (counterclockwise): theta > 0 pivots on the left corner (-b, -h), theta < 0 on the right.

    R = sqrt(b^2 + h^2), alpha = atan(b / h), I_O = I_G + m R^2 = (4/3) m R^2 about a corner,
    p^2 = m g R / I_O = 3 g / (4 R). Between impacts (energy conserved):

        theta'' = -p^2 sin(alpha sign(theta) - theta).

    At theta = 0 the other corner strikes; the impact is plastic and the old corner lifts.
    Angular momentum about the new corner is conserved: I_O w+ = (I_O - 2 m b^2) w-, so
    w+ = r w-, r = 1 - 2 m R^2 sin^2(alpha) / I_O = 1 - (3/2) sin^2(alpha). Amplitudes, from
    energy: cos(alpha - theta_(k+1)) = cos(alpha) + r^2 (cos(alpha - theta_k) - cos(alpha)).
    The impact impulse at the new corner needs the friction ratio
    |P_t / P_n| = h (1 - r) / (b (1 + r)).
    """

    b: float = 0.1
    h: float = 0.4
    m: float = 1.0
    g: float = 9.81

    @property
    def radius(self) -> float:
        return math.hypot(self.b, self.h)

    @property
    def alpha(self) -> float:
        return math.atan2(self.b, self.h)

    @property
    def p2(self) -> float:
        return 0.75 * self.g / self.radius

    @property
    def restitution(self) -> float:
        return 1.0 - 1.5 * math.sin(self.alpha) ** 2

    @property
    def impact_friction_ratio(self) -> float:
        r = self.restitution
        return self.h * (1.0 - r) / (self.b * (1.0 + r))


def rocking_sliding_impact(p: RockingBlock, w: float, mu: float) -> tuple[np.ndarray, float]:
    """The block's (x', y', th') just after its right corner strikes the floor at th = 0 while
    it rocks at rate w < 0 on its left corner, the right corner's mu below what a sticking
    impulse needs (impact_friction_ratio): the impact plastic, its friction impulse sliding,
    P_t = s mu P_n with s the sticking impulse's sign, the left corner taking none (it lifts).
    Newton-Euler of the impulses on the block (its centre G, the right corner at (b, -h) from
    it, I_G = m (b^2 + h^2) / 3):

        m dv_G = (P_t, P_n),   I_G dw = b P_n + h P_t

    before: v_G = w k x (G - A) = (-h w, b w), so the right corner's v_B = (0, 2 b w); after:
    v_B,y = 0. Returns the velocities and the left corner's normal speed after (v_G,y - b w:
    >= 0 where it lifts, as the law's set without it requires)."""
    m, b, h = p.m, p.b, p.h
    inertia = m * (b * b + h * h) / 3
    per_t = np.array([1 / m + h * h / inertia, h * b / inertia])  # dv_B per unit P_t
    per_n = np.array([h * b / inertia, 1 / m + b * b / inertia])  # ... per unit P_n
    pt_stick, pn_stick = np.linalg.solve(np.column_stack([per_t, per_n]), [0.0, -2 * b * w])
    if abs(pt_stick) <= mu * pn_stick:
        raise ValueError(f"mu = {mu} holds the corner (a sticking impact)")
    s = math.copysign(1.0, pt_stick)
    pn = -2 * b * w / (1 / m + b * (b + h * s * mu) / inertia)
    pt = s * mu * pn
    vx, vy = -h * w + pt / m, b * w + pn / m
    w_after = w + (b * pn + h * pt) / inertia
    return np.array([vx, vy, w_after]), vy - b * w_after


def _rocking_gap(p: RockingBlock, amplitude: float) -> float:
    """cos(alpha - A) - cos(alpha), written without cancellation for small A: the kinetic
    energy at theta = 0 over m g R when released from rest at A."""
    return 2.0 * math.sin(0.5 * amplitude) * math.sin(p.alpha - 0.5 * amplitude)


def _rocking_amplitude_of_gap(p: RockingBlock, gap: float) -> float:
    """The amplitude A whose gap is the given one: Newton from the small-A guess."""
    a = gap / math.sin(p.alpha) if gap < 1e-3 else p.alpha - math.acos(math.cos(p.alpha) + gap)
    for _ in range(8):
        a -= (_rocking_gap(p, a) - gap) / math.sin(p.alpha - a)
    return a


def rocking_amplitudes(p: RockingBlock, theta0: float, n: int) -> np.ndarray:
    """|theta| at the first n turning points (theta0 first), exact: each impact multiplies the
    gap cos(alpha - A) - cos(alpha) by r^2."""
    gap0 = _rocking_gap(p, abs(theta0))
    return np.array([abs(theta0)] + [_rocking_amplitude_of_gap(p, gap0 * p.restitution ** (2 * k))
                                     for k in range(1, n)])


def rocking_impact_speeds(p: RockingBlock, theta0: float, n: int) -> np.ndarray:
    """|theta'| just before each of the first n impacts, exact (energy)."""
    gaps = _rocking_gap(p, abs(theta0)) * p.restitution ** (2.0 * np.arange(n))
    return np.sqrt(2.0 * p.p2 * gaps)


def rocking_quarter_time(p: RockingBlock, amplitude: float) -> float:
    """Time from rest at |theta| = amplitude to theta = 0: the energy integral
    int dtheta / sqrt(2 p^2 (cos(alpha - theta) - cos(alpha - A))), substituted
    theta = A (1 - w^2) to remove the end's singularity (the integrand is smooth in w)."""
    a, al = amplitude, p.alpha

    def integrand(w: float) -> float:
        half = 0.5 * a * w * w
        # cos(al - th) - cos(al - a) = 2 sin(al - a + half) sin(half); sin(half) = half sinc
        sinc = math.sin(half) / half if half > 1e-300 else 1.0
        return 2.0 * a / math.sqrt(2.0 * p.p2 * 2.0 * math.sin(al - a + half) * 0.5 * a * sinc)

    return quad(integrand, 0.0, 1.0, epsabs=0.0, epsrel=1e-13, limit=200)[0]


def rocking_impact_times(p: RockingBlock, theta0: float, n: int) -> np.ndarray:
    """The first n impact times from rest at theta0 (quadrature of the exact energy integral)."""
    amp = rocking_amplitudes(p, theta0, n)
    quarters = np.array([rocking_quarter_time(p, a) for a in amp])
    return quarters[0] + np.concatenate([[0.0], np.cumsum(2.0 * quarters[1:])])


def rocking_accumulation_time(p: RockingBlock, theta0: float) -> float:
    """Where the impacts accumulate and the block comes to rest on its base: the sum of the
    impact intervals, summed until they no longer change it (they shrink as r per impact);
    the tail beyond is the small-amplitude limit (a ball bouncing under p^2 sin(alpha)),
    2 w_K r / (p^2 sin(alpha) (1 - r)) after the last impact K of speed w_K."""
    n = 2
    while rocking_amplitudes(p, theta0, n)[-1] > 1e-9 * p.alpha:
        n *= 2
    times = rocking_impact_times(p, theta0, n)
    return float(times[-1] + rocking_tail(p, rocking_impact_speeds(p, theta0, n)[-1]))


def rocking_tail(p: RockingBlock, w: float) -> float:
    """The time the impacts after one at speed w (|theta'| before it) take to accumulate, in
    the small-amplitude limit (a ball bouncing under p^2 sin(alpha), each flight r times the
    one before): 2 w r / (p^2 sin(alpha) (1 - r)); relative error O(amplitude / alpha)."""
    r = p.restitution
    return 2.0 * w * r / (p.p2 * math.sin(p.alpha) * (1.0 - r))


def rocking_base_accumulation_time(p: RockingBlock, base: BasePulse, t_end: float,
                                   mu: float) -> float:
    """Where rocking_base_run's impacts accumulate: its rest starts at an impact whose speed
    after it is below 1e-9 p; the flights left after it, the last one's r / (1 - r) times
    (the table moves uniformly by then), are added."""
    run = rocking_base_run(p, base, t_end, mu, mu)
    impacts = [t for t, name in run.switches if name == "impact"]
    assert run.switches[-1][1] == "rest" and base.accel(impacts[-1]) == 0.0
    r = p.restitution
    return impacts[-1] + (impacts[-1] - impacts[-2]) * r / (1.0 - r)


def rocking_energy(p: RockingBlock, theta: float, thetad: float) -> float:
    """Kinetic (about the pivot corner) plus potential energy, m g times the center's height."""
    return 0.5 * (4.0 / 3.0) * p.m * p.radius**2 * thetad**2 + p.m * p.g * p.radius * math.cos(
        p.alpha - abs(theta))


def rocking_run(p: RockingBlock, theta0: float, n_impacts: int,
                thetad0: float = 0.0) -> tuple[np.ndarray, np.ndarray, Run]:
    """Event-driven rocking (solve_ivp, theta = 0 located), Housner's impact at each: (impact
    times, theta' just before each, the run)."""
    run = Run()

    t, y = 0.0, np.array([theta0, thetad0])
    times, speeds = [], []
    for _ in range(n_impacts):
        side = math.copysign(1.0, y[0]) if y[0] != 0.0 else math.copysign(1.0, y[1])
        impact = _event(lambda _t, s: s[0], -side)
        sol = solve_ivp(_rocking_rhs(p, side), (t, t + 100.0), y, method="DOP853", rtol=RTOL,
                        atol=ATOL, events=impact, dense_output=True)
        t1 = sol.t_events[0][0]
        run.segments.append(Segment(t, t1, "rock", sol.sol))
        w = sol.y_events[0][0][1]
        times.append(t1)
        speeds.append(w)
        run.switches.append((t1, "impact"))
        t, y = t1, np.array([0.0, p.restitution * w])
    return np.array(times), np.array(speeds), run


def _rocking_rhs(p: RockingBlock, side: float) -> Callable[[float, np.ndarray], np.ndarray]:
    """On the left corner (side +1, theta > 0) or the right (side -1), fixed for a segment."""

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        return np.array([y[1], -p.p2 * math.sin(p.alpha * side - y[0])])

    return rhs


def rocking_pivot_force(p: RockingBlock, theta: float, thetad: float,
                        base_accel: float = 0.0) -> tuple[float, float]:
    """(F_t, F_n): the floor's force on the pivot corner (Newton for the mass center) while
    rocking: m (a_G + a_base) = F + m g, a_G in the base's frame, the base accelerating at
    base_accel along x. theta > 0 pivots on the left corner."""
    sign = math.copysign(1.0, theta) if theta != 0.0 else 1.0
    phase = p.alpha * sign - theta
    thdd = -p.p2 * (math.sin(phase) - base_accel / p.g * math.cos(phase))
    arm = _rot(theta) @ np.array([sign * p.b, p.h])  # pivot -> mass center
    acc = thdd * np.array([-arm[1], arm[0]]) - thetad**2 * arm + np.array([base_accel, 0.0])
    force = p.m * acc - p.m * np.array([0.0, -p.g])
    return float(force[0]), float(force[1])


@dataclass(frozen=True)
class BasePulse:
    """A base (table) under the block, moving horizontally: its acceleration a half-sine pulse,
    a(t) = A sin(pi t / tp) for 0 <= t <= tp and 0 after (it then moves on at 2 A tp / pi)."""

    A: float = 4.0
    tp: float = 0.25

    def accel(self, t: float) -> float:
        return self.A * math.sin(math.pi * t / self.tp) if 0.0 <= t <= self.tp else 0.0

    def onset(self, level: float) -> float:
        """First time a(t) reaches level (0 < level <= A), closed form."""
        return self.tp / math.pi * math.asin(level / self.A)


def base_slide_closed_form(base: BasePulse, g: float, mu: float) -> tuple[float, float, float]:
    """A block resting on the base that slides (mu g < g tan(alpha), mu g < A) with mu_s =
    mu_k = mu: (slide onset t0, stick time T, its slide s(T) on the base), closed form. From
    t0 (phi0 = pi t0 / tp) s' = -V(t) + mu g (t - t0), V the base's speed gained since t0; it
    sticks after the pulse, at T = t0 + (A tp / pi) (1 + cos phi0) / (mu g), and
    s(T) = -(A tp / pi) (cos phi0 (T - t0) + (tp / pi) sin phi0 + T - tp) + mu g (T - t0)^2 / 2.
    """
    t0 = base.onset(mu * g)
    phi0 = math.pi * t0 / base.tp
    scale = base.A * base.tp / math.pi
    stick = t0 + scale * (1.0 + math.cos(phi0)) / (mu * g)
    dist = -scale * (math.cos(phi0) * (stick - t0) + base.tp / math.pi * math.sin(phi0)
                     + stick - base.tp) + 0.5 * mu * g * (stick - t0) ** 2
    return t0, stick, dist


def rocking_base_rhs(p: RockingBlock, base: BasePulse,
                     side: float) -> Callable[[float, np.ndarray], np.ndarray]:
    """Rocking on a base accelerating at a(t) (Yim, Chopra and Penzien's equation), in the
    base's frame, where the inertial force -m a(t) acts at the mass center:

        theta'' = -p^2 (sin(alpha s - theta) - (a / g) cos(alpha s - theta)),

    s = +1 on the left corner (theta > 0), -1 on the right. The state [theta, theta', W] also
    integrates W, the inertial force's work in the base's frame, m a R cos(alpha s - theta)
    theta' (its moment about the pivot times the rate)."""

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        a = base.accel(t)
        phase = p.alpha * side - y[0]
        thdd = -p.p2 * (math.sin(phase) - a / p.g * math.cos(phase))
        return np.array([y[1], thdd, p.m * a * p.radius * math.cos(phase) * y[1]])

    return rhs


def rocking_base_run(p: RockingBlock, base: BasePulse, t_end: float, mu_s: float,
                     mu_k: float) -> Run:
    """Event-driven response of a block resting on a base given the pulse: it rests until the
    base's acceleration reaches g tan(alpha) (it lifts onto the trailing corner: 'rock') or
    mu_s g (it slides on the base: 'slide'), whichever comes first. Rocking: Housner's impacts,
    back to rest ('rest') when the impacts accumulate (the rate after an impact below 1e-9 p,
    or impacts closer than 1e-9 s). Sliding (without rocking: mu_k <= mu_s < tan(alpha) keeps
    the base's reaction inside the base), s'' = -a(t) - mu_k g sign(s'), sticks ('stick') when
    s' = 0 and |a| <= mu_s g. Sliding while rocking is outside the reference: the friction
    the pivot needs is left for the caller to check (rocking_pivot_force). State
    [theta, theta', s, s'] (s: the block's slide on the base); friction_work: the sliding's;
    input_work: the inertial force's work while rocking (in the base's frame)."""
    run, t, y, mode = Run(), 0.0, np.zeros(4), "rest"
    while t < t_end:
        if mode == "rest":
            t1, name = _rest_until(p, base, t, t_end, mu_s)
            run.segments.append(Segment(t, t1, "rest", _resting(y[2])))
            t = t1
            if name:
                run.switches.append((t, name))
                mode = name
        elif mode == "rock":
            t, y, mode = _rock(p, base, run, t, y, t_end)
        else:
            t, y, mode = _slide_on_base(p, base, run, t, y, t_end, mu_s, mu_k)
    return run


def _resting(s: float) -> Callable[[float], np.ndarray]:
    return lambda _t: np.array([0.0, 0.0, s, 0.0])


def _rest_until(p: RockingBlock, base: BasePulse, t0: float, t_end: float,
                mu_s: float) -> tuple[float, str]:
    """At rest from t0: the first time |a| reaches g tan(alpha) ('rock') or mu_s g ('slide')."""
    lift = _event(lambda t, _y: abs(base.accel(t)) - p.g * math.tan(p.alpha), 1.0)
    slip = _event(lambda t, _y: abs(base.accel(t)) - mu_s * p.g, 1.0)
    sol = solve_ivp(lambda _t, _y: np.zeros(1), (t0, t_end), [0.0], events=[lift, slip],
                    max_step=base.tp / 50.0, rtol=RTOL, atol=ATOL)
    if sol.status != 1:
        return t_end, ""
    return float(sol.t[-1]), "rock" if len(sol.t_events[0]) else "slide"


def _rock(p: RockingBlock, base: BasePulse, run: Run, t: float, y: np.ndarray,
          t_end: float) -> tuple[float, np.ndarray, str]:
    """One rocking arc to the next impact (or t_end); Housner's impact there."""
    if y[1] != 0.0:
        side = math.copysign(1.0, y[1])
    else:
        side = math.copysign(1.0, base.accel(t))  # from rest: onto the trailing corner
    impact = _event(lambda _t, s: s[0], -side)
    sol = solve_ivp(rocking_base_rhs(p, base, side), (t, t_end), [y[0], y[1], 0.0],
                    method="DOP853", rtol=RTOL, atol=ATOL, events=impact, dense_output=True)
    s_fixed = y[2]
    run.segments.append(Segment(t, sol.t[-1], "rock", _rocking_state(sol.sol, s_fixed)))
    run.input_work += sol.y[2, -1]
    t1 = float(sol.t[-1])
    if sol.status != 1:
        return t1, np.array([sol.y[0, -1], sol.y[1, -1], s_fixed, 0.0]), "rock"
    w = p.restitution * sol.y[1, -1]
    run.switches.append((t1, "impact"))
    if abs(w) < 1e-9 * math.sqrt(p.p2) or t1 - t < 1e-9:  # the impacts accumulate
        w = 0.0
        if abs(base.accel(t1)) <= p.g * math.tan(p.alpha):
            run.switches.append((t1, "rest"))
            return t1, np.array([0.0, 0.0, s_fixed, 0.0]), "rest"
    return t1, np.array([0.0, w, s_fixed, 0.0]), "rock"


def _rocking_state(sol: Callable[[float], np.ndarray],
                   s: float) -> Callable[[float], np.ndarray]:
    return lambda t: np.array([*np.asarray(sol(t))[:2], s, 0.0])


def _slide_on_base(p: RockingBlock, base: BasePulse, run: Run, t: float, y: np.ndarray,
                   t_end: float, mu_s: float, mu_k: float) -> tuple[float, np.ndarray, str]:
    """Slide on the base until the relative velocity is zero again (or t_end)."""
    sigma = math.copysign(1.0, y[3]) if y[3] != 0.0 else -math.copysign(1.0, base.accel(t))
    friction = -sigma * mu_k * p.g  # per unit mass

    def rhs(tt: float, s: np.ndarray) -> np.ndarray:
        return np.array([s[1], -base.accel(tt) + friction, p.m * friction * s[1]])

    stop = _event(lambda _t, s: s[1], -sigma)
    sol = solve_ivp(rhs, (t, t_end), [y[2], y[3], 0.0], method="DOP853", rtol=RTOL,
                    atol=ATOL, events=stop, dense_output=True)
    run.segments.append(Segment(t, sol.t[-1], "slide",
                                lambda tt: np.array([0.0, 0.0, *np.asarray(sol.sol(tt))[:2]])))
    run.friction_work += sol.y[2, -1]
    t1 = float(sol.t[-1])
    if sol.status != 1:
        return t1, np.array([0.0, 0.0, sol.y[0, -1], sol.y[1, -1]]), "slide"
    held = abs(base.accel(t1)) <= mu_s * p.g
    run.switches.append((t1, "stick" if held else "reverse"))
    return t1, np.array([0.0, 0.0, sol.y[0, -1], 0.0]), "rest" if held else "slide"


# =============================================================================================
# f. A cart with dry friction carrying a rod that strikes a wall


@dataclass(frozen=True)
class CartPendulumWall:
    """A cart of mass M on a rough floor (x; Coulomb friction mu, mu_s on its normal force N,
    the floor's push) carries a rod (mass m, length L, its centre c = L/2 from the pin at the
    cart's origin, inertia I = m L^2/12 there) at angle phi from hanging down; its tip strikes
    a wall x = d with restitution e (no friction at the wall).

    Lagrange, q = (x, phi), T = (M + m) x'^2/2 + m c cos(phi) x' phi' + (m c^2 + I) phi'^2/2,
    V = -m g c cos(phi):

        (M + m) x'' + m c cos(phi) phi'' = m c sin(phi) phi'^2 + F
        m c cos(phi) x'' + (m c^2 + I) phi'' = -m g c sin(phi)
        N = (M + m) g + m c (sin(phi) phi'' + cos(phi) phi'^2)   (the rod's vertical momentum)

    F = -sigma mu |N| slipping (sigma the sign of x'), or whatever holds x'' = 0 while
    |F| <= mu_s |N|. An impact: the tip's normal speed v_n = -(x' + L cos(phi) phi') (the wall's
    normal -x), its impulse P_n along -x, the cart's friction impulse P_f with the floor's normal
    impulse N_P = m c sin(phi) dphi' (the finite forces take none); (M + m, ...) dq' = (-P_n +
    P_f, -L cos(phi) P_n), v_n after = -e v_n. Coulomb's law in the impulse: the cart sticks
    (x' after 0) where that takes |P_f| <= mu_s |N_P|, else slides, P_f = -sigma mu |N_P|
    (sigma: its way before, or against the holding impulse from rest)."""

    M: float = 1.0
    m: float = 1.0
    L: float = 1.0
    d: float = 0.5
    e: float = 0.7
    mu: float = 0.2
    mu_s: float = 0.3
    g: float = 9.81

    @property
    def c(self) -> float:
        return self.L / 2

    @property
    def inertia(self) -> float:
        """The rod's inertia about its pin."""
        return self.m * self.c ** 2 + self.m * self.L ** 2 / 12

    def normal(self, phi: float, phid: float, phidd: float) -> float:
        return (self.M + self.m) * self.g + self.m * self.c * (
            math.sin(phi) * phidd + math.cos(phi) * phid ** 2)

    def stuck(self, phi: float, phid: float) -> tuple[float, float, float]:
        """(phi'', F, N) with the cart held (x'' = 0)."""
        mc = self.m * self.c
        phidd = -mc * self.g * math.sin(phi) / self.inertia
        force = mc * math.cos(phi) * phidd - mc * math.sin(phi) * phid ** 2
        return phidd, force, self.normal(phi, phid, phidd)

    def sliding(self, phi: float, phid: float, sigma: float) -> tuple[float, float, float, float]:
        """(x'', phi'', F, N) with the cart slipping the way sigma (N > 0 checked)."""
        mc, total = self.m * self.c, self.M + self.m
        a = np.array([[total, mc * math.cos(phi) + sigma * self.mu * mc * math.sin(phi)],
                      [mc * math.cos(phi), self.inertia]])
        b = np.array([mc * math.sin(phi) * phid ** 2
                      - sigma * self.mu * (total * self.g + mc * math.cos(phi) * phid ** 2),
                      -mc * self.g * math.sin(phi)])
        xdd, phidd = np.linalg.solve(a, b)
        n = self.normal(phi, phid, phidd)
        if n <= 0:
            raise PainleveError(f"the cart lifts off (N = {n})")
        return float(xdd), float(phidd), -sigma * self.mu * n, n

    def energy(self, y: np.ndarray) -> float:
        x, phi, xd, phid = y
        mc = self.m * self.c
        return 0.5 * ((self.M + self.m) * xd ** 2 + 2 * mc * math.cos(phi) * xd * phid
                      + self.inertia * phid ** 2) - mc * self.g * math.cos(phi)

    def gap(self, y: np.ndarray) -> float:
        return self.d - y[0] - self.L * math.sin(y[1])


def _cart_held(p: CartPendulumWall, phi: float, phid: float) -> tuple[bool, float]:
    _, force, n = p.stuck(phi, phid)
    return abs(force) <= p.mu_s * abs(n), force


def _cart_stick_impulse(p: CartPendulumWall, y: np.ndarray, vn: float
                        ) -> tuple[float, float, float]:
    """(dphi', P_f, N_P) of an impact that leaves the cart at rest (dx' = -x')."""
    mc, cos = p.m * p.c, math.cos(y[1])
    dxd = -y[2]  # and the restitution: -dx' - L cos(phi) dphi' = -(1 + e) v_n
    dphid = ((1 + p.e) * vn - dxd) / (p.L * cos)
    pn = -(p.inertia * dphid + mc * cos * dxd) / (p.L * cos)
    pf = (p.M + p.m) * dxd + mc * cos * dphid + pn
    return dphid, pf, mc * math.sin(y[1]) * dphid


def _cart_slide_impulse(p: CartPendulumWall, y: np.ndarray, vn: float, sigma: float
                        ) -> tuple[float, float, float]:
    """(dx', dphi', P_f) of an impact the cart slides through the way sigma."""
    mc, cos, sin = p.m * p.c, math.cos(y[1]), math.sin(y[1])
    for sign_n in (1.0, -1.0):  # the normal impulse's sign, checked below
        k = sigma * p.mu * sign_n * mc * sin  # P_f = -k dphi'
        a = np.array([[p.M + p.m, mc * cos + k, 1.0],
                      [mc * cos, p.inertia, p.L * cos],
                      [-1.0, -p.L * cos, 0.0]])
        dxd, dphid, _ = np.linalg.solve(a, [0.0, 0.0, -(1 + p.e) * vn])
        if sign_n * mc * sin * dphid >= 0:
            return float(dxd), float(dphid), -k * float(dphid)
    raise PainleveError("no consistent sliding impulse")


def cart_impact(p: CartPendulumWall, y: np.ndarray, stuck: bool) -> tuple[np.ndarray, str]:
    """The state after the tip's impact and the cart's mode in the impulse ('stick' or
    'slide')."""
    vn = -(y[2] + p.L * math.cos(y[1]) * y[3])
    sigma = math.copysign(1.0, y[2]) if not stuck else 0.0
    if sigma != 0.0:  # slipping: slides on, unless that turns its rate
        dxd, dphid, _ = _cart_slide_impulse(p, y, vn, sigma)
        if sigma * (y[2] + dxd) >= 0:
            return y + np.array([0.0, 0.0, dxd, dphid]), "slide"
    dphid, pf, n_p = _cart_stick_impulse(p, y, vn)
    if abs(pf) <= p.mu_s * abs(n_p):
        return np.array([y[0], y[1], 0.0, y[3] + dphid]), "stick"
    dxd, dphid, _ = _cart_slide_impulse(p, y, vn, -math.copysign(1.0, pf))
    return y + np.array([0.0, 0.0, dxd, dphid]), "slide"


def cart_pendulum_run(p: CartPendulumWall, t_end: float, phi0: float) -> Run:
    """Event-driven run from rest at phi0. Switches: 'stick', 'slip', 'impact'; the friction
    work is the sliding friction's power integrated plus the friction impulses' work."""
    run = Run()
    t, y = 0.0, np.array([0.0, phi0, 0.0, 0.0])
    held, force = _cart_held(p, phi0, 0.0)
    sigma = 0.0 if held else -math.copysign(1.0, force)
    while t < t_end:
        t, y, name = _cart_segment(p, run, t, y, sigma, t_end)
        if name == "end":
            break
        run.switches.append((t, name))
        if name == "impact":
            before = y.copy()
            y, how = cart_impact(p, y, sigma == 0.0)
            run.friction_work += _impulse_work(p, before, y)
            sigma = 0.0 if how == "stick" else math.copysign(1.0, y[2])
        elif name == "stop":
            sigma = 0.0
            y[2] = 0.0
        else:  # the holding force reached its limit
            sigma = -math.copysign(1.0, p.stuck(y[1], y[3])[1])
        if sigma == 0.0:
            held, force = _cart_held(p, y[1], y[3])
            if not held:
                sigma = -math.copysign(1.0, force)
            if name == "stop":
                run.switches[-1] = (t, "stick" if held else "reverse")
            elif not held:
                run.switches.append((t, "slip"))
    return run


def _impulse_work(p: CartPendulumWall, before: np.ndarray, after: np.ndarray) -> float:
    """The friction impulse's work: the energy an impact takes less the wall's share (the
    frictionless wall's impulse alone would take (1 - e^2) of the normal's relative kinetic
    energy; here measured as the energy change less the work of P_n, P_n (v_n+ + v_n-)/2)."""
    mc, cos = p.m * p.c, math.cos(before[1])
    dxd, dphid = after[2] - before[2], after[3] - before[3]
    pn = -(p.inertia * dphid + mc * cos * dxd) / (p.L * cos)
    vn = [-(y[2] + p.L * cos * y[3]) for y in (before, after)]
    return p.energy(after) - p.energy(before) - pn * (vn[0] + vn[1]) / 2


def _cart_segment(p: CartPendulumWall, run: Run, t: float, y: np.ndarray, sigma: float,
                  t_end: float) -> tuple[float, np.ndarray, str]:
    """One mode's stretch (sigma 0: the cart held) until a switch: 'impact', 'stop' (its rate
    reaches 0), 'limit' (the holding force reaches mu_s |N|), or 'end'."""

    def rhs(_t: float, s: np.ndarray) -> np.ndarray:
        if sigma == 0.0:
            phidd = p.stuck(s[1], s[3])[0]
            return np.array([0.0, s[3], 0.0, phidd, 0.0])
        xdd, phidd, force, _ = p.sliding(s[1], s[3], sigma)
        return np.array([s[2], s[3], xdd, phidd, force * s[2]])

    wall = _event(lambda _t, s: p.gap(s[:4]), -1.0)
    if sigma == 0.0:
        def other(_t: float, s: np.ndarray) -> float:
            _, force, n = p.stuck(s[1], s[3])
            return p.mu_s * abs(n) - abs(force)
        other = _event(other, -1.0)
    else:
        other = _event(lambda _t, s: s[2], -sigma)
    sol = solve_ivp(rhs, (t, t_end), [*y, 0.0], method="DOP853", rtol=RTOL, atol=ATOL,
                    events=[wall, other], dense_output=True)
    run.segments.append(Segment(t, float(sol.t[-1]), "stick" if sigma == 0.0 else "slip",
                                lambda tt, f=sol.sol: np.asarray(f(tt))[:4]))
    run.friction_work += sol.y[4, -1]
    t1, y1 = float(sol.t[-1]), sol.y[:4, -1].copy()
    if sol.status != 1:
        return t1, y1, "end"
    if len(sol.t_events[0]):
        return t1, y1, "impact"
    return t1, y1, "stop" if sigma != 0.0 else "limit"


# =============================================================================================
# g. A sliding cart carrying a ball that bounces to rest on a rough floor


@dataclass(frozen=True)
class CartBall:
    """A cart (mass M) slides on a floor with dry friction mu (mu_s), carrying a ball (mass m,
    radius r) on a frictionless vertical slider; the ball, dropped from its centre's height y0,
    bounces on the floor (restitution e, friction mu_c) and comes to rest there.

    The slider passes no vertical force, so the cart's normal force is M g throughout (in an
    impact too: its normal impulse is 0), and the ball's bounces are the bouncing ball's:
    t_1 = sqrt(2 (y0 - r) / g), impact k's speed v_k = e^(k-1) g t_1, flights 2 v_(k+1) / g,
    accumulating at t_inf = t_1 (1 + e) / (1 - e). The cart and ball move together along x
    (mass M + m): while the ball flies, x'' = -mu M g / (M + m); each impact's floor impulse
    (1 + e) m v_k slides (the cart too fast to stop), taking mu_c (1 + e) m v_k / (M + m)
    from x'; from t_inf on the ball rests, x'' = -(mu M + mu_c m) g / (M + m), until x' = 0,
    where nothing pushes it: it sticks for good."""

    M: float = 2.0
    m: float = 0.5
    r: float = 0.05
    y0: float = 1.0
    e: float = 0.5
    mu: float = 0.1
    mu_s: float = 0.15
    mu_c: float = 0.3
    v0: float = 3.0
    g: float = 9.81

    @property
    def t1(self) -> float:
        return math.sqrt(2 * (self.y0 - self.r) / self.g)

    @property
    def t_inf(self) -> float:
        return self.t1 * (1 + self.e) / (1 - self.e)

    def impacts(self) -> tuple[np.ndarray, np.ndarray]:
        """The impacts' times and speeds, until the speeds fall below 1e-16 of the first."""
        n = int(math.log(1e-16) / math.log(self.e)) + 1
        speeds = self.g * self.t1 * self.e ** np.arange(n)
        times = self.t1 + np.concatenate([[0.0], np.cumsum(2 * speeds[1:] / self.g)])
        return times, speeds


def cart_ball_motion(p: CartBall, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(x, x') at the times t (from x = 0, x' = v0), the time the cart sticks and where."""
    open_decel = p.mu * p.M * p.g / (p.M + p.m)
    closed_decel = (p.mu * p.M + p.mu_c * p.m) * p.g / (p.M + p.m)
    times, speeds = p.impacts()
    jumps = p.mu_c * (1 + p.e) * p.m * speeds / (p.M + p.m)
    # segments: (start, x, x', deceleration), each until the next
    segments, x, v, tau = [], 0.0, p.v0, 0.0
    for t_k, jump in [*zip(times, jumps), (p.t_inf, 0.0)]:
        segments.append((tau, x, v, open_decel))
        x, v = x + v * (t_k - tau) - open_decel * (t_k - tau) ** 2 / 2, \
            v - open_decel * (t_k - tau) - jump
        if v <= 0:
            raise ValueError("the cart stops while the ball bounces: not this closed form's")
        tau = t_k
    segments.append((p.t_inf, x, v, closed_decel))
    t_stop = p.t_inf + v / closed_decel
    x_stop = x + v * v / (2 * closed_decel)
    t = np.asarray(t, dtype=float)
    xs, vs = np.empty_like(t), np.empty_like(t)
    starts = np.array([seg[0] for seg in segments])
    for i, ti in enumerate(t):
        start, x0, v0, decel = segments[max(0, np.searchsorted(starts, ti, side="right") - 1)]
        dt = min(ti, t_stop) - start
        xs[i], vs[i] = x0 + v0 * dt - decel * dt ** 2 / 2, v0 - decel * dt
    return xs, vs, t_stop, x_stop
