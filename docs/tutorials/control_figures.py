"""The numbers and figures of docs/tutorials/control.md (the model as a plant):

    .venv/bin/python docs/tutorials/control_figures.py [--only cart_pole|fourbar|kapitza]

(a) the cart-pole (examples/cart_pole.yaml) held up from 0.3 rad by an LQR designed from
model.linearize, closed in C through lin.feedback(K): docs/figures/control_cart_pole.png and
docs/figures/cart_pole_lqr.gif;
(b) the four-bar's (examples/fourbar.yaml) natural frequency about its equilibrium from trim,
linearize and modes, against the period of simulated small oscillations:
docs/figures/control_fourbar.png;
(c) Kapitza's pendulum (examples/kapitza.yaml): the upright position's stability boundary from
Floquet multipliers, against the small-amplitude theory A^2 W^2 = 2 g l and Mathieu's
equation's characteristic value a_0(q) (scipy.special.mathieu_a): docs/figures/control_kapitza.png.

Every number the tutorial quotes is printed here. About a minute on one core.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
FIGURES = ROOT / "docs" / "figures"
np.set_printoptions(precision=4, suppress=True)


# ---- (a) the cart-pole held up by an LQR ------------------------------------------------------


def lqr_cart_pole():
    """The tutorial's design, as it shows it: (model, op, lin, K, closed loop, open loop)."""
    from scipy.linalg import solve_continuous_are

    import nemc

    model = nemc.compile(EXAMPLES / "cart_pole.yaml")
    op = model.trim({"th": 0.1})  # upright: th = 0 at rest, F = 0 (x is left where it is)
    lin = model.linearize(op.y, op.u)
    Q = np.diag([1.0, 1.0, 10.0, 1.0])  # x, dot(x), th, dot(th)
    R = np.array([[0.1]])
    P = solve_continuous_are(lin.A, lin.B, Q, R)
    K = np.linalg.solve(R, lin.B.T @ P)  # F = -K (y - op.y)
    closed = model.simulate((0, 10), {"th": 0.3}, inputs={"F": lin.feedback(K)},
                            t_eval=np.linspace(0, 10, 1001))
    open_loop = model.simulate((0, 10), {"th": 0.3}, t_eval=np.linspace(0, 10, 1001))
    return model, op, lin, K, closed, open_loop


def cart_pole() -> None:
    import matplotlib.pyplot as plt

    model, op, lin, K, closed, open_loop = lqr_cart_pole()
    print("(a) cart-pole")
    print("  trim:", op, "undetermined:", op.undetermined)
    print("  A =\n", lin.A, "\n  B =", lin.B.ravel())
    print("  open-loop eigenvalues:", np.sort(np.linalg.eigvals(lin.A).real))
    print("  K =", K.ravel())
    poles = np.linalg.eigvals(lin.A - lin.B @ K)
    print("  closed-loop poles:", poles[np.argsort(poles.real)])
    print("  closed loop:", closed.method, closed.message, "nfev", closed.nfev)
    print("  y(10) =", np.array2string(closed.y[:, -1], formatter={"float": "{:.2e}".format}),
          f"max |y(10) - op.y| = {np.abs(closed.y[:, -1] - op.y).max():.2e}")
    force = closed.outputs["force"]
    print(f"  max |F| = {np.abs(force).max():.4g} N at t = {closed.t[np.abs(force).argmax()]}"
          f"; min x = {closed.y[0].min():.4g} m at t = {closed.t[closed.y[0].argmin()]:.3g}")
    late = np.nonzero(np.abs(closed.y[2]) > 0.01)[0].max()
    print(f"  |th| < 0.01 rad from t = {closed.t[late + 1]:.3g} s on")
    falls = np.nonzero(np.abs(open_loop.y[2]) > np.pi / 2)[0][0]
    print(f"  open loop: |th| passes pi/2 at t = {open_loop.t[falls]:.3g} s")

    figure, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True, constrained_layout=True)
    upright = open_loop.t <= open_loop.t[falls] + 0.3
    axes[0].plot(closed.t, closed.y[2], label="LQR through lin.feedback(K)")
    axes[0].plot(open_loop.t[upright], open_loop.y[2][upright], "--", label="F = 0: it falls")
    axes[0].set_ylim(-0.4, 1.8)
    axes[0].set_ylabel("th (rad from upright)")
    axes[0].legend(loc="upper right")
    axes[1].plot(closed.t, closed.y[0])
    axes[1].set_ylabel("x (m)")
    axes[2].plot(closed.t, force)
    axes[2].set_ylabel("F (N)")
    axes[2].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.4)
    figure.suptitle("cart-pole from th = 0.3 rad: Q = diag(1, 1, 10, 1), R = 0.1")
    figure.savefig(FIGURES / "control_cart_pole.png", dpi=100)
    short = model.simulate((0, 5), {"th": 0.3}, inputs={"F": lin.feedback(K)})
    short.animate(FIGURES / "cart_pole_lqr.gif", traces=["pole.tip"], size=4.0)
    print("  wrote docs/figures/control_cart_pole.png, docs/figures/cart_pole_lqr.gif")


# ---- (b) the four-bar's natural frequency -----------------------------------------------------


def fourbar() -> None:
    import matplotlib.pyplot as plt

    import nemc

    model = nemc.compile(EXAMPLES / "fourbar.yaml")
    op = model.trim({"q1": -1.5, "q2": -0.2, "q3": 1.2})  # a hanging guess
    lin = model.linearize(op.y)
    modes = lin.modes()
    omega = modes.frequencies[0]
    print("(b) four-bar")
    print("  trim:", op)
    print("  independent:", lin.state_names, "dependent:", lin.dependent)
    print("  A =\n", lin.A)
    print(modes)
    print(f"  omega = {omega:.10g} rad/s, {modes.hertz[0]:.10g} Hz, period "
          f"{2 * np.pi / omega:.10g} s")
    other = model.linearize(op.y, independent=["q3"]).modes().frequencies[0]
    print(f"  in q3: omega = {other:.10g} rad/s")

    def rising(t, y):  # q1 passing its equilibrium value upwards
        return y[0] - op.y[0]

    rising.direction = 1
    amplitudes = np.array([0.2, 0.1, 0.05, 0.02, 0.01, 0.005])
    periods = []
    for amplitude in amplitudes:
        run = model.simulate((0, 10), {"q1": op.y[0] + amplitude, "dot(q1)": 0.0},
                             method="DOP853", rtol=1e-12, atol=1e-13, events=[rising])
        crossings = run.t_events[0]
        periods.append((crossings[-1] - crossings[0]) / (crossings.size - 1))
        print(f"  amplitude {amplitude:<5g} rad: {crossings.size - 1} periods, period "
              f"{periods[-1]:.10f} s, omega {2 * np.pi / periods[-1]:.8f} rad/s, "
              f"T / T_lin - 1 = {periods[-1] * omega / (2 * np.pi) - 1:.4g}")
    shift = np.array(periods) * omega / (2 * np.pi) - 1
    limit = (4 * periods[-1] - periods[-2]) / 3  # Richardson: T(a) = T(0) + c a^2 + ...
    print(f"  extrapolated to amplitude 0: period {limit:.10f} s, "
          f"{limit * omega / (2 * np.pi) - 1:.2g} from linearize's")
    slope = np.polyfit(np.log(amplitudes), np.log(shift), 1)[0]
    print(f"  log-log slope of the shift: {slope:.4f}; shift / amplitude^2: "
          f"{(shift / amplitudes**2).round(4)}")

    figure, ax = plt.subplots(figsize=(6, 4.2), constrained_layout=True)
    ax.loglog(amplitudes, shift, "o", label="simulated: T / (2π/ω) − 1")
    fit = shift[-1] / amplitudes[-1] ** 2
    ax.loglog(amplitudes, fit * amplitudes**2, ":", label=f"{fit:.3f} × amplitude²")
    ax.set_xlabel("amplitude of q1 (rad)")
    ax.set_ylabel("period's excess over linearize's")
    ax.set_title(f"four-bar about its equilibrium: ω = {omega:.4f} rad/s from modes()")
    ax.grid(alpha=0.4, which="both")
    ax.legend()
    figure.savefig(FIGURES / "control_fourbar.png", dpi=100)
    print("  wrote docs/figures/control_fourbar.png")


# ---- (c) Kapitza's pendulum ------------------------------------------------------------------


def kapitza() -> None:
    import matplotlib.pyplot as plt
    from scipy.special import mathieu_a

    import nemc

    model = nemc.compile(EXAMPLES / "kapitza.yaml")
    g, rod = model.parameters["g"], model.parameters["L"]
    length = 2 * rod / 3  # the rod's reduced length I_O / (m L/2)
    upright = {"th": np.pi / 2}

    def unstable(amplitude: float, w: float) -> bool:
        floquet = model.floquet(2 * np.pi / w, upright, params={"A": amplitude, "W": w})
        return abs(np.trace(floquet.monodromy)) > 2

    def boundary(amplitude: float) -> float:
        low, high = (np.array([0.5, 1.5]) * np.sqrt(2 * g * length) / amplitude).tolist()
        assert unstable(amplitude, low) and not unstable(amplitude, high)
        while high - low > 1e-11 * high:
            middle = (low + high) / 2
            low, high = (middle, high) if unstable(amplitude, middle) else (low, middle)
        return (low + high) / 2

    def mathieu(amplitude: float) -> float:
        """phi'' = (g - A W^2 cos W t) phi / l is Mathieu's equation in tau = W t / 2 with
        a = -4 g / (l W^2), q = 2 A / l: stable above a_0(q)."""
        return float(np.sqrt(-4 * g / (length * mathieu_a(0, 2 * amplitude / length))))

    print("(c) Kapitza")
    amplitudes = np.array([0.002, 0.005, 0.01, 0.02, 0.04, 0.06])
    found = []
    for amplitude in amplitudes:
        theory = np.sqrt(2 * g * length) / amplitude
        found.append(boundary(amplitude))
        print(f"  A = {amplitude:<5g} m: W* = {found[-1]:.8f} rad/s (Floquet); theory "
              f"{theory:.4f} ({found[-1] / theory - 1:+.3%}); Mathieu {mathieu(amplitude):.8f} "
              f"({found[-1] / mathieu(amplitude) - 1:+.1e})")
    scene = model.floquet(2 * np.pi / model.parameters["W"], upright)
    print("  the scene (A 0.02, W 200): multipliers", scene.multipliers, "|mu|max",
          scene.max_modulus, "exponents", scene.exponents)
    for w in (0.95 * found[3], 1.05 * found[3]):
        runs = model.simulate((0, 3), {"th": np.pi / 2 + 0.05}, params={"W": w},
                              t_eval=np.linspace(0, 3, 301))
        print(f"  W = {w:.2f}: max |th - pi/2| over 3 s = "
              f"{np.abs(runs.y[0] - np.pi / 2).max():.3g} rad ({runs.method})")

    sweep = np.linspace(50, 250, 401)
    largest = [model.floquet(2 * np.pi / w, upright, params={"W": w}).max_modulus
               for w in sweep]
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.3), constrained_layout=True)
    left.plot(sweep, largest)
    theory = np.sqrt(2 * g * length) / 0.02
    left.axvline(theory, color="k", ls=":", label=f"A²W² = 2gl: W = {theory:.2f}")
    left.axvline(found[3], color="C3", ls="--", label=f"|tr M| = 2: W = {found[3]:.2f}")
    left.axvline(200, color="C2", ls="-.", label="the scene, W = 200")
    left.set_xlabel("W (rad/s)")
    left.set_ylabel("max |Floquet multiplier|")
    left.set_title("upright, A = 0.02 m")
    left.legend()
    fine = np.linspace(0.002, 0.3, 200) * length
    ratio = lambda a, w: (a * w) ** 2 / (2 * g * length)  # noqa: E731
    right.plot(fine / length, [ratio(a, mathieu(a)) for a in fine], label="Mathieu a₀(q)")
    right.plot(amplitudes / length, ratio(amplitudes, np.array(found)), "o",
               label="nemc: model.floquet, bisected")
    right.axhline(1, color="k", ls=":", label="small-amplitude theory")
    right.set_xlabel("A / l")
    right.set_ylabel("A²W²/(2gl) at the boundary")
    right.set_title("stability boundary of the upright rod")
    right.legend()
    right.grid(alpha=0.4)
    left.grid(alpha=0.4)
    figure.savefig(FIGURES / "control_kapitza.png", dpi=100)
    print("  wrote docs/figures/control_kapitza.png")


def main() -> int:
    import matplotlib

    matplotlib.use("Agg")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=["cart_pole", "fourbar", "kapitza"])
    args = parser.parse_args()
    for part in (cart_pole, fourbar, kapitza):
        if args.only in (None, part.__name__):
            part()
    return 0


if __name__ == "__main__":
    sys.exit(main())
